"""A decision worker that dies does not take the monitor down: answers keep coming, a new worker takes over."""

from __future__ import annotations

import os
import signal
import subprocess

from discern.monitor.client import Monitor
from discern.monitor.example_planner import highway_scene
from tests.monitor_process import serve, status, wait_until


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
