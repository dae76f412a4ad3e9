"""Turns that must give way, pedestrians stepping in, emergency vehicles inside the junction, school buses across
undivided roads: the reviewer's defects 2, 6, 8 and 13."""

from __future__ import annotations

import pytest

from discern.rules.scene import Scene
from discern.sanity import reasoner_for
from tests.scenes import obj, scene

US, UK = reasoner_for("us"), reasoner_for("uk")
CROSSROADS = ("oncoming", "cross_left", "cross_right")


def moving(cls: str, x: float, y: float, kind: str, vx: float = 0.0, vy: float = 0.0, lane: int = 1, **extra) -> dict:
    return obj(cls, x, y, lane=lane, kind=kind, velocity={"x": vx, "y": vy}, **extra)


def arriving(intent: str, *objects, distance: float = 8, speed: float = 6.0, other_lanes=CROSSROADS, **kw):
    return scene(speed=speed, limit=15.6, intent=intent, light="green", other_lanes=other_lanes, objects=objects,
                 intersection={"type": "signaled", "stage": "arriving", "distance": distance}, **kw)


GIVE_WAY_ARRIVING = {
    "pedestrian on the crossing to the right": (US, "turn_right", arriving(
        "enter_right_lane", moving("pedestrian", 9, 12, "cross_right", vy=1.2))),
    "pedestrian on the crossing to the left": (US, "turn_left", arriving(
        "enter_left_lane", moving("pedestrian", -9, 12, "cross_left", vy=1.2))),
    "oncoming car": (US, "turn_left", arriving("enter_left_lane", moving("car", -3.5, 30, "oncoming", vy=-12))),
    "cyclist on the kerb side (US)": (US, "turn_right", arriving(
        "enter_right_lane", moving("bicycle", 3.5, 2, "shoulder", vy=5), other_lanes=CROSSROADS + ("shoulder",))),
    "cyclist on the kerb side (UK)": (UK, "turn_left", arriving(
        "enter_left_lane", moving("bicycle", -3.5, 2, "shoulder", vy=5), other_lanes=CROSSROADS + ("shoulder",))),
    "cross traffic at a minor road": (US, "turn_left", scene(
        speed=6.0, limit=15.6, intent="enter_left_lane", other_lanes=("cross_left", "cross_right"),
        objects=[moving("car", -20, 8, "cross_left", vx=12)],
        intersection={"type": "t_intersect", "stage": "arriving", "distance": 8, "road": "minor"})),
}


@pytest.mark.parametrize("case", sorted(GIVE_WAY_ARRIVING))
def test_a_turn_that_must_give_way_while_arriving_near_the_line_is_replaced_by_braking_not_speed(case):
    reasoner, turn, sc = GIVE_WAY_ARRIVING[case]
    verdict = reasoner.decide(sc, turn)
    assert (verdict.decision.value, verdict.action.value) == ("override", "brake")
    assert verdict.recommended.value == "brake"
    speeding_up = reasoner.decide(sc, "accelerate")
    assert speeding_up.decision.value == "override" and "acc.slow_for_turn" in speeding_up.rules


def test_a_turn_that_must_give_way_calls_for_braking_and_no_speeding_up_only_near_the_line_and_while_moving():
    far = arriving("enter_left_lane", moving("car", -3.5, 110, "oncoming", vy=-12), distance=60)
    near = arriving("enter_left_lane", moving("car", -3.5, 58, "oncoming", vy=-12), distance=8)
    assert US.decide(far, "cruise").recommended.value == "accelerate"
    assert US.decide(near, "cruise").recommended.value == "brake"
    assert "acc.slow_for_turn" in US.decide(near, "accelerate").rules
    stopped_short = arriving("enter_left_lane", moving("car", -3.5, 58, "oncoming", vy=-12), distance=8, speed=0.0)
    assert US.decide(stopped_short, "accelerate").decision.value == "approve"  # it may move up to the line


def at_the_line(intent: str, light: str, pedestrian: dict):
    return scene(speed=0.0, limit=15.6, intent=intent, light=light, other_lanes=CROSSROADS, objects=[pedestrian],
                 intersection={"type": "signaled", "stage": "at", "distance": 0})


@pytest.mark.parametrize("light", ["red", "green"])
@pytest.mark.parametrize("x", [-2.5, -5.0])
def test_a_pedestrian_walking_towards_the_turn_side_blocks_the_turn_before_it_gets_there(light, x):
    stepping_in = at_the_line("enter_right_lane", light, moving("pedestrian", x, 1, "cross_left", vx=1.4))
    verdict = US.decide(stepping_in, "turn_right")
    assert verdict.decision.value == "override" and "tr.crossing_user" in verdict.rules


