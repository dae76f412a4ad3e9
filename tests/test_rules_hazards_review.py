"""Review of the braking rules: a pedestrian in the crosswalk on the ego's half of the road, giving way while arriving on
a minor road, an all-way stop known by its arrival order, and a yellow light stopped for only where that is comfortable."""

from __future__ import annotations

import pytest

from discern.rules.facts import Params
from discern.sanity import window_reasoner
from tests.scenes import obj, scene

REASONERS = {"us": window_reasoner(), "uk": window_reasoner(jurisdiction="uk")}
CROSS = ("oncoming", "cross_left", "cross_right")
STANDING = {"x": 0.0, "y": 0.0}


def decide(sc, proposed: str, jurisdiction: str = "us"):
    return REASONERS[jurisdiction].decide(sc, proposed)


def overridden_with_brake(verdict) -> bool:
    return (verdict.decision.value, verdict.action.value) == ("override", "brake")


def in_crosswalk(x: float, y: float, kind: str = "cross_right", cls: str = "pedestrian", **extra):
    return obj(cls, x, y, lane=1, kind=kind, **extra)


# --- 3: a pedestrian in the crosswalk on the ego's half of the road ---------------------------------------------

@pytest.mark.parametrize("jurisdiction", ["us", "uk"])
def test_a_pedestrian_standing_in_the_crosswalk_in_the_next_lane_stops_the_ego(jurisdiction):
    # two same-direction lanes, the pedestrian in the crosswalk in lane 2, 8 m ahead; the ego at 12 m/s
    standing = scene(speed=12, limit=15.6, lanes=2, other_lanes=CROSS, objects=[in_crosswalk(3.5, 8)])
    for proposed in ("cruise", "accelerate"):
        verdict = decide(standing, proposed, jurisdiction)
        assert overridden_with_brake(verdict) and "brake.pedestrian_at_crossing" in verdict.rules, proposed


@pytest.mark.parametrize("jurisdiction", ["us", "uk"])
def test_the_ego_does_not_pass_a_car_stopped_at_the_crosswalk_for_a_pedestrian(jurisdiction):
    stopped = obj("car", 3.5, 4, lane=2, velocity=STANDING)
    sc = scene(speed=12, limit=15.6, lanes=2, other_lanes=CROSS, objects=[stopped, in_crosswalk(3.5, 10)])
    verdict = decide(sc, "cruise", jurisdiction)
    assert overridden_with_brake(verdict) and "brake.pedestrian_at_crossing" in verdict.rules


def test_a_pedestrian_at_the_edge_of_the_egos_half_within_its_stopping_distance_forbids_cruising_and_speeding_up():
    """0.25 m outside the ego's lane, 20 m ahead (beyond the 15 m crossing distance) at 15 m/s: 33.75 m to stop."""
    def approach(y: float):
        return scene(speed=15, limit=15.6, other_lanes=CROSS, light="green", objects=[in_crosswalk(2.0, y)],
                     intersection={"type": "signaled", "stage": "arriving", "distance": y - 3})

    for proposed in ("cruise", "accelerate"):
        verdict = decide(approach(20), proposed)
        assert overridden_with_brake(verdict) and "brake.pedestrian_at_crossing" in verdict.rules, proposed
    text = REASONERS["us"].decide(approach(20), "cruise", explain=True).justification.text
    assert "pedestrian 1 is a vulnerable road user in a crossing ahead on the ego's half of the road" in text
    # beyond the stopping distance plus the minimum gap (43.75 m) the ego need not brake yet
    assert decide(approach(48), "cruise").decision.value == "approve"
    # on the far half of the road, away from the ego's side, it is not the ego's to stop for
    far_half = scene(speed=12, limit=15.6, other_lanes=CROSS, objects=[in_crosswalk(-9, 25, kind="cross_left")])
    assert decide(far_half, "cruise").decision.value == "approve"


