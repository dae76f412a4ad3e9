"""`discern eval highway`, and `demo()` for the closed-loop part of `discern demo`."""

from __future__ import annotations

import argparse
import math
import os
import sys
from dataclasses import replace
from datetime import datetime, timezone
from pathlib import Path

from discern.monitor.config import path_arg, path_text

DEMO_FAULTS = ("none", "signs,missed")
MONITOR_WAIT_S = 5.0
MAX_NOISE_M = 100.0  # std at 150 m is 3.2 times it: more would put objects past the scene's 10 km bound
MAX_DURATION_S = 3600.0  # an hour of driving an episode: an evaluation that ends


def register(subparsers) -> None:
    evaluate = subparsers.add_parser("eval", help="closed-loop evaluations")
    targets = evaluate.add_subparsers(dest="target", required=True, metavar="TARGET")
    highway = targets.add_parser(
        "highway",
        help="planner alone vs planner + Discern vs planner + RSS on seeded highway-env episodes",
        description="Runs the same seeded highway-env episodes with the DQN planner (or your own, --planner) alone, "
        "shielded by Discern, and shielded by an RSS longitudinal check; prints a comparison table and writes CSV and "
        "PNG.",
    )
    _options(highway)
    highway.set_defaults(func=_run_eval)


def demo(out: Path = Path("out/demo-highway"), episodes: int = 3, duration: float | None = None) -> int:
    """The short closed-loop demo for `discern demo`: planner vs + Discern vs + RSS, with and without faults."""
    parser = argparse.ArgumentParser(prog="discern eval highway")
    _options(parser)
    argv = ["--episodes", str(episodes), "--faults", *DEMO_FAULTS, "--out", str(out)]
    if duration is not None:
        argv += ["--duration", str(duration)]
    args = parser.parse_args(argv)
    args.argv = ["eval", "highway", *argv]  # the command that makes the same folder
    return _run_eval(args)


