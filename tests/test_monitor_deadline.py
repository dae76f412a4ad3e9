"""Over the decision budget the monitor answers anyway: a fail-safe verdict, never silence."""

from __future__ import annotations

import threading

import pytest

from discern.monitor.client import Monitor
from discern.monitor.example_planner import highway_scene
from discern.monitor.protocol import RULE_DEADLINE, failsafe_verdict
from discern.monitor.vehicle_state import PERMITTED_MEMORY_S, PermittedMemory
from discern.rules.scene import Action
from discern.rules.verdict import Decision
from tests.monitor_process import serve, status, wait_until

BUDGET_MS = 50
DELAY_MS = 400  # test-only hook: every decision sleeps this long first


@pytest.fixture(scope="module")
def slow_monitor():
    proc, ep = serve("--id", "slow", "--budget-ms", str(BUDGET_MS), "--test-only-decision-delay-ms", str(DELAY_MS))
    yield ep
    assert proc.stop() == 0, proc.output


def test_a_decision_over_budget_gets_a_failsafe_verdict_at_the_deadline(slow_monitor):
    with Monitor("slowpoke", connect=[slow_monitor], timeout=5) as monitor:
        verdict = monitor.check(highway_scene(0, 4), "accelerate")
    assert verdict.failsafe and verdict.rules == [RULE_DEADLINE]
    assert verdict.decision is Decision.override and verdict.action is Action.brake
    assert f"no decision within the {BUDGET_MS} ms budget" in verdict.error
    assert verdict.frame_id == 0 and verdict.proposed is Action.accelerate
    assert verdict.latency_ms < DELAY_MS  # at the deadline, or sooner once the monitor knows it is slow


def test_a_backlog_is_answered_in_time_and_nothing_is_lost(slow_monitor):
    verdicts = {}
    [before] = status(slow_monitor, "slow")  # counts so far: other tests share this monitor
    misses, proposals, failsafes = before["deadline_misses"], before["proposals"], before["failsafes"]

    def ask(i):
        with Monitor(f"queued_{i}", connect=[slow_monitor], timeout=5) as monitor:
            verdicts[i] = monitor.check(highway_scene(1, 4), "cruise")

    threads = [threading.Thread(target=ask, args=(i,)) for i in range(6)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(30)
    assert sorted(verdicts) == list(range(6))
    assert all(v.failsafe and v.rules == [RULE_DEADLINE] for v in verdicts.values())
    assert all(v.latency_ms < DELAY_MS for v in verdicts.values())  # none waited for the slow worker
    assert all(f"no decision within the {BUDGET_MS} ms budget" in v.error for v in verdicts.values())
    assert all(v.frame_id == 1 and v.proposed is Action.cruise for v in verdicts.values())  # matchable to their frame
    report = wait_until(lambda: [r for r in status(slow_monitor, "slow") if r["deadline_misses"] >= misses + 6])
    assert report and report[0]["failsafes"] - failsafes == report[0]["proposals"] - proposals == 6


def test_a_late_failsafe_uses_the_most_cautious_recently_permitted_action():
    memory = PermittedMemory()
    memory.remember("v", (Action.accelerate, Action.cruise, Action.change_lane_left), now=10.0)
    recent = failsafe_verdict("v", "late", RULE_DEADLINE, permitted=memory.recent("v", 10.1))
    stale = failsafe_verdict("v", "late", RULE_DEADLINE, permitted=memory.recent("v", 10.0 + 2 * PERMITTED_MEMORY_S))
    other = failsafe_verdict("w", "late", RULE_DEADLINE, permitted=memory.recent("w", 10.1))
    assert recent.action is Action.cruise and stale.action is Action.brake and other.action is Action.brake


def test_a_worker_that_once_was_slow_still_tries_fresh_proposals():
    """The decision-time estimate must never lock every proposal out (it only learns from decisions)."""
    import time
    from collections import deque

    from discern.monitor.decision_pool import Job, WorkerSettings, _Judge
    from discern.rules.scene import Proposal

    judge = _Judge(WorkerSettings(window_s=2.0, shadow=False))
    judge.time.learn(1, 10.0)  # after a pathological decision
    payload = Proposal(vehicle="v", action="cruise", scene=highway_scene(0, 4)).model_dump_json().encode()
    now = time.monotonic()
    [fresh] = judge.next_batch(deque([Job(1, "v", payload, now, now + BUDGET_MS / 1000)]))
    assert fresh.verdict is not None and fresh.decision == "approve"
    [stale] = judge.next_batch(deque([Job(2, "v", payload, now - 0.045, now + 0.005)]))  # 5 ms of 50 left
    assert stale.verdict is None and "left after queueing" in stale.no_verdict
