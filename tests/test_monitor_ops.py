"""What an operator sees of a running monitor: its stderr under a flood, overlapping shards, a closed terminal."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys

import pytest
import zenoh

from discern.monitor.client import Monitor
from discern.monitor.config import ZenohSettings, free_port
from discern.monitor.example_planner import highway_scene
from discern.monitor.log import RecoveryReport, read_log
from tests.monitor_process import REPO, DiscernProcess, endpoint, serve, status, wait_until

pytestmark = pytest.mark.wall_clock  # run alone: see the marker in pyproject.toml

REFUSAL = re.compile(r"WARNING discern\.monitor\.server: refused a proposal on ")
MORE = re.compile(r"; and (\d+) more like it \(json\) in the last \d\.\d s$")


def flood(ep: str, count: int) -> None:
    session = zenoh.open(ZenohSettings(listen=[], connect=[ep]).to_zenoh())
    try:
        for i in range(count):
            session.put(f"discern/flood_{i % 10}/proposal", b"not json")
    finally:
        session.close()


def refusals_said(output: str) -> tuple[int, int]:
    """Lines warning of refusals, and the refusals they speak for."""
    said = [line for line in output.splitlines() if REFUSAL.search(line)]
    return len(said), sum(1 + int(more.group(1)) if (more := MORE.search(line)) else 1 for line in said)


def test_a_flood_of_refusals_is_warned_of_once_a_second_with_counts():
    """1,000 bad payloads wrote 1,000 warnings."""
    proc, ep = serve("--id", "flooded", "--budget-ms", "5000")
    try:
        flood(ep, 300)
        assert wait_until(lambda: status(ep, "flooded")[0]["errors"] == 300, timeout=30)
    finally:
        assert proc.stop() == 0, proc.output
    lines, refusals = refusals_said(proc.output)
    assert refusals == 300 and lines <= 6, proc.output


def test_verbose_warns_of_every_refusal():
    proc, ep = serve("--id", "told", "--budget-ms", "5000", "-v")
    try:
        flood(ep, 20)
        assert wait_until(lambda: status(ep, "told")[0]["errors"] == 20, timeout=30)
    finally:
        assert proc.stop() == 0, proc.output
    assert refusals_said(proc.output) == (20, 20), proc.output


def test_deadline_failsafes_are_summed_up_on_stderr():
    """Brakes sent to vehicles for want of a decision left no line at all."""
    proc, ep = serve("--id", "slow", "--budget-ms", "50", "--test-only-decision-delay-ms", "300")
    try:
        with Monitor("car_1", connect=[ep], timeout=1) as planner:
            verdicts = [planner.check(highway_scene(frame, 4), "cruise") for frame in range(3)]
    finally:
        assert proc.stop() == 0, proc.output
    assert all(v.rules == ["monitor.deadline"] for v in verdicts)
    assert re.search(r"WARNING .*fail-safe verdicts in the last \d+ s: 3 with no decision within the 50 ms budget, "
                     r"0 for an internal error", proc.output), proc.output


def test_overlapping_vehicle_filters_are_warned_of_by_status_and_at_start_up():
    """A shadow monitor of every vehicle beside a shard answered the shard's vehicles too, unnoticed."""
    router_ep = endpoint(free_port())
    started = []
    try:
        started.append(DiscernProcess("router", "--listen", router_ep).wait_ready())
        client = ("--mode", "client", "--connect", router_ep, "--budget-ms", "5000")
        for monitor_id, vehicles in (("shard_a", "fleet_a_*"), ("shard_b", "fleet_b_*")):
            started.append(DiscernProcess("serve", *client, "--id", monitor_id, "--vehicles", vehicles).wait_ready())
        assert wait_until(lambda: len(status(router_ep)) == 2, timeout=15)
        started.append(DiscernProcess("serve", *client, "--id", "shadow_all", "--vehicles", "*", "--shadow").wait_ready())
        shadow = started[-1]
        assert wait_until(lambda: shadow.output.count("both serve") >= 2, timeout=15), shadow.output
        done = subprocess.run([sys.executable, "-m", "discern.monitor.commands", "status", "--connect", router_ep],
                              cwd=REPO, capture_output=True, text=True, timeout=60)
    finally:
        for proc in reversed(started):
            proc.stop()
    for first, second in (("shard_a (vehicles fleet_a_$*)", "shadow_all (vehicles *)"),
                          ("shard_b (vehicles fleet_b_$*)", "shadow_all (vehicles *)")):
        assert f"monitors {first} and {second} both serve some vehicles" in shadow.output, shadow.output
    assert "both serve" not in started[1].output + started[2].output  # disjoint shards
    warned = sorted(re.findall(r"monitors (\w+) .*? and (\w+) ", done.stderr))
    assert done.returncode == 0 and len(warned) == 2, done.stderr
    assert all("shadow_all" in pair and set(pair) & {"shard_a", "shard_b"} for pair in warned), done.stderr


def test_a_hangup_stops_the_monitor_and_its_router_cleanly(tmp_path):
    """Closing the terminal (SIGHUP to the whole job) killed the monitor: exit 129, no summary, a log without footer."""
    router_ep = endpoint(free_port())
    router = DiscernProcess("router", "--listen", router_ep, own_group=True).wait_ready()
    proc = DiscernProcess("serve", "--mode", "client", "--connect", router_ep, "--id", "hup", "--budget-ms", "5000",
                          "--log-dir", str(tmp_path), own_group=True).wait_ready()
    try:
        with Monitor("car_1", connect=[router_ep], mode="client", timeout=5) as planner:
            assert planner.wait_for_monitor(timeout=10)
            assert not planner.check(highway_scene(0, 4), "cruise").failsafe
    finally:
        after_hangup = []  # each one's exit status, None where the hangup did not stop it
        for started in (proc, router):
            os.killpg(started.proc.pid, signal.SIGHUP)
            try:
                after_hangup.append(started.proc.wait(30))
            except subprocess.TimeoutExpired:
                after_hangup.append(None)
            started.stop()  # stopped either way: a test leaves nothing running
    assert after_hangup[0] == 0 and "discern serve: stopped after 1 proposals" in proc.output, proc.output
    assert after_hangup[1] == 0, router.output
    report = RecoveryReport()
    assert [r.kind for r in read_log([tmp_path], report) if r.vehicle == "car_1"] == ["proposal", "verdict"]
    assert [f.state for f in report.files] == ["complete"], report.summary()


# A signal's handler runs on the main thread at whatever line it has reached, also inside the wait for a stop: a
# handler that took a lock that wait holds (threading.Event.set) deadlocked, and the monitor never stopped.
STOP_AT_EVERY_LINE = """
import signal, sys
from discern.monitor.commands import _stop_on_signal

stop = _stop_on_signal()
handler = signal.getsignal(signal.SIGTERM)
busy = False

def at_every_line(frame, event, arg):
    global busy
    if event == "line" and not busy:
        busy = True
        handler(signal.SIGTERM, frame)
        busy = False
    return at_every_line

sys.settrace(at_every_line)
stop.wait(0.01)
sys.settrace(None)
print("stop asked:", stop.wait(0))
"""


def test_a_stop_signal_handled_at_any_line_of_the_wait_for_a_stop_ends_that_wait():
    try:
        done = subprocess.run([sys.executable, "-c", STOP_AT_EVERY_LINE], capture_output=True, text=True, timeout=60,
                              cwd=REPO)
    except subprocess.TimeoutExpired:
        raise AssertionError("the stop handler deadlocked inside the wait for a stop") from None
    assert done.returncode == 0 and done.stdout.strip() == "stop asked: True", done.stderr
