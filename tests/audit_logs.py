"""Real MCAP logs for the audit tests, written by the real monitor judging real proposals over zenoh (loopback).

Four monitors run one after the other, each into its own directory:
- `fleet`: enforcing; car_a on a highway above the limit alternately cruises
  (approved) and accelerates (overridden by acc.at_limit); car_b in town has a
  pedestrian ahead (cruise overridden to brake), car_c the same street empty
  (approved); one malformed payload from car_b gets a bad-input fail-safe;
- `shadow`: shadow mode; car_s accelerates above the limit (vetoed);
- `slow`: every decision takes longer than the budget (deadline fail-safes);
- `memory`: car_m sees a pedestrian ahead, then loses it: the sanity layer's
  object permanence keeps it braking for a while, a decision that needs history.
The logs are made once per test session.
"""

from __future__ import annotations

import json
import re
import shutil
import time
from pathlib import Path
from typing import Iterable, Optional, Union

from mcap.reader import make_reader
from mcap.writer import Writer

from discern.monitor.client import Monitor
from discern.monitor.config import LogSettings, MonitorConfig, ZenohSettings, free_port
from discern.monitor.log import McapLogWriter, vehicle_topic
from discern.monitor.server import MonitorServer
from discern.rules.scene import Proposal, Scene
from tests.scenes import obj, scene

FLEET_A_FRAMES = 40
PEDESTRIAN_FRAMES = 10  # car_b
CLEAR_FRAMES = 10  # car_c
SHADOW_FRAMES = 30  # 3 s at 10 Hz: longer than the 2 s history window, so the last frames repeat exactly
SLOW_FRAMES = 3
MEMORY_SEEN, MEMORY_LOST = 5, 10
# frames in fleet + shadow + slow: car_a, car_b (+ its malformed payload), car_c, car_s, car_l
FRAMES = FLEET_A_FRAMES + PEDESTRIAN_FRAMES + 1 + CLEAR_FRAMES + SHADOW_FRAMES + SLOW_FRAMES

_made: dict[str, Path] = {}



def highway(frame: int, speed: float = 31.0):
    return scene(
        speed=speed,
        lane=2,
        lanes=3,
        limit=30.0,
        zone="highway",
        frame=frame,
        timestamp=frame * 0.1,
        objects=(obj("car", 0.0, 80.0, lane=2, vy=31.0), obj("car", -3.5, -10.0, lane=1, vy=30.0)),  # past two seconds
    )


def town(frame: int, pedestrian: bool):
    objects = (obj("pedestrian", 0.5, 12.0, lane=1),) if pedestrian else ()
    return scene(speed=8.0, limit=13.9, frame=frame, timestamp=frame * 0.1, objects=objects)


def flashing(frame: int, lights: bool = True):
    """A car ahead whose emergency lights are on in some frames: one on duty once seen on in two frames of the
    window (or in the first frame, when no earlier one is known): a verdict that depends on the history."""
    return scene(frame=frame, timestamp=frame * 0.1, objects=(obj("car", 0.0, 40.0, lane=1, emergency_lights=lights),))


def serve_log(directory: Path, monitor_id: str, send, log: Optional[dict] = None, **config) -> list[Path]:
    """Run a monitor logging to `directory` while `send(endpoint)` talks to it; its log files.

    `log`: LogSettings other than a flush every 0.05 s."""
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    settings = MonitorConfig(
        monitor_id=monitor_id,
        zenoh=ZenohSettings(listen=[endpoint]),
        workers=1,
        log=LogSettings(directory=directory, **{"flush_seconds": 0.05, **(log or {})}),
        **config,
    )
    with MonitorServer(settings) as server:
        send(endpoint)
        files = list(server.log.files)
    return files


def _fleet(endpoint: str) -> None:
    with (
        Monitor("car_a", connect=[endpoint], timeout=10.0) as car_a,
        Monitor("car_b", connect=[endpoint], timeout=10.0) as car_b,
        Monitor("car_c", connect=[endpoint], timeout=10.0) as car_c,
    ):
        for i in range(FLEET_A_FRAMES):
            verdicts = [car_a.check(highway(i), "accelerate" if i % 2 else "cruise")]
            if i < PEDESTRIAN_FRAMES:
                verdicts.append(car_b.check(town(i, pedestrian=True), "cruise"))
            if i < CLEAR_FRAMES:
                verdicts.append(car_c.check(town(i, pedestrian=False), "cruise"))
            assert not any(v.failsafe for v in verdicts), [v.error for v in verdicts]
            time.sleep(0.01)  # spread the log over several chunks
        replies = car_b.session.get("discern/car_b/check", payload=b'{"action": "cruise", "scene": ', timeout=10.0)
        assert any(r.ok is not None for r in replies)


def _shadow(endpoint: str) -> None:
    with Monitor("car_s", connect=[endpoint], timeout=10.0) as car_s:
        for i in range(SHADOW_FRAMES):
            car_s.check(highway(i, speed=32.0), "accelerate")


def _memory(endpoint: str) -> None:
    with Monitor("car_m", connect=[endpoint], timeout=10.0) as car_m:
        for i in range(MEMORY_SEEN + MEMORY_LOST):
            assert not car_m.check(town(i, pedestrian=i < MEMORY_SEEN), "cruise").failsafe


