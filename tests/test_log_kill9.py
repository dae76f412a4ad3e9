"""`kill -9` of a real `discern serve` loses at most about a second of log, and the rest reads back."""

from __future__ import annotations

import time

from discern.monitor.client import Monitor
from discern.monitor.example_planner import highway_scene
from discern.monitor.log import RecoveryReport, read_log
from tests.monitor_process import serve

FLUSH_S = 0.25
LOSS_BOUND_S = 1.0


def _answered_until_killed(proc, ep: str, vehicle: str, seconds: float, failsafe: bool, period_s: float):
    """Ask every `period_s` for `seconds`, then kill -9 the monitor: when each frame was answered, and the kill's time.
    Every verdict must be a fail-safe or none must, as `failsafe` says."""
    answered: dict[int, float] = {}
    try:
        with Monitor(vehicle, connect=[ep], timeout=5) as monitor:
            frame, stop_at = 0, time.monotonic() + seconds
            while time.monotonic() < stop_at:
                assert monitor.check(highway_scene(frame, 8), "cruise").failsafe is failsafe
                answered[frame] = time.monotonic()
                frame += 1
                time.sleep(period_s)
            killed_at = time.monotonic()
            proc.kill9()
    finally:
        proc.stop()
    return answered, killed_at


def _logged_frames(records, vehicle: str) -> tuple[set[int], set[int]]:
    """The frames whose verdict, and whose proposal, the log holds."""
    return ({r.verdict.frame_id for r in records if r.kind == "verdict" and r.vehicle == vehicle},
            {r.proposal.scene.frame_id for r in records if r.kind == "proposal"})


def test_sigkill_leaves_a_log_readable_up_to_the_last_second(tmp_path):
    proc, ep = serve("--id", "victim", "--budget-ms", "5000", "--log-dir", str(tmp_path), "--log-flush-s", str(FLUSH_S))
    answered, killed_at = _answered_until_killed(proc, ep, "doomed", 2.5, failsafe=False, period_s=0.02)
    assert proc.proc.returncode == -9

    report = RecoveryReport()
    records = list(read_log(tmp_path, report))
    [recovery] = report.files
    assert recovery.state == "truncated"  # no summary: it was killed
    assert 0 < recovery.recovered_bytes <= recovery.size_bytes
    verdict_frames, proposal_frames = _logged_frames(records, "doomed")
    must_have = {f for f, t in answered.items() if killed_at - t > LOSS_BOUND_S}
    assert len(must_have) > 10
    assert must_have <= verdict_frames and must_have <= proposal_frames
    assert any(r.kind == "status" for r in records)
    assert "truncated" in report.summary()


def test_sigkill_while_the_worker_stalls_keeps_the_fail_safes_sent_before_the_last_second(tmp_path):
    """The fail-safes a stalled worker causes are logged within HOLD_S, not when the worker wakes (or never)."""
    proc, ep = serve("--id", "stalled", "--budget-ms", "50", "--test-only-decision-delay-ms", "4000",
                     "--log-dir", str(tmp_path), "--log-flush-s", str(FLUSH_S))
    answered, killed_at = _answered_until_killed(proc, ep, "waiting", 3.0, failsafe=True, period_s=0.05)

    records = list(read_log(tmp_path, RecoveryReport()))
    verdict_frames, proposal_frames = _logged_frames(records, "waiting")
    must_have = {f for f, t in answered.items() if killed_at - t > LOSS_BOUND_S}
    assert len(must_have) > 10
    assert must_have <= verdict_frames and must_have <= proposal_frames  # read by the monitor, not the stalled worker
    assert not any(r.kind == "rejected" for r in records)
