"""Turn a Scene into ASP facts.

clingo reasons over integers, so distances become centimetres and speeds
cm/s; the predicate templates convert them back for people.
"""

from __future__ import annotations

import math
import re
from dataclasses import asdict, dataclass, fields
from typing import Protocol, Sequence

from clingo import String

from .scene import MAX_RANGE_M, Action, Scene, TrafficLight


def cm(metres: float) -> int:
    return int(round(metres * 100))


MIN_PARAM = 0.01  # the smallest parameter value the facts (in cm and ms) do not round to 0
# The largest value of each kind of parameter. The rules multiply speeds (cm/s, up to MAX_SPEED_MS) by times (ms) in
# clingo's 32-bit integers: past a minute, a reaction time would wrap into a wrong, possibly permissive, verdict.
MAX_PARAM_TIME_S = 60.0
MAX_PARAM_DECEL = 100.0  # m/s², ten times gravity
MAX_PARAM_SPEED = 50.0  # m/s: a closing speed (up to twice MAX_SPEED_MS) raised by accel_step, times a minute, still fits
_TIMES = frozenset({"reaction_s", "headway_s", "slow_headway_s", "turn_gap_s"})
_DECELERATIONS = frozenset({"decel", "heavy_decel"})
_SPEEDS = frozenset({"stopped_speed", "drift_speed", "accel_step", "speed_margin", "turn_speed", "caution_speed", "caution_drop",
                     "cyclist_speed", "slow_traffic_speed", "fast_traffic_speed"})


def _largest(name: str) -> float:
    if name in _TIMES:
        return MAX_PARAM_TIME_S
    if name in _SPEEDS:
        return MAX_PARAM_SPEED
    return MAX_PARAM_DECEL if name in _DECELERATIONS else MAX_RANGE_M


@dataclass(frozen=True)
class Params:
    """Physical and behavioural parameters of the catalog, in SI units."""

    reaction_s: float = 1.0  # perception + actuation latency before braking starts
    decel: float = 6.0  # m/s^2, firm braking on a dry road
    heavy_decel: float = 4.5  # m/s^2, a loaded truck's or bus's full braking (FMVSS 121: 250 ft from 60 mph, 4.7 m/s^2)
    min_gap: float = 10.0  # m, AV-CSR's fixed gap: the floor of every gap
    headway_s: float = 2.0  # time gap kept to a vehicle ahead when following in faster-moving traffic (Highway Code 126)
    slow_headway_s: float = 1.0  # time gap kept up to slow_traffic_speed, where the gap needed to stop is the rule
    slow_traffic_speed: float = 15.6464  # m/s (35 mph), up to this speed slow_headway_s applies; above it the time gap
    # rises evenly to headway_s at fast_traffic_speed, so that no small change of speed doubles the gap kept
    fast_traffic_speed: float = 17.8816  # m/s (40 mph), from this speed on traffic is faster-moving: headway_s applies
    swerve_dist: float = 20.0  # m, AV-CSR's look-ahead for swerving around objects
    overtake_dist: float = 40.0  # m, how far ahead a slower vehicle makes the ego overtake
    merge_dist: float = 150.0  # m, an ending lane closer than this must be left
    side_clearance: float = 1.0  # m, a side sensor closer than this blocks a lane change
    evade_dist: float = 0.5  # m, AV-CSR's contact distance for range sensors
    tailgate_dist: float = 8.0  # m, a follower closer than this makes braking for nothing unsafe
    crossing_dist: float = 15.0  # m, vulnerable road users crossing nearer than this block a turn
    turn_gap_s: float = 5.0  # time a turn across traffic takes to clear: traffic due sooner blocks it
    stopped_speed: float = 0.5  # m/s, slower than this a vehicle, the ego or another, has stopped
    drift_speed: float = 0.5  # m/s, a vehicle moving sideways at least this fast is moving into the next lane
    range_match: float = 3.0  # m, a range reading this close to an object's distance is that object
    lane_width: float = 3.5  # m, places objects reported without a lane; a side reading within it is in the next lane
    accel_step: float = 0.5  # m/s an accelerate adds before the next decision: nearer the limit than this, it would pass it
    speed_margin: float = 2.2352  # m/s (5 mph), how far above the limit the ego may be before it must slow down
    turn_speed: float = 8.9408  # m/s (20 mph), the fastest the ego turns at an intersection
    turn_dist: float = 10.0  # m, a turn starts no farther than this before the stop line
    move_over_dist: float = 150.0  # m, an emergency vehicle nearer than this (either way) or a stopped school bus ahead
    caution_speed: float = 6.7056  # m/s (15 mph), the slowest cautious speed (cautious_speed/1)
    caution_drop: float = 8.9408  # m/s (20 mph), how far below the limit caution takes the ego (US Move Over laws)
    cyclist_speed: float = 8.9408  # m/s (20 mph, AASHTO's design bicyclist), the fastest a cyclist of unknown speed is taken to ride

    @classmethod
    def overrides(cls, pairs: list[str]) -> tuple[dict[str, float], list[str]]:
        """`NAME=VALUE` settings as given on a command line: the values, and a problem for each bad one.

        Every parameter is a gap, time, speed or deceleration (decel divides), and the facts carry them in
        cm and ms: a value below MIN_PARAM would reach the rules as 0 and turn the rules that use it off.
        """
        known = {f.name for f in fields(cls)}
        values: dict[str, float] = {}
        problems: list[str] = []
        for pair in pairs:
            name, equals, value = pair.partition("=")
            if not equals:
                problems.append(f"--param {pair!r}: expected NAME=VALUE, such as decel=4")
                continue
            try:
                number = None if "_" in value else float(value)  # Python's 4_0 is 40: no operator's 4.0
            except ValueError:
                number = None
            if name not in known:
                problems.append(f"unknown --param {name!r} (known: {', '.join(sorted(known))})")
            elif name in values:  # one of the two would be dropped unsaid: which one the operator meant is theirs to say
                problems.append(f"--param {name} given twice ({values[name]:g} and {value})")
            elif number is None or not (math.isfinite(number) and MIN_PARAM <= number <= _largest(name)):
                bound = f"from {MIN_PARAM:g} to {_largest(name):g}"
                problems.append(f"--param {name} needs a number {bound}, got {value!r}")
            else:
                values[name] = number
        return values, problems

    def facts(self) -> str:
        values = asdict(self)
        return "".join(
            [
                f"param(reaction_ms,{int(round(values.pop('reaction_s') * 1000))}).",
                f"param(headway_ms,{int(round(values.pop('headway_s') * 1000))}).",
                f"param(slow_headway_ms,{int(round(values.pop('slow_headway_s') * 1000))}).",
                f"param(turn_gap_ms,{int(round(values.pop('turn_gap_s') * 1000))}).",
                f"param(decel,{cm(values.pop('decel'))}).",
            ]
            + [f"param({name},{cm(value)})." for name, value in values.items()]
        )


