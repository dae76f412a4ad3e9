"""A readied worker's decision time after it has waited idle: what bench_core.py's "Control readied" rows leave out.

bench_core.py decides each frame right after readying its Control. A sidecar worker readies it, then waits for
the next proposal (50 ms at 20 Hz), its core idle or running other processes meanwhile: the caches it warmed
are cooled again when the proposal comes. Here each frame is decided right after readying and after an idle
wait, cases interleaved frame by frame.

Run: python bench/bench_idle.py [--repeats 20]   (one process; writes docs/benchmarks.md)
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.report import machine, pct, write_section  # noqa: E402
from discern.adapters.avcsr import read_dir  # noqa: E402
from discern.monitor.allocator import relaunch  # noqa: E402
from discern.monitor.decision_worker import defer_full_collections  # noqa: E402
from discern.monitor.example_planner import highway_scene, planner_action  # noqa: E402
from discern.rules.engine import Reasoner  # noqa: E402
from discern.sanity import window_reasoner  # noqa: E402

KITTI = Path(__file__).resolve().parents[2] / "shared" / "avcsr" / "kitti"
IDLE_MS = (0, 5, 20, 50)  # 0: at once, as bench_core.py; 50: a proposal every 50 ms (20 Hz)


def run(reasoner: Reasoner, cases: list[tuple], repeats: int) -> dict[int, list[float]]:
    """Milliseconds per decision by idle wait, each frame decided after each wait in turn."""
    times: dict[int, list[float]] = {idle: [] for idle in IDLE_MS}
    for _ in range(repeats):
        for scene, action in cases:
            for idle in IDLE_MS:
                reasoner.prepare()
                if idle:
                    time.sleep(idle / 1000)
                start = time.perf_counter()
                reasoner.decide(scene, action)
                times[idle].append((time.perf_counter() - start) * 1000)
    return times


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeats", type=int, default=20, help="decisions per KITTI frame and wait")
    args = parser.parse_args()
    kitti = [(f.scene, f.expected) for f in read_dir(KITTI)]
    highway = [(highway_scene(f, 50), planner_action(f)) for f in range(24)]
    reasoner = window_reasoner()
    for scene, action in kitti + highway:  # warm-up: slices and caches, as bench_core.py
        reasoner.decide(scene, action)
    defer_full_collections()
    results = {
        "24 KITTI frames (approve, summary + rule ids)": run(reasoner, kitti, args.repeats),
        "24 of the example planner's 50-object highway frames": run(reasoner, highway, max(1, args.repeats // 4)),
    }
    rows = [
        f"| {name} | {'decided at once' if idle == 0 else f'after {idle} ms idle'} | {len(values)} | "
        f"{statistics.median(values):.2f} | {pct(values, 99):.2f} | {max(values):.2f} |"
        for name, by_idle in results.items() for idle, values in by_idle.items()
    ]
    body = "\n".join([
        "## A readied worker after an idle wait",
        "",
        f"Command: `python bench/bench_idle.py --repeats {args.repeats}`  ",
        f"Machine: {machine()}; one process, wall-clock per decision; before each, the frame's Control readied "
        "(`Reasoner.prepare`), then the wait, asleep, as a sidecar worker waits for its next proposal; the waits "
        "interleaved frame by frame. The first row of each case decides at once, as bench_core.py's \"Control "
        "readied\" rows do; those repeat a frame back to back, where here frames and waits take turns, so its "
        "caches are colder here.",
        "",
        "| case | decided | decisions | median ms | p99 ms | max ms |",
        "|---|---|---|---|---|---|",
        *rows,
    ])
    write_section("idle", body)
    print(body)


if __name__ == "__main__":
    relaunch()  # on jemalloc where the machine has it, as the `discern` command runs (monitor/allocator.py)
    main()
