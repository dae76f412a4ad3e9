"""Mirror a scene left-to-right: a right-hand-traffic scene becomes its left-hand-traffic twin.

Used to check that a jurisdiction pack gives the mirrored decision for the
mirrored world (the same situation in the US and in the UK).
"""

from __future__ import annotations

from discern.rules.scene import Action, ArrowDirection, Indicator, Intent, LaneKind, Scene, SensorSide

_ACTIONS = {
    Action.change_lane_left: Action.change_lane_right,
    Action.change_lane_right: Action.change_lane_left,
    Action.turn_left: Action.turn_right,
    Action.turn_right: Action.turn_left,
}
_INTENTS = {
    Intent.merge_into_left_lane: Intent.merge_into_right_lane,
    Intent.merge_into_right_lane: Intent.merge_into_left_lane,
    Intent.enter_left_lane: Intent.enter_right_lane,
    Intent.enter_right_lane: Intent.enter_left_lane,
    Intent.stay_in_leftmost_lane: Intent.stay_in_rightmost_lane,
    Intent.stay_in_rightmost_lane: Intent.stay_in_leftmost_lane,
}
_KINDS = {
    LaneKind.cross_left: LaneKind.cross_right,
    LaneKind.cross_right: LaneKind.cross_left,
    LaneKind.sidewalk_left: LaneKind.sidewalk_right,
    LaneKind.sidewalk_right: LaneKind.sidewalk_left,
}
_SIDES = {
    SensorSide.left: SensorSide.right,
    SensorSide.right: SensorSide.left,
    SensorSide.front_left: SensorSide.front_right,
    SensorSide.front_right: SensorSide.front_left,
    SensorSide.rear_left: SensorSide.rear_right,
    SensorSide.rear_right: SensorSide.rear_left,
}
_INDICATORS = {Indicator.left: Indicator.right, Indicator.right: Indicator.left}
_MOVEMENTS = {ArrowDirection.left: ArrowDirection.right, ArrowDirection.right: ArrowDirection.left}


def mirror_action(action: Action) -> Action:
    action = Action(action)
    return _ACTIONS.get(action, action)


def mirror_scene(scene: Scene) -> Scene:
    """x -> -x, lane ids counted from the other edge, left and right swapped everywhere."""
    data = scene.model_dump(mode="python", by_alias=True)
    count = {}
    for lane in scene.lanes:
        count[lane.kind] = max(count.get(lane.kind, 0), lane.id)

    def lane_id(kind: LaneKind, lane: int) -> int:
        return count.get(kind, lane) + 1 - lane

    data["ego"]["lane"] = lane_id(LaneKind.current, scene.ego.lane)
    data["ego"]["intent"] = _INTENTS.get(scene.ego.intent, scene.ego.intent)
    for lane in data["lanes"]:
        lane["id"], lane["kind"] = lane_id(lane["kind"], lane["id"]), _KINDS.get(lane["kind"], lane["kind"])
        if lane.get("movements"):  # a left-turn lane is the mirrored world's right-turn lane
            lane["movements"] = [_MOVEMENTS.get(m, m) for m in lane["movements"]]
    for light in data["traffic_lights"]:
        light["direction"] = _MOVEMENTS.get(light["direction"], light["direction"])
    for obj in data["objects"]:
        obj["position"]["x"] = -obj["position"]["x"]
        if obj.get("velocity"):
            obj["velocity"]["x"] = -obj["velocity"]["x"]
        if obj.get("lane"):
            kind, lane = obj["lane"]["kind"], obj["lane"]["id"]
            obj["lane"] = {"kind": _KINDS.get(kind, kind), "id": lane_id(kind, lane)}
        obj["indicator"] = _INDICATORS.get(obj["indicator"], obj["indicator"])
    for sign in data["signs"]:
        if sign.get("position"):
            sign["position"]["x"] = -sign["position"]["x"]
    for reading in data["sensors"]:
        reading["side"] = _SIDES.get(reading["side"], reading["side"])
    data["notes"] = []
    return Scene.model_validate(data)
