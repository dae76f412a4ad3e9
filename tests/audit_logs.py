"""Real MCAP logs for the audit tests, written by the real monitor judging real proposals over zenoh (loopback).

Three monitors run one after the other, each into its own directory:
- `fleet`: enforcing; car_a on a highway above the limit alternately cruises
  (approved) and accelerates (overridden by acc.at_limit); car_b in town meets a
  pedestrian for its first 10 frames (cruise overridden to brake), then a free
  road; one malformed payload from car_b gets a bad-input fail-safe;
- `shadow`: shadow mode; car_s accelerates above the limit (vetoed);
- `slow`: every decision takes longer than the budget (deadline fail-safes:
  the first frame's proposal is logged, the two queued behind it are not).
The logs are made once per test session.
"""

from __future__ import annotations

import socket
import time
from pathlib import Path

from discern.monitor.client import Monitor
from discern.monitor.config import LogSettings, MonitorConfig, ZenohSettings
from discern.monitor.server import MonitorServer
from tests.scenes import obj, scene

FLEET_A_FRAMES = 40
FLEET_B_FRAMES = 20
PEDESTRIAN_FRAMES = 10
SHADOW_FRAMES = 10
SLOW_FRAMES = 3

_made: dict[str, Path] = {}


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def highway(frame: int, speed: float = 31.0):
    return scene(
        speed=speed, lane=2, lanes=3, limit=30.0, zone="highway", frame=frame,
        objects=(obj("car", 0.0, 60.0, lane=2, vy=31.0), obj("car", -3.5, -10.0, lane=1, vy=30.0)),
    )


def town(frame: int, pedestrian: bool):
    objects = (obj("pedestrian", 0.5, 12.0, lane=1),) if pedestrian else ()
    return scene(speed=8.0, limit=13.9, frame=frame, objects=objects)


def _serve(directory: Path, monitor_id: str, send, **config) -> list[Path]:
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    settings = MonitorConfig(
        monitor_id=monitor_id,
        zenoh=ZenohSettings(listen=[endpoint]),
        workers=1,
        log=LogSettings(directory=directory, flush_seconds=0.05),
        **config,
    )
    with MonitorServer(settings) as server:
        send(endpoint)
        files = list(server.log.files)
    return files


def _fleet(endpoint: str) -> None:
    with Monitor("car_a", connect=[endpoint], timeout=10.0) as car_a, Monitor("car_b", connect=[endpoint], timeout=10.0) as car_b:
        for i in range(FLEET_A_FRAMES):
            verdict = car_a.check(highway(i), "accelerate" if i % 2 else "cruise")
            assert not verdict.failsafe, verdict.error
            if i < FLEET_B_FRAMES:
                car_b.check(town(i, pedestrian=i < PEDESTRIAN_FRAMES), "cruise")
            time.sleep(0.01)  # spread the log over several chunks
        replies = car_b.session.get("discern/car_b/check", payload=b'{"action": "cruise", "scene": ', timeout=10.0)
        assert any(r.ok is not None for r in replies)


def _shadow(endpoint: str) -> None:
    with Monitor("car_s", connect=[endpoint], timeout=10.0) as car_s:
        for i in range(SHADOW_FRAMES):
            car_s.check(highway(i, speed=32.0), "accelerate")


def _slow(endpoint: str) -> None:
    with Monitor("car_l", connect=[endpoint], timeout=10.0) as car_l:
        for i in range(SLOW_FRAMES):
            car_l.check(highway(i), "cruise")


def monitor_logs(tmp_path_factory) -> dict[str, Path]:
    """{'fleet': file, 'shadow': file, 'slow': file}: one MCAP file each, made on first use in the session."""
    if not _made:
        root = tmp_path_factory.mktemp("audit-logs")
        for name, send, config in (
            ("fleet", _fleet, {"budget_ms": 5000.0}),
            ("shadow", _shadow, {"budget_ms": 5000.0, "shadow": True}),
            # the first frame is being judged (slowly) at its deadline, the next two are still queued at theirs
            ("slow", _slow, {"budget_ms": 50.0, "test_decision_delay_ms": 1000.0}),
        ):
            directory = root / name
            files = _serve(directory, f"audit-{name}", send, **config)
            assert len(files) == 1, files
            _made[name] = files[0]
    return dict(_made)


def audit(capsys, *args: str) -> tuple[int, str, str]:
    """`discern audit ARGS` in this process: exit code, stdout, stderr."""
    from discern.monitor.audit.cli import main

    capsys.readouterr()
    code = main(["audit", *args])
    out = capsys.readouterr()
    return code, out.out, out.err
