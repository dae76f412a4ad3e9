"""run.json: what produced an evaluation's --out folder, so that its figures can be traced to the command, settings,
weights, rules and code that made them, and run again."""

from __future__ import annotations

import argparse
import hashlib
import platform
from dataclasses import asdict
from datetime import datetime
from importlib import metadata
from pathlib import Path

from discern.adapters.highway.envs import config_digest, episode_end, make_env
from discern.adapters.highway.perception import Faults

from .evaluate import JURISDICTION, Setup
from .planner import default_weights

LIBRARIES = ("discern", "highway-env", "gymnasium", "torch", "clingo", "ad-rss", "numpy")


def manifest(command: list[str], args: argparse.Namespace, setup: Setup, variants: list[str], fault_sets: list[Faults],
             seeds: list[int], started: datetime, finished: datetime, training: dict | None) -> dict:
    """`command`: the command line as given; `args`: every option, defaults included; `seeds`: the episodes';
    `training`: the checkpoint's metadata (Planner.training), None for one saved without any."""
    env = make_env(setup.env, duration=setup.duration)
    try:
        environment = {"id": setup.env, **episode_end(env), "config_sha256": config_digest(env)}
    finally:
        env.close()
    weights = Path(setup.weights) if setup.weights else default_weights()
    return {
        "command": command,
        "arguments": {name: str(value) if isinstance(value, Path) else value
                      for name, value in vars(args).items() if name != "argv" and not callable(value)},
        "started": started.isoformat(timespec="seconds"),
        "finished": finished.isoformat(timespec="seconds"),
        "environment": environment,
        "variants": variants,
        "episode_seeds": seeds,
        "fault_seed": fault_sets[0].seed,
        "faults": [{"label": f.label(), "kinds": {name: rate for name, (_, rate) in f.kinds().items()}, **asdict(f)}
                   for f in fault_sets],
        "judge": setup.judge_vetoes,
        "planner": {"weights": str(weights.resolve()), "sha256": _sha256(weights),
                    "training": "unknown" if training is None else training},
        "discern": _discern(setup) if "discern" in variants else None,
        "versions": {"python": platform.python_version(), **{name: _version(name) for name in LIBRARIES}},
    }


def _discern(setup: Setup) -> dict:
    """What Discern decided with: in process, these; a monitor decides with its own, which its log records."""
    if setup.monitor:
        return {"monitor": list(setup.monitor),
                "note": "a running `discern serve` decided, with its own parameters, rules and code: its log records them"}
    from discern.rules.catalog import catalog_digest
    from discern.rules.code_digest import reasoning_code_digest
    from discern.rules.engine import jurisdiction_pack
    from discern.rules.facts import Params

    overrides = dict(setup.params)
    return {
        "jurisdiction": JURISDICTION,
        "params": asdict(Params(**overrides)),
        "param_overrides": overrides,
        "catalog": catalog_digest(extra_files=[jurisdiction_pack(JURISDICTION)]),
        "reasoning_code": reasoning_code_digest(),
    }


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _version(distribution: str) -> str | None:
    try:
        return metadata.version(distribution)
    except metadata.PackageNotFoundError:
        return None
