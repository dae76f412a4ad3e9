"""Review of what stands in the ego's path: a car showing hazard lights whose speed is unknown, a standing car that
braking cannot stop short of, and a pedestrian standing on a crossing straight ahead (review of 2026-11-28)."""

from __future__ import annotations

import pytest

from discern.sanity import window_reasoner
from tests.scenes import obj, scene

REASONERS = {"us": window_reasoner(), "uk": window_reasoner(jurisdiction="uk")}
STANDING = {"x": 0.0, "y": 0.0}
CROSS = ("oncoming", "cross_left", "cross_right")


def decide(sc, proposed: str, jurisdiction: str = "us"):
    return REASONERS[jurisdiction].decide(sc, proposed, explain=True)


def highway(*objects, lane: int = 2, lanes: int = 2):
    """The ego at 30 m/s: it needs 30 m + 30²/12 m = 105 m to stop, 30 m + 30²/6 m = 180 m braking comfortably."""
    return scene(speed=30, limit=31.3, zone="highway", lane=lane, lanes=lanes, objects=list(objects))


# --- a car showing its hazard lights, of unknown speed ------------------------------------------------------------

@pytest.mark.parametrize("sources", [["camera"], ["camera", "radar"]])
def test_a_car_with_hazard_lights_and_no_known_speed_is_taken_to_stand(sources):
    """Highway Code 116: hazard lights warn that the vehicle obstructs the road; it does not keep pace with traffic."""
    flashing = obj("car", 0, 45, lane=1, indicator="hazard", sources=sources)
    verdict = decide(highway(flashing, lane=1, lanes=1), "cruise")
    assert (verdict.decision.value, verdict.action.value) == ("override", "brake")
    assert "cruise.hazard" in verdict.rules and "[def.closing_may_stand]" in verdict.justification.text
    far = obj("car", 0, 60, lane=1, indicator="hazard", sources=sources)
    assert decide(highway(far, lane=1, lanes=1), "accelerate").decision.value == "override"


def test_a_car_with_hazard_lights_and_a_known_speed_is_closed_in_on_at_that_speed():
    moving = obj("car", 0, 65, lane=1, vy=30.0, indicator="hazard")  # past the two-second headway at 30 m/s
    verdict = decide(highway(moving, lane=1, lanes=1), "cruise")
    assert verdict.decision.value == "approve"
    # it still warns: the ego does not speed up towards it (acc.lead_braking)
    assert "acc.lead_braking" in decide(highway(moving, lane=1, lanes=1), "accelerate").rules


def test_hazard_lights_in_the_next_lane_do_not_make_a_car_stand_in_the_egos_lane():
    beside = obj("car", -3.5, 45, lane=1, indicator="hazard")
    assert decide(highway(beside), "cruise").decision.value == "approve"


# --- a standing car that braking cannot stop short of ---------------------------------------------------------------

@pytest.mark.parametrize("distance", [45, 80])
def test_a_car_standing_nearer_than_the_stopping_distance_is_passed_in_a_free_lane_not_braked_for(distance):
    standing = obj("car", 0, distance, lane=2, velocity=STANDING, sources=["camera", "radar"])
    verdict = decide(highway(standing), "cruise")
    assert (verdict.decision.value, verdict.action.value) == ("override", "change_lane_left")
    assert "[cll.cannot_stop]" in verdict.justification.text


def test_a_car_with_hazard_lights_nearer_than_the_stopping_distance_is_passed_in_a_free_lane():
    flashing = obj("car", 0, 45, lane=2, indicator="hazard", sources=["camera"])
    assert decide(highway(flashing), "cruise").action.value == "change_lane_left"


def test_the_ego_brakes_for_a_standing_car_it_can_stop_for_or_when_no_lane_is_free():
    # 110 m ahead: beyond the 105 m stopping distance, inside the comfortable one: the ego slows down
    far = decide(highway(obj("car", 0, 110, lane=2, velocity=STANDING)), "cruise")
    assert (far.decision.value, far.action.value) == ("override", "brake")
    # the lane on the left taken alongside: braking is all that is left
    taken = highway(obj("car", 0, 45, lane=2, velocity=STANDING), obj("car", -3.5, 0, lane=1, vy=30.0))
    assert decide(taken, "cruise").action.value == "brake"
    # stopped in a queue behind it, the ego needs no lane change
    queued = scene(speed=0, lanes=2, lane=2, objects=[obj("car", 0, 8, lane=2, velocity=STANDING)])
    assert "cll.cannot_stop" not in decide(queued, "change_lane_left").rules


# --- a pedestrian standing on a crossing straight ahead -------------------------------------------------------------

@pytest.mark.parametrize("distance", [39, 40])
def test_a_pedestrian_standing_on_a_crossing_in_line_with_the_ego_is_stopped_for_comfortably(distance):
    """At 13.4 m/s a comfortable stop takes 13.4 m + 13.4²/6 m = 43.3 m, as for one standing in the ego's lane."""
    on_crossing = obj("pedestrian", 0.0, distance, lane=1, kind="cross_right", velocity=STANDING)
    verdict = decide(scene(speed=13.4, limit=13.4, other_lanes=CROSS, objects=[on_crossing]), "cruise")
    assert (verdict.decision.value, verdict.action.value) == ("override", "brake")
    assert "cruise.closing_in" in verdict.rules and "brake.pass_vulnerable_slowly" not in verdict.rules
    text = verdict.justification.text
    assert "is a vulnerable road user on a crossing straight ahead, in the ego's path" in text
    assert "just beside the ego's lane" not in text


def test_a_pedestrian_on_a_crossing_beyond_the_comfortable_stopping_distance_is_not_braked_for():
    on_crossing = obj("pedestrian", 0.0, 44, lane=1, kind="cross_right", velocity=STANDING)
    assert decide(scene(speed=13.4, limit=13.4, other_lanes=CROSS, objects=[on_crossing]), "cruise").decision.value == "approve"
