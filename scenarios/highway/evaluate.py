"""Closed-loop safety evaluation: the planner alone, planner + Discern, planner + the RSS peer.

Every variant drives the same seeded episodes under the same perception faults. Reported per variant
and fault set: collisions per episode and per km, and those in episodes the planner alone survived (the ones the
shield introduced), mean speed, distance, vetoes per km, the share of steps the shield changed the action, false
vetoes (oracle.py's definition), time above the true limit, the checker's time per step (p50, p99, decisions over
the monitor's budget), fail-safe verdicts, and the rules that vetoed most.
"""

from __future__ import annotations

import csv
import json
import math
import multiprocessing
import time
from collections import Counter
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from discern.monitor.config import MonitorConfig
from discern.monitor.protocol import RULE_DEADLINE
from discern.monitor.status import percentile
from discern.rules.verdict import Decision

from discern.adapters.highway.envs import make_env, policy_period
from .oracle import SPEED_TOLERANCE, proposal_was_safe
from discern.adapters.highway.perception import Faults
from .planner import Planner
from .policy import Policy, load_factory
from .wrapper import VEHICLE_PARAMS, DiscernWrapper

VARIANTS = ("planner", "discern", "rss")
NAN = float("nan")
JURISDICTION = "us"  # the in-process reasoner's rule pack (a monitor decides with its own)
SEED_BASE = 10_000  # evaluation seeds never overlap the training seeds (0..)
OUTPUTS = ("summary.csv", "episodes.csv", "summary.txt", "evaluation.png", "vetoing_rules.png", "run.json")  # report's
BUDGET_MS = MonitorConfig.budget_ms  # the monitor's default budget: past it, the sidecar's verdict is a fail-safe


@dataclass
class EpisodeResult:
    variant: str
    faults: str
    seed: int
    fault_seed: int = 0  # with `seed`, runs the episode again: --seed (seed - SEED_BASE) --fault-seed F --episodes 1
    steps: int = 0
    collided: bool = False
    distance_m: float = 0.0
    time_s: float = 0.0
    vetoes: int = 0  # the rules' verdicts that did not approve the proposal (fail-safes aside)
    intervened: int = 0  # steps whose executed action was not the proposed one (fail-safes included)
    over_budget: int = 0  # decisions that took longer than Setup.budget_ms, or that a monitor's deadline cut short
    failsafes: int = 0  # fail-safe verdicts (a monitor late or silent, a checker that failed), executed
    false_vetoes: int | None = 0  # None: not judged (--no-judge), which is not none found
    speeding_s: float = 0.0  # time with the ego above the true limit
    misread_s: float = 0.0  # time with the stack believing a misread sign
    decide_ms: list[float] = field(default_factory=list)
    rules: Counter = field(default_factory=Counter)
    failsafe_rules: Counter = field(default_factory=Counter)  # why: monitor.deadline, monitor.no_answer, ...

    def row(self) -> dict:
        row = asdict(self)
        for key in ("rules", "failsafe_rules"):
            row[key] = ";".join(f"{rule}:{n}" for rule, n in getattr(self, key).most_common())
        row["decide_ms"] = round(float(np.mean(self.decide_ms)), 3) if self.decide_ms else ""
        row["mean_speed"] = round(self.distance_m / self.time_s, 3) if self.time_s else 0.0
        return row


@dataclass(frozen=True)
class Setup:
    env: str = "highway-fast-v0"
    duration: float | None = None
    weights: str | None = None
    monitor: tuple[str, ...] = ()  # zenoh endpoints of a running `discern serve`; empty: in-process
    judge_vetoes: bool = True
    params: tuple[tuple[str, float], ...] = tuple(VEHICLE_PARAMS.items())  # Discern's Params overrides
    record: str | None = None  # folder for an MCAP log of every proposal and verdict
    planner: str | None = None  # MODULE:FACTORY of a policy (policy.py); None: the shipped planner with `weights`
    budget_ms: float = BUDGET_MS  # decisions slower than this are counted (in process nothing enforces it)


_worker: dict = {}


def _checker(variant: str, setup: Setup, vehicle: str):
    """The variant's checker, deciding for the episode's vehicle; the reasoner behind Discern's is cached."""
    if variant == "planner":
        return None
    if variant == "rss":
        from .rss import RssChecker

        return RssChecker()
    if setup.monitor:
        from .wrapper import MonitorChecker

        return MonitorChecker(vehicle=vehicle, connect=list(setup.monitor))
    from .wrapper import ReasonerChecker

    key = ("reasoner", setup.params)
    if key not in _worker:
        from discern.sanity import window_reasoner
        from discern.rules.facts import Params

        _worker[key] = window_reasoner(params=Params(**dict(setup.params)), jurisdiction=JURISDICTION)
    return ReasonerChecker(reasoner=_worker[key], vehicle=vehicle)  # the reasoner is shared, the vehicle the episode's


