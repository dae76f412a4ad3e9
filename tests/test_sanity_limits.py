"""Speed-limit plausibility: which reading governs, and what the verdict says about the others."""

from __future__ import annotations

from discern.rules.catalog import catalog_dirs, load_catalog
from discern.rules.engine import Reasoner, jurisdiction_pack
from discern.sanity.examples import MPH, limit_sign, obj, scene
from discern.sanity.jurisdiction import reasoner_for

US = reasoner_for("us")


def limit_in_force(sc, history=()) -> float:
    answer = US.solve(sc, "cruise", history).answer
    (limit,) = answer.of("effective_limit", 1)
    return limit.arguments[0].number / 100


def test_a_taped_85_in_town_cannot_raise_the_limit_past_the_plausible():
    taped = scene(speed=16.0, limit=85 * MPH, signs=[limit_sign(85)])
    verdict = US.decide(taped, "accelerate")
    assert verdict.decision.value == "override" and "san.limit.implausible" in verdict.rules
    assert "the limit reading of 38.0 m/s (85 mph) is doubted: above any plausible limit for the zone" in verdict.justification.text
    assert limit_in_force(taped) == 15.65


def test_a_map_that_agrees_vouches_for_a_high_reading():
    road = dict(speed=30.0, zone="road", limit=75 * MPH)
    assert limit_in_force(scene(**road)) == 24.59  # above any plausible road limit: the usual one applies
    assert limit_in_force(scene(**road, map_speed_limit=75 * MPH)) == 33.53


def test_the_lower_of_map_and_sign_governs():
    assert limit_in_force(scene(zone="road", limit=20.0, map_speed_limit=24.0)) == 20.0
    assert limit_in_force(scene(zone="road", limit=24.0, map_speed_limit=20.0)) == 20.0


def test_a_lower_reading_takes_effect_at_once_and_a_higher_one_on_its_second_frame():
    before = [scene(frame=i, zone="road", limit=20.0) for i in (1, 2)]
    assert limit_in_force(scene(frame=3, zone="road", limit=15.0), before) == 15.0
    assert limit_in_force(scene(frame=3, zone="road", limit=24.0), before) == 20.0
    assert limit_in_force(scene(frame=4, zone="road", limit=24.0), before[1:] + [scene(frame=3, zone="road", limit=24.0)]) == 24.0


def test_the_plausible_reading_wins_when_the_sign_and_the_perceived_limit_disagree():
    assert limit_in_force(scene(limit=13.0, signs=[limit_sign(85)])) == 13.0


def test_a_doubted_reading_is_reported_with_an_approval():
    verdict = US.decide(scene(speed=10.0, limit=85 * MPH), "cruise")
    assert verdict.decision.value == "approve" and "san.limit.implausible" in verdict.rules
    assert verdict.justification.tree == []  # the fast path still names the rule, without a tree


def test_the_core_catalog_alone_believes_the_perceived_limit():
    core = Reasoner(catalog=load_catalog([catalog_dirs()[0]], extra_files=[jurisdiction_pack("us")]), providers=[])
    answer = core.solve(scene(speed=16.0, limit=85 * MPH), "cruise").answer
    assert [s.arguments[0].number for s in answer.of("effective_limit", 1)] == [3800]


def test_a_stop_sign_misread_as_a_limit_does_not_set_the_limit():
    misread = scene(speed=5.0, limit=None, signs=[limit_sign(45)],
                    intersection={"type": "unsignaled", "stage": "arriving", "stop_line": True},
                    objects=[obj(1, "car", -3.5, -20.0, 1)], lanes=2, lane=2)
    assert limit_in_force(misread) == 15.65  # the zone's usual limit, not the "45" of the stickered sign
