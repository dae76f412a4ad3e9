"""Decision time of two revisions of Discern, measured side by side: what a change of rules or code costs.

The absolute figures of bench_core.py move with the VM's speed, which drifts by up to 3x within the
hour; a change that costs or saves a tenth of a decision shows only when both revisions run at the
same moment, one per core (bench/side_by_side.py). Each revision is taken from git (`git archive`),
or the working tree, and imported from its own folder.

Run: python bench/bench_revisions.py --base REV [--head REV] [--cases kitti 50] [--seconds 20] [--rounds 1]
     (needs 2 cores; writes docs/benchmarks.md)
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.report import machine, pct, write_section  # noqa: E402
from bench.side_by_side import CASES, PAIRED_WITHIN_S, TREE, compare, label  # noqa: E402
from discern.monitor.allocator import relaunch  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
PARTS = ("adapters", "monitor", "rules", "sanity", "scenarios")  # the folders pyproject.toml maps under discern.
WORKING_TREE = "working tree"


def git(*args: str) -> str:
    done = subprocess.run(["git", *args], cwd=REPO, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"bench_revisions: git {' '.join(args)}: {done.stderr.strip()}")
    return done.stdout.strip()


def tree_of(revision: str, role: str, workdir: Path) -> tuple[Path, str]:
    """A folder to import this revision's Discern from (`role`: base or head), and the revision's name."""
    if revision == WORKING_TREE:
        source, name = REPO, f"working tree (on {git('rev-parse', '--short', 'HEAD')})"
    else:
        commit = git("rev-parse", "--short", "--verify", f"{revision}^{{commit}}")
        source = workdir / f"{role}-{commit}"
        archive = workdir / f"{role}.tar"
        git("archive", "--output", str(archive), commit, *PARTS)
        with tarfile.open(archive) as tar:
            tar.extractall(source, filter="data")
        name = f"{commit} ({git('log', '-1', '--format=%cs %s', commit)[:60]})"
    tree = workdir / f"tree-{role}"
    (tree / "discern").mkdir(parents=True)
    for part in PARTS:
        (tree / "discern" / part).symlink_to(source / part)
    return tree, name


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--base", required=True, help="the revision to compare against (a commit, tag or branch)")
    parser.add_argument("--head", default=WORKING_TREE, help="the revision to measure (default: the working tree)")
    parser.add_argument("--cases", nargs="+", default=["kitti", "50"], choices=sorted(CASES))
    parser.add_argument("--seconds", type=float, default=20.0, help="seconds per round and case")
    parser.add_argument("--rounds", type=int, default=1, help="rounds per case, each run on both core placements")
    args = parser.parse_args()
    if os.cpu_count() is None or os.cpu_count() < 2:
        raise SystemExit("bench_revisions: needs 2 cores, one per revision")
    with tempfile.TemporaryDirectory(prefix="discern-bench-revisions-") as tmp:
        (base_tree, base_name), (head_tree, head_name) = (
            tree_of(revision, role, Path(tmp)) for revision, role in ((args.base, "base"), (args.head, "head")))
        variants = {"base": dict(os.environ, **{TREE: str(base_tree)}), "head": dict(os.environ, **{TREE: str(head_tree)})}
        results = [(case, readied, compare(variants, case, readied, args.seconds, args.rounds, Path(tmp)))
                   for case in args.cases for readied in (False, True)]
    rows = []
    for case, readied, r in results:
        base, head = r["ms"]["base"], r["ms"]["head"]
        rows.append(
            f"| {label(case, readied)} | {r['pairs']} | {statistics.median(base):.2f} / {statistics.median(head):.2f} | "
            f"{pct(base, 99):.2f} / {pct(head, 99):.2f} | {r['ratio']:.2f} ({r['placements'][0]:.2f}, {r['placements'][1]:.2f}) |"
        )
    command = f"python bench/bench_revisions.py --base {args.base}" + (
        f" --head {args.head}" if args.head != WORKING_TREE else "")
    body = "\n".join([
        "## Revisions side by side",
        "",
        f"Command: `{command} --cases {' '.join(args.cases)} --seconds {args.seconds:g} --rounds {args.rounds}`  ",
        f"Machine: {machine()}; base: {base_name}; head: {head_name}. Two decision processes at once, one per "
        "revision, one per core (swapped every round), each deciding the same 24 frames in blocks as bench_core.py "
        "does (its warm-up and garbage collector policy; \"Control readied\": `Reasoner.prepare` before each "
        f"decision); blocks that started within {PAIRED_WITHIN_S} s of each other are paired, and the ratio is the geometric mean of the two core placements' median ratios of paired blocks. Both processes share "
        "the machine's memory bandwidth and caches, so each is slower than alone; the ratio is what compares.",
        "",
        "| case | paired blocks | median ms base / head | p99 ms base / head | head / base (each core placement) |",
        "|---|---|---|---|---|",
        *rows,
    ])
    write_section("revisions", body)
    print(body)


if __name__ == "__main__":
    relaunch()  # on jemalloc where the machine has it; the workers inherit it
    main()
