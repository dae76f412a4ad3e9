import json

from clingo import Function, Number, String

from discern.rules.justify import first_argument
from discern.rules.render import render_html, render_json, render_text
from discern.rules.verdict import Verdict
from tests.scenes import obj, scene


def test_veto_names_the_vetoing_rules_and_the_numbers(reasoner):
    verdict = reasoner.decide(scene(speed=4, objects=[obj("pedestrian", 0, 6, lane=1)]), "accelerate")
    assert verdict.decision.value == "override" and verdict.action.value == "brake"
    assert {"acc.lane_not_clear", "acc.hazard", "brake.obstacle_ahead"} <= set(verdict.rules)
    text = verdict.justification.text
    assert "pedestrian 1 is 6.0 m ahead" in text and "6.0 m < 10.0 m" in text
    assert "accelerate is forbidden, because  [acc.hazard]" in text


def test_negative_justification_says_there_is_no_evidence(reasoner):
    verdict = reasoner.decide(scene(speed=5, limit=15), "accelerate", explain=True)
    text = verdict.justification.text
    assert "there is no evidence that accelerate is forbidden, because" in text
    assert "rule acc.red_light needs that the traffic light is red, and there is no evidence of it" in text


def test_hierarchy_is_not_spelled_out_class_by_class(reasoner):
    verdict = reasoner.decide(scene(speed=4, objects=[obj("pedestrian", 0, 6, lane=1)]), "accelerate", explain=True)
    assert "there is no evidence that a pedestrian is a kind of automobile" in verdict.justification.text
    assert "rule ent.transitive" not in verdict.justification.text


def test_approval_fast_path_has_summary_and_rules_without_tree(reasoner):
    verdict = reasoner.decide(scene(speed=5, limit=15), "accelerate")
    assert verdict.justification.tree == [] and verdict.rules == ["dec.permitted", "acc.below_limit"]
    assert verdict.justification.summary.startswith("approve accelerate")


def test_json_rendering_round_trips_the_verdict(reasoner):
    verdict = reasoner.decide(scene(lane=1, lanes=2), "change_lane_left")
    again = Verdict.model_validate(json.loads(render_json(verdict)))
    assert again == verdict and render_text(again.justification) == verdict.justification.text


def test_html_is_self_contained_with_collapsible_nodes(reasoner):
    page = render_html(reasoner.decide(scene(lane=1, lanes=2), "change_lane_left"))
    assert "<details open><summary>" in page and "cll.no_lane" in page
    assert "http://" not in page and "https://" not in page and "<script" not in page


def test_veto_proof_is_compact_unless_an_explanation_is_asked_for(reasoner):
    sc = scene(speed=4, objects=[obj("pedestrian", 0, 6, lane=1)])
    brief = reasoner.decide(sc, "accelerate").justification.text
    full = reasoner.decide(sc, "accelerate", explain=True).justification.text
    assert "braking from 4.0 m/s takes 5.3 m" in full and "braking from" not in brief
    assert "pedestrian 1 is 6.0 m ahead" in brief and len(brief) < len(full)


def test_an_atoms_first_argument_is_cut_from_its_text_as_clingo_prints_it():
    args = [Number(-5), Function("obstacle", [Number(1), Number(2)]), Function("", [Number(1), Function("a")]),
            String('a,b"),('), Function("cruise")]
    for first in args:
        atom = Function("p", [first, Number(3)])
        assert first_argument(str(atom)) == str(first)
        assert first_argument(str(Function("q", [first]))) == str(first)
