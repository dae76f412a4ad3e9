"""The planner interface of `discern eval highway`: evaluate your own policy with the shipped one's metrics.

    discern eval highway --planner my_module:make_policy

`make_policy(seed)` is called at the start of every episode with the episode's environment seed (a stochastic
policy seeds itself from it, so a run repeats) and returns the policy: a callable that takes the frame as the
vehicle's sensors report it (`perception.Perceived`) and returns a DiscreteMetaAction index (actions.LANE_LEFT,
IDLE, LANE_RIGHT, FASTER, SLOWER: 0..4). A class whose constructor takes the seed and which defines `__call__` is
such a factory. What the policy should read:

- `perceived.camera_tracks()`: the vehicles the camera reports, with the injected faults (missed detections gone,
  phantoms present, noisy distances): what a camera-driven planner sees;
- `perceived.sign.limit`: the speed limit it read off the last sign (misread under `signs`);
- `perceived.truth.ego` and `perceived.truth.lanes`: the ego's own state and the map's lanes.

`perceived.truth.tracks` is the simulator's ground truth: a policy that reads it drives past every perception fault.
The shipped planner (planner.Planner) is such a policy.
"""

from __future__ import annotations

import importlib
import os
import sys
from typing import Callable, Protocol

from discern.adapters.highway.perception import Perceived

Policy = Callable[[Perceived], int]


class PolicyFactory(Protocol):
    def __call__(self, seed: int) -> Policy: ...


def load_factory(spec: str) -> PolicyFactory:
    """`MODULE:NAME` as `--planner` gives it; the working directory is searched first, as `python -m` would."""
    module_name, _, name = spec.partition(":")
    if not module_name or not name:
        raise ValueError(f"--planner {spec!r}: give it as MODULE:FACTORY (e.g. my_planner:make_policy)")
    if os.getcwd() not in sys.path:  # the `discern` script's own folder heads sys.path, not the working directory
        sys.path.insert(0, os.getcwd())
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise ValueError(f"--planner {spec!r}: cannot import {module_name}: {exc}") from None
    factory = module
    for part in name.split("."):
        factory = getattr(factory, part, None)
    if not callable(factory):
        raise ValueError(f"--planner {spec!r}: {module_name} has no callable {name}")
    return factory
