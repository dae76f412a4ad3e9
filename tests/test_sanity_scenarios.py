"""The sanity layer's fault-injection scenarios (scenarios/sanity/*.json), run frame by frame."""

from __future__ import annotations

from pathlib import Path

import pytest

from discern.rules.scene import Scene
from discern.sanity import reasoner_for
from discern.scenarios.model import Scenario
from discern.scenarios.runner import run

ROOT = Path(__file__).resolve().parents[1] / "scenarios" / "sanity"
FILES = sorted(ROOT.glob("*.json"))


def problems(scenario: Scenario) -> list[str]:
    """What `discern scenarios run` finds wrong, frame by frame (scenarios.runner checks each expectation)."""
    return [f"frame {o.index}: {p}" for o in run(scenario, reasoner_for(scenario.jurisdiction)) for p in o.problems]


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