def test_a_stopped_ego_waits_for_a_pedestrian_in_the_crosswalk_just_ahead():
    waiting = scene(speed=0, limit=15.6, lanes=2, other_lanes=CROSS, objects=[in_crosswalk(3.5, 6, velocity=STANDING)])
    verdict = decide(waiting, "accelerate")
    assert overridden_with_brake(verdict)
    assert "cruise.hazard" in decide(waiting, "cruise").rules


# --- 7: giving way while arriving on the minor road ---------------------------------------------------------------

def minor_arriving(distance: float, speed: float = 8.0):
    coming = obj("car", -35, 12, lane=1, kind="cross_left", velocity={"x": 13.0, "y": 0.0})
    return scene(speed=speed, limit=15.6, other_lanes=CROSS, objects=[coming],
                 intersection={"type": "t_intersect", "road": "minor", "stage": "arriving", "distance": distance})


@pytest.mark.parametrize("jurisdiction", ["us", "uk"])
def test_arriving_on_the_minor_road_the_ego_slows_once_it_could_no_longer_stop_comfortably_at_the_line(jurisdiction):
    # 8 m/s, 14 m from the line: 13.3 m to stop braking firmly, 18.7 m braking comfortably; a major-road car due in 2.7 s
    for proposed in ("cruise", "accelerate"):
        verdict = decide(minor_arriving(14), proposed, jurisdiction)
        assert overridden_with_brake(verdict) and "brake.minor_road_yield" in verdict.rules, proposed
    # 40 m off it can still stop comfortably: it need not slow yet
    assert decide(minor_arriving(40), "cruise", jurisdiction).decision.value == "approve"


def test_arriving_on_the_minor_road_with_no_known_distance_to_the_line_the_ego_gives_way():
    unknown = scene(speed=8, limit=15.6, other_lanes=CROSS,
                    objects=[obj("car", -35, 12, lane=1, kind="cross_left", velocity={"x": 13.0, "y": 0.0})],
                    intersection={"type": "t_intersect", "road": "minor", "stage": "arriving"})
    verdict = decide(unknown, "cruise")
    assert overridden_with_brake(verdict) and "brake.minor_road_yield" in verdict.rules


# --- 12: an arrival rank means an all-way stop --------------------------------------------------------------------

def test_an_arrival_rank_makes_the_approach_stop_controlled_with_no_stop_sign_seen():
    rolling_first = scene(speed=8, limit=15.6, other_lanes=CROSS,
                          intersection={"type": "four_way", "stage": "at", "distance": 0, "arrival_rank": 1})
    verdict = decide(rolling_first, "cruise")
    assert overridden_with_brake(verdict) and "brake.stop_sign_full_stop" in verdict.rules
    arriving_second = scene(speed=8, limit=15.6, other_lanes=CROSS,
                            intersection={"type": "four_way", "stage": "arriving", "distance": 12, "arrival_rank": 2})
    verdict = decide(arriving_second, "cruise")
    assert overridden_with_brake(verdict) and "brake.stop_sign" in verdict.rules
    text = REASONERS["us"].decide(arriving_second, "cruise", explain=True).justification.text
    assert "def.stop_control_arrival_rank" in text and "only an all-way stop keeps" in text
    # stopped at the line and first, it goes
    stopped_first = scene(speed=0, limit=15.6, other_lanes=CROSS,
                          intersection={"type": "four_way", "stage": "at", "distance": 0, "arrival_rank": 1})
    assert decide(stopped_first, "accelerate").decision.value == "approve"


# --- 9: a yellow is stopped for only where the ego can stop comfortably ------------------------------------------

def yellow(distance: float, speed: float = 15.6, *objects):
    return scene(speed=speed, limit=15.6, light="yellow", other_lanes=CROSS, objects=list(objects),
                 intersection={"type": "signaled", "stage": "arriving", "distance": distance})


