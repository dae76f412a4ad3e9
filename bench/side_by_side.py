"""Two variants of Discern's decision loop timed at the same moment, one per core, their blocks paired.

The development VM's speed drifts by up to 3x within the hour, more than most changes move a decision,
so two variants are never timed one after the other: two processes, one on each core, decide the same
frames in blocks of 24; blocks that started within half a second of each other are paired, and the two
swap cores every round. The ratio is taken per placement (which variant on which core), as the median of
its paired blocks' median ratios, and the two placements' ratios are averaged geometrically: one core of
the VM can be a tenth faster than the other, which a median over all pairs does not cancel. A variant is the
environment its process runs in: a malloc (bench_allocator.py) or a source tree (bench_revisions.py).

Run as a worker (what `compare` starts): python bench/side_by_side.py CASE READIED CORE START SECONDS OUT
"""

from __future__ import annotations

import bisect
import json
import math
import os
import random
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Mapping

TREE = "DISCERN_BENCH_TREE"  # a folder with discern/<part> folders: the worker imports Discern from it
KITTI = Path(__file__).resolve().parents[2] / "shared" / "avcsr" / "kitti"
CASES = {"kitti": "24 KITTI frames", "10": "random scenes, 10 objects", "50": "random scenes, 50 objects",
         "200": "random scenes, 200 objects"}
PAIRED_WITHIN_S = 0.5


def label(case: str, readied: bool) -> str:
    return CASES[case] + (", Control readied" if readied else "")


def compare(variants: Mapping[str, Mapping[str, str]], case: str, readied: bool, seconds: float, rounds: int,
            workdir: Path) -> dict:
    """Run the two variants (name -> environment) side by side: their timings, how many blocks were paired,
    each core placement's median ratio of paired blocks (the second's / the first's), and `ratio`, their
    geometric mean."""
    (first, _), (second, _) = variants.items()
    ms: dict[str, list[float]] = {first: [], second: []}
    ratios: dict[int, list[float]] = {0: [], 1: []}  # by placement: the first variant on core 0, or on core 1
    malloc: dict[str, str] = {}
    for round_ in range(2 * rounds):
        start = time.time() + 5  # both loaded and warm before it
        runs = []
        for k, (name, env) in enumerate(variants.items()):
            out = workdir / f"variant{k}.json"
            command = [sys.executable, __file__, case, str(int(readied)), str((round_ + k) % 2), str(start),
                       str(seconds), str(out)]
            runs.append((name, out, subprocess.Popen(command, env=dict(env))))
        for name, _, process in runs:
            if process.wait() != 0:
                raise SystemExit(f"side_by_side: the {name} worker failed on {label(case, readied)}")
        (_, a_out, _), (_, b_out, _) = runs
        a, b = json.loads(a_out.read_text()), json.loads(b_out.read_text())
        malloc.update({first: a["malloc"], second: b["malloc"]})
        starts = [began for began, _ in b["blocks"]]
        for began, block in a["blocks"]:
            i = bisect.bisect_left(starts, began)
            near = [j for j in (i - 1, i) if 0 <= j < len(starts) and abs(starts[j] - began) < PAIRED_WITHIN_S]
            if near:
                other = b["blocks"][min(near, key=lambda j: abs(starts[j] - began))][1]
                ratios[round_ % 2].append(statistics.median(other) / statistics.median(block))
        ms[first] += [t for _, block in a["blocks"] for t in block]
        ms[second] += [t for _, block in b["blocks"] for t in block]
    if not ratios[0] or not ratios[1]:
        raise SystemExit(f"side_by_side: no paired blocks on one core placement of {label(case, readied)}")
    placements = [statistics.median(r) for r in ratios.values()]
    ratio = math.exp(statistics.mean(math.log(r) for r in placements))
    return {"ms": ms, "pairs": len(ratios[0]) + len(ratios[1]), "ratio": ratio, "placements": placements,
            "malloc": malloc}


def worker(case: str, readied: bool, core: int, start: float, seconds: float, out: str) -> None:
    """Decide the case's 24 frames again and again, as bench_core.py does; blocks of timings to `out`."""
    from bench.report import timed
    from bench.scenes import WARM_UP_SCENES, random_scene
    from discern.adapters.avcsr import read_dir
    from discern.monitor.allocator import in_use
    from discern.rules.engine import Reasoner
    try:
        from discern.monitor.decision_worker import defer_full_collections
    except ImportError:  # a tree from before 2026-11-25, when it lived in the decision pool
        from discern.monitor.decision_pool import defer_full_collections
    try:
        from discern.sanity import window_reasoner
    except ImportError:  # a tree from before the sanity layer composed its Reasoner, which had the window by default
        window_reasoner = Reasoner

    tree = os.environ.get(TREE)
    if tree and Path(sys.modules[Reasoner.__module__].__file__).resolve().parent != (Path(tree) / "discern" / "rules").resolve():
        raise SystemExit(f"side_by_side: Discern was imported from {sys.modules[Reasoner.__module__].__file__}, not {tree}")
    os.sched_setaffinity(0, {core})
    reasoner = window_reasoner()
    if case == "kitti":
        frames = [(f.scene, f.expected) for f in read_dir(KITTI)]
        warm = []
    else:
        rng, warm_rng = random.Random(2026), random.Random(7)
        frames = [(random_scene(rng, int(case), i), "cruise") for i in range(24)]
        warm = [(random_scene(warm_rng, int(case), i), "cruise") for i in range(WARM_UP_SCENES)]
    for scene, action in warm + frames:
        reasoner.decide(scene, action)
    defer_full_collections()
    between = reasoner.prepare if readied else None
    while time.time() < start:
        time.sleep(0.001)
    blocks = []
    while time.time() < start + seconds:
        began = time.time()
        block = []
        for scene, action in frames:
            block += timed(lambda: reasoner.decide(scene, action), 1, between=between)
        blocks.append((began, block))
    Path(out).write_text(json.dumps({"malloc": in_use(), "blocks": blocks}))


def _use_tree() -> None:
    """Import Discern from the variant's tree, not from the installed (editable) one."""
    tree = os.environ.get(TREE)
    if tree:
        sys.meta_path[:] = [f for f in sys.meta_path if not getattr(f, "__module__", "").startswith("__editable__")]
        sys.path.insert(0, tree)


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # bench/ itself, from the tree running the comparison
    _use_tree()
    from discern.monitor.allocator import relaunch

    relaunch()  # DISCERN_MALLOC picks the worker's malloc (bench_allocator.py); LD_PRELOAD set already, it goes on
    case_, readied_, core_, start_, seconds_, out_ = sys.argv[1:]
    worker(case_, readied_ == "1", int(core_), float(start_), float(seconds_), out_)
