"""Decision time on glibc's malloc against preloaded jemalloc (monitor/allocator.py), measured side by side.

The development VM's speed drifts by up to 2x within minutes, more than the
difference measured here, so the two allocators run at the same time: two
processes, one on each core, each deciding the same frames in blocks of 24;
blocks that started within half a second of each other are paired, and the
two swap cores every round. The ratio is the median of the paired blocks'
median ratios.

Run: python bench/bench_allocator.py [--seconds 30] [--rounds 2]   (needs 2 cores; writes docs/benchmarks.md)
"""

from __future__ import annotations

import argparse
import bisect
import json
import os
import random
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.report import machine, pct, timed, write_section  # noqa: E402
from bench.scenes import random_scene  # noqa: E402
from discern.monitor.allocator import chosen, in_use, relaunch  # noqa: E402

KITTI = Path(__file__).resolve().parents[2] / "shared" / "avcsr" / "kitti"
CASES = {"kitti": "24 KITTI frames, Control readied", "50": "random scenes, 50 objects, Control readied",
         "200": "random scenes, 200 objects, Control readied"}
PAIRED_WITHIN_S = 0.5


def worker(case: str, core: int, start: float, seconds: float, out: str) -> None:
    """Decide the case's 24 frames again and again, readied as a sidecar worker does; blocks of timings to `out`."""
    from discern.adapters.avcsr import read_dir
    from discern.monitor.decision_worker import defer_full_collections
    from discern.rules.engine import Reasoner

    os.sched_setaffinity(0, {core})
    reasoner = Reasoner()
    if case == "kitti":
        frames = [(f.scene, f.expected) for f in read_dir(KITTI)]
    else:
        rng = random.Random(2026)
        frames = [(random_scene(rng, int(case), i), "cruise") for i in range(24)]
    for scene, action in frames:
        reasoner.decide(scene, action)
    defer_full_collections()
    while time.time() < start:
        time.sleep(0.001)
    blocks = []
    while time.time() < start + seconds:
        began = time.time()
        block = []
        for scene, action in frames:
            block += timed(lambda: reasoner.decide(scene, action), 1, between=reasoner.prepare)
        blocks.append((began, block))
    Path(out).write_text(json.dumps({"malloc": in_use(), "blocks": blocks}))


def side_by_side(case: str, seconds: float, rounds: int, workdir: Path) -> dict:
    glibc_ms, jemalloc_ms, ratios, names = [], [], [], set()
    for round_ in range(2 * rounds):
        start = time.time() + 5  # both loaded and warm before it
        runs = []
        for name, malloc in (("glibc", "system"), ("jemalloc", "auto")):
            core = (round_ + (name == "jemalloc")) % 2
            out = workdir / f"{name}.json"
            env = dict(os.environ, DISCERN_MALLOC=malloc)
            env.pop("LD_PRELOAD", None)
            runs.append((out, subprocess.Popen(
                [sys.executable, __file__, "--worker", case, str(core), str(start), str(seconds), str(out)], env=env)))
        for _, process in runs:
            if process.wait() != 0:
                raise SystemExit(f"bench_allocator: a {case} worker failed")
        glibc, jemalloc = (json.loads(out.read_text()) for out, _ in runs)
        names.update((glibc["malloc"], jemalloc["malloc"]))
        starts = [began for began, _ in jemalloc["blocks"]]
        for began, block in glibc["blocks"]:
            i = bisect.bisect_left(starts, began)
            near = [j for j in (i - 1, i) if 0 <= j < len(starts) and abs(starts[j] - began) < PAIRED_WITHIN_S]
            if near:
                other = jemalloc["blocks"][min(near, key=lambda j: abs(starts[j] - began))][1]
                ratios.append(statistics.median(other) / statistics.median(block))
        glibc_ms += [t for _, block in glibc["blocks"] for t in block]
        jemalloc_ms += [t for _, block in jemalloc["blocks"] for t in block]
    return {"glibc": glibc_ms, "jemalloc": jemalloc_ms, "ratios": ratios, "malloc": sorted(names)}


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--seconds", type=float, default=30.0, help="seconds per round and case")
    parser.add_argument("--rounds", type=int, default=2, help="rounds per case, each run on both core placements")
    parser.add_argument("--worker", nargs=5, metavar=("CASE", "CORE", "START", "SECONDS", "OUT"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        case, core, start, seconds, out = args.worker
        worker(case, int(core), float(start), float(seconds), out)
        return
    if os.cpu_count() is None or os.cpu_count() < 2:
        raise SystemExit("bench_allocator: needs 2 cores, one per allocator")
    if chosen({}) is None:
        raise SystemExit("bench_allocator: no jemalloc on this machine (Debian: apt install libjemalloc2)")
    with tempfile.TemporaryDirectory(prefix="discern-bench-malloc-") as tmp:
        results = {case: side_by_side(case, args.seconds, args.rounds, Path(tmp)) for case in CASES}
    rows = []
    for case, label in CASES.items():
        r = results[case]
        rows.append(
            f"| {label} | {len(r['ratios'])} | {statistics.median(r['glibc']):.2f} / {statistics.median(r['jemalloc']):.2f} | "
            f"{pct(r['glibc'], 99):.2f} / {pct(r['jemalloc'], 99):.2f} | {statistics.median(r['ratios']):.2f} |"
        )
    body = "\n".join([
        "## Allocator: glibc's malloc against preloaded jemalloc",
        "",
        f"Command: `python bench/bench_allocator.py --seconds {args.seconds:g} --rounds {args.rounds}`  ",
        f"Machine: {machine()}; two decision processes at once, one on glibc's malloc and one with "
        f"{', '.join(n for n in results['kitti']['malloc'] if n != 'glibc malloc')}, one per core (swapped "
        f"every round), each deciding the same 24 frames in blocks, Controls readied as in the sidecar "
        f"(`Reasoner.prepare`); blocks that started within {PAIRED_WITHIN_S} s of each other are paired. "
        "Both processes share the machine's memory bandwidth and caches, so each is slower than alone; the "
        "ratio is what compares.",
        "",
        "| case | paired blocks | median ms glibc / jemalloc | p99 ms glibc / jemalloc | jemalloc / glibc (median of pairs) |",
        "|---|---|---|---|---|",
        *rows,
    ])
    write_section("allocator", body)
    print(body)


if __name__ == "__main__":
    relaunch()  # a worker on DISCERN_MALLOC=system stays on glibc's malloc
    main()
