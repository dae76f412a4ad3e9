"""A planner's loop when the monitor has stopped reading: zenoh's queues fill, and `check` still keeps its timeout."""

from __future__ import annotations

import os
import signal
import time

import pytest

from discern.monitor.client import Monitor
from discern.monitor.example_planner import highway_scene
from tests.monitor_process import serve

pytestmark = pytest.mark.wall_clock  # run alone: see the marker in pyproject.toml

TIMEOUT_S = 0.05
JUNK = "x" * 1_000_000  # a megabyte a proposal: the buffers between planner and monitor fill in a few dozen


@pytest.mark.parametrize("style", ["query", "pubsub"])
def test_check_returns_within_its_timeout_while_the_monitor_reads_nothing(style):
    """A query waited for room on the congested link (zenoh's default for queries, CongestionControl.BLOCK): once
    the monitor stopped reading, a `check` with a 50 ms timeout took 5 s, zenoh's wait before it closes the link."""
    proc, ep = serve("--id", "stopped", "--budget-ms", "5000")
    try:
        with Monitor("car_1", connect=[ep], style=style, timeout=TIMEOUT_S) as planner:
            assert planner.wait_for_monitor(timeout=10)
            assert not planner.check(highway_scene(0, 4), "cruise", timeout=5).failsafe
            os.kill(proc.proc.pid, signal.SIGSTOP)  # as a monitor stuck, swapped out or starved of its core
            try:
                took = []
                for frame in range(1, 80):  # 80 MB: a query waited at the twentieth on the development VM
                    started = time.monotonic()
                    verdict = planner.check({"frame_id": frame, "junk": JUNK}, "cruise")
                    took.append(time.monotonic() - started)
                    assert verdict.failsafe
            finally:
                os.kill(proc.proc.pid, signal.SIGCONT)
    finally:
        assert proc.stop() == 0, proc.output
    assert max(took) < TIMEOUT_S + 0.5, f"the slowest check took {max(took):.2f} s (call {took.index(max(took))})"
