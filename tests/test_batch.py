import random

import pytest

from bench.scenes import random_scene as dense_scene
from discern.adapters.avcsr import read_dir
from discern.monitor.example_planner import highway_scene, planner_action
from discern.rules.batch import FrameTagger, static_predicates
from discern.rules.engine import Request
from discern.rules.scene import Action
from tests.test_engine import full_model, random_scene


def _comparable(verdict):
    return verdict.model_dump(exclude={"latency_ms"})


def _frames(seed, count):
    rng = random.Random(seed)
    previous = random_scene(rng)
    out = []
    for _ in range(count):
        sc = random_scene(rng)
        history = (previous.model_copy(update={"frame_id": sc.frame_id - 1, "timestamp": sc.timestamp - 0.1}),)
        out.append((sc, rng.choice(["cruise", "accelerate", "brake", "change_lane_left", "turn_right"]), history))
        previous = sc
    return out


def test_each_frame_of_a_batch_has_exactly_its_solo_answer_set(reasoner):
    frames = _frames(3, 30)
    solved = reasoner.solve_many([(sc, "cruise", history) for sc, _, history in frames])
    for (sc, _, history), one in zip(frames, solved):
        assert set(one.answer.all()) == full_model(reasoner, sc, history)


def test_batched_verdicts_equal_one_by_one_verdicts_with_their_proofs(reasoner):
    frames = _frames(5, 24)
    requests = [Request(sc, action, history, explain=i % 3 == 0, shadow=i % 5 == 0, vehicle=f"v{i % 4}")
                for i, (sc, action, history) in enumerate(frames)]
    batched = reasoner.decide_many(requests)
    for request, verdict in zip(requests, batched):
        alone = reasoner.decide(request.scene, request.proposed, request.history, explain=request.explain,
                                shadow=request.shadow, vehicle=request.vehicle)
        assert _comparable(verdict) == _comparable(alone)


def test_dense_frames_read_from_their_fact_text_in_a_batch_decide_as_alone(reasoner):
    """A batch's frames read the facts no rule defines from their own fact text, as a solo frame does."""
    rng = random.Random(13)
    actions = ["cruise", "accelerate", "change_lane_left", "brake", "turn_right"]
    requests = [Request(dense_scene(rng, rng.choice([30, 60]), i, perception=i % 2 == 0), actions[i % 5],
                        explain=i % 3 == 0) for i in range(10)]
    batched = reasoner.decide_many(requests)
    assert sum(v.decision.value != "approve" for v in batched) >= 3  # vetoes: proofs that read objects' facts
    for request, verdict in zip(requests, batched):
        alone = reasoner.decide(request.scene, request.proposed, explain=request.explain)
        assert _comparable(verdict) == _comparable(alone)


def test_the_sidecars_highway_frames_decide_in_a_batch_as_alone(reasoner):
    """The example planner's dense highway frames, as a busy worker batches them: vetoes whose proofs look up
    objects' lanes, which frames give and rules derive too."""
    requests = [Request(highway_scene(f, 50), planner_action(f), explain=f % 4 == 0) for f in range(12)]
    batched = reasoner.decide_many(requests)
    assert sum(v.decision.value == "override" for v in batched) >= 3
    assert any("lane" in v.justification.text for v in batched if v.decision.value == "override")
    for request, verdict in zip(requests, batched):
        alone = reasoner.decide(request.scene, request.proposed, explain=request.explain)
        assert _comparable(verdict) == _comparable(alone)


def test_a_batch_decided_from_facts_given_by_the_caller_equals_the_batch_decided_from_scenes(reasoner):
    requests = [Request(sc, Action(action), history) for sc, action, history in _frames(9, 12)]
    facts = [reasoner.frame_facts(r.scene, r.proposed, r.history) for r in requests]
    from_facts = reasoner.decide_many(requests, facts)
    assert [_comparable(v) for v in from_facts] == [_comparable(v) for v in reasoner.decide_many(requests)]


def test_the_papers_kitti_frames_decide_the_same_in_one_batch(reasoner, avcsr_dir):
    frames = read_dir(avcsr_dir)
    batched = reasoner.decide_many([Request(f.scene, f.expected) for f in frames])
    assert [v.action for v in batched] == [f.expected for f in frames]
    assert [_comparable(v) for v in batched] == [_comparable(reasoner.decide(f.scene, f.expected)) for f in frames]


def test_class_hierarchy_and_parameters_are_shared_but_scene_derived_predicates_are_per_frame(reasoner):
    static = static_predicates(reasoner.catalog, shared={"param"})
    assert {"is_a", "rank", "param"} <= static
    assert not {"hazard", "permitted", "applicable", "ego_speed"} & static


def test_frame_tagging_leaves_quoted_strings_alone(reasoner):
    tagger = FrameTagger(reasoner.catalog)
    text = 'ego_path("a.b(c"). stop_line.obj_path(3,"x\\"y.z(").'.replace(" ", "")
    assert tagger.tag_text(text, 7) == 'ego_path(7,"a.b(c").stop_line(7).obj_path(7,3,"x\\"y.z(").'


def _models(reasoner, texts):
    return [set(one.answer.all()) for one in reasoner.solve_facts(texts, [Action.cruise] * len(texts))]


def test_plain_facts_given_as_terms_ground_to_the_same_atoms_as_the_same_facts_parsed(reasoner, avcsr_dir):
    """Generated facts reach clingo as terms; any other text (here: a trailing space) is parsed as text."""
    texts = [reasoner.frame_facts(sc, Action(action), history) for sc, action, history in _frames(7, 20)]
    texts += [reasoner.frame_facts(f.scene, f.expected, ()) for f in read_dir(avcsr_dir)]
    batch = FrameTagger(reasoner.catalog, shared={"param"}).batch(texts)
    assert not batch.text and batch.groups  # all generated text is plain
    assert _models(reasoner, texts) == _models(reasoner, [t + " " for t in texts])


def test_text_that_is_not_plain_facts_is_left_to_clingo(reasoner):
    tagger = FrameTagger(reasoner.catalog)
    for text in ("a(b(1)).", "a(1;2).", "a(1..2).", "-a(1).", "a:-b.", "a().", "a(1,).", "a(1)b.", "A(1).", 'a("x").',
                 "a(1) .", "a(1)", "a(1.b.",
                 "a(-0).", "a(007).", "a(1-2).", "a(_X).", "a(_)."):
        batch = tagger.batch([text])
        assert batch.text and not [g for g in batch.groups if g[0] != "discern_frame"], text


def test_plain_looking_facts_that_are_no_terms_get_clingos_own_parse_error(reasoner):
    with pytest.raises(RuntimeError):
        reasoner.solve_facts(["ego_speed(12-).", "ego_speed(3)."], [Action.cruise] * 2)


def test_a_frame_fact_that_the_catalog_defines_is_refused(reasoner):
    for text in ("is_a(car,vehicle).", "is_a(car, vehicle)."):  # plain text, and text with a space
        with pytest.raises(ValueError, match="is_a"):
            FrameTagger(reasoner.catalog).batch([text])
