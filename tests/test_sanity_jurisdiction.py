"""Jurisdiction packs: the mirrored world gets the mirrored decision; what differs by law differs."""

from __future__ import annotations

import random

import pytest

from discern.rules.engine import jurisdiction_pack
from discern.rules.scene import Action
from discern.sanity import reasoner_for, window_reasoner
from tests.mirror import mirror_action, mirror_scene
from tests.scenes import obj, scene, sensor

US, UK = reasoner_for("us"), reasoner_for("uk")


AT = {"type": "four_way", "stage": "at"}
ARRIVING = {"type": "signaled", "stage": "arriving", "distance": 20.0}

MIRROR_CASES = {
    "swerve around a roadblock": (scene(lanes=3, lane=2,
                                        objects=[obj("roadblock", 0.0, 15.0, 2, oid=1, sources=("camera", "radar"))],
                                        limit=13.0), "cruise"),
    "overtake a slower truck": (scene(speed=20.0, zone="highway", limit=29.0, lanes=2, lane=2,
                                      objects=[obj("truck", 0.0, 30.0, 2, oid=1, vy=15.0,
                                                   sources=("camera", "radar"))]), "cruise"),
    "lane change into a taken lane": (scene(lanes=2, lane=2,
                                            objects=[obj("car", -3.5, 2.0, 1, oid=1, sources=("camera", "radar"))],
                                            limit=13.0), "change_lane_left"),
    "merge when the lane ends": (scene(lanes=3, lane=2, limit=13.0, lane_ends={2: 80.0}), "cruise"),
    "turn across oncoming traffic": (scene(speed=3.0, limit=11.0, intent="enter_left_lane", intersection=AT,
                                           other_lanes=("oncoming",),
                                           objects=[obj("car", -3.0, 8.0, 1, oid=1, kind="oncoming",
                                                        sources=("camera", "radar"))]),
                                     "turn_left"),
    "turn on the kerb side": (scene(speed=3.0, limit=11.0, intent="enter_right_lane", intersection=AT,
                                    other_lanes=("oncoming",), objects=[obj("car", -3.0, 8.0, 1, oid=1, kind="oncoming",
                                                                            sources=("camera", "radar"))]),
                              "turn_right"),
    "turn with a pedestrian crossing": (scene(speed=3.0, limit=11.0, intent="enter_right_lane", intersection=AT,
                                              other_lanes=("cross_left",),
                                              objects=[obj("pedestrian", 4.0, 4.0, 1, oid=1, kind="cross_left",
                                                           sources=("camera", "radar"))]), "turn_right"),
    "barrier on the passing side": (scene(speed=27.0, zone="highway", limit=29.0, lanes=2,
                                          sensors=[sensor("left", 0.4, "ultrasonic")]), "cruise"),
    "emergency vehicle behind": (scene(speed=12.0, lanes=2, limit=13.0,
                                       objects=[obj("emergency_vehicle", 0.0, -30.0, 1, oid=4, vy=20.0,
                                                    emergency_lights=True, sources=("camera", "radar"))]),
                                 "cruise"),
    "pull over from the wrong lane": (scene(lanes=2, lane=1, intent="pull_over", limit=13.0), "pull_over"),
    "cruise from a turn-only lane on its red arrow": (
        scene(speed=8.0, lanes=2, lane=1, intersection=ARRIVING, limit=13.0, movements={1: ["left"], 2: ["straight"]},
              lights=[{"colour": "green"}, {"colour": "red", "direction": "left"}]), "cruise"),
    "turn from a lane that goes straight on only": (
        scene(speed=3.0, limit=11.0, intent="enter_left_lane", intersection=AT, lights=[{"colour": "green"}],
              movements={1: ["straight"]}), "turn_left"),
}


def mirrored(verdict):
    return (verdict.decision, mirror_action(verdict.action),
            mirror_action(verdict.recommended) if verdict.recommended else None)


