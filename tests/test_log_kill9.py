"""`kill -9` of a real `discern serve` loses at most about a second of log, and the rest reads back.

The monitors log with the default `--log-flush-s` (0.5 s), the setting the promise is made for.
"""

from __future__ import annotations

import time

import pytest

from discern.monitor.client import Monitor
from discern.monitor.example_planner import highway_scene
from discern.monitor.log import RecoveryReport, read_log
from tests.monitor_process import serve

pytestmark = pytest.mark.wall_clock  # run alone: see the marker in pyproject.toml

LOSS_BOUND_S = 1.0
# A held fail-safe is logged HOLD_S (0.5 s) after it was sent, checked every 0.1 s, and flushed within 0.1 s then:
# about 0.7 s. Checked with some slack, short of the promised second: until 2026-11-27 it took up to 1.25 s.
HELD_LOSS_BOUND_S = 0.85


def _answered_until_killed(proc, ep: str, vehicle: str, seconds: float, failsafe: bool, period_s: float, log_dir):
    """Ask every `period_s` for `seconds` and on, then kill -9 the monitor just before the log's next periodic flush,
    the worst moment (0.4 s after one was seen: the file grew): when each frame was answered, and the kill's time.
    Every verdict must be a fail-safe or none must, as `failsafe` says."""
    answered: dict[int, float] = {}
    try:
        with Monitor(vehicle, connect=[ep], timeout=5) as monitor:
            frame, started, kill_at, size = 0, time.monotonic(), None, None
            while kill_at is None or time.monotonic() < kill_at:
                assert monitor.check(highway_scene(frame, 8), "cruise").failsafe is failsafe
                answered[frame] = time.monotonic()
                frame += 1
                time.sleep(period_s)
                if kill_at is None and time.monotonic() - started >= seconds:
                    grown = sum(p.stat().st_size for p in log_dir.glob("*.mcap"))
                    if size is not None and grown != size:  # a flush: the next periodic one comes 0.5 s after it
                        kill_at = time.monotonic() + 0.4 - period_s
                    size = grown
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
    proc, ep = serve("--id", "victim", "--budget-ms", "5000", "--log-dir", str(tmp_path))
    answered, killed_at = _answered_until_killed(proc, ep, "doomed", 2.5, failsafe=False, period_s=0.02,
                                                 log_dir=tmp_path)
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
                     "--log-dir", str(tmp_path))
    answered, killed_at = _answered_until_killed(proc, ep, "waiting", 3.0, failsafe=True, period_s=0.05,
                                                 log_dir=tmp_path)

    records = list(read_log(tmp_path, RecoveryReport()))
    verdict_frames, proposal_frames = _logged_frames(records, "waiting")
    must_have = {f for f, t in answered.items() if killed_at - t > HELD_LOSS_BOUND_S}
    assert len(must_have) > 10
    assert must_have <= verdict_frames and must_have <= proposal_frames  # read by the monitor, not the stalled worker
    assert not any(r.kind == "rejected" for r in records)
