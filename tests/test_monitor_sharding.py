"""A fleet split across monitor processes behind one zenoh router (`discern router`, as zenohd would)."""

from __future__ import annotations

import subprocess
import sys
import time

import pytest
import zenoh

from discern.monitor import keys
from discern.monitor.client import Monitor
from discern.monitor.example_planner import highway_scene
from discern.monitor.config import free_port
from tests.monitor_process import REPO, DiscernProcess, endpoint, serve, status, wait_until

pytestmark = pytest.mark.wall_clock  # run alone: see the marker in pyproject.toml


@pytest.fixture(scope="module")
def fleet():
    router_ep = endpoint(free_port())
    started = []
    try:
        router = DiscernProcess("router", "--listen", router_ep).wait_ready()
        started.append(router)
        for shard in ("a", "b"):
            started.append(
                DiscernProcess(
                    "serve", "--mode", "client", "--connect", router_ep, "--id", f"shard_{shard}",
                    "--vehicles", f"fleet_{shard}_*", "--budget-ms", "5000",
                ).wait_ready()
            )
        # Both monitors' declarations must have reached the router before planners ask.
        wait_until(lambda: len(status(router_ep)) == 2, timeout=15)
        yield router_ep
    finally:
        for proc in reversed(started):
            proc.stop()


def test_each_vehicle_is_judged_by_the_monitor_of_its_shard(fleet):
    for vehicle, frames in (("fleet_a_1", 3), ("fleet_a_2", 1), ("fleet_b_1", 2)):
        with Monitor(vehicle, connect=[fleet], mode="client", timeout=5) as monitor:
            verdicts = [monitor.check(highway_scene(f, 8), "cruise") for f in range(frames)]
        assert all(v.vehicle == vehicle and not v.failsafe for v in verdicts)
    counts = {s["monitor_id"]: s["proposals"] for s in status(fleet)}
    assert counts == {"shard_a": 4, "shard_b": 2}


def test_publish_subscribe_works_through_the_router(fleet):
    with Monitor("fleet_b_7", connect=[fleet], mode="client", style="pubsub", timeout=5) as monitor:
        assert monitor.wait_for_monitor()
        frames = iter(range(10, 1000))
        # our verdict subscription may still be on its way to the monitor's side: retry with new frames
        verdict = wait_until(lambda: (v := monitor.check(highway_scene(next(frames), 8), "cruise", timeout=1)) and not v.failsafe and v)
        later = monitor.check(highway_scene(next(frames), 8), "cruise")
    assert verdict and verdict.vehicle == "fleet_b_7" and not later.failsafe and later.frame_id == verdict.frame_id + 1


def test_a_planner_can_tell_whether_a_monitor_serves_its_vehicle(fleet):
    with Monitor("fleet_a_9", connect=[fleet], mode="client") as served:
        assert served.wait_for_monitor(timeout=5)
    with Monitor("fleet_c_9", connect=[fleet], mode="client") as unserved:
        assert not unserved.wait_for_monitor(timeout=0.3)


def test_a_vehicle_no_monitor_serves_gets_a_client_side_failsafe(fleet):
    with Monitor("fleet_c_1", connect=[fleet], mode="client", timeout=0.3) as monitor:
        verdict = monitor.check(highway_scene(0, 4), "cruise")
    assert verdict.failsafe and verdict.rules == ["monitor.no_answer"]
    assert verdict.error.endswith("is reachable"), verdict.error  # linked, no TLS: no talk of certificates


def test_a_peer_mode_planner_reaches_its_shard_through_the_router(fleet):
    with Monitor("fleet_b_3", connect=[fleet], timeout=5) as monitor:  # peer, the client's default mode
        verdict = monitor.check(highway_scene(0, 8), "cruise")
    assert verdict.vehicle == "fleet_b_3" and not verdict.failsafe


def test_a_session_connected_to_two_monitors_does_not_link_them():
    """Gossip scouting would introduce the monitors to each other: both would then answer every vehicle."""
    first, first_ep = serve("--id", "apart_1", "--budget-ms", "5000")
    second, second_ep = serve("--id", "apart_2", "--budget-ms", "5000")
    try:
        both = subprocess.run(
            [sys.executable, "-m", "discern.monitor.commands", "status", "--connect", first_ep, "--connect", second_ep],
            cwd=REPO, capture_output=True, text=True, timeout=60,
        )
        assert both.returncode == 0, both.stderr
        time.sleep(1)  # time enough for a gossiped link to form
        assert [s["monitor_id"] for s in status(first_ep)] == ["apart_1"]
        with Monitor("car_1", connect=[first_ep], timeout=5) as monitor:
            assert not monitor.check(highway_scene(0, 4), "cruise").failsafe
        assert [s["proposals"] for s in status(first_ep)] == [1]
        assert [s["proposals"] for s in status(second_ep)] == [0]
    finally:
        first.stop()
        second.stop()


def test_a_check_two_monitors_answer_takes_the_first_verdict_not_the_slower_ones():
    """zenoh's default consolidation kept only the latest reply and gave it once both had come: the check waited for
    the slower monitor and took its verdict, here its deadline fail-safe, where the faster had approved."""
    fast_ep, slow_ep = endpoint(free_port()), endpoint(free_port())
    fast = DiscernProcess("serve", "--listen", fast_ep, "--id", "first_fast", "--budget-ms", "5000")
    slow = DiscernProcess("serve", "--listen", slow_ep, "--id", "first_slow", "--budget-ms", "2000",
                          "--test-only-decision-delay-ms", "2500")
    try:
        fast.wait_ready()
        slow.wait_ready()
        with Monitor("two_answerers", connect=[fast_ep, slow_ep], timeout=60) as monitor:
            probe = f"{keys.check_key('two_answerers')}?{keys.PROBE}"
            # both monitors known to the planner's session, so that the check goes to both
            assert wait_until(lambda: sum(reply.ok is not None for reply in monitor.session.get(
                probe, timeout=5, consolidation=zenoh.ConsolidationMode.NONE)) == 2)
            verdict = monitor.check(highway_scene(0, 4), "cruise")
        assert not verdict.failsafe and verdict.decision.value == "approve", verdict.error
    finally:
        fast.stop()
        slow.stop()