def outcome(verdict):
    return (verdict.decision, verdict.action, verdict.recommended)


@pytest.mark.parametrize("case", sorted(MIRROR_CASES))
def test_mirrored_scene_gets_the_mirrored_decision_in_the_uk(case):
    sc, proposed = MIRROR_CASES[case]
    us = US.decide(sc, proposed)
    uk = UK.decide(mirror_scene(sc), mirror_action(proposed))
    assert outcome(uk) == mirrored(us)


def test_mirrored_random_scenes_get_mirrored_decisions():
    rng = random.Random(5)
    for _ in range(40):
        lanes = rng.randint(1, 3)
        objects = [obj(rng.choice(["car", "truck", "pedestrian", "roadblock"]), rng.uniform(-8, 8),
                       rng.uniform(-25, 50), rng.randint(1, lanes), oid=i, vy=rng.choice([None, rng.uniform(0, 25)]),
                       sources=("camera", "radar")) for i in range(1, rng.randint(1, 5))]
        sc = scene(speed=rng.uniform(0, 13), lane=rng.randint(1, lanes), lanes=lanes, limit=13.0, objects=objects,
                   sensors=rng.choice([(), (sensor(rng.choice(["left", "front_right", "rear_left"]), rng.uniform(0.2, 6)),)]),
                   intent=rng.choice(["continue_in_lane", "enter_left_lane", "stay_in_rightmost_lane"]),
                   intersection=rng.choice([None, AT]))
        proposed = rng.choice(list(Action))
        assert outcome(UK.decide(mirror_scene(sc), mirror_action(proposed))) == mirrored(US.decide(sc, proposed))


@pytest.mark.parametrize("x", [1.75, 3.5, 5.25])
def test_a_car_on_either_edge_of_the_shoulder_keeps_the_ego_from_pulling_over_citing_the_same_rules_in_the_uk(x):
    """A car with no lane on the line between the kerb lane and the shoulder, or on the shoulder's outer edge: the
    shoulder's edges were included on one kerb side and left out on the other, so the US ego pulled over onto a car
    5.25 m to its right, and the UK ego cited no shoulder for one on the inner line."""
    sc = scene(lanes=2, lane=2, limit=13.4, objects=[obj("car", x, 12.0, oid=1, vy=0.0, sources=("camera", "radar"))])
    us, uk = US.decide(sc, "pull_over"), UK.decide(mirror_scene(sc), "pull_over")
    assert outcome(uk) == mirrored(us) and uk.rules == us.rules
    assert "po.kerb_taken" in us.rules


def test_mirroring_twice_gives_the_scene_back():
    sc = MIRROR_CASES["turn with a pedestrian crossing"][0]
    assert mirror_scene(mirror_scene(sc)).model_dump(exclude={"notes"}) == sc.model_dump(exclude={"notes"})


def test_right_on_red_is_allowed_in_the_us_after_a_stop_and_never_in_the_uk():
    stopped = scene(speed=0.0, limit=11.0, intent="enter_right_lane", lights=[{"colour": "red"}], intersection=AT)
    rolling = stopped.model_copy(update={"ego": stopped.ego.model_copy(update={"speed": 4.0})})
    signed = scene(speed=0.0, limit=11.0, intent="enter_right_lane", lights=[{"colour": "red"}], intersection=AT,
                   signs=[{"kind": "no_turn_on_red"}])
    assert US.decide(stopped, "turn_right").decision.value == "approve"
    assert US.decide(rolling, "turn_right").decision.value == "override"
    assert US.decide(signed, "turn_right").decision.value == "override"
    assert UK.decide(stopped, "turn_right").decision.value == "override"
    assert UK.decide(mirror_scene(stopped), "turn_left").rules[0] == "tl.red_light"


