"""A refusal stays a refusal when the monitor is busy: named, counted as bad input, and matched to its own frame."""

from __future__ import annotations

import json
import math
import time

import pytest
import zenoh

from discern.monitor.client import Monitor
from discern.monitor.config import ZenohSettings
from discern.monitor.example_planner import highway_scene
from discern.rules.scene import Action, Proposal
from discern.rules.verdict import Decision, Verdict
from tests.monitor_process import serve, status, wait_until

pytestmark = pytest.mark.wall_clock  # run alone: see the marker in pyproject.toml

DELAY_MS = 800  # test-only hook: each batch of decisions sleeps this long first


@pytest.fixture(scope="module")
def shedding_monitor():
    """A proposal queued behind one decision has under half its budget left: the worker sheds it."""
    proc, ep = serve("--id", "shedding", "--shadow", "--budget-ms", "1000", "--test-only-decision-delay-ms", str(DELAY_MS))
    yield ep
    assert proc.stop() == 0, proc.output


@pytest.fixture(scope="module")
def patient_monitor():
    """Budget enough to decide what waits behind one decision: its refusals come, late."""
    proc, ep = serve("--id", "patient", "--budget-ms", "5000", "--test-only-decision-delay-ms", str(DELAY_MS))
    yield ep
    assert proc.stop() == 0, proc.output


def proposal(vehicle: str, frame: int, action: str = "cruise") -> str:
    return Proposal(vehicle=vehicle, action=action, scene=highway_scene(frame, 3)).model_dump_json(by_alias=True)


def test_bad_input_shed_for_lack_of_time_is_refused_by_name_not_answered_as_a_missed_deadline(shedding_monitor):
    ep = shedding_monitor
    session = zenoh.open(ZenohSettings(listen=[], connect=[ep]).to_zenoh())
    try:
        [before] = status(ep, "shedding")
        busy = session.get("discern/shed_busy/check", payload=proposal("shed_busy", 1).encode(), timeout=10)
        time.sleep(0.05)  # queued behind it
        nan = proposal("shed_busy", 2, "accelerate").replace('"speed":25.0', '"speed":NaN', 1)
        assert "NaN" in nan
        pending = {
            "schema": session.get("discern/shed_busy/check", payload=nan.encode(), timeout=10),
            "json": session.get("discern/shed_other/check", payload=b'{"action": "cruise", "scene": {', timeout=10),
        }
        verdicts = {}
        for kind, replies in pending.items():
            [reply] = [r.ok for r in replies if r.ok is not None]
            verdicts[kind] = Verdict.model_validate_json(reply.payload.to_bytes())
        list(busy)
    finally:
        session.close()
    for kind, verdict in verdicts.items():
        assert verdict.rules == ["monitor.bad_input"] and verdict.failsafe, verdict
        # no proposed action could be read to keep, so even in shadow mode it brakes
        assert verdict.decision is Decision.override and verdict.action is Action.brake and verdict.proposed is None
        assert verdict.latency_ms > DELAY_MS / 2  # it waited for the busy worker: shed, not refused on arrival
    assert "scene.ego.speed: Input should be a finite number" in verdicts["schema"].error
    assert verdicts["schema"].frame_id == 2
    assert verdicts["json"].error.startswith("malformed JSON")
    [after] = wait_until(lambda: [r for r in status(ep, "shedding") if r["proposals"] >= before["proposals"] + 3])
    assert after["deadline_misses"] == before["deadline_misses"]
    for kind in ("schema", "json"):
        assert after["errors_by_kind"].get(kind, 0) == before["errors_by_kind"].get(kind, 0) + 1


def test_a_late_refusal_over_publish_subscribe_is_not_taken_for_the_next_frames_verdict(patient_monitor):
    seen: list[Verdict] = []
    with Monitor("late_refusal", connect=[patient_monitor], timeout=5, style="pubsub", on_verdict=seen.append) as monitor:
        assert monitor.wait_for_monitor(timeout=5)
        wait_until(lambda: False, timeout=0.3)  # let the verdict subscription reach the monitor
        monitor.publish(highway_scene(1, 3), "cruise")  # the worker's next DELAY_MS
        time.sleep(0.02)
        bad = json.loads(highway_scene(2, 3).model_dump_json(by_alias=True))
        bad["ego"]["speed"] = math.nan
        gave_up = monitor.check(bad, "cruise", timeout=0.2)  # its refusal comes once the worker is free
        assert gave_up.failsafe and "no verdict" in gave_up.error and gave_up.frame_id == 2
        verdict = monitor.check(highway_scene(3, 3), "cruise")
        late = wait_until(lambda: [v for v in seen if v.frame_id == 2])
    assert verdict.frame_id == 3 and verdict.decision is Decision.approve and not verdict.failsafe, verdict
    assert [v.rules for v in late] == [["monitor.bad_input"]] and "scene.ego.speed" in late[0].error  # named for frame 2