def test_a_pedestrian_walking_towards_the_left_blocks_a_left_turn_and_one_walking_away_does_not_block_a_right_turn():
    towards_the_left = at_the_line("enter_left_lane", "green", moving("pedestrian", 5, 1, "cross_right", vx=-1.4))
    verdict = US.decide(towards_the_left, "turn_left")
    assert verdict.decision.value == "override" and "tl.crossing_user" in verdict.rules
    walking_away = at_the_line("enter_right_lane", "green", moving("pedestrian", -5, 1, "cross_left", vx=-1.4))
    assert US.decide(walking_away, "turn_right").decision.value == "approve"
    too_slow_to_matter = at_the_line("enter_right_lane", "green", moving("pedestrian", -10, 1, "cross_left", vx=1.4))
    assert US.decide(too_slow_to_matter, "turn_right").decision.value == "approve"


EMERGENCY = {
    "on the cross road to the left": moving("emergency_vehicle", -40, 8, "cross_left", vx=12, emergency_lights=True),
    "behind": moving("emergency_vehicle", 0, -25, "current", vy=14, emergency_lights=True),
}


def with_emergency(where: str, stage: str, speed: float = 8.0):
    return scene(speed=speed, limit=15.6, light="green", other_lanes=CROSSROADS, objects=[EMERGENCY[where]],
                 intersection={"type": "signaled", "stage": stage})


@pytest.mark.parametrize("where", sorted(EMERGENCY))
def test_an_emergency_vehicle_makes_the_ego_clear_the_intersection_not_stop_in_it(where):
    inside = with_emergency(where, "enter")
    assert US.decide(inside, "cruise").decision.value == "approve"
    pulling_over = US.decide(inside, "pull_over")
    assert (pulling_over.decision.value, pulling_over.action.value) == ("override", "cruise")
    assert "po.in_intersection" in pulling_over.rules
    still_at_the_line = US.decide(with_emergency(where, "at", speed=0.0), "accelerate")
    assert still_at_the_line.action.value == "brake" and "san.emergency.give_way" in still_at_the_line.rules


def four_lanes_with_bus(ego_lane: int, proposed: str = "cruise", divided: bool = False):
    """Two lanes each way; a median between them only where the scene says the road is divided."""
    bus = moving("bus", -7, 30, "oncoming", lane=2, emergency_lights=True)
    data = scene(speed=12, limit=15.6, lane=ego_lane, lanes=2, other_lanes=("oncoming",), objects=[bus],
                 divided_road=divided).model_dump(mode="json", by_alias=True, exclude_none=True)
    data["lanes"].append({"kind": "oncoming", "id": 2})
    return US.decide(Scene.model_validate(data), proposed)


@pytest.mark.parametrize("ego_lane", [1, 2])
def test_a_school_bus_stopped_across_a_four_lane_road_not_known_to_be_divided_stops_the_ego(ego_lane):
    verdict = four_lanes_with_bus(ego_lane)
    assert (verdict.decision.value, verdict.action.value) == ("override", "brake")
    assert "san.school_bus.stop" in verdict.rules


def test_a_school_bus_across_a_road_the_map_marks_divided_is_passed():
    """UVC 11-705(d): only separate roadways exempt the far side."""
    verdict = four_lanes_with_bus(1, divided=True)
    assert verdict.decision.value == "approve" and "san.school_bus.stop" not in verdict.rules


# The second turn review: unknown speeds, unlabelled traffic, red lights and unmarked junctions, bounds.

def left_turn_at_green(*objects, speed: float = 3.0, stage: str = "at"):
    return scene(speed=speed, limit=13.4, intent="enter_left_lane", light="green", other_lanes=("oncoming",),
                 objects=objects, intersection={"type": "signaled", "stage": stage})


def test_an_oncoming_car_of_unknown_speed_is_taken_to_arrive_at_the_limit_as_one_measured_there_would():
    unknown = US.decide(left_turn_at_green(obj("car", -3.5, 50, lane=1, kind="oncoming")), "turn_left", explain=True)
    assert (unknown.decision.value, unknown.action.value) == ("override", "brake")
    assert "tl.yield_oncoming" in unknown.rules
    text = unknown.justification.text
    assert "would reach the ego's path in 3.0 s, because  [def.oncoming_worst_due]" in text
    assert "[def.oncoming_unknown_close]" in text
    at_the_limit = US.decide(left_turn_at_green(moving("car", -3.5, 50, "oncoming", vy=-13.4)), "turn_left")
    assert at_the_limit.decision.value == "override" and "tl.yield_oncoming" in at_the_limit.rules
    # one that would take longer than the turn gap even at the limit (100 m over 16.4 m/s: 6.1 s) does not hold it
    assert US.decide(left_turn_at_green(obj("car", -3.5, 100, lane=1, kind="oncoming")), "turn_left").decision.value == "approve"


