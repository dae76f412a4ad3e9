"""Per-frame decision time of the reasoning core, scaling with scene size, and memory over a long run.

Run: python bench/bench_core.py [--frames 10000]   (one process, one core; writes docs/benchmarks.md)
"""

from __future__ import annotations

import argparse
import gc
import random
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.scenes import WARM_UP_SCENES, random_scene  # noqa: E402
from bench.report import machine, pct, timed, write_section  # noqa: E402
from discern.monitor.allocator import relaunch  # noqa: E402
from discern.adapters.avcsr import read_dir  # noqa: E402
from discern.monitor.example_planner import highway_scene, planner_action  # noqa: E402
from discern.monitor.decision_worker import defer_full_collections  # noqa: E402
from discern.rules.engine import Request  # noqa: E402
from discern.sanity import window_reasoner  # noqa: E402

KITTI = Path(__file__).resolve().parents[2] / "shared" / "avcsr" / "kitti"
SCALING_TARGETS = {10: "-", 50: "p99 ≤ 5 ms", 200: "p99 ≤ 15 ms"}  # objects per random scene: p99 target


def rss_mib() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS"):
            return int(line.split()[1]) / 1024
    return float("nan")


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--frames", type=int, default=10_000, help="frames for the memory run")
    parser.add_argument("--repeats", type=int, default=50, help="timed decisions per KITTI frame")
    args = parser.parse_args()
    reasoner = window_reasoner()
    ready = window_reasoner()  # its Controls readied before each decision, as a sidecar worker does while it waits
    frames = read_dir(KITTI)
    for f in frames:  # warm-up: slices and caches
        reasoner.decide(f.scene, f.expected)
        ready.decide(f.scene, f.expected)
    defer_full_collections()  # the monitor's decision workers' policy: rules frozen, full collections when idle
    kitti_before = reasoner.slicer.regrounds + ready.slicer.regrounds

    fast, readied, approve_tree, veto_tree = [], [], [], []
    for f in frames:
        fast += timed(lambda: reasoner.decide(f.scene, f.expected), args.repeats)
        readied += timed(lambda: ready.decide(f.scene, f.expected), args.repeats, between=ready.prepare)
        approve_tree += timed(lambda: reasoner.decide(f.scene, f.expected, explain=True), max(1, args.repeats // 5))
        wrong = "accelerate" if f.expected.value != "accelerate" else "turn_left"
        veto_tree += timed(lambda: reasoner.decide(f.scene, wrong), max(1, args.repeats // 5))

    kitti_regrounds = reasoner.slicer.regrounds + ready.slicer.regrounds - kitti_before

    rng = random.Random(2026)
    warm_rng = random.Random(7)  # other scenes of each size: what a worker that has run a while has seen
    scaling, scaling_ready, regrounds = {}, {}, {}
    for n in SCALING_TARGETS:
        gc.collect()  # between cases, where a worker's IdleWork would run
        scenes = [random_scene(rng, n, i) for i in range(60)]
        for sc in [random_scene(warm_rng, n, i) for i in range(WARM_UP_SCENES)]:
            reasoner.decide(sc, "cruise")
            ready.decide(sc, "cruise")
        before = reasoner.slicer.regrounds + ready.slicer.regrounds
        scaling[n], scaling_ready[n] = [], []
        for sc in scenes:
            scaling[n] += timed(lambda: reasoner.decide(sc, "cruise"), 3)
            scaling_ready[n] += timed(lambda: ready.decide(sc, "cruise"), 3, between=ready.prepare)
        regrounds[n] = reasoner.slicer.regrounds + ready.slicer.regrounds - before

    # Throughput mode: many frames in one grounding (Reasoner.decide_many), as the busy sidecar and the replay run.
    batch = [Request(f.scene, f.expected) for f in frames]
    kitti_batched = [t / len(batch) for t in timed(lambda: reasoner.decide_many(batch), args.repeats)]
    dense = [Request(sc, "cruise") for sc in [random_scene(rng, 50, i) for i in range(24)]]
    dense_batched = [t / len(dense) for t in timed(lambda: reasoner.decide_many(dense), max(1, args.repeats // 5))]
    # the sidecar's own load (bench_worker.py, bench_zenoh.py): the example planner's proposals, most of them overridden
    highway = [Request(highway_scene(f, 50), planner_action(f)) for f in range(24)]
    highway_overrides = sum(v.decision.value == "override" for v in reasoner.decide_many(highway))
    highway_batched = [t / len(highway) for t in timed(lambda: reasoner.decide_many(highway), max(1, args.repeats // 5))]

    gc.collect()
    samples = []
    scenes = [random_scene(rng, 20, i) for i in range(200)]
    start_rss = rss_mib()
    for i in range(args.frames):  # the readied path: it holds the most (ready and spent Controls)
        ready.prepare()
        ready.decide(scenes[i % len(scenes)], "accelerate")
        if i % 1000 == 999:
            samples.append(rss_mib())

    def row(name: str, values: list[float], target: str) -> str:
        return (f"| {name} | {len(values)} | {statistics.median(values):.2f} | {pct(values, 99):.2f} | "
                f"{max(values):.2f} | {target} |")

    body = "\n".join([
        "## Reasoning core: per-frame decision",
        "",
        f"Command: `python bench/bench_core.py --frames {args.frames} --repeats {args.repeats}`  ",
        f"Machine: {machine()}; one process, wall-clock per decision (clingo grounding + verdict + proof), "
        "cases interleaved frame by frame; \"Control readied\" rows: the frame's clingo Control was made, with "
        "the rules its kind of frame is expected to need (rules/presence.py), before the timed decision, and the previous frame's Control freed, "
        "as a sidecar worker does while it waits for the next proposal (`Reasoner.prepare`, rules/controls.py); "
        "the other rows make and free it within the decision; "
        "the garbage collector as in the monitor's decision workers (`defer_full_collections`: the loaded rules "
        "frozen after warm-up, full collections only between cases, where a worker runs them while idle; "
        "otherwise, measured, each full collection took about 75 ms after a few thousand 200-object decisions, "
        "freeing nothing). Warm-up: each KITTI frame decided once; for the random scenes, "
        f"{WARM_UP_SCENES} other scenes of the same size, so that the predicates and patterns seen with atoms (rules/presence.py) "
        "are those of a worker that has run a while. Decisions grounded twice because a predicate or pattern first got atoms in "
        f"them, among the timed ones: KITTI {kitti_regrounds} of {len(fast) + len(readied) + len(approve_tree) + len(veto_tree)}, "
        + ", ".join(f"{n} objects {regrounds[n]} of {len(scaling[n]) + len(scaling_ready[n])}" for n in SCALING_TARGETS)
        + ".",
        "",
        "| case | decisions | median ms | p99 ms | max ms | target |",
        "|---|---|---|---|---|---|",
        row("24 KITTI frames, annotated action proposed (approve, summary + rule ids)", fast, "p99 ≤ 2 ms"),
        row("24 KITTI frames, as above, Control readied", readied, "p99 ≤ 2 ms"),
        row("24 KITTI frames, approve with the full proof tree (explain)", approve_tree, "-"),
        row("24 KITTI frames, a forbidden action proposed (override, the veto's proof to 4 levels)", veto_tree, "-"),
        *(row(f"random scenes, {n} objects{label}", cases[n], SCALING_TARGETS[n])
          for label, cases in (("", scaling), (", Control readied", scaling_ready)) for n in SCALING_TARGETS),
        "",
        "Throughput mode, many frames in one grounding (`Reasoner.decide_many`, as the sidecar's workers and the "
        "replay use it when frames queue up): milliseconds per frame, each sample one batch's time over its frames. "
        "Not a latency: every frame of a batch waits for the whole batch.",
        "",
        "| case | batches | median ms/frame | p99 ms/frame | max ms/frame | target |",
        "|---|---|---|---|---|---|",
        row("24 KITTI frames in one batch (approve, summary + rule ids)", kitti_batched, "-"),
        row("24 random 50-object scenes in one batch", dense_batched, "-"),
        row(f"24 of the example planner's 50-object highway frames in one batch ({highway_overrides} overrides)",
            highway_batched, "-"),
        "",
        f"Memory over {args.frames} consecutive decisions (20-object scenes, Control readied): RSS before {start_rss:.1f} MiB, "
        "then every 1,000 frames: " + ", ".join(f"{s:.1f}" for s in samples) + " MiB.",
    ])
    write_section("core", body)
    print(body)


if __name__ == "__main__":
    relaunch()  # on jemalloc where the machine has it, as the `discern` command runs (monitor/allocator.py)
    main()
