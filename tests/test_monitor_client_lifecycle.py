"""A planner's Monitor gives back what it holds, its zenoh session and that session's declarations, when closed."""

from __future__ import annotations

import gc
import os
import subprocess
import sys
import weakref

import pytest
import zenoh

from discern.monitor.client import Monitor
from discern.monitor.config import ZenohSettings
from tests.monitor_process import endpoint, free_port, wait_until


def open_fds() -> int:
    return len(os.listdir("/proc/self/fd"))


def test_closing_monitors_leaks_no_file_descriptors():
    """A session closed with its publisher and querier still declared kept a /dev/shm mapping open: one fd a Monitor."""
    ep = endpoint(free_port())
    Monitor("fds", connect=[ep]).close()  # zenoh's runtime opens what it keeps for the process first
    before = open_fds()
    for i in range(30):
        Monitor("fds", connect=[ep], style=("query", "pubsub")[i % 2]).close()
    assert open_fds() - before < 5


@pytest.mark.parametrize("style", ["query", "pubsub"])
def test_a_closed_monitor_waits_for_no_monitor(style):
    monitor = Monitor("closed_wait", connect=[endpoint(free_port())], style=style)
    monitor.close()
    assert monitor.wait_for_monitor(timeout=0.1) is False


@pytest.mark.parametrize("style, on_verdict", [("query", None), ("query", print), ("pubsub", None)])
def test_a_monitor_dropped_unclosed_is_collected_and_its_session_closed(style, on_verdict):
    """atexit held its bound close() and zenoh its subscriber's callback: a dropped Monitor kept its link for good."""
    ep = endpoint(free_port())
    peer = zenoh.open(ZenohSettings(listen=[ep]).to_zenoh())
    try:
        monitor = Monitor("dropped", connect=[ep], style=style, on_verdict=on_verdict)
        assert wait_until(lambda: list(peer.info.peers_zid()))
        session, dropped = monitor.session, weakref.ref(monitor)
        del monitor
        gc.collect()
        assert dropped() is None and session.is_closed()
        assert wait_until(lambda: not list(peer.info.peers_zid()))  # its link is gone too
    finally:
        peer.close()


@pytest.mark.parametrize("style", ["query", "pubsub"])
def test_a_planner_that_never_closes_its_monitor_still_exits(style):
    """zenoh runs a subscriber's callback on a thread that is not a daemon: Python waited for it, before its atexit
    hooks, so a planner process holding an unclosed pubsub Monitor at exit hung for good."""
    script = (f"from discern.monitor.client import Monitor\n"
              f"m = Monitor('exits', connect=[{endpoint(free_port())!r}], style={style!r})\n")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
