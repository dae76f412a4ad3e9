"""Audit and replay throughput on monitor-format MCAP logs, across worker processes.

Run: python bench/bench_audit.py [--frames 8000] [--vehicles 16] [--workers 2] [--repeats 3]
(writes the "Audit replay" section of docs/benchmarks.md)

The logs are written by the monitor's own McapLogWriter with verdicts from the
real Reasoner (sanity layer included, each frame judged with its vehicle's
history window as the monitor keeps it), rotated into several files like a
long-running monitor's. Two
fleets are measured: every scene distinct (highway traffic, with the monitor's example
planner's action cycle), and half the vehicles waiting at a red light, whose scenes
repeat frame after frame (once the 2 s history window is full, the replay
solves each distinct frame once).
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import random
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.report import machine, write_section  # noqa: E402
from discern.monitor.allocator import relaunch  # noqa: E402
from discern.monitor.audit.aggregate import audit_logs  # noqa: E402
from discern.monitor.config import LogSettings, MonitorConfig  # noqa: E402
from discern.monitor.example_planner import planner_action  # noqa: E402
from discern.monitor.log import McapLogWriter, read_log, vehicle_topic  # noqa: E402
from discern.monitor.vehicle_state import VehicleState  # noqa: E402
from discern.rules.scene import (  # noqa: E402
    Action,
    DetectedObject,
    Ego,
    Lane,
    LaneKind,
    LaneRef,
    LightColour,
    ObjectClass,
    Proposal,
    Scene,
    TrafficLight,
    Vec2,
    Velocity,
)
from discern.sanity import window_reasoner  # noqa: E402

PERIOD_S = 0.1  # 10 Hz planner


def traffic_scene(frame_id: int, vehicle: int) -> Scene:
    """Highway traffic around the ego, different every frame: a lead car, cars in the lanes beside."""
    rng = random.Random(vehicle * 1_000_003 + frame_id)
    t = frame_id * PERIOD_S
    speed = 26.0 + 3.0 * math.sin(t / 7.0 + vehicle)
    objects = [
        DetectedObject(
            id=1,
            cls=ObjectClass.car,
            position=Vec2(x=rng.uniform(-0.2, 0.2), y=45.0 + 15.0 * math.sin(t / 5.0 + vehicle)),
            lane=LaneRef(kind=LaneKind.current, id=2),
            velocity=Velocity(x=0.0, y=speed + rng.uniform(-1, 1)),
        )
    ]
    for i in range(2, 2 + rng.randint(1, 5)):
        lane = rng.choice((1, 3))
        objects.append(
            DetectedObject(
                id=i,
                cls=rng.choice((ObjectClass.car, ObjectClass.car, ObjectClass.truck)),
                position=Vec2(x=(lane - 2) * 3.5 + rng.uniform(-0.3, 0.3), y=rng.uniform(-40, 80)),
                lane=LaneRef(kind=LaneKind.current, id=lane),
                velocity=Velocity(x=0.0, y=rng.uniform(20, 32)),
            )
        )
    return Scene(
        frame_id=frame_id,
        timestamp=round(1.0 + t, 6),
        ego=Ego(speed=round(speed, 3), lane=2, zone="highway"),
        speed_limit=33.3,
        lanes=[Lane(kind=LaneKind.current, id=i, speed_limit=33.3) for i in (1, 2, 3)],
        objects=objects,
    )


def red_light_scene(frame_id: int, vehicle: int) -> Scene:
    """Stopped at a red light behind a queue: the same scene every frame, only the frame id and time move."""
    queue = [
        DetectedObject(
            id=i + 1,
            cls=ObjectClass.car,
            position=Vec2(x=0.0, y=7.0 + 6.5 * i),
            lane=LaneRef(kind=LaneKind.current, id=1),
            velocity=Velocity(x=0.0, y=0.0),
        )
        for i in range(1 + vehicle % 3)
    ]
    return Scene(
        frame_id=frame_id,
        timestamp=round(1.0 + frame_id * PERIOD_S, 6),
        ego=Ego(speed=0.0, lane=1, zone="city"),
        speed_limit=13.9,
        lanes=[Lane(kind=LaneKind.current, id=1), Lane(kind=LaneKind.current, id=2)],
        objects=queue,
        traffic_lights=[TrafficLight(colour=LightColour.red)],
    )


def write_fleet(directory: Path, frames: int, vehicles: int, waiting_share: float, rotate_mb: float) -> list[Path]:
    """A fleet's log as the monitor writes it: each frame judged with its vehicle's history, proposal then verdict."""
    reasoner = window_reasoner()
    writer = McapLogWriter(
        LogSettings(directory=directory, rotate_bytes=int(rotate_mb * 2**20), flush_seconds=0.2), "bench"
    )
    waiting = int(round(vehicles * waiting_share))
    states = [VehicleState(MonitorConfig().window_s) for _ in range(vehicles)]
    t0 = time.time_ns()
    for f in range(frames // vehicles):
        for v in range(vehicles):
            name = f"car_{v:03d}"
            if v < waiting:
                scene, action = red_light_scene(f, v), (Action.brake if f % 4 else Action.cruise)
            else:
                scene, action = traffic_scene(f, v), planner_action(f + v)
            arrived = t0 + int((f * PERIOD_S + v * 1e-4) * 1e9)
            history = states[v].admit(scene, arrived / 1e9)
            verdict = reasoner.decide(scene, action, history=history, vehicle=name)
            writer.write(
                vehicle_topic(name, "proposal"), "proposal", Proposal(vehicle=name, action=action, scene=scene), arrived
            )
            writer.write(vehicle_topic(name, "verdict"), "verdict", verdict, arrived + 3_000_000)
    writer.close()
    assert writer.dropped == 0, writer.dropped
    return writer.files


def replay_cli(files: list[Path], workers: int, out: Path) -> dict:
    """`discern audit --replay` in its own process, as a user runs it; its JSON report (which times the replay)."""
    command = [str(Path(sys.executable).with_name("discern")), "audit", "--replay", *map(str, files),
               "--workers", str(workers), "--json", str(out), "--quiet"]
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    return json.loads(out.read_text())


def measure(files: list[Path], workers: int, repeats: int) -> dict:
    """The audit once, then the replay `repeats` times: the run with the median rate, and the range."""
    start = time.perf_counter()
    tally = audit_logs([str(f) for f in files], workers=workers)
    audit_s = time.perf_counter() - start
    runs = []
    for _ in range(repeats):
        doc = replay_cli(files, workers, files[0].parent / "replay.json")
        assert not doc["changes"], "the shipped rules must reproduce their own log"
        runs.append(doc)
    runs.sort(key=lambda r: r["frames_per_s"])
    doc = runs[len(runs) // 2]
    return {
        "frames": tally.frames,
        "disagreements": len(tally.disagreements),
        "audit_s": audit_s,
        "replayed": doc["frames"],
        "solved": doc["solved"],
        "decided": doc["decided_in_full"],
        "reused": doc["reused"],
        "wall_s": doc["wall_s"],
        "fps": doc["frames_per_s"],
        "fps_range": (runs[0]["frames_per_s"], runs[-1]["frames_per_s"]),
        "solve_ms": 1000 * doc["solver_s"] / max(1, doc["solved"]),  # grounding and reading answers (+ full decisions)
        "cpu_ms": 1000 * doc["worker_cpu_s"] / max(1, doc["frames"]),
        "workers": doc["workers"],
    }


def read_cost(files: list[Path]) -> float:
    """Seconds to read and validate every record once, in this process (the part every worker repeats per file)."""
    start = time.perf_counter()
    for _ in read_log([str(f) for f in files]):
        pass
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=8000)
    parser.add_argument("--vehicles", type=int, default=16)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--rotate-mb", type=float, default=1.0, help="log file size: more files, more parallel jobs")
    parser.add_argument("--repeats", type=int, default=3, help="replays per case; the median is reported")
    parser.add_argument(
        "--no-write", action="store_true", help="print the section instead of writing docs/benchmarks.md"
    )
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for label, share in (
            ("every scene distinct (highway traffic)", 0.0),
            ("half the fleet waiting at a red light", 0.5),
        ):
            directory = Path(tmp) / f"share{share}"
            files = write_fleet(directory, args.frames, args.vehicles, share, args.rotate_mb)
            size_mb = sum(f.stat().st_size for f in files) / 2**20
            reading = read_cost(files)
            for workers in sorted({1, args.workers}):
                m = measure(files, workers, args.repeats)
                rows.append((label, len(files), size_mb, reading, m))
                print(label, workers, m, flush=True)
    command = (f"python bench/bench_audit.py --frames {args.frames} --vehicles {args.vehicles} "
               f"--workers {args.workers} --rotate-mb {args.rotate_mb:g} --repeats {args.repeats}")
    lines = [
        "## Audit replay",
        "",
        f"Command: `{command}`  ",
        f"Machine: {machine()}; logs written by the monitor's McapLogWriter (zstd), verdicts from the shipped catalog; "
        f"each replay run {args.repeats} times as a user runs it (`discern audit --replay FILES --workers N --json`, "
        "its own process; the rate is its report's, from loading the rules to the last frame), the median run shown "
        "with the range of its rate.",
        "",
        "| fleet | files (MiB) | workers | frames (disagreements) | audit s (frames/s) | replay s | replay frames/s (range) | solved / reused (decided in full) | solver ms per solved frame | worker CPU ms per frame |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for label, nfiles, size_mb, _reading, m in rows:
        low, high = m["fps_range"]
        lines.append(
            f"| {label} | {nfiles} ({size_mb:.1f}) | {m['workers']} | {m['replayed']} ({m['disagreements']}) | {m['audit_s']:.2f} "
            f"({m['frames'] / m['audit_s']:.0f}) | {m['wall_s']:.2f} | **{m['fps']:.0f}** ({low:.0f}–{high:.0f}) | "
            f"{m['solved']} / {m['reused']} ({m['decided']}) | {m['solve_ms']:.2f} | {m['cpu_ms']:.2f} |"
        )
    lines.append("")
    lines.append(
        "Reading and validating every record once, in one process: "
        + ", ".join(f"{label}: {reading:.2f} s" for label, _, _, reading, _ in rows[:: len({1, args.workers})])
        + f". Python {platform.python_version()}."
    )
    distinct = [m for label, _, _, _, m in rows if m["reused"] == 0]
    if distinct:
        best = max(distinct, key=lambda m: m["fps"])
        low = best["fps_range"][0]
        verdict = "met" if best["fps"] >= 2000 else "missed"
        spread = (f"every run at or above it (slowest {low:.0f})" if low >= 2000
                  else f"the slowest of the {args.repeats} runs gave {low:.0f}")
        lines += [
            "",
            f"Target ≥ 2,000 frames/s on 2 cores, every scene distinct: {verdict} by the median run "
            f"({best['fps']:.0f} frames/s with {best['workers']} worker(s)); {spread}. Frames are grounded 96 at a time "
            "in one clingo Control (rules/batch.py), their facts handed over as terms rather than text to parse, so "
            "the per-rule cost of grounding is paid once per batch; what is "
            "left per frame is clingo's own work on the frame's facts and rule instances and the Python around it "
            f"({distinct[0]['solve_ms']:.2f} ms of solver time and {distinct[0]['cpu_ms']:.2f} ms of worker CPU per "
            "frame in the one-worker run). Frames that repeat (a vehicle standing at a light, once its 2 s history "
            "window is full) are solved once.",
        ]
    body = "\n".join(lines)
    if args.no_write:
        print(body)
    else:
        write_section("audit", body)
        print(body)


if __name__ == "__main__":
    relaunch()  # on jemalloc where the machine has it, as the `discern` command runs (monitor/allocator.py)
    main()
