"""A decision worker that dies does not take the monitor down: answers keep coming, a new worker takes over."""

from __future__ import annotations

import os
import signal
import subprocess
import time

import pytest
import zenoh

from discern.monitor.client import Monitor
from discern.monitor.config import ZenohSettings
from discern.monitor.example_planner import highway_scene
from discern.monitor.log import read_log
from discern.monitor.protocol import RULE_INTERNAL_ERROR
from discern.rules.scene import Proposal
from discern.rules.verdict import Verdict
from tests.monitor_process import serve, status, wait_until

pytestmark = pytest.mark.wall_clock  # run alone: see the marker in pyproject.toml

LONG_BUDGET_MS = 10_000  # a fail-safe at the deadline would come this late: far later than any other answer


def decision_workers(pid: int) -> list[int]:
    out = subprocess.run(["ps", "-ww", "-o", "pid=,args=", "--ppid", str(pid)], capture_output=True, text=True).stdout
    return [int(line.split()[0]) for line in out.splitlines() if "spawn_main" in line]


def test_a_killed_decision_worker_is_replaced_and_every_proposal_answered():
    proc, ep = serve("--id", "crashy", "--budget-ms", "500")
    try:
        with Monitor("phoenix", connect=[ep], timeout=5) as monitor:
            frames = iter(range(1000))
            assert not monitor.check(highway_scene(next(frames), 8), "cruise").failsafe
            [worker] = decision_workers(proc.proc.pid)
            os.kill(worker, signal.SIGKILL)
            right_after = monitor.check(highway_scene(next(frames), 8), "cruise")
            assert right_after.frame_id is not None and right_after.latency_ms < 1000  # answered, fail-safe or not
            recovered = wait_until(
                lambda: (v := monitor.check(highway_scene(next(frames), 8), "cruise")) and not v.failsafe and v,
                timeout=60,
            )
        assert recovered, proc.output
        [new_worker] = decision_workers(proc.proc.pid)
        assert new_worker != worker
        [report] = status(ep, "crashy")
        assert report["internal_errors"] >= 1
        assert "decision worker 0 died" in proc.output
    finally:
        assert proc.stop() == 0, proc.output


def test_every_proposal_after_a_worker_crash_is_decided_by_its_replacement():
    proc, ep = serve("--id", "relay", "--budget-ms", str(LONG_BUDGET_MS))
    try:
        with Monitor("relay_car", connect=[ep], timeout=2 * LONG_BUDGET_MS / 1000) as monitor:
            assert not monitor.check(highway_scene(0, 8), "cruise").failsafe
            [worker] = decision_workers(proc.proc.pid)
            os.kill(worker, signal.SIGKILL)
            assert wait_until(lambda: "decision worker 0 died" in proc.output), proc.output
            after = [monitor.check(highway_scene(frame, 8), "cruise") for frame in range(1, 4)]
        assert [(v.frame_id, v.failsafe) for v in after] == [(1, False), (2, False), (3, False)], proc.output
        assert all(v.latency_ms < LONG_BUDGET_MS / 2 for v in after)  # decided, not answered at the deadline
    finally:
        assert proc.stop() == 0, proc.output


def test_a_proposal_in_the_hands_of_a_crashing_worker_gets_a_prompt_failsafe_naming_the_crash(tmp_path):
    proc, ep = serve(
        "--id", "dropper", "--budget-ms", str(LONG_BUDGET_MS), "--test-only-decision-delay-ms", "2000",
        "--log-dir", str(tmp_path),
    )
    session = zenoh.open(ZenohSettings(listen=[], connect=[ep]).to_zenoh())
    try:
        payload = Proposal(vehicle="held", action="cruise", scene=highway_scene(4, 8)).model_dump_json().encode()
        replies = session.get("discern/held/check", payload=payload, timeout=2 * LONG_BUDGET_MS / 1000)
        time.sleep(0.5)  # the worker has taken it and sleeps over it
        [worker] = decision_workers(proc.proc.pid)
        sent = time.monotonic()
        os.kill(worker, signal.SIGKILL)
        [reply] = [r.ok for r in replies if r.ok is not None]
        waited = time.monotonic() - sent
    finally:
        session.close()
        assert proc.stop() == 0, proc.output
    verdict = Verdict.model_validate_json(reply.payload.to_bytes())
    assert waited < LONG_BUDGET_MS / 2000, waited
    assert verdict.failsafe and verdict.rules == [RULE_INTERNAL_ERROR] and verdict.frame_id == 4
    assert "decision worker 0 died" in verdict.error, verdict.error
    records = [r for r in read_log(tmp_path) if r.vehicle == "held"]
    assert [r.kind for r in records] == ["rejected", "verdict"]  # never read, so not logged as a proposal
    assert records[0].rejected.error.startswith("not read") and records[1].verdict.error == verdict.error