def test_zone_limits_are_the_countrys():
    sc = scene(speed=14.0, limit=None)  # 31 mph in a town, nothing posted
    assert US.decide(sc, "accelerate").decision.value == "approve"  # US usual 35 mph
    uk = UK.decide(sc, "accelerate")
    assert uk.decision.value == "override" and "san.limit.zone_default" in uk.rules  # UK 30 mph
    assert "(30 mph) is usual and none above 22.4 m/s (50 mph) is plausible  [jur.uk.zone_limits]" in uk.justification.text
    assert not any(r.startswith("jur.") for r in uk.rules)  # a setting shown in the proof, not a rule that forbids


def test_unknown_jurisdiction_is_rejected_naming_the_known_ones():
    with pytest.raises(ValueError, match=r"unknown jurisdiction 'fr': choose from us, uk"):
        reasoner_for("fr")
    with pytest.raises(ValueError, match="unknown jurisdiction"):
        window_reasoner(jurisdiction="mars")


def test_reasoner_for_builds_each_jurisdiction_once():
    assert reasoner_for("uk") is UK and reasoner_for(" UK ") is UK
    assert jurisdiction_pack("UK").name == "uk.lp"


def test_default_reasoner_is_us_and_lists_the_pack_rules():
    ids = {r.id for r in window_reasoner().catalog.rules}
    assert {"jur.us", "jur.right_hand_traffic", "jur.us.right_on_red"} <= ids and "jur.uk" not in ids


def test_moving_to_the_kerb_side_lane_past_a_slower_truck_is_allowed_in_the_us_and_not_in_the_uk():
    """US law lets a driver pass on the right on a road of several lanes (UVC 11-304); the Highway Code forbids moving
    to a lane on the left to overtake (rule 268): the mirrored scene is not the mirrored decision."""
    sc = scene(speed=20.0, zone="highway", limit=29.0, lanes=3, lane=2,
               objects=[obj("truck", 0.0, 30.0, 2, oid=1, vy=15.0, sources=("camera", "radar"))])
    assert US.decide(sc, "change_lane_right").decision.value == "approve"
    uk = UK.decide(mirror_scene(sc), "change_lane_left")
    assert uk.decision.value == "override" and "jur.uk.no_overtaking_on_the_left" in uk.rules


def test_holding_speed_past_a_slower_car_on_the_right_is_an_undertake_in_the_uk():
    """Highway Code 268: the ego at 30 m/s in lane 1 would pass a car doing 22 m/s in lane 2, 10 m ahead, on its
    left; it slows to match instead. Within the speed margin of its speed the lanes move alike: no undertake."""
    def beside(vy: float):
        return scene(speed=30.0, zone="highway", limit=31.0, lanes=2, lane=1,
                     objects=[obj("car", 3.5, 10.0, 2, oid=1, vy=vy, sources=("camera", "radar"))])

    held = UK.decide(beside(22.0), "cruise")
    assert held.decision.value == "override" and held.action.value == "brake"
    assert "jur.uk.no_overtaking_on_the_left" in held.vetoed_by
    assert UK.decide(beside(29.0), "cruise").decision.value == "approve"


def test_a_car_signalling_a_right_turn_may_be_passed_on_its_left_in_the_uk():
    """Highway Code 163: overtaking on the left is allowed when the vehicle in front signals to turn right."""
    turning = obj("car", 0.0, 30.0, 2, oid=1, vy=3.0, indicator="right", sources=("camera", "radar"))
    sc = scene(speed=14.0, limit=15.6, lanes=2, lane=2, objects=[turning])
    assert UK.decide(sc, "change_lane_left").decision.value == "approve"
    plain = scene(speed=14.0, limit=15.6, lanes=2, lane=2,
                  objects=[obj("car", 0.0, 30.0, 2, oid=1, vy=3.0, sources=("camera", "radar"))])
    assert "jur.uk.no_overtaking_on_the_left" in UK.decide(plain, "change_lane_left").rules


