"""A planner's Monitor gives back what it holds, its zenoh session and that session's declarations, when closed."""

from __future__ import annotations

import os

import pytest

from discern.monitor.client import Monitor
from tests.monitor_process import endpoint, free_port


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
