"""Every driving rule of the catalog: one scene where it fires, one where it does not.

"Fires" means an instance of the rule has a body that holds in the frame's
answer set; "blocked" scenes differ from the firing one by the condition or
exception that stops the rule.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from discern.rules.catalog import catalog_dirs, load_catalog
from discern.rules.engine import Reasoner
from discern.rules.justify import Prover
from tests.scenes import obj, scene

REASONER = Reasoner()

ped_ahead = obj("pedestrian", 0, 6, lane=1)
box_ahead = obj("roadblock", 0, 15, lane=2)
car_left_close = obj("car", -3.5, 2, lane=1)
at_stop = {"type": "four_way", "stage": "at"}

CASES = {
    "brake.hazard": (scene(objects=[ped_ahead]), scene()),
    "brake.obstacle_ahead": (scene(objects=[ped_ahead]), scene(objects=[obj("plastic_bag", 0, 6, lane=1)])),
    "brake.red_light": (
        scene(light="red", intersection={"type": "signaled", "stage": "arriving"}),
        scene(light="red", intersection={"type": "signaled", "stage": "enter"}),
    ),
    "brake.stop_sign": (
        scene(sign="stop", intersection={"type": "four_way", "stage": "arriving"}),
        scene(sign="stop", intersection={"type": "four_way", "stage": "at"}),
    ),
    "brake.yellow_light_can_stop": (
        scene(speed=10, light="yellow", intersection={"type": "signaled", "stage": "arriving", "distance": 40}),
        scene(speed=10, light="yellow", intersection={"type": "signaled", "stage": "arriving", "distance": 12}),
    ),
    "brake.yellow_light_unknown": (scene(light="yellow"), scene(light="green")),
    "brake.path_crossing": (
        scene(path="sp1", objects=[obj("truck", -8, 10, lane=1, kind="cross_right", predicted_path="op1")],
              crossings=[("sp1", "op1")], other_lanes=("cross_right",)),
        scene(path="sp1", objects=[obj("truck", -8, 10, lane=1, kind="cross_right", predicted_path="op2")],
              crossings=[("sp1", "op1")], other_lanes=("cross_right",)),
    ),
    "brake.front_sensor_close": (scene(sensors={"front": 0.3}), scene(sensors={"front": 2.0})),
    "brake.wait_to_turn": (
        scene(intent="enter_left_lane", intersection={"type": "t_intersect", "stage": "at"}),
        scene(intent="enter_left_lane", intersection={"type": "t_intersect", "stage": "enter"}),
    ),
    "brake.all_way_stop_order": (
        scene(intersection={"type": "unsignaled", "stage": "at", "arrival_rank": 2}),
        scene(intersection={"type": "unsignaled", "stage": "at", "arrival_rank": 1}),
    ),
    "brake.minor_road_yield": (
        scene(intersection={"type": "t_intersect", "stage": "at", "road": "minor"}, other_lanes=("cross_left",),
              objects=[obj("car", -20, 12, lane=1, kind="cross_left")]),
        scene(intersection={"type": "t_intersect", "stage": "at", "road": "major"}, other_lanes=("cross_left",),
              objects=[obj("car", -20, 12, lane=1, kind="cross_left")]),
    ),
    "brake.merge_blocked": (
        scene(lane=2, lanes=2, intent="merge_into_left_lane", objects=[obj("car", -3.5, 3, lane=1)]),
        scene(lane=2, lanes=2, intent="merge_into_left_lane", objects=[obj("car", -3.5, 30, lane=1)]),
    ),
    "brake.lane_end_give_way": (
        scene(lane=1, lanes=2, lane_ends={1: 80}, objects=[obj("car", 3.5, 0, lane=2)]),
        scene(lane=1, lanes=2, lane_ends={1: 80}),
    ),
    "brake.lane_end_reached": (scene(speed=15, lanes=1, lane_ends={1: 20}), scene(speed=15, lanes=1, lane_ends={1: 60})),
    "acc.below_limit": (scene(speed=10, limit=15), scene(speed=15, limit=15)),
    "acc.lane_not_clear": (scene(speed=15, objects=[obj("car", 0, 13, lane=1)]), scene(objects=[obj("car", 0, 40, lane=1)])),
    "acc.red_light": (scene(light="red"), scene(light="green")),
    "acc.at_limit": (scene(speed=15, limit=15), scene(speed=14, limit=15)),
    "acc.hazard": (scene(sensors={"front": 0.2}), scene(sensors={"front": 3.0})),
    "cruise.default": (scene(), None),
    "cruise.hazard": (scene(objects=[ped_ahead]), scene(objects=[obj("pedestrian", 0, 30, lane=1)])),
    "brake.no_phantom_braking": (
        scene(objects=[obj("car", 0, -4, lane=1, vy=10)]),
        scene(objects=[obj("car", 0, -4, lane=1, vy=10), ped_ahead]),
    ),
    "cll.swerve": (scene(lane=2, lanes=2, objects=[box_ahead]), scene(lane=2, lanes=2, objects=[obj("pedestrian", 0, 15, lane=2)])),
    "clr.swerve": (scene(lane=1, lanes=2, objects=[obj("roadblock", 0, 15, lane=1)]),
                   scene(lane=1, lanes=2, objects=[obj("roadblock", 0, 35, lane=1)])),
    "cll.intent_leftmost": (scene(lane=2, lanes=3, intent="stay_in_leftmost_lane"),
                            scene(lane=1, lanes=3, intent="stay_in_leftmost_lane")),
    "clr.intent_rightmost": (scene(lane=1, lanes=2, intent="stay_in_rightmost_lane"),
                             scene(lane=2, lanes=2, intent="stay_in_rightmost_lane")),
    "cll.intent_merge": (scene(lane=2, lanes=2, intent="merge_into_left_lane"), scene(lane=2, lanes=2)),
    "clr.intent_merge": (scene(lane=1, lanes=2, intent="merge_into_right_lane"), scene(lane=1, lanes=2)),
    "cll.lane_ends": (scene(lane=2, lanes=2, lane_ends={2: 80}), scene(lane=2, lanes=2, lane_ends={2: 400})),
    "clr.lane_ends": (scene(lane=1, lanes=2, lane_ends={1: 80}), scene(lane=1, lanes=2, lane_ends={1: 80, 2: 90})),
    "cll.overtake": (scene(speed=20, limit=30, lane=2, lanes=2, objects=[obj("truck", 0, 30, lane=2, vy=15)]),
                     scene(speed=20, limit=30, lane=2, lanes=2, objects=[obj("truck", 0, 30, lane=2, vy=31)])),
    "clr.left_contact": (scene(lane=1, lanes=2, sensors={"left": 0.4}), scene(lane=1, lanes=2, sensors={"left": 0.9})),
    "cll.right_contact": (scene(lane=2, lanes=2, sensors={"right": 0.4}), scene(lane=2, lanes=2, sensors={"right": 0.9})),
    "cll.no_lane": (scene(lane=1, lanes=2), scene(lane=2, lanes=2)),
    "clr.no_lane": (scene(lane=2, lanes=2), scene(lane=1, lanes=2)),
    "cll.lane_taken": (scene(lane=2, lanes=2, objects=[car_left_close]), scene(lane=2, lanes=2, objects=[obj("car", -3.5, 25, lane=1)])),
    "clr.lane_taken": (scene(lane=1, lanes=2, objects=[obj("car", 3.5, -4, lane=2)]),
                       scene(lane=1, lanes=2, objects=[obj("car", 3.5, -40, lane=2)])),
    "cll.sensor_blocked": (scene(lane=2, lanes=2, sensors={"left": 0.4}), scene(lane=2, lanes=2, sensors={"left": 2.5})),
    "clr.sensor_blocked": (scene(lane=1, lanes=2, sensors={"rear_right": 0.6}), scene(lane=1, lanes=2, sensors={"rear_right": 2.5})),
    "cll.in_intersection": (scene(lane=2, lanes=2, intersection=at_stop), scene(lane=2, lanes=2)),
    "clr.in_intersection": (scene(lane=1, lanes=2, intersection={"type": "signaled", "stage": "enter"}), scene(lane=1, lanes=2)),
    "tl.intent": (scene(intent="enter_left_lane"), scene(intent="enter_right_lane")),
    "tr.intent": (scene(intent="enter_right_lane"), scene(intent="enter_left_lane")),
    "tl.no_road": (scene(), scene(intersection=at_stop)),
    "tr.no_road": (scene(), scene(other_lanes=("cross_right",))),
    "tl.path_crossing": (
        scene(intersection=at_stop, path="sp1", objects=[obj("car", -5, 8, predicted_path="op1")], crossings=[("sp1", "op1")]),
        scene(intersection=at_stop, path="sp1", objects=[obj("car", -5, 8, predicted_path="op1")]),
    ),
    "tr.path_crossing": (
        scene(intersection=at_stop, path="sp1", objects=[obj("bicycle", 4, 4, predicted_path="op1")], crossings=[("sp1", "op1")]),
        scene(intersection=at_stop, path="sp2", objects=[obj("bicycle", 4, 4, predicted_path="op1")], crossings=[("sp1", "op1")]),
    ),
    "tl.not_leftmost": (scene(lane=2, lanes=2, intersection=at_stop), scene(lane=1, lanes=2, intersection=at_stop)),
    "tr.not_rightmost": (scene(lane=1, lanes=2, intersection=at_stop), scene(lane=2, lanes=2, intersection=at_stop)),
    "tl.red_light": (scene(light="red", intersection=at_stop), scene(light="green", intersection=at_stop)),
    "tr.red_light": (scene(light="red", intersection=at_stop), scene(light="green", intersection=at_stop)),
    "tr.crossing_user": (
        scene(intersection=at_stop, other_lanes=("cross_left",), objects=[obj("pedestrian", 4, 4, lane=1, kind="cross_left")]),
        scene(intersection=at_stop, other_lanes=("cross_left",), objects=[obj("pedestrian", -4, 4, lane=1, kind="cross_left")]),
    ),
    "tl.crossing_user": (
        scene(intersection=at_stop, other_lanes=("cross_right",), objects=[obj("bicycle", -4, 5, lane=1, kind="cross_right")]),
        scene(intersection=at_stop, other_lanes=("cross_right",), objects=[obj("car", -4, 5, lane=1, kind="cross_right")]),
    ),
    "tl.yield_oncoming": (
        scene(intersection=at_stop, other_lanes=("oncoming",), objects=[obj("car", -3, 8, lane=1, kind="oncoming")]),
        scene(intersection=at_stop, other_lanes=("oncoming",), objects=[obj("car", -3, 25, lane=1, kind="oncoming")]),
    ),
    "dec.actions": (scene(), None),
    "dec.permitted": (scene(), None),
    "dec.suggested": (scene(), None),
    "dec.preference": (scene(speed=5, limit=15), None),
    "dec.fallback_brake": (None, scene()),
    "jur.right_hand_traffic": (scene(), None),
    "po.intent": (scene(intent="pull_over"), scene()),
    "po.not_edge_lane": (scene(lane=1, lanes=2), scene(lane=2, lanes=2)),
}


def fired(sc) -> set[str]:
    return Prover(REASONER.catalog, REASONER.solve(sc, "cruise").answer).fired_rules()


@pytest.mark.parametrize("rule_id", sorted(r for r, (firing, _) in CASES.items() if firing is not None))
def test_rule_fires_in_its_scene(rule_id):
    firing, _ = CASES[rule_id]
    assert rule_id in fired(firing)


@pytest.mark.parametrize("rule_id", sorted(r for r, (_, blocked) in CASES.items() if blocked is not None))
def test_rule_does_not_fire_when_its_condition_or_exception_fails(rule_id):
    _, blocked = CASES[rule_id]
    assert rule_id not in fired(blocked)


def test_every_driving_rule_has_a_case_or_a_jurisdiction_case():
    uk_only = {"clr.overtake", "tr.yield_oncoming"}
    ids = {r.id for r in REASONER.catalog.driving_rules() if r.file.startswith(str(catalog_dirs()[0]))}
    assert ids - set(CASES) - uk_only == set()


def test_fallback_brake_is_recommended_when_no_rule_calls_for_anything(tmp_path: Path):
    rules = tmp_path / "rules"
    shutil.copytree(catalog_dirs()[0], rules)
    speed = rules / "30_speed.lp"
    speed.write_text(speed.read_text().replace("applicable(cruise).", ""))
    reasoner = Reasoner(catalog=load_catalog([rules]))
    verdict = reasoner.decide(scene(speed=15, limit=15), "cruise")
    assert verdict.recommended.value == "brake"
    assert "dec.fallback_brake" in Prover(reasoner.catalog, reasoner.solve(scene(speed=15, limit=15), "cruise").answer).fired_rules()
