"""The RSS peer: ad-rss's safe distance and the shield built on it."""

import pytest

pytest.importorskip("ad_rss")

from discern.scenarios.highway.rss import RssChecker, RssParameters, safe_distance
from discern.rules.scene import Action, DetectedObject, Ego, Lane, LaneKind, LaneRef, Scene, Size, Vec2, Velocity, Zone
from discern.rules.verdict import Decision


def rss_formula(v_rear: float, v_front: float, p: RssParameters) -> float:
    """The RSS paper's safe longitudinal distance (same direction), never negative: what ad-rss must compute."""
    rho, a, bmin, bmax = p.response_time, p.accel_max, p.brake_min, p.brake_max
    d = v_rear * rho + 0.5 * a * rho**2 + (v_rear + rho * a) ** 2 / (2 * bmin) - v_front**2 / (2 * bmax)
    return max(d, 0.0)


@pytest.mark.parametrize("rear,front", [(30.0, 25.0), (25.0, 30.0), (30.0, 0.0), (20.0, 20.0), (10.0, 40.0)])
def test_ad_rss_safe_distance_matches_the_rss_paper_formula(rear, front):
    p = RssParameters()
    assert safe_distance(rear, front, p) == pytest.approx(rss_formula(rear, front, p), abs=1e-3)


def _scene(gap_ahead: float, lead_speed: float, lane: int = 2) -> Scene:
    return Scene(
        frame_id=1,
        ego=Ego(speed=30.0, lane=2, zone=Zone.highway),
        lanes=[Lane(kind=LaneKind.current, id=i, speed_limit=30.0) for i in (1, 2, 3)],
        objects=[
            DetectedObject(
                id=1,
                cls="car",
                position=Vec2(x=(lane - 2) * 4.0, y=gap_ahead),  # bumper to bumper, as scene.py reports it
                lane=LaneRef(kind=LaneKind.current, id=lane),
                velocity=Velocity(y=lead_speed),
                size=Size(length=5.0, width=2.0),
            )
        ],
    )


def test_rss_brakes_when_the_leader_is_closer_than_the_safe_distance():
    verdict = RssChecker().check(_scene(gap_ahead=40.0, lead_speed=25.0), Action.accelerate)
    assert verdict.decision is Decision.override and verdict.action is Action.brake
    assert verdict.rules == ["rss_longitudinal"] and "RSS" in verdict.justification.summary


def test_rss_approves_a_safe_gap_and_blocks_a_lane_change_into_an_unsafe_one():
    checker = RssChecker()
    assert checker.check(_scene(gap_ahead=150.0, lead_speed=25.0), Action.cruise).decision is Decision.approve
    blocked = checker.check(_scene(gap_ahead=30.0, lead_speed=25.0, lane=3), Action.change_lane_right)
    assert blocked.decision is Decision.override and blocked.action is Action.cruise


def test_rss_reads_the_scene_gap_as_bumper_to_bumper_without_taking_car_lengths_off():
    need = safe_distance(30.0, 25.0, RssParameters())
    checker = RssChecker()
    assert checker.check(_scene(gap_ahead=need + 1.0, lead_speed=25.0), Action.cruise).decision is Decision.approve
    assert checker.check(_scene(gap_ahead=need - 1.0, lead_speed=25.0), Action.cruise).decision is Decision.override