def test_a_standing_oncoming_car_holds_a_left_turn_only_where_it_stands_in_its_sweep_however_fast_the_ego_creeps():
    """A left turn's arc (10 to 15 m radius) crosses the oncoming lane 7.6 to 9.6 m ahead: a car standing there is an
    obstacle in the turn's path; one waiting at its line across the intersection is not traffic that is due. Neither
    depends on how fast the ego creeps (a standing car is never due)."""
    in_the_sweep, across = moving("car", -3.5, 8, "oncoming"), moving("car", -3.5, 14, "oncoming")
    for speed in (0.0, 1.0, 2.0, 4.0):
        blocked = US.decide(left_turn_at_green(in_the_sweep, speed=speed), "turn_left")
        assert blocked.decision.value == "override" and blocked.rules == ["tl.oncoming_lane_blocked"], speed
        verdict = US.decide(left_turn_at_green(across, speed=speed), "turn_left")
        assert verdict.decision.value == "approve" and "tl.intent" in verdict.rules, speed
    # before the line the turn has not begun: traffic standing short of the intersection is not in its sweep
    queued = scene(speed=0.0, limit=13.4, intent="enter_left_lane", light="green", other_lanes=("oncoming",),
                   intersection={"type": "signaled", "stage": "arriving", "distance": 9.0},
                   objects=[moving("car", -3.5, 1, "oncoming")])
    assert "tl.oncoming_lane_blocked" not in US.decide(queued, "turn_left").rules
    creeping_towards = moving("car", -3.5, 8, "oncoming", vy=-2.0)
    verdict = US.decide(left_turn_at_green(creeping_towards, speed=2.0), "turn_left")
    assert verdict.decision.value == "override" and "tl.yield_oncoming" in verdict.rules


def test_an_unlabelled_car_coming_towards_the_ego_on_the_passing_side_is_oncoming_traffic():
    unlabelled = obj("car", -3.5, 20, velocity={"x": 0.0, "y": -15.0})
    verdict = US.decide(left_turn_at_green(unlabelled), "turn_left", explain=True)
    assert (verdict.decision.value, verdict.action.value) == ("override", "brake")
    assert "tl.yield_oncoming" in verdict.rules and "[def.oncoming_from_velocity]" in verdict.justification.text
    mirrored = scene(speed=3.0, limit=13.4, intent="enter_right_lane", light="green", other_lanes=("oncoming",),
                     objects=[obj("car", 3.5, 20, velocity={"x": 0.0, "y": -15.0})],
                     intersection={"type": "signaled", "stage": "at"})
    assert "tr.yield_oncoming" in UK.decide(mirrored, "turn_right").rules
    # in the same-direction lanes, or driving the ego's way, it is no oncoming traffic
    ahead_in_lane = obj("car", 0, 20, velocity={"x": 0.0, "y": 5.0})
    assert US.decide(left_turn_at_green(ahead_in_lane), "turn_left").decision.value == "approve"


def test_an_unlabelled_car_driving_across_the_egos_road_is_cross_traffic_for_a_turn():
    unlabelled = obj("car", -20, 8, velocity={"x": 12.0, "y": 0.0})
    verdict = US.decide(left_turn_at_green(unlabelled), "turn_left", explain=True)
    assert (verdict.decision.value, verdict.action.value) == ("override", "brake")
    assert "tl.yield_cross_traffic" in verdict.rules and "[def.crossing_from_velocity]" in verdict.justification.text
    driving_away = obj("car", -20, 8, velocity={"x": -12.0, "y": 0.0})
    assert US.decide(left_turn_at_green(driving_away), "turn_left").decision.value == "approve"


def red_light_right_turn(sign: str | None = None, light: str | None = "red"):
    return scene(speed=0.0, limit=13.4, intent="enter_right_lane", light=light, sign=sign, other_lanes=("cross_left",),
                 objects=[obj("car", -30, 8, lane=1, kind="cross_left")],
                 intersection={"type": "signaled", "stage": "at"})


