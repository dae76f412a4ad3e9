"""Frames grounded with only the rules that can fire, as learned from earlier frames, get the whole slice's answers.

test_engine.py compares a long varied run's answer sets with the full program's."""

from discern.adapters.avcsr import read_dir
from discern.rules.engine import Reasoner
from discern.rules.scene import Action
from tests.scenes import obj, scene


def fact_names(reasoner, sc, proposed="cruise"):
    return reasoner.predicates_of(reasoner.frame_facts(sc, Action(proposed), ()))


def test_a_predicate_absent_from_earlier_frames_is_derived_when_a_frame_has_it():
    reasoner, fresh = Reasoner(), Reasoner()
    far, near = scene(objects=[obj("pedestrian", 0, 80, lane=1)]), scene(objects=[obj("pedestrian", 0, 6, lane=1)])
    assert fact_names(reasoner, far) == fact_names(reasoner, near)  # the same kinds of facts: one learned set
    reasoner.decide(far, "accelerate")
    assert "hazard" not in reasoner.slicer.learned(fact_names(reasoner, far))
    verdict = reasoner.decide(near, "accelerate")
    assert verdict.model_dump(exclude={"latency_ms"}) == fresh.decide(near, "accelerate").model_dump(exclude={"latency_ms"})
    assert verdict.action.value == "brake" and "brake.obstacle_ahead" in verdict.rules
    assert "hazard" in reasoner.slicer.learned(fact_names(reasoner, near))


def test_kitti_frames_ground_fewer_rules_than_their_slice_once_learned(avcsr_dir):
    reasoner = Reasoner()
    frames = read_dir(avcsr_dir)
    for f in frames:
        reasoner.decide(f.scene, f.expected)
    catalog = reasoner.catalog
    for f in frames:
        names = fact_names(reasoner, f.scene, f.expected.value)
        learned = reasoner.slicer.learned(names)
        assert len(catalog.rules_within(learned)) < len(catalog.program_for(names))
