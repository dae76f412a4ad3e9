"""run.json: what produced an evaluation's --out folder, so that its figures can be traced to the command, settings,
weights, rules and code that made them, and run again."""

from __future__ import annotations

import argparse
import hashlib
import importlib
import platform
import subprocess
from dataclasses import asdict
from datetime import datetime
from importlib import metadata, resources
from pathlib import Path

from discern.adapters.highway.envs import config_digest, episode_end, make_env
from discern.adapters.highway.perception import Faults

from .evaluate import JURISDICTION, Setup
from .planner import default_weights

LIBRARIES = ("discern", "highway-env", "gymnasium", "torch", "clingo", "ad-rss", "numpy")
# Every package whose code decides a figure: the reasoning (as rules.code_digest), the scenes and faults, the loop.
CODE_PACKAGES = ("discern.rules", "discern.sanity", "discern.adapters.highway", "discern.scenarios.highway")
ROOT = Path(__file__).resolve().parents[2]  # the discern package's folder: in a checkout, the repository's root


def code_state(setup: Setup, variants: list[str]) -> dict:
    """The code and rules a run starts with, taken before its first episode: files edited while it runs (a long one)
    must not be recorded as what made its figures."""
    return {"code": {**_git(), "sha256": code_digest()},
            "discern": _discern(setup) if "discern" in variants else None}


def manifest(command: list[str], args: argparse.Namespace, setup: Setup, variants: list[str], fault_sets: list[Faults],
             seeds: list[int], started: datetime, finished: datetime, training: dict | None, code: dict) -> dict:
    """`command`: the command line as given; `args`: every option, defaults included; `seeds`: the episodes';
    `training`: the checkpoint's metadata (Planner.training), None for one saved without any or a --planner's;
    `code`: code_state's, taken at the start."""
    env = make_env(setup.env, duration=setup.duration)
    try:
        environment = {"id": setup.env, **episode_end(env), "config_sha256": config_digest(env)}
    finally:
        env.close()
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
        "budget_ms": setup.budget_ms,
        "planner": _planner(setup, training),
        **code,
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


def _planner(setup: Setup, training: dict | None) -> dict:
    if setup.planner is not None:  # the user's: its module's file stands for its code
        module = importlib.import_module(setup.planner.partition(":")[0])
        source = Path(module.__file__) if getattr(module, "__file__", None) else None
        return {"factory": setup.planner, "module_file": str(source.resolve()) if source else None,
                "sha256": _sha256(source) if source else None}
    weights = Path(setup.weights) if setup.weights else default_weights()
    return {"weights": str(weights.resolve()), "sha256": _sha256(weights),
            "training": "unknown" if training is None else training}


def code_digest() -> str:
    """sha256 of the Python sources of CODE_PACKAGES, with their names: the same code, the same digest."""
    digest = hashlib.sha256()
    for package in CODE_PACKAGES:
        root = resources.files(package)
        for source in sorted((p for p in root.iterdir() if p.name.endswith(".py")), key=lambda p: p.name):
            digest.update(f"{package}.{source.name}\0".encode() + source.read_bytes() + b"\0")
    return digest.hexdigest()


def _git(root: Path = ROOT) -> dict:
    """The commit the code was checked out at and whether tracked files differ from it; None for both outside a git
    checkout of discern itself (an installed package: the digests stand alone)."""
    def git(*argv: str) -> str | None:
        try:
            done = subprocess.run(["git", "-C", str(root), *argv], capture_output=True, text=True, timeout=30)
        except (OSError, subprocess.TimeoutExpired):
            return None
        return done.stdout.strip() if done.returncode == 0 else None

    top = git("rev-parse", "--show-toplevel")
    if top is None or Path(top).resolve() != root:  # a package installed inside some other repository
        return {"git_commit": None, "git_dirty": None}
    status = git("status", "--porcelain", "--untracked-files=no")
    return {"git_commit": git("rev-parse", "HEAD"), "git_dirty": None if status is None else bool(status)}


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _version(distribution: str) -> str | None:
    try:
        return metadata.version(distribution)
    except metadata.PackageNotFoundError:
        return None