def test_a_yellow_the_ego_could_stop_for_only_by_braking_hard_is_driven_through():
    # 15.6 m/s, 36.5 m from the line: 35.9 m to stop braking firmly (6 m/s²), 56.2 m braking comfortably (3 m/s²)
    tailgater = obj("car", 0, -6, lane=1, vy=15.6)
    assert decide(yellow(36.5, 15.6, tailgater), "cruise").decision.value == "approve"
    assert decide(yellow(36.5), "cruise").decision.value == "approve"
    # 60 m from the line it stops comfortably, so it must
    verdict = decide(yellow(60), "cruise")
    assert overridden_with_brake(verdict) and "brake.yellow_light_can_stop" in verdict.rules
    text = REASONERS["us"].decide(yellow(60), "cruise", explain=True).justification.text
    assert "braking comfortably, the ego stops within 56.2 m" in text


def test_the_comfortable_rate_is_never_above_the_firm_one():
    # firm braking set to 2 m/s² (a slippery road): from 10 m/s that takes 35 m, so 30 m from the line is too close
    slippery = window_reasoner(params=Params(decel=2.0))
    assert slippery.decide(yellow(30, 10.0), "cruise").decision.value == "approve"
    assert decide(yellow(30, 10.0), "cruise").action.value == "brake"  # 26.7 m at 3 m/s²
    assert decide(yellow(20, 10.0), "cruise").decision.value == "approve"  # 18.3 m braking firmly, 26.7 m comfortably


@pytest.mark.parametrize("kind", ["cross_left", "cross_right"])
def test_a_vehicle_of_unknown_speed_across_the_egos_path_is_not_taken_to_drive_away(kind):
    """A car labelled in a crossing lane, standing 20 m ahead in the ego's path, was taken to keep pace with the
    traffic (closing at 0 m/s, a 10 m gap): speeding up towards it at 15 m/s was approved."""
    across = scene(speed=15, limit=20, other_lanes=(kind,), objects=[obj("car", 0, 20, lane=1, kind=kind)])
    assert overridden_with_brake(decide(across, "accelerate"))
    in_the_egos_lane = scene(speed=15, limit=20, objects=[obj("car", 0, 20, lane=1)])  # AV-CSR's reading: it keeps pace
    assert decide(in_the_egos_lane, "accelerate").decision.value == "approve"


# --- a stop sign read with no intersection known ------------------------------------------------------------------

def test_a_stop_sign_with_no_intersection_known_is_stopped_at_then_passed_when_clear():
    moving = scene(speed=10, limit=13.4, sign="stop")
    for proposed in ("accelerate", "cruise"):
        verdict = decide(moving, proposed)
        assert overridden_with_brake(verdict) and "brake.stop_sign" in verdict.rules, proposed
    # no rolling right turn through it
    turning = scene(speed=8, limit=13.4, sign="stop", intent="enter_right_lane", other_lanes=CROSS)
    verdict = decide(turning, "turn_right")
    assert overridden_with_brake(verdict) and "brake.stop_sign" in verdict.rules
    # stopped, with the way clear, the ego goes; with cross traffic near, it waits
    assert decide(scene(speed=0, limit=13.4, sign="stop"), "accelerate").decision.value == "approve"
    stopped_turning = scene(speed=0, limit=13.4, sign="stop", intent="enter_right_lane", other_lanes=CROSS)
    assert decide(stopped_turning, "turn_right").decision.value == "approve"
    coming = obj("car", -25, 6, lane=1, kind="cross_left", velocity={"x": 15.0, "y": 0.0})
    busy = scene(speed=0, limit=13.4, sign="stop", other_lanes=CROSS, objects=[coming])
    verdict = decide(busy, "accelerate")
    assert overridden_with_brake(verdict) and "brake.stop_sign_cross_traffic" in verdict.rules


# --- slowing early for a standing hazard --------------------------------------------------------------------------

