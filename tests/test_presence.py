"""Frames grounded with only the rules that can fire, as learned from earlier frames, get the whole slice's answers.

test_engine.py compares a long varied run's answer sets with the full program's."""

from discern.adapters.avcsr import read_dir
from discern.rules.catalog import load_catalog
from discern.rules.presence import PresenceSlicer
from discern.rules.scene import Action
from discern.rules.terms import pattern_text
from discern.sanity import window_reasoner
from tests.scenes import obj, scene


def kind_of(reasoner, sc, proposed="cruise"):
    text = reasoner.frame_facts(sc, Action(proposed), ())
    return reasoner.slicer.kind(reasoner.predicates_of(text), text)


def test_a_predicate_absent_from_earlier_frames_is_derived_when_a_frame_has_it():
    reasoner, fresh = window_reasoner(), window_reasoner()
    far, near = scene(objects=[obj("pedestrian", 0, 80, lane=1)]), scene(objects=[obj("pedestrian", 0, 6, lane=1)])
    assert kind_of(reasoner, far) == kind_of(reasoner, near)  # the same kinds of facts: one learned set
    reasoner.decide(far, "accelerate")
    assert "hazard" not in reasoner.slicer.learned(kind_of(reasoner, far)).present
    verdict = reasoner.decide(near, "accelerate")
    assert verdict.model_dump(exclude={"latency_ms"}) == fresh.decide(near, "accelerate").model_dump(exclude={"latency_ms"})
    assert verdict.action.value == "brake" and "brake.obstacle_ahead" in verdict.rules
    assert "hazard" in reasoner.slicer.learned(kind_of(reasoner, near)).present


def test_kitti_frames_ground_fewer_rules_than_their_slice_once_learned(avcsr_dir):
    reasoner = window_reasoner()
    frames = read_dir(avcsr_dir)
    for f in frames:
        reasoner.decide(f.scene, f.expected)
    catalog = reasoner.catalog
    for f in frames:
        kind = kind_of(reasoner, f.scene, f.expected.value)
        names = kind[0]
        learned = reasoner.slicer.learned(kind)
        left_out = learned.absent | learned.unmatched
        assert len(catalog.rules_within(learned.present, left_out)) < len(catalog.rules_within(learned.present))
        assert len(catalog.rules_within(learned.present)) < len(catalog.program_for(names))


def test_a_pattern_that_the_facts_match_makes_a_frame_of_another_kind_grounded_without_a_guard():
    reasoner, fresh = window_reasoner(), window_reasoner()
    onward, merging = scene(lanes=2), scene(lanes=2, intent="merge_into_right_lane")
    merge = "intent(merge_into_right_lane)"
    assert merge in {pattern_text(p) for p in kind_of(reasoner, onward)[1]}  # its facts match no such atom
    assert merge not in {pattern_text(p) for p in kind_of(reasoner, merging)[1]}
    reasoner.decide(onward, "cruise")
    learned = reasoner.slicer.learned(kind_of(reasoner, onward))
    assert merge in {pattern_text(p) for p in learned.unmatched} and merge not in {pattern_text(p) for p in learned.absent}
    verdict = reasoner.decide(merging, "change_lane_right")
    assert reasoner.slicer.regrounds == 0
    assert verdict.model_dump(exclude={"latency_ms"}) == fresh.decide(merging, "change_lane_right").model_dump(exclude={"latency_ms"})
    assert "clr.intent_merge" in verdict.rules  # the rule the other kind leaves out: the intent calls for the lane change


def test_frames_whose_facts_put_objects_in_other_lanes_learn_apart_and_a_derived_lane_is_still_found():
    """obj_lane is given by facts and derived by rules too: the facts key the kind, a guard checks what rules add."""
    reasoner, fresh = window_reasoner(), window_reasoner()
    pavement = dict(cls="pedestrian", y=10, lane=1, kind="sidewalk_right")
    beside, ahead, in_lane = (scene(other_lanes=("sidewalk_right",), objects=[o]) for o in (
        obj(x=4.0, **pavement), obj(x=0.5, **pavement), obj("pedestrian", 0.5, 10, lane=1)))
    assert kind_of(reasoner, beside) == kind_of(reasoner, ahead)  # the same facts but for a position: one kind
    assert kind_of(reasoner, beside) != kind_of(reasoner, in_lane)
    reasoner.decide(in_lane, "cruise")
    reasoner.decide(beside, "cruise")
    learned = reasoner.slicer.learned(kind_of(reasoner, beside))
    assert "in_ego_lane" not in learned.present  # not learned from the frame with a pedestrian in the ego's lane
    assert "obj_lane(_,current,_)" in {pattern_text(p) for p in learned.absent}
    verdict = reasoner.decide(ahead, "cruise")  # labelled on the pavement, yet in the ego's path: moved into its lane
    assert reasoner.slicer.regrounds == 1
    assert verdict.model_dump(exclude={"latency_ms"}) == fresh.decide(ahead, "cruise").model_dump(exclude={"latency_ms"})
    assert verdict.action.value == "brake"


