"""What the monitor keeps per vehicle goes once the vehicle falls silent: memory follows the active vehicles."""

from __future__ import annotations

import json
import threading

import pytest
import zenoh

from discern.monitor.config import MonitorConfig, ZenohSettings, free_port
from discern.monitor.example_planner import highway_scene
from discern.monitor.server import MonitorServer
from discern.rules.scene import Proposal
from discern.rules.verdict import Verdict
from tests.monitor_process import endpoint, wait_until

pytestmark = pytest.mark.wall_clock  # run alone: see the marker in pyproject.toml

VEHICLES = ("exp_a", "exp_b", "exp_c")


@pytest.fixture(scope="module")
def monitor():
    ep = endpoint(free_port())
    # A budget that the first frames of three vehicles meet, queued on a cold monitor that grounds each of them with
    # its whole slice, on a loaded 2-core machine: this is about what the monitor forgets, not about its deadline.
    config = MonitorConfig(monitor_id="expiry", zenoh=ZenohSettings(listen=[ep]), window_s=1.5, budget_ms=1000)
    with MonitorServer(config) as server:
        session = zenoh.open(ZenohSettings(listen=[], connect=[ep]).to_zenoh())
        try:
            yield server, session
        finally:
            session.close()


def publish_and_wait(session, vehicles, frame: int) -> list[Verdict]:
    """Publish one proposal per vehicle and collect their verdicts from the verdict keys."""
    got, lock, done = [], threading.Lock(), threading.Event()

    def on_verdict(sample):
        with lock:
            got.append(Verdict.model_validate_json(sample.payload.to_bytes()))
            if len(got) == len(vehicles):
                done.set()

    sub = session.declare_subscriber("discern/*/verdict", on_verdict)
    try:
        wait_until(lambda: False, timeout=0.3)  # let the subscription reach the monitor
        for vehicle in vehicles:
            proposal = Proposal(vehicle=vehicle, action="cruise", scene=highway_scene(frame, 2))
            session.put(f"discern/{vehicle}/proposal", proposal.model_dump_json(by_alias=True).encode())
        assert done.wait(10), got
    finally:
        sub.undeclare()
    return got


def test_a_vehicles_state_is_dropped_after_it_falls_silent_and_a_returning_vehicle_starts_afresh(monitor):
    server, session = monitor
    verdicts = publish_and_wait(session, VEHICLES, frame=5)
    assert not any(v.failsafe for v in verdicts), [v.error for v in verdicts]
    assert set(server._vehicles) >= set(VEHICLES) and set(server._publishers) >= set(VEHICLES)
    assert set(server._permitted._last) >= set(VEHICLES) and server.status().vehicles >= len(VEHICLES)

    def forgotten():
        return not (set(VEHICLES) & (set(server._vehicles) | set(server._publishers) | set(server._permitted._last)))

    assert wait_until(forgotten, timeout=12)  # window 1.5 s + budget 1 s + the margin, swept every second
    assert server.status().vehicles == 0
    [back] = publish_and_wait(session, VEHICLES[:1], frame=1)  # an older frame: after the silence, a new episode
    assert back.vehicle == VEHICLES[0] and back.frame_id == 1 and not back.failsafe, back.error
    assert VEHICLES[0] in server._publishers and server.status().vehicles == 1


def test_a_key_of_another_shape_is_refused_and_names_no_vehicle(monitor):
    """A key the filter cannot match is impossible over zenoh now ('**' is refused), so it is handed in directly."""
    server, _ = monitor
    before = server.status()
    payload = json.dumps({"action": "cruise", "scene": json.loads(highway_scene(1, 2).model_dump_json())}).encode()
    for key in ("discern/car_1/extra/proposal", "discern/proposal"):
        server._submit(key, zenoh.ZBytes(payload), None)
    after = server.status()
    assert after.errors_by_kind.get("vehicle", 0) == before.errors_by_kind.get("vehicle", 0) + 2
    assert after.vehicles == before.vehicles and "car_1" not in server._vehicles and not server._open