PARAM_NAMES = frozenset(re.findall(r"param\((\w+),", Params().facts()))  # as the rules read them: reaction_ms
# The predicates scene_facts gives (a test checks it on every scenario file): a catalog rule that reads another
# one that no catalog fact or rule gives either reads nothing, a misspelling (catalog.py warns of it).
SCENE_PREDICATES = frozenset({
    ("ego_speed", 1), ("ego_lane", 1), ("intent", 1), ("zone", 1), ("ego_path", 1), ("speed_limit", 1),
    ("map_speed_limit", 1), ("road_divided", 0), ("lane", 2), ("lane_ends", 2), ("lane_leaves_road", 1),
    ("lane_speed_limit", 3), ("object", 2), ("obj_pos", 3), ("obj_lane", 3), ("lane_unreported", 1),
    ("obj_velocity", 3), ("has_velocity", 1), ("obj_indicator", 2), ("obj_emergency_lights", 1), ("obj_path", 2),
    ("obj_source", 2), ("obj_elevation", 2), ("obj_track_age", 2), ("traffic_light", 1), ("light_flashing", 1),
    ("light_steady", 1), ("traffic_sign", 1), ("sign_reading", 3), ("intersection", 1), ("intersection_stage", 1),
    ("intersection_road", 1), ("arrival_rank", 1), ("intersection_distance", 1), ("stop_line", 0),
    ("stop_controlled", 0), ("sensor", 3), ("paths_cross", 2), ("proposed", 1),
    ("lane_movement", 2),
})



class FactProvider(Protocol):
    """Adds facts derived from more than the current frame (the sanity layer's window). One that defines
    `bind(static_atoms, params)` is handed the catalog's static model and the parameters once, by its Reasoner.

    It names what it gives, so that the catalog loader and the proofs know it without importing its layer:
    `predicates` beside SCENE_PREDICATES, and `params` the names of its window_param/2 settings."""

    predicates: frozenset[tuple[str, int]]
    params: frozenset[str]

    def facts(self, scene: Scene, history: Sequence[Scene]) -> str: ...