def test_the_ego_slows_early_for_a_pedestrian_or_a_standing_car_within_its_comfortable_stopping_distance():
    """At 20 m/s braking comfortably (3 m/s²) takes 86.7 m with the reaction; firm braking (6 m/s²) 53.3 m."""
    pedestrian = scene(speed=20, limit=29, zone="highway", objects=[obj("pedestrian", 0, 60, lane=1)])
    # 80 m: past the two-second following gap to a standing car (which forbids both itself, nearer), inside 86.7 m
    standing_car = scene(speed=20, limit=29, zone="highway", objects=[obj("car", 0, 80, lane=1, velocity=STANDING)])
    for sc in (pedestrian, standing_car):
        for proposed in ("accelerate", "cruise"):
            verdict = REASONERS["us"].decide(sc, proposed, explain=True)
            assert overridden_with_brake(verdict), proposed
            assert ("acc.lane_not_clear" if proposed == "accelerate" else "cruise.closing_in") in verdict.rules
            text = verdict.justification.full_text()
            assert "nearer than the ego" in text and "braking comfortably" in text
    # beyond the comfortable stopping distance one step of accelerating on, from 10.5 m/s: 10.5 m + 10.5²/6 m = 28.9 m
    far = scene(speed=10, limit=15.6, objects=[obj("car", 0, 29.5, lane=1, velocity=STANDING)])
    assert decide(far, "accelerate").decision.value == "approve"
    # a car of unknown speed is taken to move with the traffic: no early stop for it
    assert decide(scene(speed=20, limit=29, zone="highway", objects=[obj("car", 0, 54, lane=1)]), "cruise").decision.value == "approve"


# --- things the ego can drive over ----------------------------------------------------------------------------

def test_a_plastic_bag_ahead_does_not_make_the_ego_brake_with_a_car_tailgating():
    bag = obj("plastic_bag", 0, 20, lane=1)
    tailgater = obj("car", 0, -5, lane=1, vy=15)
    sc = scene(speed=15, limit=15.6, objects=[bag, tailgater])
    verdict = decide(sc, "cruise")
    assert verdict.decision.value == "approve" and "cruise.closing_in" not in verdict.rules
    assert decide(sc, "brake").decision.value == "override"  # brake.no_phantom_braking: nothing to brake for
    assert "brake.no_phantom_braking" in decide(sc, "brake").rules
    assert decide(scene(speed=10, limit=15.6, objects=[bag]), "accelerate").decision.value == "approve"


# --- a yellow light with no known distance to the line ----------------------------------------------------------

def test_the_ego_does_not_accelerate_towards_a_yellow_light():
    unknown = scene(speed=10, limit=13.4, light="yellow")
    verdict = decide(unknown, "accelerate")
    assert overridden_with_brake(verdict) and "acc.yellow_light" in verdict.rules
    # too close to stop comfortably, it goes through at its speed, without speeding up
    close = scene(speed=10, limit=13.4, light="yellow", intersection={"type": "signaled", "stage": "arriving", "distance": 12})
    verdict = decide(close, "accelerate")
    assert (verdict.decision.value, verdict.action.value) == ("override", "cruise") and "acc.yellow_light" in verdict.rules
    assert decide(close, "cruise").decision.value == "approve"
    inside = scene(speed=10, limit=13.4, light="yellow", intersection={"type": "signaled", "stage": "enter"})
    assert decide(inside, "accelerate").decision.value == "approve"


def test_decelerations_in_a_justification_read_in_metres_per_second_squared():
    approach = scene(speed=10, limit=13.4, light="yellow",
                     intersection={"type": "signaled", "stage": "arriving", "distance": 32})
    text = REASONERS["us"].decide(approach, "accelerate", explain=True).justification.text
    assert "3.0 m/s² ≤ 6.0 m/s²" in text and "comfortable braking is a deceleration of 3.0 m/s²" in text
    assert "3.0 m/s ≤" not in text
