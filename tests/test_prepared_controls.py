import weakref

import pytest

from discern.adapters.avcsr import read_dir
from discern.rules import controls
from discern.rules.controls import PreparedControls
from discern.rules.engine import Reasoner
from discern.sanity import window_reasoner
from tests.test_batch import _comparable, _frames


def test_verdicts_on_controls_readied_in_idle_time_equal_verdicts_on_fresh_ones(avcsr_dir):
    frames = [(f.scene, f.expected, ()) for f in read_dir(avcsr_dir)] + _frames(7, 24)
    fresh, warm = window_reasoner(), window_reasoner()
    for scene, action, history in frames:
        warm.decide(scene, action, history)
    warm.prepare()
    for i, (scene, action, history) in enumerate(frames):
        explain = i % 2 == 0
        verdict = warm.decide(scene, action, history, explain=explain)
        assert warm.prepare() == 1  # the frame took its slice's ready Control, so idle time makes it anew
        assert _comparable(verdict) == _comparable(fresh.decide(scene, action, history, explain=explain))


def test_idle_time_readies_each_recent_slice_once(avcsr_dir):
    frame = read_dir(avcsr_dir)[0]
    reasoner = window_reasoner()
    reasoner.decide(frame.scene, frame.expected)
    assert reasoner.prepare() == 1
    assert reasoner.prepare() == 0


def test_a_frame_takes_the_control_readied_for_its_slice_instead_of_making_one():
    made = []
    prepared = PreparedControls(lambda names: made.append(names) or [])
    prepared.take(frozenset({"p"}))
    prepared.prepare()
    assert len(made) == 2
    prepared.take(frozenset({"p"}))
    assert len(made) == 2


def test_idle_time_readies_the_most_recent_slice_first():
    made = []
    prepared = PreparedControls(lambda names: made.append(names) or [])
    older, newer = frozenset({"older"}), frozenset({"newer"})
    prepared.take(older)
    prepared.take(newer)
    assert prepared.prepare(limit=1) == 1
    assert made[-1] == newer
    assert prepared.prepare() == 1
    assert made[-1] == older


def test_a_slice_learned_from_another_is_readied_in_its_place():
    made = []
    prepared = PreparedControls(lambda cut: made.append(cut) or [])
    whole, learned = frozenset({"p", "q"}), frozenset({"p"})
    prepared.take(whole)
    prepared.succeed([whole], learned)
    assert prepared.prepare() == 1
    assert made[-1] == learned


def test_after_a_kinds_first_frame_idle_time_readies_the_slice_its_next_frames_take(avcsr_dir):
    frame = read_dir(avcsr_dir)[0]
    reasoner = window_reasoner()
    reasoner.decide(frame.scene, frame.expected)  # grounds the whole slice and learns the kind's
    assert reasoner.prepare() == 1
    text = reasoner.frame_facts(frame.scene, frame.expected, ())
    slicer = reasoner.slicer
    control = slicer.controls.take(slicer.learned(slicer.kind(reasoner.predicates_of(text), text)))
    assert list(control.symbolic_atoms.by_signature("param", 2))  # made in idle time: its static part is grounded


def test_only_the_most_recent_slices_are_kept_ready():
    prepared = PreparedControls(lambda names: [])
    for i in range(controls.RECENT_SLICES + 5):
        prepared.take(frozenset({f"p{i}"}))
    assert prepared.prepare() == controls.RECENT_SLICES


def test_a_retired_control_is_freed_at_once_where_nothing_prepares_controls():
    prepared = PreparedControls(lambda names: [])
    control = prepared.take(frozenset({"p"}))
    freed = weakref.ref(control)
    prepared.retire(control)
    del control
    assert freed() is None


def test_a_retired_control_is_freed_by_the_next_prepare_or_at_once_past_the_limit():
    prepared = PreparedControls(lambda names: [])
    prepared.prepare()  # a caller with idle time
    freed = []
    for _ in range(controls.SPENT_HELD + 1):
        control = prepared.take(frozenset({"p"}))
        freed.append(weakref.ref(control))
        prepared.retire(control)
        del control
    assert [ref() is None for ref in freed] == [False] * controls.SPENT_HELD + [True]
    prepared.prepare()
    assert all(ref() is None for ref in freed)


def test_a_readied_control_has_what_no_frame_changes_grounded_before_the_frame_comes(avcsr_dir):
    frame = read_dir(avcsr_dir)[0]
    reasoner = window_reasoner()
    for _ in range(2):  # the first frame of its kind learns the slice (presence.py), the second uses it
        reasoner.decide(frame.scene, frame.expected)
    reasoner.prepare()
    text = reasoner.frame_facts(frame.scene, frame.expected, ())
    control = reasoner.slicer.controls.take(reasoner.slicer.learned(reasoner.slicer.kind(reasoner.predicates_of(text), text)))
    atoms = control.symbolic_atoms
    assert any(a.symbol.arguments[0].name == "car" for a in atoms.by_signature("is_a", 2))  # the class hierarchy
    assert any(a.symbol.arguments[0].name == "reaction_ms" for a in atoms.by_signature("param", 2))  # the parameters
    assert not list(atoms.by_signature("ego_speed", 1)) and not list(atoms.by_signature("permitted", 1))


def test_a_frame_fact_of_a_predicate_the_catalog_defines_for_every_frame_is_refused_by_name(avcsr_dir):
    class Relabels:
        predicates = frozenset({("is_a", 2)})
        params = frozenset()

        def facts(self, scene, history):
            return "is_a(car,bicycle)."

    frame = read_dir(avcsr_dir)[0]
    reasoner = Reasoner(providers=[Relabels()])
    for _ in range(2):  # every such frame, not only the first of its kind
        with pytest.raises(ValueError, match="frame fact is_a is defined by the catalog"):
            reasoner.decide(frame.scene, frame.expected)
