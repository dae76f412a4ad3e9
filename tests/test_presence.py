"""Frames grounded with only the rules that can fire, as learned from earlier frames, get the whole slice's answers.

test_engine.py compares a long varied run's answer sets with the full program's."""

from discern.adapters.avcsr import read_dir
from discern.rules.catalog import load_catalog
from discern.rules.engine import Reasoner
from discern.rules.scene import Action
from discern.rules.terms import pattern_text
from tests.scenes import obj, scene


def fact_names(reasoner, sc, proposed="cruise"):
    return reasoner.predicates_of(reasoner.frame_facts(sc, Action(proposed), ()))


def test_a_predicate_absent_from_earlier_frames_is_derived_when_a_frame_has_it():
    reasoner, fresh = Reasoner(), Reasoner()
    far, near = scene(objects=[obj("pedestrian", 0, 80, lane=1)]), scene(objects=[obj("pedestrian", 0, 6, lane=1)])
    assert fact_names(reasoner, far) == fact_names(reasoner, near)  # the same kinds of facts: one learned set
    reasoner.decide(far, "accelerate")
    assert "hazard" not in reasoner.slicer.learned(fact_names(reasoner, far)).present
    verdict = reasoner.decide(near, "accelerate")
    assert verdict.model_dump(exclude={"latency_ms"}) == fresh.decide(near, "accelerate").model_dump(exclude={"latency_ms"})
    assert verdict.action.value == "brake" and "brake.obstacle_ahead" in verdict.rules
    assert "hazard" in reasoner.slicer.learned(fact_names(reasoner, near)).present


def test_kitti_frames_ground_fewer_rules_than_their_slice_once_learned(avcsr_dir):
    reasoner = Reasoner()
    frames = read_dir(avcsr_dir)
    for f in frames:
        reasoner.decide(f.scene, f.expected)
    catalog = reasoner.catalog
    for f in frames:
        names = fact_names(reasoner, f.scene, f.expected.value)
        learned = reasoner.slicer.learned(names)
        assert len(catalog.rules_within(learned.present, learned.absent)) < len(catalog.rules_within(learned.present))
        assert len(catalog.rules_within(learned.present)) < len(catalog.program_for(names))


def test_a_pattern_absent_from_earlier_frames_is_matched_when_a_frame_has_it():
    reasoner, fresh = Reasoner(), Reasoner()
    onward, merging = scene(lanes=2), scene(lanes=2, intent="merge_into_right_lane")
    names = fact_names(reasoner, onward)
    assert names == fact_names(reasoner, merging)  # intent(continue_in_lane), intent(merge_into_right_lane): one kind
    reasoner.decide(onward, "cruise")
    assert "intent(merge_into_right_lane)" in {pattern_text(p) for p in reasoner.slicer.learned(names).absent}
    before = reasoner.slicer.regrounds
    verdict = reasoner.decide(merging, "change_lane_right")
    assert reasoner.slicer.regrounds == before + 1
    assert verdict.model_dump(exclude={"latency_ms"}) == fresh.decide(merging, "change_lane_right").model_dump(exclude={"latency_ms"})
    assert "clr.intent_merge" in verdict.rules  # the rule left out before: the intent calls for the lane change
    assert "intent(merge_into_right_lane)" not in {pattern_text(p) for p in reasoner.slicer.learned(names).absent}
    reasoner.decide(merging, "change_lane_right")
    assert reasoner.slicer.regrounds == before + 1  # learned: the next such frame is grounded once


def test_a_rule_requires_the_constants_and_functors_of_its_positive_atoms_not_their_variables(tmp_path):
    (tmp_path / "r.lp").write_text(
        "%! rule x.a\n%! says A.\n%! source s\n"
        "a(X) :- p(X, left, f(Y), Z+1), q(X), r(c), not s(d), X > 0.\n")
    rule = load_catalog([tmp_path]).compiled[0]
    assert {pattern_text(p) for p in rule.requires} == {"p(_,left,f(_),_)", "r(c)"}
