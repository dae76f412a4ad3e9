"""Decision time on glibc's malloc against preloaded jemalloc (monitor/allocator.py), measured side by side.

The development VM's speed drifts by up to 2x within minutes, more than the difference measured here,
so the two allocators run at the same time, one process on each core (bench/side_by_side.py).

Run: python bench/bench_allocator.py [--seconds 30] [--rounds 2]   (needs 2 cores; writes docs/benchmarks.md)
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.report import machine, pct, write_section  # noqa: E402
from bench.side_by_side import PAIRED_WITHIN_S, compare, label  # noqa: E402
from discern.monitor.allocator import chosen, relaunch  # noqa: E402

CASES = ("kitti", "50", "200")  # each with its Controls readied, as in the sidecar


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--seconds", type=float, default=30.0, help="seconds per round and case")
    parser.add_argument("--rounds", type=int, default=2, help="rounds per case, each run on both core placements")
    args = parser.parse_args()
    if os.cpu_count() is None or os.cpu_count() < 2:
        raise SystemExit("bench_allocator: needs 2 cores, one per allocator")
    if chosen({}) is None:
        raise SystemExit("bench_allocator: no jemalloc on this machine (Debian: apt install libjemalloc2)")
    base = {k: v for k, v in os.environ.items() if k != "LD_PRELOAD"}
    variants = {"glibc": dict(base, DISCERN_MALLOC="system"), "jemalloc": dict(base, DISCERN_MALLOC="auto")}
    with tempfile.TemporaryDirectory(prefix="discern-bench-malloc-") as tmp:
        results = {case: compare(variants, case, True, args.seconds, args.rounds, Path(tmp)) for case in CASES}
    rows = []
    for case in CASES:
        r = results[case]
        glibc, jemalloc = r["ms"]["glibc"], r["ms"]["jemalloc"]
        rows.append(
            f"| {label(case, True)} | {r['pairs']} | {statistics.median(glibc):.2f} / {statistics.median(jemalloc):.2f} | "
            f"{pct(glibc, 99):.2f} / {pct(jemalloc, 99):.2f} | {r['ratio']:.2f} ({r['placements'][0]:.2f}, {r['placements'][1]:.2f}) |"
        )
    body = "\n".join([
        "## Allocator: glibc's malloc against preloaded jemalloc",
        "",
        f"Command: `python bench/bench_allocator.py --seconds {args.seconds:g} --rounds {args.rounds}`  ",
        f"Machine: {machine()}; two decision processes at once, one on glibc's malloc and one with "
        f"{results['kitti']['malloc']['jemalloc']}, one per core (swapped "
        f"every round), each deciding the same 24 frames in blocks, Controls readied as in the sidecar "
        f"(`Reasoner.prepare`); blocks that started within {PAIRED_WITHIN_S} s of each other are paired, and the ratio is the geometric mean of the two core placements' median ratios of paired blocks. "
        "Both processes share the machine's memory bandwidth and caches, so each is slower than alone; the "
        "ratio is what compares.",
        "",
        "| case | paired blocks | median ms glibc / jemalloc | p99 ms glibc / jemalloc | jemalloc / glibc (each core placement) |",
        "|---|---|---|---|---|",
        *rows,
    ])
    write_section("allocator", body)
    print(body)


if __name__ == "__main__":
    relaunch()
    main()
