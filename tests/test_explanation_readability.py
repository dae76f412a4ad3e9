"""What a safety driver reads first: the deciding reason with its numbers, long lists of rules that did not apply as
one line, exceptions worded as denials, the pack's words for colours, and speeds in the unit of its signs."""

import json
import re

import jsonschema
import pytest

from discern.rules.render import render_html, render_json, render_text
from discern.rules.scene import Scene
from discern.rules.verdict import JustificationNode
from discern.sanity import reasoner_for

SCHEMA = json.loads((__import__("pathlib").Path(__file__).parents[1] / "rules/schema/verdict.schema.json").read_text())

# A car 4 m behind at the ego's speed, nothing ahead: braking is phantom braking (the reviewer's flood repro).
TAILGATED = {"frame_id": 1, "timestamp": 0.1, "ego": {"speed": 10.0, "lane": 1}, "speed_limit": 15.0,
             "lanes": [{"kind": "current", "id": 1}],
             "objects": [{"id": 1, "class": "car", "position": {"y": -4.0}, "lane": {"kind": "current", "id": 1},
                          "velocity": {"y": 10.0}}]}
AT_RED = {"frame_id": 1, "timestamp": 0.1, "ego": {"speed": 0.0, "lane": 2, "zone": "city", "intent": "enter_right_lane"},
          "speed_limit": 13.4, "lanes": [{"kind": "current", "id": 1}, {"kind": "current", "id": 2},
                                         {"kind": "oncoming", "id": 1}, {"kind": "cross_left", "id": 1},
                                         {"kind": "cross_right", "id": 1}],
          "traffic_lights": [{"colour": "red"}], "intersection": {"type": "signaled", "stage": "at", "distance": 0.0},
          "objects": []}
AMBER = {"frame_id": 1, "timestamp": 0.1, "ego": {"speed": 13.41, "lane": 1, "intent": "continue_in_lane", "zone": "city"},
         "speed_limit": 13.41, "lanes": [{"kind": "current", "id": 1}], "traffic_lights": [{"colour": "yellow"}],
         "intersection": {"type": "signaled", "stage": "arriving", "distance": 35.0}}


def _decide(data: dict, proposed: str, pack: str, explain: bool = True):
    return reasoner_for(pack).decide(Scene.model_validate(data), proposed, explain=explain)


def _tags(nodes: list[JustificationNode]) -> set[str]:
    found, pending = set(), list(nodes)
    while pending:
        node = pending.pop()
        found.add(node.rule)
        pending.extend(node.children)
    return found


def test_a_phantom_brake_override_reads_the_deciding_reason_first_in_a_short_text():
    verdict = _decide(TAILGATED, "brake", "uk")
    lines = verdict.justification.text.splitlines()
    assert len(lines) <= 60, len(lines)  # 219 lines before the negative proofs folded
    deciding = next(i for i, line in enumerate(lines) if "4.0 m < 8.0 m" in line)
    assert deciding < 15 and "[brake.no_phantom_braking]" in lines[1]
    full = verdict.justification.full_text().splitlines()
    assert len(full) > 3 * len(lines)  # every line is still there to be asked for


def test_a_negative_proof_over_many_rules_reads_as_one_line_naming_them_and_keeps_them_in_the_tree():
    verdict = _decide(TAILGATED, "brake", "uk")
    text = verdict.justification.text
    line = next(line for line in text.splitlines() if "there is no evidence that there is a reason to brake" in line)
    named = re.search(r"none of the (\d+) rules for it applies: (.*)$", line)
    assert named and named.group(2).startswith("brake.hazard, brake.yellow_light_unknown")
    assert int(named.group(1)) == len(named.group(2).split(", ")) > 10
    assert "rule brake.red_light needs" not in text  # the hazard rules one click away, not 26 lines
    tree = json.loads(render_json(verdict))
    jsonschema.validate(tree, SCHEMA)
    assert "brake.red_light" in json.dumps(tree["justification"]["tree"])  # as child nodes in the JSON
    assert set(verdict.rules) <= _tags(verdict.justification.tree)
    page = render_html(verdict)
    assert f"none of the {named.group(1)} rules for it applies" in page and "rule brake.red_light needs" in page  # folded, there


def test_the_replacements_proof_is_cut_short_in_the_text_but_whole_in_the_full_text():
    verdict = _decide(TAILGATED, "brake", "uk")
    assert "the speed limit in force is 13.4 m/s (30 mph), because …" in verdict.justification.text
    assert "the ego's speed is bounded by a limit of 13.4 m/s (30 mph), because" in verdict.justification.full_text()


def test_an_exception_the_pack_has_no_rule_for_is_not_named():
    text = _decide(AT_RED, "turn_right", "uk").justification.full_text()
    assert "turning right on red" not in text
    assert "no exception applies, as there is no evidence that the light flashes red" in text


@pytest.mark.parametrize("pack", ["us", "uk"])
def test_no_negative_line_states_an_exception_as_a_claim_after_a_colon(pack):
    for data, proposed in ((AT_RED, "turn_right"), (AT_RED, "accelerate"), (AMBER, "cruise"), (AMBER, "accelerate")):
        text = _decide(data, proposed, pack).justification.full_text()
        assert "there is no evidence that an exception applies:" not in text


def test_the_uk_pack_says_amber_and_the_us_pack_yellow():
    uk = _decide(AMBER, "cruise", "uk").justification.full_text()
    assert "there is a hazard: the traffic light is amber" in uk and "the light flashes amber" in uk
    assert "yellow" not in uk.replace("yellow_light", "")  # rule ids keep their names
    us = _decide(AMBER, "accelerate", "us").justification.full_text()
    assert "the traffic light is yellow" in us and "amber" not in us


def test_the_egos_speed_and_its_comparison_with_the_limit_read_in_mph_too():
    over = dict(TAILGATED, objects=[], ego={"speed": 15.66, "lane": 1}, speed_limit=13.41)
    for pack in ("uk", "us"):
        text = _decide(over, "cruise", pack).justification.full_text()
        assert "the ego drives at 15.7 m/s (35 mph)" in text
        # close enough to need two decimals: the sum in them too, as 30 mph is 13.41 m/s only to the centimetre
        assert "15.66 m/s (35.03 mph) > 13.41 m/s (30 mph) + 2.24 m/s (5 mph) = 15.65 m/s (35.01 mph)" in text
    level = dict(over, ego={"speed": 15.65, "lane": 1})
    text = _decide(level, "cruise", "uk").justification.full_text()
    assert "needs that 15.65 m/s (35 mph) > 13.41 m/s (30 mph) + 2.24 m/s (5 mph), which is false" in text


def test_the_full_text_is_what_check_explain_full_prints(capsys):
    verdict = _decide(TAILGATED, "brake", "uk")
    assert render_text(verdict.justification, full=True) == verdict.justification.full_text()