def _recorder(setup: Setup):
    if setup.record is None:
        return None
    if "recorder" not in _worker:
        from discern.monitor.config import LogSettings
        from discern.monitor.log.writer import McapLogWriter
        from discern.rules.catalog import catalog_digest
        from discern.rules.engine import jurisdiction_pack

        # the in-process reasoner's (the shipped catalog, JURISDICTION's pack): a running monitor logs its own verdicts
        _worker["recorder"] = McapLogWriter(LogSettings(directory=Path(setup.record)), "highway-eval", dict(setup.params),
                                            jurisdiction=JURISDICTION,
                                            catalog=catalog_digest(extra_files=[jurisdiction_pack(JURISDICTION)]))
    return _worker["recorder"]


def close_recorder() -> None:
    recorder = _worker.pop("recorder", None)
    if recorder is not None:
        recorder.close()


def episode_vehicle(variant: str, faults: Faults, seed: int) -> str:
    """The vehicle an episode drives as, for a monitor and the log: one zenoh key chunk ([A-Za-z0-9_-]), so the
    label's ',', '@' and ':' become '-' and a decimal point 'p' (discern_missed-0p9-signs_10000)."""
    chunk = faults.label().translate(str.maketrans({",": "-", "@": "-", ":": "-", ".": "p", "+": ""}))
    return f"{variant}_{chunk}_{seed}"


def _policy(setup: Setup, seed: int) -> Policy:
    """The episode's policy: the shipped planner (loaded once per process), or the user's factory's for this seed."""
    if setup.planner is not None:
        return load_factory(setup.planner)(seed)
    key = ("planner", setup.weights)
    if key not in _worker:
        _worker[key] = Planner.load(setup.weights)
    return _worker[key]


def _action(policy: Policy, perceived, where: str) -> int:
    action = policy(perceived)
    if isinstance(action, bool) or not isinstance(action, (int, np.integer)) or not 0 <= action <= 4:
        raise RuntimeError(f"{where}: the planner returned {action!r}, not a DiscreteMetaAction index (0..4)")
    return int(action)


def run_episode(variant: str, faults: Faults, seed: int, setup: Setup) -> EpisodeResult:
    """One seeded episode; through a monitor, as its own vehicle, whose frame ids no other episode has used.

    A fail-safe verdict (a monitor late or silent, a checker that failed) is executed, as the vehicle would, and
    counted apart from the rules' vetoes. In process nothing enforces the budget (the decisions, and so the episode,
    stay the same for the same seeds): decisions slower than it are counted, as the sidecar would have overridden them.
    """
    policy = _policy(setup, seed)
    vehicle = episode_vehicle(variant, faults, seed)
    checker = _checker(variant, setup, vehicle)
    env = DiscernWrapper(
        make_env(setup.env, duration=setup.duration),
        checker=checker,
        faults=faults,
        passthrough=checker is None,
        # Discern's verdicts only: RSS's in the same log would read, to the audit, as Discern's own
        recorder=_recorder(setup) if variant == "discern" else None,
        vehicle=vehicle,
    )
    result = EpisodeResult(variant=variant, faults=faults.label(), seed=seed, fault_seed=faults.seed,
                           false_vetoes=0 if setup.judge_vetoes else None)
    period = policy_period(env)
    env.reset(seed=seed)
    done = False
    try:
        while not done:
            perceived = env.perceived
            truth = perceived.truth
            action = _action(policy, perceived, f"{variant} episode {seed} ({faults.label()}), step {result.steps}")
            started = time.perf_counter()
            verdict = env.judge(action)
            if verdict is not None:
                result.decide_ms.append((time.perf_counter() - started) * 1000.0)
                # a monitor's deadline fail-safe comes at its budget, a hair either side of it by the client's clock
                result.over_budget += result.decide_ms[-1] > setup.budget_ms or RULE_DEADLINE in verdict.rules
            if verdict is not None and verdict.failsafe:
                result.failsafes += 1
                result.failsafe_rules.update(verdict.rules)
            elif verdict is not None and verdict.decision is not Decision.approve:
                result.vetoes += 1
                result.rules.update(verdict.vetoed_by)
                true_limit = truth.lane_limit(truth.ego.lane)
                if setup.judge_vetoes and proposal_was_safe(env, action, true_limit):
                    result.false_vetoes += 1
            before = truth.ego.road_position
            _, _, terminated, truncated, info = env.execute(action, verdict)
            after = env.perceived.truth
            result.steps += 1
            result.intervened += info["executed_action"] != action
            result.time_s += period
            result.distance_m += max(after.ego.road_position - before, 0.0)
            limit = after.lane_limit(after.ego.lane)
            if limit is not None and after.ego.speed > limit + SPEED_TOLERANCE:
                result.speeding_s += period
            if perceived.sign.misread:
                result.misread_s += period
            result.collided = bool(info.get("crashed", False))
            done = terminated or truncated
    finally:
        env.close()
        if setup.monitor and variant == "discern":
            checker.close()  # the episode's own zenoh session (RSS's checker has none)
    return result


