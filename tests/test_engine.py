import json
import random
import shutil

import clingo
import pytest
from pydantic import ValidationError

from discern.rules.catalog import catalog_dirs, load_driving_rules
from discern.rules.engine import Request, jurisdiction_pack
from discern.rules.fact_text import fact_names
from discern.rules.facts import Params, scene_facts
from discern.rules.scene import Action, Scene
from discern.sanity import window_reasoner
from tests.conftest import REPO
from tests.scenes import obj, scene, sensor

CLASSES = ["car", "truck", "pedestrian", "bicycle", "plastic_bag", "roadblock", "unknown"]


def random_scene(rng: random.Random):
    lanes = rng.randint(1, 4)
    objects = [obj(rng.choice(CLASSES), rng.uniform(-8, 8), rng.uniform(-30, 60), lane=rng.randint(1, lanes),
                   vy=rng.choice([None, rng.uniform(0, 30)])) for _ in range(rng.randint(0, 6))]
    extra = {}
    if rng.random() < 0.4:
        extra["intersection"] = {"type": "four_way", "stage": rng.choice(["arriving", "at", "enter"])}
    if rng.random() < 0.3:  # an arrow beside the ball, or alone
        arrow = {"colour": rng.choice(["red", "yellow", "green"]), "direction": rng.choice(["straight", "left", "right"])}
        extra["traffic_lights"] = [arrow] + ([{"colour": rng.choice(["red", "green"])}] if rng.random() < 0.7 else [])
    return scene(speed=rng.uniform(0, 30), lane=rng.randint(1, lanes), lanes=lanes, limit=rng.choice([None, 15, 30]),
                 objects=objects, light=rng.choice([None, "red", "green", "yellow"]),
                 sensors=rng.choice([(), [sensor("left", rng.uniform(0, 3))]]),
                 intent=rng.choice(["continue_in_lane", "merge_into_left_lane", "enter_right_lane"]), **extra)


def full_model(reasoner, sc, history=()):
    """The answer set of the catalog files as written (no slicing, no rewriting), solved by clingo."""
    ctl = clingo.Control(["--warn=none"])
    for path in [p for d in catalog_dirs() for p in sorted(d.glob("*.lp"))] + [jurisdiction_pack(reasoner.jurisdiction)]:
        ctl.load(str(path))
    provided = "".join(p.facts(sc, history) for p in reasoner.providers)
    ctl.add("base", [], reasoner._param_facts + scene_facts(sc, Action.cruise) + provided)
    ctl.ground([("base", [])])
    atoms = []
    ctl.solve(on_model=lambda m: atoms.extend(m.symbols(atoms=True)))
    return set(atoms)


@pytest.mark.parametrize("jurisdiction", ["us", "uk"])
def test_grounded_slice_equals_the_solved_answer_set_of_the_full_program(jurisdiction):
    # fresh: it learns from these frames alone which rules can fire (presence.py); its rules specialised to the
    # jurisdiction's settings and parameters (specialize.py)
    reasoner = window_reasoner(jurisdiction=jurisdiction)
    rng = random.Random(7)
    previous = random_scene(rng)
    for _ in range(150):
        sc = random_scene(rng)
        history = (previous.model_copy(update={"frame_id": sc.frame_id - 1, "timestamp": sc.timestamp - 0.1}),)
        assert set(reasoner.solve(sc, "cruise", history).answer.all()) == full_model(reasoner, sc, history)
        previous = sc


def test_an_arrow_is_a_lamp_of_its_own_in_the_facts_and_a_ball_keeps_its_colour():
    lights = [{"colour": "green"}, {"colour": "red", "direction": "left"}, {"colour": "yellow", "direction": "straight", "flashing": True},
              {"colour": "none", "direction": "right"}]
    facts = scene_facts(scene(traffic_lights=lights))
    for fact in ("traffic_light(green).", "light_steady(green).", "traffic_light(red_left_arrow).",
                 "light_steady(red_left_arrow).", "light_flashing(yellow_straight_arrow)."):
        assert fact in facts
    assert "right_arrow" not in facts and "traffic_light(red)." not in facts


def test_a_light_without_a_direction_is_a_ball_and_a_direction_must_be_a_movement():
    assert Scene.model_validate({**scene().model_dump(by_alias=True), "traffic_lights": [{"colour": "red"}]}).traffic_lights[0].direction is None
    with pytest.raises(ValueError, match="direction"):
        scene(traffic_lights=[{"colour": "red", "direction": "u_turn"}])


def test_fact_names_found_for_slicing_include_zero_arity_facts():
    assert fact_names("a(1).stop_line.b(x,2).") == {"a", "stop_line", "b"}


def test_fact_names_skip_dots_inside_quoted_ids():
    assert fact_names('ego_path("a.param").obj_path(1,"x.\\".forbidden").zone(city).') == {"ego_path", "obj_path", "zone"}


def test_path_id_that_reads_like_a_parameter_fact_is_decided_alone_and_in_a_batch(reasoner):
    scene = Scene.model_validate_json((REPO / "docs/examples/scene.json").read_text(encoding="utf-8"))
    dotted = scene.model_copy(update={"ego": scene.ego.model_copy(update={"predicted_path": "a.param"})})
    alone = reasoner.decide(dotted, "cruise")
    batched = reasoner.decide_many([Request(dotted, "cruise"), Request(scene, "cruise")])[0]
    assert alone.decision == batched.decision == reasoner.decide(scene, "cruise").decision


