"""The sanity layer's fault-injection scenarios (scenarios/sanity/*.json), run frame by frame."""

from __future__ import annotations

from pathlib import Path

import pytest

from discern.rules.scene import Scene
from discern.sanity import reasoner_for
from discern.scenarios.model import Scenario

ROOT = Path(__file__).resolve().parents[1] / "scenarios" / "sanity"
FILES = sorted(ROOT.glob("*.json"))


def problems(scenario: Scenario) -> list[str]:
    reasoner = reasoner_for(scenario.jurisdiction)
    found, history = [], []
    for index, frame in enumerate(scenario.frames):
        verdict = reasoner.decide(frame.scene, frame.proposed, history=tuple(history), explain=True)
        expect = frame.expect
        where = f"frame {index}"
        if expect.decision is not None and verdict.decision is not expect.decision:
            found.append(f"{where}: decision {verdict.decision.value}, expected {expect.decision.value}")
        if expect.action is not None and verdict.action is not expect.action:
            found.append(f"{where}: action {verdict.action.value}, expected {expect.action.value}")
        if expect.recommended is not None and verdict.recommended is not expect.recommended:
            found.append(f"{where}: recommended {verdict.recommended}, expected {expect.recommended.value}")
        found += [f"{where}: rule {r} not in {verdict.rules}" for r in expect.rules if r not in verdict.rules]
        found += [f"{where}: rule {r} in {verdict.rules}" for r in expect.absent_rules if r in verdict.rules]
        found += [f"{where}: text lacks {t!r}" for t in expect.text_contains if t not in verdict.justification.full_text()]
        history.append(frame.scene)
    return found


@pytest.mark.parametrize("path", FILES, ids=[p.stem for p in FILES])
def test_sanity_scenario_gets_its_expected_verdicts(path):
    assert problems(Scenario.load(path)) == []


def test_fault_injection_scenarios_of_the_issue_are_present():
    names = {p.stem for p in FILES}
    assert {"taped_sign_35_reads_85", "misread_sign_30_reads_80", "stop_sign_read_as_speed_limit_45",
            "camera_clear_left_sensor_hit", "camera_loses_car_in_left_lane", "phantom_camera_object",
            "sign_flickers", "emergency_vehicle_flashing", "flashing_red_light", "flashing_yellow_light",
            "steady_red_one_frame_dropped"} <= names


def test_every_scenario_frame_is_a_valid_scene_in_a_known_jurisdiction():
    for path in FILES:
        scenario = Scenario.load(path)
        assert scenario.jurisdiction in ("us", "uk") and all(isinstance(f.scene, Scene) for f in scenario.frames)


def test_a_wrong_expectation_is_caught():
    scenario = Scenario.load(ROOT / "taped_sign_35_reads_85.json")
    scenario.frames[2].expect.decision = scenario.frames[0].expect.decision  # approve, which is wrong
    assert problems(scenario) == ["frame 2: decision override, expected approve"]