def _run_task(task) -> EpisodeResult:
    return run_episode(*task)


def summarise(results: list[EpisodeResult]) -> list[dict]:
    """One row per (fault set, variant).

    `collisions_introduced`: a shielded variant's collisions in episodes where the planner alone (same seeds, same
    faults) did not collide: the crashes the shield's own decisions led to, which the totals net against the ones it
    prevented. NaN where the planner alone did not drive every one of the row's episodes in this run.
    """
    alone = {(r.faults, r.fault_seed, r.seed): r.collided for r in results if r.variant == "planner"}
    rows = []
    keys = sorted({(r.faults, r.variant) for r in results}, key=lambda k: (k[0] != "none", k[0], VARIANTS.index(k[1])))
    for faults, variant in keys:
        group = [r for r in results if r.faults == faults and r.variant == variant]
        km = sum(r.distance_m for r in group) / 1000.0
        hours = sum(r.time_s for r in group)
        rules = Counter()
        for r in group:
            rules.update(r.rules)
        decide = [ms for r in group for ms in r.decide_ms]
        vetoes = sum(r.vetoes for r in group)
        checked = variant != "planner"  # the planner alone vetoes nothing: its figures are missing, not 0 (NaN)
        # without the judge (--no-judge) false vetoes were not looked for: not measured, not 0 (NaN)
        judged = checked and all(r.false_vetoes is not None for r in group)
        false_vetoes = sum(r.false_vetoes for r in group) if judged else NAN
        paired = checked and all((r.faults, r.fault_seed, r.seed) in alone for r in group)
        introduced = sum(r.collided and not alone[(r.faults, r.fault_seed, r.seed)] for r in group) if paired else NAN
        steps = sum(r.steps for r in group)
        rows.append(
            {
                "faults": faults,
                "variant": variant,
                "episodes": len(group),
                "collisions": sum(r.collided for r in group),
                "collisions_per_episode": sum(r.collided for r in group) / len(group),
                "collisions_per_km": sum(r.collided for r in group) / km if km else 0.0,
                "collisions_introduced": introduced,
                "km": km,
                "mean_speed": (km * 1000.0 / hours) if hours else 0.0,
                "vetoes_per_km": (vetoes / km if km else 0.0) if checked else NAN,
                "intervened_share": (sum(r.intervened for r in group) / steps if steps else 0.0) if checked else NAN,
                "false_vetoes": false_vetoes,
                "false_vetoes_per_km": (false_vetoes / km if km else 0.0) if judged else NAN,
                "false_veto_share": (false_vetoes / vetoes if vetoes else 0.0) if judged else NAN,
                "speeding_s": sum(r.speeding_s for r in group),
                # by nearest rank, as the monitor's status, the audit and the benchmarks report them
                "decide_ms_p50": percentile(sorted(decide), 50) if decide else NAN,
                "decide_ms_p99": percentile(sorted(decide), 99) if decide else NAN,
                "over_budget": sum(r.over_budget for r in group) if checked else NAN,
                "failsafes": sum(r.failsafes for r in group) if checked else NAN,
                "top_rules": ", ".join(f"{rule} ({n})" for rule, n in rules.most_common(4)),
            }
        )
    return rows


