"""The highway-env configurations the closed loop runs on, in one place so training and evaluation agree."""

from __future__ import annotations

import hashlib
import json
import math
import warnings

import gymnasium as gym
import highway_env  # noqa: F401  (registers the environments)
import numpy as np

# The default target speeds (20, 25, 30 m/s) top out at the 30 m/s lane limit and cannot brake below 20:
# a planner that misreads a sign could never speed and a shield could never slow behind slow traffic.
# The closed loop widens them to 10..40 m/s in 5 m/s steps (Vehicle.MAX_SPEED is 40); nothing else changes.
TARGET_SPEEDS = tuple(float(v) for v in np.linspace(10.0, 40.0, 7))
SPEED_STEP = TARGET_SPEEDS[1] - TARGET_SPEEDS[0]  # what one FASTER or SLOWER moves the target speed by

SUPPORTED = ("highway-fast-v0", "highway-v0", "merge-v0")
# merge-v0 has no duration: its episode ends on a crash or once the ego is past the merge, x > 370 m
# (MergeEnv._is_terminated), which the slowest target speed reaches from its start at x = 30 m in 34 s.
MERGE_END_X = 370.0


def make_env(name: str = "highway-fast-v0", duration: float | None = None) -> gym.Env:
    """One environment with the closed loop's action space (DiscreteMetaAction over TARGET_SPEEDS), the one to give
    DiscernWrapper and a planner trained for the loop; `duration` shortens episodes (seconds).

    merge-v0 never truncates an episode itself: there `duration` is a step limit, so that it holds as it does on the
    highway roads.
    """
    if name not in SUPPORTED:
        raise ValueError(f"unsupported environment {name!r}: choose one of {', '.join(SUPPORTED)}")
    config: dict = {"action": {"type": "DiscreteMetaAction", "target_speeds": list(TARGET_SPEEDS)}}
    if duration is not None:
        config["duration"] = duration
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # merge-v0 is "out of date" but is what the issue names
        env = gym.make(name, config=config)
    if name == "merge-v0" and duration is not None:  # highway-env's own rule: truncated once time >= duration
        env = gym.wrappers.TimeLimit(env, max_episode_steps=math.ceil(duration / policy_period(env)))
    return env


def episode_end(env) -> dict:
    """What ends the environment's episodes besides a crash: its duration (None: none) and, on merge-v0, the merge."""
    config = env.unwrapped.config
    end = {"duration_s": config.get("duration")}
    if env.unwrapped.spec is not None and env.unwrapped.spec.id == "merge-v0":
        end["past_x_m"] = MERGE_END_X
    return end


def config_digest(env) -> str:
    """sha256 of the environment's whole configuration: the same digest, the same road, traffic, rewards, timing and
    action space (what a checkpoint was trained on, and what an evaluation ran, compare by it)."""
    return hashlib.sha256(json.dumps(env.unwrapped.config, sort_keys=True, default=repr).encode()).hexdigest()


def policy_period(env) -> float:
    return 1.0 / float(env.unwrapped.config["policy_frequency"])


def speed_index(speed: float) -> int:
    """The index MDPVehicle maps a speed to (nearest target speed)."""
    return int(np.clip(round((speed - TARGET_SPEEDS[0]) / SPEED_STEP), 0, len(TARGET_SPEEDS) - 1))
