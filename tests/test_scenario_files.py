from pathlib import Path

import pytest

from discern.rules.scene import Action
from discern.sanity import reasoner_for
from discern.scenarios import runner

ROOT = Path(__file__).resolve().parents[1] / "scenarios"
FILES = sorted(ROOT.rglob("*.json"))


@pytest.mark.parametrize("path", FILES, ids=[str(p.relative_to(ROOT)) for p in FILES])
def test_scenario_gets_its_expected_verdicts(path):
    scenario = runner.load(path)
    outcomes = runner.run(scenario, reasoner_for(scenario.jurisdiction))
    assert [(o.index, o.problems) for o in outcomes if not o.passed] == []


def test_paper_synthetic_and_walkthrough_scenarios_are_present():
    names = {p.stem for p in (ROOT / "paper").glob("*.json")}
    assert {"boxed_in", "object_enters_lane_next_lane_clear", "object_enters_lane_next_lanes_taken",
            "lane_ends_merge_right", "kitti_merge_left_heavy_traffic", "kitti_wait_for_pedestrians_right_turn"} <= names


def test_every_driving_rule_has_a_scenario_file_whose_verdict_cites_it():
    """The decision machinery (dec.*) aside: it is in every verdict's proof, not a rule one scene shows."""
    from discern.rules.catalog import catalog_dirs, load_catalog

    driving = {r.id for r in load_catalog().driving_rules()
               if r.file.startswith(str(catalog_dirs()[0])) and not r.id.startswith("dec.")}
    files = {p.stem: runner.load(p) for p in (ROOT / "rules").glob("*.json")}
    assert driving - set(files) == set()
    assert [rule for rule in driving if not any(rule in f.expect.rules for f in files[rule].frames)] == []


def test_a_wrong_expectation_is_reported_as_a_failure(reasoner):
    scenario = runner.load(ROOT / "paper" / "boxed_in.json")
    scenario.frames[0].expect.action = Action.accelerate
    outcome = runner.run(scenario, reasoner)[0]
    assert not outcome.passed and "expected accelerate" in outcome.problems[0]


def test_a_rule_expected_absent_is_reported_when_the_verdict_cites_it(reasoner):
    scenario = runner.load(ROOT / "paper" / "boxed_in.json")
    cited = runner.run(scenario, reasoner)[0].verdict.rules[0]
    scenario.frames[0].expect.absent_rules = [cited]
    outcome = runner.run(scenario, reasoner)[0]
    assert not outcome.passed and "expected absent" in outcome.problems[0]


def test_every_fact_a_frame_gives_is_of_a_predicate_the_catalog_loader_knows_frames_give():
    """The loader warns of a rule that reads a predicate nothing gives (`Reasoner.frame_predicates`, its providers'
    too) or a window_param no provider names: a frame fact it did not know of would make it warn of a sound rule."""
    import clingo

    from discern.sanity.window import WINDOW_PARAMS

    texts = []
    for path in FILES:
        scenario = runner.load(path)
        reasoner = reasoner_for(scenario.jurisdiction)
        history = []
        for frame in scenario.frames:
            texts.append(reasoner.frame_facts(frame.scene, frame.proposed, tuple(history)) + reasoner.params.facts())
            history.append(frame.scene)
    control = clingo.Control(["--warn=none"])
    control.add("base", [], "".join(texts))
    control.ground([("base", [])])
    given = {(name, arity) for name, arity, _ in control.symbolic_atoms.signatures}
    assert given - reasoner.frame_predicates == set()
    named = {atom.symbol.arguments[0].name for atom in control.symbolic_atoms.by_signature("window_param", 2)}
    assert named == WINDOW_PARAMS