def scene_facts(scene: Scene, proposed: Action | None = None) -> str:
    ego = scene.ego
    out = [
        f"ego_speed({cm(ego.speed)}).",
        f"ego_lane({ego.lane}).",
        f"intent({ego.intent.value}).",
        f"zone({ego.zone.value}).",
    ]
    if ego.predicted_path:
        out.append(f"ego_path({_const(ego.predicted_path)}).")
    if scene.speed_limit is not None:
        out.append(f"speed_limit({cm(scene.speed_limit)}).")
    if scene.map_speed_limit is not None:
        out.append(f"map_speed_limit({cm(scene.map_speed_limit)}).")
    if scene.divided_road:
        out.append("road_divided.")
    for lane in scene.lanes:
        out.append(f"lane({lane.kind.value},{lane.id}).")
        if lane.ends_in is not None and lane.kind.value == "current":
            out.append(f"lane_ends({lane.id},{cm(lane.ends_in)}).")
            if lane.leaves_road:
                out.append(f"lane_leaves_road({lane.id}).")
        for movement in lane.movements or ():  # a current lane's only (scene.Lane)
            out.append(f"lane_movement({lane.id},{movement.value}).")
        if lane.speed_limit is not None:
            out.append(f"lane_speed_limit({lane.kind.value},{lane.id},{cm(lane.speed_limit)}).")
    for obj in scene.objects:
        oid = obj.id
        out.append(f"object({oid},{obj.cls.value}).")
        out.append(f"obj_pos({oid},{cm(obj.position.x)},{cm(obj.position.y)}).")
        if obj.lane is not None:
            out.append(f"obj_lane({oid},{obj.lane.kind.value},{obj.lane.id}).")
        else:
            out.append(f"lane_unreported({oid}).")
        if obj.velocity is not None:
            out.append(f"obj_velocity({oid},{cm(obj.velocity.x)},{cm(obj.velocity.y)}).has_velocity({oid}).")
        if obj.indicator.value != "none":
            out.append(f"obj_indicator({oid},{obj.indicator.value}).")
        if obj.emergency_lights:
            out.append(f"obj_emergency_lights({oid}).")
        if obj.predicted_path:
            out.append(f"obj_path({oid},{_const(obj.predicted_path)}).")
        for source in obj.sources:
            out.append(f"obj_source({oid},{source.value}).")
        if obj.elevation is not None:
            out.append(f"obj_elevation({oid},{cm(obj.elevation)}).")
        if obj.track_age is not None:
            out.append(f"obj_track_age({oid},{obj.track_age}).")
    for light in scene.traffic_lights:
        if light.colour.value != "none":
            out.append(f"traffic_light({lamp(light)}).")
            out.append(f"light_{'flashing' if light.flashing else 'steady'}({lamp(light)}).")
    for sign in scene.signs:
        out.append(f"traffic_sign({sign.kind.value}).")
        if sign.value is not None:
            out.append(f"sign_reading({sign.kind.value},{cm(sign.value)},{sign.source.value}).")
    if scene.intersection is not None:
        x = scene.intersection
        out.append(f"intersection({x.type.value}).intersection_stage({x.stage.value}).")
        if x.road:
            out.append(f"intersection_road({x.road}).")
        if x.arrival_rank is not None:
            out.append(f"arrival_rank({x.arrival_rank}).")
        if x.distance is not None:
            out.append(f"intersection_distance({cm(x.distance)}).")
        if x.stop_line:
            out.append("stop_line.")
        if x.stop_controlled:
            out.append("stop_controlled.")
    for reading in scene.sensors:
        out.append(f"sensor({reading.side.value},{cm(reading.distance)},{reading.kind.value}).")
    for crossing in scene.path_crossings:
        out.append(f"paths_cross({_const(crossing.ego_path)},{_const(crossing.object_path)}).")
    if proposed is not None:
        out.append(f"proposed({proposed.value}).")
    return "".join(out)


def lamp(light: TrafficLight) -> str:
    """The constant the rules know a lit light by: its colour for a ball, `red_left_arrow` for an arrow. An arrow is a
    lamp of its own, so that what is seen of it (lit, flashing, remembered) is never taken for the ball's; the catalog
    reads its movement and colour off `arrow_lamp/3`. The facts stay plain constants (fact_text.py)."""
    colour = light.colour.value
    return colour if light.direction is None else f"{colour}_{light.direction.value}_arrow"


def _const(name: str) -> str:
    """Path ids become clingo strings, escaped by clingo, unless they are plain ASCII constants already."""
    if name.isascii() and name[:1].islower() and name.replace("_", "").isalnum():
        return name
    return str(String(name))