def compare(rows: list[dict]) -> list[str]:
    """The targets: collisions cut by >= 90 % at >= 90 % of the planner's mean speed."""
    lines = []
    for faults in dict.fromkeys(r["faults"] for r in rows):
        base = next((r for r in rows if r["faults"] == faults and r["variant"] == "planner"), None)
        if base is None:
            continue
        for r in rows:
            if r["faults"] != faults or r["variant"] == "planner":
                continue
            kept = r["mean_speed"] / base["mean_speed"] if base["mean_speed"] else float("nan")
            if not base["collisions_per_km"]:
                lines.append(
                    f"faults={faults:<14} {r['variant']:<8} the planner alone did not collide: nothing to cut; "
                    f"mean speed kept {kept:6.1%}"
                )
                continue
            cut = 1.0 - r["collisions_per_km"] / base["collisions_per_km"]
            met = cut >= 0.9 and kept >= 0.9
            lines.append(
                f"faults={faults:<14} {r['variant']:<8} collisions/km cut {cut:6.1%}, mean speed kept {kept:6.1%} "
                f"-> target {'met' if met else 'missed'}"
            )
    for r in rows:
        if r["variant"] != "planner" and r["collisions_introduced"] > 0:  # NaN (no planner episodes) compares False
            lines.append(f"faults={r['faults']:<14} {r['variant']:<8} {r['collisions_introduced']} of its "
                         f"{r['collisions']} collisions came in episodes the planner alone survived")
    return lines


LEGEND = ("introduced: collisions in episodes the planner alone survived; interv %: steps whose action the shield "
          "changed; over budget: decisions slower than {budget:g} ms, which the sidecar would have answered with its "
          "fail-safe (counted, not enforced, in process); failsafe: fail-safe verdicts executed")


def format_table(rows: list[dict], budget_ms: float = BUDGET_MS) -> str:
    columns = [
        ("faults", "faults", "{}"),
        ("variant", "variant", "{}"),
        ("episodes", "eps", "{}"),
        ("collisions", "coll", "{}"),
        ("collisions_per_episode", "coll/ep", "{:.3f}"),
        ("collisions_per_km", "coll/km", "{:.3f}"),
        ("collisions_introduced", "introduced", "{:.0f}"),
        ("km", "km", "{:.1f}"),
        ("mean_speed", "speed m/s", "{:.2f}"),
        ("vetoes_per_km", "veto/km", "{:.2f}"),
        ("intervened_share", "interv %", "{:.1%}"),
        ("false_vetoes_per_km", "false/km", "{:.2f}"),
        ("speeding_s", "speeding s", "{:.0f}"),
        ("decide_ms_p50", "p50 ms", "{:.1f}"),
        ("decide_ms_p99", "p99 ms", "{:.1f}"),
        ("over_budget", "over budget", "{:.0f}"),
        ("failsafes", "failsafe", "{:.0f}"),
    ]
    cells = [[c[1] for c in columns]] + [[_cell(fmt, r[key]) for key, _, fmt in columns] for r in rows]
    widths = [max(len(row[i]) for row in cells) for i in range(len(columns))]
    lines = ["  ".join(cell.ljust(w) for cell, w in zip(row, widths)) for row in cells]
    lines.insert(1, "  ".join("-" * w for w in widths))
    tops = [f"top vetoing rules [{r['faults']}/{r['variant']}]: {r['top_rules']}" for r in rows if r["top_rules"]]
    return "\n".join(lines + ["", LEGEND.format(budget=budget_ms)] + tops)


def _cell(fmt: str, value) -> str:
    """A figure a variant does not have (the planner alone decides nothing) reads '–', as in docs/evaluation.md."""
    return "–" if isinstance(value, float) and math.isnan(value) else fmt.format(value)