def _slow(endpoint: str) -> None:
    with Monitor("car_l", connect=[endpoint], timeout=10.0) as car_l:
        for i in range(SLOW_FRAMES):
            car_l.check(highway(i), "cruise")


def monitor_logs(tmp_path_factory) -> dict[str, Path]:
    """{'fleet': file, 'shadow': file, 'slow': file, 'memory': file}: one MCAP file each, made once per session."""
    if not _made:
        root = tmp_path_factory.mktemp("audit-logs")
        for name, send, config in (
            ("fleet", _fleet, {"budget_ms": 1000.0}),
            ("shadow", _shadow, {"budget_ms": 1000.0, "shadow": True}),
            ("memory", _memory, {"budget_ms": 1000.0}),
            ("slow", _slow, {"budget_ms": 50.0, "test_decision_delay_ms": 1000.0}),
        ):
            directory = root / name
            files = serve_log(directory, f"audit-{name}", send, **config)
            assert len(files) == 1, files
            _made[name] = files[0]
    return dict(_made)


def write_log(
    directory: Path, frames: Iterable[tuple[str, Scene, str, int, Optional[int]]], reasoner, monitor_id: str = "m1"
) -> Path:
    """A log written by the monitor's own writer, at the times given, without a monitor's pace: the file.

    Each frame is (vehicle, scene, action, proposal time, verdict time or None for a verdict lost); the
    verdict is the shipped rules' (without history).
    """
    writer = McapLogWriter(LogSettings(directory=directory), monitor_id)
    for vehicle, frame_scene, action, proposed_ns, decided_ns in frames:
        proposal = Proposal(vehicle=vehicle, action=action, scene=frame_scene)
        writer.write(vehicle_topic(vehicle, "proposal"), "proposal", proposal, log_time_ns=proposed_ns)
        if decided_ns is not None:
            verdict = reasoner.decide(frame_scene, proposal.action, vehicle=vehicle)
            writer.write(vehicle_topic(vehicle, "verdict"), "verdict", verdict, log_time_ns=decided_ns)
    writer.close()
    assert writer.dropped == 0
    [path] = writer.files
    return path


def audit(capsys, *args: str) -> tuple[int, str, str]:
    """`discern audit ARGS` in this process: exit code, stdout, stderr."""
    from discern.monitor.cli import main

    capsys.readouterr()
    code = main(["audit", *args])
    out = capsys.readouterr()
    return code, out.out, out.err


def tolerant_rules(directory: Path) -> Path:
    """A copy of the shipped driving rules whose acc.at_limit tolerates 5 m/s over the limit."""
    from discern.rules.catalog import catalog_dirs

    rules = directory / "catalog"
    shutil.copytree(catalog_dirs()[0], rules)
    for path in rules.glob("*.lp"):
        text = path.read_text()
        start = text.find("%! rule acc.at_limit\n")
        if start < 0:
            continue
        end = text.find("\n\n", start)
        block = text[start:end]
        edited = re.sub(r"V \+ D > S\.$", "V + D > S + 500.", block, flags=re.M)
        assert edited != block, block
        path.write_text(text[:start] + edited + text[end:])
        return rules
    raise AssertionError("rule acc.at_limit is not in the shipped catalog")


def rewrite(
    source: Path, targets: list[Path], splits: tuple[int, ...] = (), foreign: bool = False,
    metadata: Union[None, dict[str, str], list[dict[str, str]]] = None, version: Optional[int] = None,
) -> None:
    """Copy a log's messages, in order, into new files with the mcap library (as another recorder would).

    Messages after the k-th index in `splits` go to targets[k + 1]: a rotation, where the monitor's would be.
    `metadata`: a `discern` metadata record for every file, as the monitor writes one (a list: one per file).
    `version`: the schema version every message that states one states instead (a log of another version).
    """
    with open(source, "rb") as f:
        messages = list(make_reader(f).iter_messages(log_time_order=False))
    outputs = [open(t, "wb") for t in targets]
    writers = [Writer(o) for o in outputs]
    ids: list[dict] = [{} for _ in targets]
    for k, w in enumerate(writers):
        w.start(profile="", library="test")
        if metadata is not None:
            w.add_metadata("discern", metadata[k] if isinstance(metadata, list) else metadata)
    for i, (schema, channel, message) in enumerate(messages):
        k = min(sum(split < i for split in splits), len(targets) - 1)
        w, known = writers[k], ids[k]
        if channel.topic not in known:
            schema_id = w.register_schema(schema.name, schema.encoding, schema.data)
            known[channel.topic] = w.register_channel(channel.topic, channel.message_encoding, schema_id)
        data = message.data
        if version is not None and "version" in json.loads(data):
            data = json.dumps({**json.loads(data), "version": version}).encode()
        w.add_message(known[channel.topic], message.log_time, data, message.publish_time)
        if foreign:
            if "camera" not in known:
                camera = w.register_schema("acme.CameraInfo", "jsonschema", b'{"type": "object"}')
                known["camera"] = w.register_channel("/camera/front/info", "json", camera)
                debug = w.register_schema("discern.Debug", "jsonschema", b'{"type": "object"}')
                known["debug"] = w.register_channel("/discern/car_a/debug", "json", debug)
            w.add_message(known["camera"], message.log_time, b'{"width": 1920}', message.log_time)
            w.add_message(known["debug"], message.log_time, b'{"x": 1}', message.log_time)
    for w, o in zip(writers, outputs, strict=True):
        w.finish()
        o.close()