def test_recommended_action_is_always_permitted(reasoner):
    rng = random.Random(11)
    for _ in range(60):
        verdict = reasoner.decide(random_scene(rng), "accelerate")
        assert verdict.recommended in verdict.permitted
        assert verdict.action in verdict.permitted


def test_stopping_gap_grows_with_speed(reasoner):
    box = [obj("roadblock", 0, 40, lane=1)]
    assert reasoner.decide(scene(speed=10, limit=40, objects=box), "cruise").decision.value == "approve"
    fast = reasoner.decide(scene(speed=25, limit=40, objects=box), "cruise")
    assert fast.decision.value == "override" and "brake.obstacle_ahead" in fast.rules
    assert "braking from 25.0 m/s takes 77.1 m" in reasoner.decide(scene(speed=25, limit=40, objects=box), "cruise",
                                                                     explain=True).justification.text


def test_latency_and_frame_are_reported(reasoner):
    verdict = reasoner.decide(scene(frame=42), "cruise", vehicle="car7")
    assert verdict.frame_id == 42 and verdict.vehicle == "car7" and verdict.latency_ms > 0


def test_a_forbidden_lane_change_is_replaced_by_holding_the_speed_not_by_speeding_up(reasoner):
    verdict = reasoner.decide(scene(speed=10, limit=15), "change_lane_left")
    decided = (verdict.decision.value, verdict.action.value, verdict.recommended.value)
    assert decided == ("override", "cruise", "accelerate")
    assert verdict.justification.summary.endswith("; recommended: accelerate")
    assert "cruise replaces the forbidden proposal, because  [dec.replacement_holds_speed]" in verdict.justification.text


def test_a_forbidden_proposal_is_replaced_by_the_recommended_action_when_that_is_not_speeding_up(reasoner):
    verdict = reasoner.decide(scene(speed=10, limit=15, objects=[obj("pedestrian", 0, 6, lane=1)]), "change_lane_left")
    assert (verdict.action.value, verdict.recommended.value) == ("brake", "brake")
    assert "brake replaces the forbidden proposal, because  [dec.replacement]" in verdict.justification.text


def test_accelerating_is_forbidden_within_one_step_of_the_limit():
    stepping = window_reasoner(params=Params(accel_step=5.0))
    assert "acc.at_limit" in stepping.decide(scene(speed=11, limit=15), "accelerate").rules
    assert stepping.decide(scene(speed=10, limit=15), "accelerate").decision.value == "approve"
    assert window_reasoner().decide(scene(speed=11, limit=15), "accelerate").decision.value == "approve"


def test_a_shadow_veto_proves_the_recommendation_for_nothing_replaces_the_proposal(reasoner):
    verdict = reasoner.decide(scene(speed=10, limit=15), "change_lane_left", shadow=True)
    assert (verdict.decision.value, verdict.action.value) == ("veto", "change_lane_left")
    assert "replaces the forbidden proposal" not in verdict.justification.text
    assert "accelerate is the recommended action, because  [dec.preference]" in verdict.justification.text


def test_an_override_with_nothing_recommended_says_that_the_brake_is_the_monitors_own_choice(tmp_path):
    """An edited catalog may recommend nothing: the brake executed must not come without a word for it."""
    edited = tmp_path / "catalog"
    shutil.copytree(catalog_dirs()[0], edited)
    decision = edited / "90_decision.lp"
    text = decision.read_text()
    rule = "recommended(A) :- suggested(A), not outranked(A).\n"
    assert rule in text
    decision.write_text(text.replace(rule, "recommended(A) :- suggested(A), not outranked(A), not suggested(A).\n"))
    reasoner = window_reasoner(catalog=load_driving_rules([edited], extra_files=[jurisdiction_pack("us")]))
    verdict = reasoner.decide(scene(speed=4, objects=[obj("pedestrian", 0, 6, lane=1)]), "accelerate")
    assert (verdict.decision.value, verdict.action.value, verdict.recommended) == ("override", "brake", None)
    last = verdict.justification.tree[-1]
    assert (last.literal, last.holds, last.kind) == ("not recommended(_)", True, "absent")
    assert "no evidence that any action is recommended: the monitor brakes" in verdict.justification.text


def test_a_catalog_written_before_replacements_overrides_with_the_recommended_action(tmp_path):
    """An edited copy of rules/catalog from before replacement/1 (given with --rules) decides as it did then."""
    older = tmp_path / "catalog"
    shutil.copytree(catalog_dirs()[0], older)
    decision = older / "90_decision.lp"
    text = decision.read_text()
    start = text.index("%! rule dec.replacement\n")
    end = text.index("held_instead(accelerate) :- permitted(cruise).\n") + len("held_instead(accelerate) :- permitted(cruise).\n")
    decision.write_text(text[:start] + text[end:])
    reasoner = window_reasoner(catalog=load_driving_rules([older], extra_files=[jurisdiction_pack("us")]))
    verdict = reasoner.decide(scene(speed=10, limit=15), "change_lane_left", explain=True)
    assert (verdict.decision.value, verdict.action.value) == ("override", "accelerate")
    assert "accelerate is the recommended action, because  [dec.preference]" in verdict.justification.text


def test_a_scene_given_as_json_is_decided_as_the_model_it_validates_to(reasoner):
    data = json.loads((REPO / "docs" / "examples" / "scene.json").read_text())
    as_json = reasoner.decide(data, "accelerate")
    assert as_json.justification.summary == reasoner.decide(Scene.model_validate(data), "accelerate").justification.summary
    with pytest.raises(ValidationError, match="ego"):
        reasoner.decide({"frame_id": 1}, "cruise")
