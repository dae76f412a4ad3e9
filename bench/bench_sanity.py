"""Per-frame decision time with the sanity layer and a 2 s frame window, against the core alone.

Run: python bench/bench_sanity.py [--repeats 30]   (one process; writes the "Sanity layer" section of docs/benchmarks.md)
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
from discern.monitor.decision_worker import defer_full_collections  # noqa: E402
from discern.rules.catalog import catalog_dirs, load_catalog  # noqa: E402
from discern.rules.engine import Reasoner, jurisdiction_pack  # noqa: E402
from discern.rules.scene import Scene  # noqa: E402
from discern.sanity import WindowConfig, window_reasoner  # noqa: E402
from discern.scenarios.model import Scenario  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
KITTI = ROOT.parent / "shared" / "avcsr" / "kitti"
SCENARIOS = ROOT / "scenarios" / "sanity"
RATE_HZ = 10.0  # frames per second of the synthetic window: 2 s = 20 frames of history


def window_before(scene: Scene, seconds: float) -> tuple[Scene, ...]:
    """The frames before `scene` at RATE_HZ, objects moved back along their velocities (oldest first)."""
    frames = []
    for k in range(int(seconds * RATE_HZ), 0, -1):
        dt = k / RATE_HZ
        data = scene.model_dump(by_alias=True)
        data["frame_id"] = max(scene.frame_id - k, 0)
        data["timestamp"] = scene.timestamp - dt
        for obj in data["objects"]:
            v = obj.get("velocity") or {"x": 0.0, "y": scene.ego.speed}
            obj["position"]["x"] -= v["x"] * dt
            obj["position"]["y"] -= (v["y"] - scene.ego.speed) * dt
        data["notes"] = []
        frames.append(Scene.model_validate(data))
    return tuple(frames)


def seen_before(reasoner: Reasoner, history: tuple[Scene, ...]) -> None:
    """Read each history frame as the current frame of its own decision, untimed, as a sidecar worker did.

    The window provider summarises a frame once, when it is current, and looks the summary up in the
    twenty later windows it sits in; timing the first decision over a made-up history would charge it
    for summarising twenty frames at once (the provider took 1.9 against 0.5 ms at 50 objects, on the VM at
    a slow moment), which no worker pays.
    """
    for i, past in enumerate(history):
        for provider in reasoner.providers:
            provider.facts(past, history[:i])


def load_average() -> str:
    try:
        return Path("/proc/loadavg").read_text().split()[0]
    except OSError:
        return "?"


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeats", type=int, default=30, help="timed decisions per KITTI frame and case")
    parser.add_argument("--window", type=float, default=2.0, help="seconds of history")
    args = parser.parse_args()

    load_before = load_average()
    core = Reasoner(catalog=load_catalog([catalog_dirs()[0]], extra_files=[jurisdiction_pack("us")]), providers=[])
    sanity = window_reasoner()
    # The same two, their Controls readied before each decision as a sidecar worker does while it waits.
    core_ready = Reasoner(catalog=core.catalog, providers=[])
    sanity_ready = window_reasoner()
    assert sanity.providers and sanity.providers[0].config == WindowConfig(seconds=args.window)
    frames = read_dir(KITTI)
    windows = [window_before(f.scene, args.window) for f in frames]
    agree = sum(sanity.decide(f.scene, f.expected, history=w).recommended is f.expected for f, w in zip(frames, windows))

    cases: dict[str, list[float]] = {k: [] for k in (
        "core", "sanity", "sanity_window", "sanity_window_tree", "provider", "core_ready", "sanity_window_ready")}
    for _ in range(2):  # warm-up: slices and caches
        for f, w in zip(frames, windows):
            core.decide(f.scene, f.expected)
            sanity.decide(f.scene, f.expected, history=w)
            core_ready.decide(f.scene, f.expected)
            sanity_ready.decide(f.scene, f.expected, history=w)
    defer_full_collections()  # the monitor's decision workers' policy: rules frozen, full collections when idle
    provider = sanity.providers[0]
    for f, w in zip(frames, windows):
        # Interleaved so that load on the machine hits every case alike.
        for _ in range(args.repeats):
            cases["core"] += timed(lambda: core.decide(f.scene, f.expected), 1)
            cases["sanity"] += timed(lambda: sanity.decide(f.scene, f.expected), 1)
            cases["sanity_window"] += timed(lambda: sanity.decide(f.scene, f.expected, history=w), 1)
            cases["provider"] += timed(lambda: provider.facts(f.scene, w), 1)
            cases["core_ready"] += timed(lambda: core_ready.decide(f.scene, f.expected), 1, between=core_ready.prepare)
            cases["sanity_window_ready"] += timed(lambda: sanity_ready.decide(f.scene, f.expected, history=w), 1,
                                                  between=sanity_ready.prepare)
        cases["sanity_window_tree"] += timed(lambda: sanity.decide(f.scene, f.expected, history=w, explain=True),
                                             max(args.repeats // 5, 1))

    scenario_times: list[float] = []
    scenario_frames = 0
    for path in sorted(SCENARIOS.glob("*.json")):
        scenario = Scenario.load(path)
        reasoner = sanity if scenario.jurisdiction == "us" else window_reasoner(jurisdiction=scenario.jurisdiction)
        history: list[Scene] = []
        for frame in scenario.frames:
            scenario_times += timed(lambda: reasoner.decide(frame.scene, frame.proposed, history=tuple(history),
                                                            explain=True), 5)
            history.append(frame.scene)
            scenario_frames += 1

    rng = random.Random(2026)
    warm_rng = random.Random(7)  # other scenes of each size: what a worker that has run a while has seen
    scaling: dict[int, tuple[list[float], ...]] = {}
    regrounds: dict[int, int] = {}  # timed decisions of the sanity layer grounded twice (rules/presence.py)
    for n in (10, 50):
        gc.collect()  # between cases, where a worker's IdleWork would run, as in bench_core.py
        scenes = [random_scene(rng, n, i, perception=True) for i in range(60)]  # 180 decisions a case, as there
        hists = [window_before(sc, args.window) for sc in scenes]
        for h in hists:
            seen_before(sanity, h)
            seen_before(sanity_ready, h)
        for sc in [random_scene(warm_rng, n, i, perception=True) for i in range(WARM_UP_SCENES)]:
            h = window_before(sc, args.window)
            core.decide(sc, "cruise")
            sanity.decide(sc, "cruise", history=h)
            core_ready.decide(sc, "cruise")
            sanity_ready.decide(sc, "cruise", history=h)
        plain, windowed, plain_ready, windowed_ready = [], [], [], []
        before = sanity.slicer.regrounds + sanity_ready.slicer.regrounds
        for sc, h in zip(scenes, hists):
            for _ in range(3):
                plain += timed(lambda: core.decide(sc, "cruise"), 1)
                windowed += timed(lambda: sanity.decide(sc, "cruise", history=h), 1)
                plain_ready += timed(lambda: core_ready.decide(sc, "cruise"), 1, between=core_ready.prepare)
                windowed_ready += timed(lambda: sanity_ready.decide(sc, "cruise", history=h), 1,
                                        between=sanity_ready.prepare)
        scaling[n] = (plain, windowed, plain_ready, windowed_ready)
        regrounds[n] = sanity.slicer.regrounds + sanity_ready.slicer.regrounds - before

    def row(name: str, values: list[float], base: list[float] | None = None) -> str:
        extra = f"{statistics.median(values) - statistics.median(base):+.2f}" if base else "-"
        return (f"| {name} | {len(values)} | {statistics.median(values):.2f} | {pct(values, 99):.2f} | "
                f"{max(values):.2f} | {extra} |")

    history_frames = int(args.window * RATE_HZ)
    body = "\n".join([
        "## Sanity layer",
        "",
        f"Command: `python bench/bench_sanity.py --repeats {args.repeats} --window {args.window:g}`  ",
        f"Machine: {machine()}; one process, wall-clock per decision, cases interleaved frame by frame; "
        f"1-minute load average {load_before} at the start and {load_average()} at the end of the run.  ",
        f"\"core\" is the driving catalog with the US pack and no sanity rules or provider; \"sanity\" is the default "
        f"Reasoner (catalog + sanity rules + US pack + WindowProvider). The window is {args.window:g} s of history at "
        f"{RATE_HZ:g} Hz ({history_frames} earlier frames, objects moved back along their velocities). "
        f"KITTI agreement with the sanity layer and the window: {agree}/{len(frames)}. "
        "\"Control readied\": the frame's clingo Control made before the timed decision, as a sidecar worker does "
        "while it waits for the next proposal (`Reasoner.prepare`, rules/controls.py). Random scenes: "
        f"each reasoner first decides {WARM_UP_SCENES} other scenes of the same size, as in bench_core.py, and its "
        "window provider has read each earlier frame of a scene's window as the current frame of its own decision, "
        "as in a sidecar worker, where a frame is summarised once, when it comes, and looked up in the later "
        "windows it sits in. Decisions of the sanity layer grounded twice because a predicate or pattern first got "
        "atoms in them (the first frame of a kind its reasoner had not seen, rules/presence.py), among the timed ones: "
        + ", ".join(f"{n} objects {regrounds[n]} of {len(scaling[n][1]) + len(scaling[n][3])}" for n in scaling) + ".",
        "",
        "| case | decisions | median ms | p99 ms | max ms | median vs core ms |",
        "|---|---|---|---|---|---|",
        row("24 KITTI frames, core alone (approve, summary + rule ids)", cases["core"]),
        row("24 KITTI frames, sanity layer, no history", cases["sanity"], cases["core"]),
        row(f"24 KITTI frames, sanity layer, {args.window:g} s window", cases["sanity_window"], cases["core"]),
        row(f"24 KITTI frames, sanity layer, {args.window:g} s window, full proof tree", cases["sanity_window_tree"]),
        row("24 KITTI frames, core alone, Control readied", cases["core_ready"]),
        row(f"24 KITTI frames, sanity layer, {args.window:g} s window, Control readied", cases["sanity_window_ready"],
            cases["core_ready"]),
        row(f"WindowProvider.facts alone, {history_frames}-frame window (KITTI)", cases["provider"]),
        row(f"{scenario_frames} frames of scenarios/sanity, history, full proof tree", scenario_times),
        row("random scenes, 10 objects, core alone", scaling[10][0]),
        row(f"random scenes, 10 objects, sanity layer, {args.window:g} s window", scaling[10][1], scaling[10][0]),
        row("random scenes, 50 objects, core alone", scaling[50][0]),
        row(f"random scenes, 50 objects, sanity layer, {args.window:g} s window", scaling[50][1], scaling[50][0]),
        row("random scenes, 10 objects, core alone, Control readied", scaling[10][2]),
        row(f"random scenes, 10 objects, sanity layer, {args.window:g} s window, Control readied", scaling[10][3],
            scaling[10][2]),
        row("random scenes, 50 objects, core alone, Control readied", scaling[50][2]),
        row(f"random scenes, 50 objects, sanity layer, {args.window:g} s window, Control readied", scaling[50][3],
            scaling[50][2]),
    ])
    write_section("sanity", body)
    print(body)


if __name__ == "__main__":
    relaunch()  # on jemalloc where the machine has it, as the `discern` command runs (monitor/allocator.py)
    main()