def _options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--episodes", type=int, default=20, help="seeded episodes per variant and fault set (default: 20)")
    parser.add_argument(
        "--faults",
        nargs="+",
        default=list(DEMO_FAULTS),
        metavar="SET",
        help="fault sets, each 'none', 'all' (all but dropped) or a comma list of noise, missed, dropped, phantoms, signs "
        "(e.g. --faults none signs,missed; default: %(default)s)",
    )
    parser.add_argument("--variants", default="planner,discern,rss", help="comma list of planner, discern, rss (default: %(default)s)")
    parser.add_argument("--seed", type=int, default=0,
                        help="first episode seed offset; also seeds the faults (default: %(default)s)")
    parser.add_argument("--fault-seed", type=int, default=None,
                        help="seeds the faults instead of --seed: --seed 3 --fault-seed 0 --episodes 1 runs the "
                             "fourth episode of a --seed 0 run alone, faults and all")
    parser.add_argument("--env", default="highway-fast-v0", help="highway-fast-v0 (default), highway-v0 or merge-v0")
    parser.add_argument("--duration", type=float, default=None, help="episode length in seconds (env default)")
    # the defaults are perception.DEFAULT_RATES' (not imported here: it needs highway-env, which `discern` may lack)
    parser.add_argument("--miss-rate", type=float, default=None,
                        help="camera miss chance per vehicle and frame (default: 0.05 where a set names missed or dropped)")
    parser.add_argument("--phantom-rate", type=float, default=None, help="phantom chance per frame (default: 0.1 where a set names phantoms)")
    parser.add_argument("--sign-rate", type=float, default=None,
                        help="chance each sign is misread (default: 0.5 where a set names signs)")
    parser.add_argument("--sign-value", type=float, default=None, help="limit read off a misread sign, m/s (default: 80)")
    parser.add_argument(
        "--noise", type=float, default=None, help="distance noise, metres: std NOISE*(0.2 + range/50 m), 1.2*NOISE at 50 m (default: 1 where a set "
        "names noise)"
    )
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="override one of Discern's reasoning parameters (discern.rules.facts.Params); "
        "the closed loop sets decel=4 (what highway-env's vehicle can brake) and accel_step=2.5 (half a step of "
        "its speed grid), e.g. --param headway_s=2",
    )
    parser.add_argument("--jobs", type=int, default=1, help="worker processes (default: 1)")
    parser.add_argument(
        "--monitor",
        nargs="?",
        const="tcp/127.0.0.1:7447",
        default=None,
        metavar="ENDPOINT",
        help="ask a running `discern serve` over zenoh instead of the in-process reasoner (default endpoint: %(const)s)",
    )
    parser.add_argument(
        "--record", type=path_arg, default=None, metavar="DIR", help="log every proposal and verdict to MCAP in DIR (--jobs 1)"
    )
    parser.add_argument("--no-judge", action="store_true", help="skip the ground-truth false-veto judge")
    parser.add_argument("--weights", type=path_text, default=None, help="planner weights (default: the packaged ones)")
    parser.add_argument(
        "--planner", default=None, metavar="MODULE:FACTORY",
        help="evaluate your own policy instead of the shipped DQN: FACTORY(seed) is called at each episode's start and "
             "returns a callable from the perceived frame to a meta-action index (docs/evaluation.md, \"Your own "
             "planner\"); MODULE is looked for in the working directory first",
    )
    parser.add_argument(
        "--budget-ms", type=float, default=None,
        help="count the decisions slower than this (default: the monitor's budget, 50 ms); with --monitor, give "
             "the monitor's own --budget-ms",
    )
    parser.add_argument("--out", type=path_arg, default=Path("out/eval-highway"), help="folder for CSV, PNG and table (default: %(default)s)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def _run_eval(args: argparse.Namespace) -> int:
    try:
        from discern.adapters.highway.envs import SUPPORTED
        from .evaluate import BUDGET_MS, VARIANTS, Setup, episode_seeds, evaluate, report
        from .manifest import code_state, manifest
        from .planner import Planner
        from .policy import load_factory
        from discern.adapters.highway.perception import Faults
    except ImportError as exc:
        print(
            f"discern eval: error: the highway evaluation needs the planner extra (pip install 'discern[planner]'): {exc}",
            file=sys.stderr,
        )
        return 2
    variants = [v.strip() for v in args.variants.split(",") if v.strip()]
    problems = [f"unknown variant {v!r} (choose from {', '.join(VARIANTS)})" for v in variants if v not in VARIANTS]
    if not variants:
        problems.append(f"--variants names no variant (choose from {', '.join(VARIANTS)})")
    problems += [f"--variants names {v!r} twice: its episodes would count twice in its row"
                 for v in sorted({v for v in variants if variants.count(v) > 1})]
    if args.episodes < 1:
        problems.append(f"--episodes must be at least 1, got {args.episodes}")
    if args.env not in SUPPORTED:
        problems.append(f"unsupported --env {args.env!r} (choose from {', '.join(SUPPORTED)})")
    params = _params(args.param, problems)
    if args.monitor and args.record is not None:
        problems.append("--record has nothing to add with --monitor: the monitor logs every proposal and verdict "
                        "itself, with the parameters it decides with (`discern serve --log-dir DIR`)")
    if args.monitor and args.param:
        problems.append("--param has no effect with --monitor: the monitor decides with its own parameters; "
                        "give them to it (`discern serve --param decel=4 --param accel_step=2.5`)")
    if args.record is not None and "discern" not in variants:
        problems.append("--record logs Discern's verdicts: add discern to --variants")
    if args.monitor and variants and "discern" not in variants:
        problems.append("--monitor serves the discern variant: add discern to --variants")
    if args.record is not None and args.jobs > 1:
        problems.append("--record writes one MCAP log from one process: use it with --jobs 1")
    if args.seed < 0:
        problems.append(f"--seed must be at least 0 (the environment's seeds are), got {args.seed}")
    if args.fault_seed is not None and args.fault_seed < 0:
        problems.append(f"--fault-seed must be at least 0, got {args.fault_seed}")
    if args.jobs < 1:
        problems.append(f"--jobs must be at least 1, got {args.jobs}")
    problems += [f"{flag} {path}: not a directory" for flag, path in (("--out", args.out), ("--record", args.record))
                 if path is not None and path.exists() and not path.is_dir()]
    if args.duration is not None and not (0 < args.duration <= MAX_DURATION_S):  # NaN fails too
        # an episode ends only on a crash or its duration: a huge one never ends for a planner that does not crash
        problems.append(f"--duration must be a number of seconds above 0 and at most {MAX_DURATION_S:g}, "
                        f"got {args.duration:g}")
    if args.planner is not None and args.weights is not None:
        problems.append("--weights are the shipped planner's: --planner brings its own policy")
    if args.budget_ms is not None and not (math.isfinite(args.budget_ms) and args.budget_ms > 0):
        problems.append(f"--budget-ms must be a number of milliseconds above 0, got {args.budget_ms:g}")
    factory = None
    if args.planner is not None:
        try:
            factory = load_factory(args.planner)
        except ValueError as exc:
            problems.append(str(exc))
    problems += _rate_problems(args) + _unused_fault_settings(args)
    fault_sets = []
    for kinds in args.faults:
        try:
            fault_sets.append(
                Faults.preset(
                    kinds,
                    seed=args.seed if args.fault_seed is None else args.fault_seed,
                    miss_rate=args.miss_rate,
                    phantom_rate=args.phantom_rate,
                    sign_rate=args.sign_rate,
                    sign_value=args.sign_value,
                    noise=args.noise,
                )
            )
        except ValueError as exc:
            problems.append(str(exc))
    # the same kinds and rates in another order are the same set: its episodes would run twice, in two rows
    unordered = [replace(f, order=()) for f in fault_sets]
    problems += [
        f"--faults gives more than one set that comes out as {f.label()!r} with these rates: the same episodes twice"
        for f in dict.fromkeys(fault_sets[unordered.index(u)] for u in unordered if unordered.count(u) > 1)
    ]
    if not problems:
        problems += _folder_problems((("--out", args.out), ("--record", args.record)))
    if args.monitor and "discern" in variants and not problems:
        problems += _monitor_problems(args.monitor)
    if problems:
        for problem in problems:
            print(f"discern eval: error: {problem}", file=sys.stderr)
        return 2
    setup = Setup(
        env=args.env, duration=args.duration, weights=args.weights, monitor=(args.monitor,) if args.monitor else (),
        judge_vetoes=not args.no_judge,
        params=params,
        record=str(args.record) if args.record else None,
        planner=args.planner,
        budget_ms=BUDGET_MS if args.budget_ms is None else args.budget_ms,
    )
    code = code_state(setup, variants)  # the code and rules the episodes will run, not those found once they are done
    started = datetime.now(timezone.utc)
    try:
        # weights that are no planner's fail now, not in the first episode
        training = None if factory is not None else Planner.load(args.weights).training
        results = evaluate(args.episodes, fault_sets, variants, setup, seed=args.seed, jobs=args.jobs, progress=not args.quiet)
    except (OSError, RuntimeError) as exc:
        print(f"discern eval: error: {exc}", file=sys.stderr)
        return 2
    run = manifest(["discern", *args.argv], args, setup, variants, fault_sets, episode_seeds(args.episodes, args.seed),
                   started, datetime.now(timezone.utc), training, code)
    try:
        _, text, written = report(results, args.out, run, setup.budget_ms)
    except OSError as exc:  # a folder not writable, or removed while the episodes ran
        print(f"discern eval: error: cannot write {args.out}: {exc}", file=sys.stderr)
        return 2
    print(text)
    print(f"\nwrote {args.out}/: {', '.join(written)}")
    return 0


def _folder_problems(flags) -> list[str]:
    """Output folders made before the first episode: a run of half an hour is not lost at its end to a path
    that lies inside a file or a folder it may not write."""
    problems = []
    for flag, path in flags:
        if path is None:
            continue
        try:
            path.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            problems.append(f"{flag} {path}: cannot make the folder: {exc.strerror or exc}")
            continue
        if not os.access(path, os.W_OK):
            problems.append(f"{flag} {path}: cannot write into it")
    return problems


def _rate_problems(args: argparse.Namespace) -> list[str]:
    """Chances in [0, 1], a noise of at most MAX_NOISE_M, and a sign value a Scene can hold (0..150 m/s)."""
    from discern.rules.scene import MAX_SPEED_MS as MAX_SIGN_VALUE

    problems = []
    for flag, value in (("--miss-rate", args.miss_rate), ("--phantom-rate", args.phantom_rate), ("--sign-rate", args.sign_rate)):
        if value is not None and not 0.0 <= value <= 1.0:
            problems.append(f"{flag} is a chance and must lie in [0, 1], got {value}")
    if args.noise is not None and not (math.isfinite(args.noise) and 0.0 <= args.noise <= MAX_NOISE_M):
        problems.append(f"--noise must lie in [0, {MAX_NOISE_M:g}] metres, got {args.noise}")
    if args.sign_value is not None and not 0.0 <= args.sign_value <= MAX_SIGN_VALUE:
        problems.append(f"--sign-value must lie in [0, {MAX_SIGN_VALUE:g}] m/s, got {args.sign_value}")
    return problems


def _unused_fault_settings(args: argparse.Namespace) -> list[str]:
    """A setting for a fault no set injects, or one that turns a named fault off, would give a row that is not what its
    label or the command line says."""
    from discern.adapters.highway.perception import ALL_FAULTS

    named = {kind.strip() for kinds in args.faults for kind in kinds.split(",")}
    named |= set(ALL_FAULTS) if "all" in named else set()
    named |= {"missed"} if "dropped" in named else set()  # --miss-rate sets how often either happens
    problems = []
    for flag, value, kind in (("--miss-rate", args.miss_rate, "missed"), ("--phantom-rate", args.phantom_rate, "phantoms"),
                              ("--sign-rate", args.sign_rate, "signs"), ("--sign-value", args.sign_value, "signs"),
                              ("--noise", args.noise, "noise")):
        if value is None:
            continue
        if kind not in named:
            problems.append(f"{flag} {value:g} sets the {kind!r} fault, which no --faults set injects")
        elif value == 0 and flag != "--sign-value":
            problems.append(f"{flag} 0 turns the {kind!r} fault off, but a --faults set names it: leave {kind!r} out "
                            "of that set instead")
    return problems


def _monitor_problems(endpoint: str) -> list[str]:
    """Without a reachable monitor every verdict would be a fail-safe brake dressed up as a normal row."""
    from .wrapper import MonitorChecker

    try:
        probe = MonitorChecker(vehicle="highway-eval-probe", connect=[endpoint])
    except Exception as exc:  # zenoh refuses a malformed endpoint
        return [f"--monitor {endpoint}: cannot open a zenoh session: {str(exc).splitlines()[0] if str(exc) else exc!r}"]
    try:
        if probe.client.wait_for_monitor(MONITOR_WAIT_S):
            return []
    finally:
        probe.close()
    return [f"no monitor answered on {endpoint} within {MONITOR_WAIT_S:g} s: start one with `discern serve --listen {endpoint}`"]


def _params(pairs: list[str], problems: list[str]) -> tuple[tuple[str, float], ...]:
    from discern.rules.facts import Params

    from .wrapper import VEHICLE_PARAMS

    values, bad = Params.overrides(pairs)
    problems += bad
    return tuple(sorted({**VEHICLE_PARAMS, **values}.items()))