def write_csv(path: Path, rows: list[dict]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def evaluation_figure(rows: list[dict]):
    """The bar charts of evaluation.png; a figure a row does not have (NaN: the planner's vetoes, false vetoes not
    judged) gets no bar, where a 0 would read as measured."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fault_sets = list(dict.fromkeys(r["faults"] for r in rows))
    variants = [v for v in VARIANTS if any(r["variant"] == v for r in rows)]
    metrics = [
        ("collisions_per_km", "collisions per km"),
        ("mean_speed", "mean speed (m/s)"),
        ("vetoes_per_km", "vetoes per km"),
        ("false_vetoes_per_km", "false vetoes per km"),
    ]
    fig, axes = plt.subplots(1, len(metrics), figsize=(4.2 * len(metrics), 3.6))
    width = 0.8 / len(variants)
    colours = {"planner": "#b0b0b0", "discern": "#1f77b4", "rss": "#ff7f0e"}
    for ax, (key, title) in zip(axes, metrics):
        measured = False
        for i, variant in enumerate(variants):
            bars = [(x + i * width, r[key]) for x, f in enumerate(fault_sets) for r in rows
                    if r["faults"] == f and r["variant"] == variant and not math.isnan(r[key])]
            measured |= bool(bars)
            ax.bar([x for x, _ in bars], [v for _, v in bars], width, label=variant, color=colours.get(variant))
        if not measured:
            ax.text(0.5, 0.5, "not measured", transform=ax.transAxes, ha="center", va="center", color="#808080")
            ax.set_yticks([])
        # every variant's slot, drawn or not: the fault sets line up across the panels
        ax.set_xlim(-width / 2 - 0.1, len(fault_sets) - 1 + (len(variants) - 0.5) * width + 0.1)
        ax.set_xticks(np.arange(len(fault_sets)) + width * (len(variants) - 1) / 2)
        ax.set_xticklabels([f"faults: {f}" for f in fault_sets], fontsize=8)
        ax.set_title(title)
        ax.grid(axis="y", alpha=0.3)
    axes[0].legend()
    fig.tight_layout()
    return fig


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib.pyplot as plt

    fig = evaluation_figure(rows)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_rules(results: list[EpisodeResult], path: Path, top: int = 8) -> bool:
    """Which of Discern's rules did the vetoing, per fault set (the RSS peer has one rule); False, and nothing
    written, without a Discern episode."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    groups = sorted({(r.faults, r.variant) for r in results if r.variant == "discern"}, key=lambda g: (g[0] != "none", g))
    if not groups:
        return False
    fig, axes = plt.subplots(1, len(groups), figsize=(5.2 * len(groups), 3.4), squeeze=False)
    for ax, (faults, variant) in zip(axes[0], groups):
        counts = Counter()
        for r in results:
            if (r.faults, r.variant) == (faults, variant):
                counts.update(r.rules)
        names, values = zip(*counts.most_common(top)) if counts else ((), ())
        ax.barh(list(reversed(names)), list(reversed(values)), color="#1f77b4")
        ax.set_title(f"{variant}, faults: {faults}", fontsize=9)
        ax.tick_params(axis="y", labelsize=7)
        ax.set_xlabel("vetoes citing the rule")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


def episode_seeds(episodes: int, seed: int = 0) -> list[int]:
    """The environment seeds of a run of `episodes` from `seed`, the same for every variant and fault set."""
    return [SEED_BASE + seed + episode for episode in range(episodes)]


def evaluate(
    episodes: int,
    fault_sets: list[Faults],
    variants: list[str],
    setup: Setup,
    seed: int = 0,
    jobs: int = 1,
    progress: bool = True,
) -> list[EpisodeResult]:
    from tqdm import tqdm

    tasks = [
        (variant, faults, episode, setup)
        for faults in fault_sets
        for variant in variants
        for episode in episode_seeds(episodes, seed)
    ]
    if setup.monitor and setup.record is not None:
        raise ValueError("a running monitor logs its own verdicts, with its own parameters: record with its --log-dir")
    bar = tqdm(total=len(tasks), desc="episodes", unit="ep", disable=not progress)
    results = []
    if jobs <= 1:
        try:
            for task in tasks:
                results.append(_run_task(task))
                bar.update()
        finally:  # a log cut short by an episode that failed still gets its summary
            close_recorder()
    else:
        with multiprocessing.get_context("spawn").Pool(jobs) as pool:
            for result in pool.imap(_run_task, tasks, chunksize=2):
                results.append(result)
                bar.update()
    bar.close()
    return results


def report(results: list[EpisodeResult], out: Path | None, manifest: dict | None = None,
           budget_ms: float = BUDGET_MS) -> tuple[list[dict], str, list[str]]:
    """The summary rows, the table, and the names of the files written into `out`, `manifest` as run.json (see
    manifest.py); `budget_ms`: the budget the episodes counted decisions against (Setup.budget_ms). The OUTPUTS an
    earlier run left there go first: one this run does not write (vetoing_rules.png without Discern) would read as
    this run's."""
    rows = summarise(results)
    text = format_table(rows, budget_ms) + "\n\n" + "\n".join(compare(rows))
    written = []
    if out is not None:
        for name in OUTPUTS:
            (out / name).unlink(missing_ok=True)
        write_csv(out / "summary.csv", rows)
        write_csv(out / "episodes.csv", [r.row() for r in results])
        (out / "summary.txt").write_text(text + "\n")
        plot(rows, out / "evaluation.png")
        written += ["summary.csv", "episodes.csv", "summary.txt", "evaluation.png"]
        if plot_rules(results, out / "vetoing_rules.png"):
            written.append("vetoing_rules.png")
        if manifest is not None:
            (out / "run.json").write_text(json.dumps(manifest, indent=2) + "\n")
            written.append("run.json")
    return rows, text, written
