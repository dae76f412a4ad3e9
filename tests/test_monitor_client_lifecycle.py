"""A planner's Monitor gives back what it holds, its zenoh session and that session's declarations, when closed."""

from __future__ import annotations

import gc
import itertools
import os
import subprocess
import sys
import threading
import weakref

import pytest
import zenoh

from discern.monitor.client import CLOSED, Monitor
from discern.monitor.config import ZenohSettings, free_port
from discern.monitor.example_planner import highway_scene
from tests.monitor_process import endpoint, serve, wait_until

pytestmark = pytest.mark.wall_clock  # run alone: see the marker in pyproject.toml


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


class Planner:
    """A planner that holds its Monitor and takes its verdicts in a method of its own."""

    def __init__(self, ep: str, style: str):
        self.monitor = Monitor("planner", connect=[ep], style=style, on_verdict=self.seen)

    def seen(self, verdict) -> None:
        pass


@pytest.mark.parametrize("style", ["query", "pubsub"])
def test_a_planner_dropped_with_its_monitor_unclosed_has_the_session_closed(style):
    """Its on_verdict refers back to the Monitor: what closes the session must not hold the callback for good."""
    planner = Planner(endpoint(free_port()), style)
    session, dropped = planner.monitor.session, weakref.ref(planner.monitor)
    del planner
    gc.collect()
    assert dropped() is None and session.is_closed()


@pytest.mark.parametrize("style", ["query", "pubsub"])
def test_a_planner_that_never_closes_its_monitor_still_exits(style):
    """zenoh runs a subscriber's callback on a thread that is not a daemon: Python waited for it, before its atexit
    hooks, so a planner process holding an unclosed pubsub Monitor at exit hung for good."""
    script = (f"from discern.monitor.client import Monitor\n"
              f"m = Monitor('exits', connect=[{endpoint(free_port())!r}], style={style!r})\n")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr


@pytest.fixture(scope="module")
def monitor():
    proc, ep = serve("--id", "lifecycle", "--budget-ms", "5000")
    yield ep
    assert proc.stop() == 0, proc.output


@pytest.mark.parametrize("style", ["query", "pubsub"])
def test_closing_while_other_threads_publish_and_check_closes_the_session_and_stops_them(monitor, style):
    """close() while another thread's put held the publisher raised pyo3's "Already borrowed": the session stayed
    open for good (a second close() did nothing) and the "closed" Monitor went on publishing. Not every close meets
    a put in flight: twenty do, near enough for certain."""
    frames = itertools.count()
    for trial in range(20):
        client = Monitor(f"closing_{style}_{trial}", connect=[monitor], style=style, timeout=0.5)
        assert client.wait_for_monitor(timeout=10)
        problems: list[str] = []
        sent = threading.Semaphore(0)

        def publish():
            while True:
                try:
                    client.publish(highway_scene(next(frames), 4), "cruise")
                except ValueError as exc:
                    if str(exc) != CLOSED:
                        problems.append(f"publish raised {exc!r}")
                    return
                except Exception as exc:
                    problems.append(f"publish raised {exc!r}")
                    return
                sent.release()

        def check():
            try:
                while client.check(highway_scene(next(frames), 4), "cruise").error != CLOSED:
                    sent.release()
            except Exception as exc:
                problems.append(f"check raised {exc!r}")

        threads = [threading.Thread(target=target) for target in (publish, publish, check)]
        for thread in threads:
            thread.start()
        for _ in range(30):  # under way: the close meets them mid-flight
            assert sent.acquire(timeout=60), problems
        client.close()
        for thread in threads:
            thread.join(60)
        assert not problems and not any(thread.is_alive() for thread in threads), problems
        assert client.session.is_closed()