def test_a_turn_on_red_yields_to_cross_traffic_of_unknown_speed_as_at_a_stop_sign():
    on_red = US.decide(red_light_right_turn(), "turn_right", explain=True)
    assert (on_red.decision.value, on_red.action.value) == ("override", "brake")
    assert "tr.yield_cross_traffic" in on_red.rules
    assert "the traffic light is red" in on_red.justification.text
    at_stop_sign = US.decide(red_light_right_turn(sign="stop", light=None), "turn_right")
    assert at_stop_sign.decision.value == "override" and "tr.yield_cross_traffic" in at_stop_sign.rules


def unmarked_crossroads(x: float, **kw):
    kind = "cross_right" if x > 0 else "cross_left"
    return scene(speed=10.0, limit=13.4, other_lanes=("cross_left", "cross_right"),
                 objects=[obj("car", x, 8, lane=1, kind=kind)],
                 intersection={"type": "unsignaled", "stage": "arriving", "distance": 6, **kw})


def test_at_an_unmarked_junction_the_ego_does_not_speed_up_into_cross_traffic_it_must_give_way_to():
    from_the_right = US.decide(unmarked_crossroads(10), "accelerate")
    assert (from_the_right.decision.value, from_the_right.action.value) == ("override", "brake")
    assert "brake.uncontrolled_junction" in from_the_right.rules
    # due in 2.2 s from the left: in the US the car on the left gives way; in the UK no one has priority
    assert US.decide(unmarked_crossroads(-30), "accelerate").decision.value == "approve"
    uk = UK.decide(unmarked_crossroads(-30), "accelerate")
    assert uk.action.value == "brake" and "brake.uncontrolled_junction" in uk.rules
    # on the major road the cross traffic gives way
    assert US.decide(unmarked_crossroads(10, road="major"), "accelerate").decision.value == "approve"


@pytest.mark.parametrize("where", [{"x": 80, "y": 5}, {"x": 4, "y": -40}])
def test_a_pedestrian_far_along_the_cross_road_or_behind_the_ego_does_not_block_its_turn(where):
    def right_turn(x, y):
        return scene(speed=2.0, limit=13.4, intent="enter_right_lane", other_lanes=("cross_right",),
                     objects=[obj("pedestrian", x, y, lane=1, kind="cross_right")],
                     intersection={"type": "four_way", "stage": "at"})

    far = US.decide(right_turn(**where), "turn_right")
    assert far.decision.value == "approve" and "tr.intent" in far.rules
    at_the_corner = US.decide(right_turn(4, 5), "turn_right")
    assert at_the_corner.decision.value == "override" and "tr.crossing_user" in at_the_corner.rules


def exit_lane(intent: str, ends_in: float, speed: float = 20.0, exits: tuple = (2,)):
    return scene(speed=speed, limit=29.0, zone="highway", lane=1, lanes=2, intent=intent, lane_ends={2: ends_in},
                 exits=exits)


def test_the_ego_may_move_into_an_exit_lane_its_route_asks_for_though_the_lane_ends_ahead():
    verdict = US.decide(exit_lane("merge_into_right_lane", 120), "change_lane_right")
    assert verdict.decision.value == "approve" and "clr.intent_merge" in verdict.rules
    by_choice = US.decide(exit_lane("continue_in_lane", 120), "change_lane_right")
    assert by_choice.decision.value == "override" and "clr.target_lane_ends" in by_choice.rules
    # within the stopping distance (53.3 m at 20 m/s) it ends too soon to be used
    too_late = US.decide(exit_lane("merge_into_right_lane", 45), "change_lane_right")
    assert too_late.decision.value == "override" and "clr.target_lane_ends" in too_late.rules
    # a lane that drops into the next one is no way off the road, whatever the route says
    dropping = US.decide(exit_lane("merge_into_right_lane", 120, exits=()), "change_lane_right")
    assert dropping.decision.value == "override" and "clr.target_lane_ends" in dropping.rules


def test_in_the_exit_lane_its_route_asks_for_the_ego_is_not_sent_back_out_as_from_a_lane_drop():
    """Entered, the exit lane 'ends' where the ego leaves the road with it: no merging back, no braking for its end."""
    in_exit = scene(speed=20, lane=2, lanes=2, zone="highway", limit=29, intent="merge_into_right_lane",
                    lane_ends={2: 50.0}, exits=(2,))
    verdict = US.decide(in_exit, "cruise")
    assert verdict.decision.value == "approve" and verdict.recommended.value != "change_lane_left"
    # the same lane not marked as leaving the road is a lane drop, however the route reads: still left
    for intent in ("merge_into_right_lane", "continue_in_lane"):
        dropping = scene(speed=20, lane=2, lanes=2, zone="highway", limit=29, intent=intent, lane_ends={2: 50.0})
        assert US.decide(dropping, "cruise").action.value == "change_lane_left", intent