@pytest.mark.parametrize("reasoner, side, proposed", [(US, "left", "change_lane_left"), (UK, "right", "change_lane_right")])
def test_the_ego_does_not_overtake_a_car_signalling_towards_the_passing_side(reasoner, side, proposed):
    """Highway Code 167; US manuals: a car ahead signalling towards the passing side is about to turn across it."""
    lane = 2 if side == "left" else 1
    signalling = obj("car", 0.0, 30.0, lane, oid=1, vy=3.0, indicator=side, sources=("camera", "radar"))
    verdict = reasoner.decide(scene(speed=13.0, limit=13.4, lanes=2, lane=lane, objects=[signalling]), proposed)
    assert verdict.decision.value == "override"
    assert f"{'cll' if side == 'left' else 'clr'}.lead_signals_{side}" in verdict.vetoed_by


def test_a_speed_setting_reads_in_the_unit_of_the_packs_signs_too():
    """The margin over the limit is shown as a driver reads limits: '2.24 m/s (5 mph)'."""
    over = scene(speed=15.2, zone="city", limit=13.41)
    text = UK.decide(over, "cruise", explain=True).justification.full_text()
    assert "the margin allowed over the limit is 2.24 m/s (5 mph)" in text


@pytest.mark.parametrize("reasoner, lane, towards", [(US, 1, "change_lane_right"), (UK, 2, "change_lane_left")])
def test_a_route_that_asks_to_pull_over_moves_the_ego_towards_the_kerb_lane_first(reasoner, lane, towards):
    verdict = reasoner.decide(scene(speed=10.0, lanes=2, lane=lane, intent="pull_over", limit=13.0), "pull_over")
    assert verdict.decision.value == "override" and verdict.action.value == towards


def test_a_uk_amber_is_stopped_for_wherever_the_ego_can_stop_before_the_line_and_a_us_yellow_only_comfortably():
    """Highway Code 175: amber means stop unless so close that pulling up might cause an accident. At 30 mph, 35 m
    from the line, the ego stops in 28.4 m braking firmly, not in the comfortable 43.4 m the US yellow asks."""
    def amber(distance: float, *objects):
        return scene(speed=13.41, limit=13.41, lights=[{"colour": "yellow"}], objects=objects,
                     intersection={"type": "signaled", "stage": "arriving", "distance": distance})

    uk = UK.decide(amber(35.0), "cruise", explain=True)
    assert uk.action.value == "brake" and "[jur.uk.amber_light]" in uk.justification.text
    assert US.decide(amber(35.0), "cruise").decision.value == "approve"
    assert UK.decide(amber(20.0), "cruise").decision.value == "approve"  # it cannot stop before the line
    # braking firmly might make it run into the ego
    close_behind = obj("car", 0.0, -6.0, 1, oid=1, vy=13.41, sources=("camera", "radar"))
    assert UK.decide(amber(35.0, close_behind), "cruise").decision.value == "approve"


def test_turning_into_a_road_in_the_uk_gives_way_to_a_pedestrian_waiting_at_its_corner_and_the_us_mirror_need_not():
    """Highway Code H2 (2022): give way to pedestrians crossing or waiting to cross a road into which you turn."""
    def turning(side: str, ahead: float = 6.0):
        x = -6.0 if side == "left" else 6.0
        return scene(speed=0.0, limit=13.4, intent=f"enter_{side}_lane", lights=[{"colour": "green"}],
                     other_lanes=("oncoming", f"cross_{side}", f"sidewalk_{side}"),
                     intersection={"type": "signaled", "stage": "at", "distance": 0.0},
                     objects=[obj("pedestrian", x, ahead, 1, oid=2, kind=f"sidewalk_{side}", vy=0.0,
                                  sources=("camera", "radar"))])

    uk = UK.decide(turning("left"), "turn_left")
    assert uk.action.value == "brake" and "tl.crossing_user" in uk.vetoed_by
    assert UK.decide(turning("left", ahead=30.0), "turn_left").decision.value == "approve"  # past the corner
    assert US.decide(turning("right"), "turn_right").decision.value == "approve"