def test_a_derived_pattern_absent_from_earlier_frames_is_matched_when_a_frame_has_it():
    reasoner, fresh = window_reasoner(), window_reasoner()
    right, left = (scene(intersection={"type": "four_way", "stage": "at"}, other_lanes=("cross_left",),
                         objects=[obj("pedestrian", x, 4, lane=1, kind="cross_left")]) for x in (4.0, -4.0))
    kind = kind_of(reasoner, right, "turn_left")  # the proposal is a fact of the kind: the movement a light governs
    assert kind == kind_of(reasoner, left, "turn_left")  # the same facts but for a position: one kind
    reasoner.decide(right, "turn_left")
    assert "crossing_user(_,left)" in {pattern_text(p) for p in reasoner.slicer.learned(kind).absent}
    verdict = reasoner.decide(left, "turn_left")
    assert reasoner.slicer.regrounds == 1  # its guard found the atom: the frame grounded again with the whole slice
    assert verdict.model_dump(exclude={"latency_ms"}) == fresh.decide(left, "turn_left").model_dump(exclude={"latency_ms"})
    assert verdict.decision.value == "override"
    assert "crossing_user(_,left)" not in {pattern_text(p) for p in reasoner.slicer.learned(kind).absent}
    reasoner.decide(left, "turn_left")
    assert reasoner.slicer.regrounds == 1  # learned: the next such frame is grounded once


def test_a_rule_joined_with_a_listed_kind_is_left_out_only_when_no_kind_of_the_list_has_atoms():
    """`obj_lane(O,K,_), crossing_kind(K)`: the catalog lists cross_left and cross_right, so the rule needs one."""
    catalog = window_reasoner().catalog
    crossing = [r for r in catalog.compiled if r.info.id == "def.crossing_user"]
    present = catalog.derivable(frozenset({"object", "obj_pos", "obj_lane", "ego_lane", "lane", "ego_speed"}))
    left, right = (next(p for p in catalog.patterns_within(present) if pattern_text(p) == f"obj_lane(_,{k},_)")
                   for k in ("cross_left", "cross_right"))
    assert crossing and all(catalog.alternatives[r.index] == (frozenset({left, right}),) for r in crossing)
    statements = [r.statement for r in crossing]
    assert all(s in catalog.rules_within(present, frozenset({left})) for s in statements)
    assert not any(s in catalog.rules_within(present, frozenset({left, right})) for s in statements)


def test_frames_without_crossing_traffic_ground_no_crossing_rules_and_a_crossing_frame_decides_as_alone():
    reasoner, fresh = window_reasoner(), window_reasoner()
    crossing = scene(intersection={"type": "four_way", "stage": "at"}, other_lanes=("cross_left",),
                     objects=[obj("pedestrian", -4.0, 4, lane=1, kind="cross_left")])
    quiet = scene(intersection={"type": "four_way", "stage": "at"}, other_lanes=("cross_left",),
                  objects=[obj("car", 0.0, 30, lane=1)])
    reasoner.decide(quiet, "turn_left")
    text = reasoner.frame_facts(quiet, Action("turn_left"), ())
    program = reasoner.slicer.program(reasoner.slicer.learned(kind_of(reasoner, quiet, "turn_left")))
    ids = {r.statement: r.info.id for r in reasoner.catalog.compiled}
    assert "lane(cross_left,1)" in text and "def.crossing_user" not in {ids.get(s) for s in program}
    verdict = reasoner.decide(crossing, "turn_left")
    assert verdict.model_dump(exclude={"latency_ms"}) == fresh.decide(crossing, "turn_left").model_dump(exclude={"latency_ms"})
    assert verdict.decision.value == "override"


def test_a_rule_requires_the_constants_and_functors_of_its_positive_atoms_not_their_variables(tmp_path):
    (tmp_path / "r.lp").write_text(
        '%! pred a(X) :: "@(X) is an a"\n%! rule x.a\n%! says A.\n%! source s\n'
        "a(X) :- p(X, left, f(Y), Z+1), q(X), r(c), not s(d), X > 0.\n")
    rule = load_catalog([tmp_path]).compiled[0]
    assert {pattern_text(p) for p in rule.requires} == {"p(_,left,f(_),_)", "r(c)"}


def test_a_derived_predicate_that_no_left_out_rule_needs_gets_atoms_without_grounding_the_frame_again(tmp_path):
    (tmp_path / "r.lp").write_text(
        '%! pred p(X) :: "@(X) is a p"\n%! pred q(X) :: "@(X) is a q"\n%! pred r(X) :: "@(X) is an r"\n'
        "%! rule x.p\n%! says P.\n%! source s\np(X) :- f(X), X > 9.\n"
        "%! rule x.q\n%! says Q.\n%! source s\nq(X) :- f(X), X > 5.\n"
        "%! rule x.r\n%! says R.\n%! source s\nr(X) :- p(X), g(X).\n")
    slicer = PresenceSlicer(load_catalog([tmp_path]))
    names = frozenset({"f", "g"})

    def atoms(text):
        control = slicer.ground(names, text)
        return {str(a.symbol) for a in control.symbolic_atoms if a.symbol.name in ("p", "q", "r")}

    assert atoms("f(1).g(1).") == set()
    assert atoms("f(7).g(7).") == {"q(7)"} and slicer.regrounds == 0  # r, left out, needs p, which has none; no rule needs q
    assert atoms("f(10).g(10).") == {"p(10)", "q(10)", "r(10)"} and slicer.regrounds == 1
