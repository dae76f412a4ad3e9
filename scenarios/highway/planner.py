"""The ML planner under test: a small DQN plus a sign-following cruise control.

The DQN sees the camera's tracks (what perception hands it, faults included), not the simulator's truth,
so a missed detection or a phantom misleads it the way it would mislead a real stack. Its cruise control
follows the speed-limit sign it reads: a misread sign makes it speed, which is what Discern must catch.
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np
import torch
from torch import nn

from discern.adapters.highway.actions import FASTER, IDLE, LANE_LEFT, LANE_RIGHT, SLOWER
from discern.adapters.highway.envs import TARGET_SPEEDS, speed_index
from discern.adapters.highway.perception import Perceived
from discern.adapters.highway.truth import EgoTruth, Track

OBSERVED_TRACKS = 6
EGO_FEATURES = 5
TRACK_FEATURES = 5
OBSERVATION_SIZE = EGO_FEATURES + OBSERVED_TRACKS * TRACK_FEATURES
N_ACTIONS = 5
HIDDEN = 256
WEIGHTS_FILE = "dqn_highway_fast.pt"


def observation(ego: EgoTruth, lanes: int, tracks: list[Track]) -> np.ndarray:
    """The DQN's input: the ego row and the nearest tracks, relative and scaled to about [-1, 1]."""
    obs = np.zeros(OBSERVATION_SIZE, dtype=np.float32)
    obs[:EGO_FEATURES] = (
        ego.speed / 40.0,
        ego.v_right / 10.0,
        ego.lateral / ego.lane_width,
        float(ego.lane == 1),
        float(ego.lane >= lanes),
    )
    nearest = sorted(tracks, key=lambda t: np.hypot(t.ahead, t.right))[:OBSERVED_TRACKS]
    for i, t in enumerate(nearest):
        start = EGO_FEATURES + i * TRACK_FEATURES
        obs[start : start + TRACK_FEATURES] = (
            1.0,
            t.ahead / 100.0,
            t.right / 12.0,
            (t.v_ahead - ego.speed) / 20.0,
            (t.v_right - ego.v_right) / 10.0,
        )
    return np.clip(obs, -1.0, 1.0)


class QNetwork(nn.Module):
    def __init__(self) -> None:
        super().__init__()
        self.layers = nn.Sequential(
            nn.Linear(OBSERVATION_SIZE, HIDDEN),
            nn.ReLU(),
            nn.Linear(HIDDEN, HIDDEN),
            nn.ReLU(),
            nn.Linear(HIDDEN, N_ACTIONS),
        )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.layers(x)


def follow_sign(action: int, speed: float, read_limit: float | None) -> int:
    """Cruise control on the read limit: speed up to it while below, never ask to exceed it, slow above it."""
    if read_limit is None:
        return action
    next_target = TARGET_SPEEDS[min(speed_index(speed) + 1, len(TARGET_SPEEDS) - 1)]
    if action in (IDLE, FASTER) and speed > read_limit + 2.0:
        return SLOWER
    if action == FASTER and next_target > read_limit:
        return IDLE
    if action == IDLE and next_target <= read_limit and speed < read_limit - 1.0:
        return FASTER
    return action


def available(action: int, ego: EgoTruth, lanes: int) -> bool:
    if action == LANE_LEFT:
        return ego.lane > 1
    if action == LANE_RIGHT:
        return ego.lane < lanes
    return True


def default_weights() -> Path:
    """The shipped checkpoint (trained before checkpoints carried metadata)."""
    return Path(str(resources.files("discern.scenarios.highway") / "weights" / WEIGHTS_FILE))


def save_checkpoint(path: Path, network: QNetwork, training: dict) -> None:
    """The weights with how they were trained (steps, seed, versions, the environment's configuration digest), in one
    file that Planner.load reads: metadata in a file of its own would not travel with the weights."""
    torch.save({"state_dict": network.state_dict(), "training": training}, path)


def _mismatch(state, expected: dict) -> str:
    """How a loaded state dict differs from the network's, in one line ('' if it fits): torch's own message puts
    each kind of difference on a line of its own, under a first line that names none."""
    if not isinstance(state, dict):
        return f"a {type(state).__name__}, not a state dict"
    if not all(isinstance(v, torch.Tensor) for v in state.values()):
        return "a dict of other things than tensors, not a state dict"
    missing = [k for k in expected if k not in state]
    unexpected = [str(k) for k in state if k not in expected]
    shapes = [f"{k} ({_shape(state[k])} in the file, {_shape(v)} here)" for k, v in expected.items()
              if k in state and state[k].shape != v.shape]
    return "; ".join(f"{what} {', '.join(keys)}" for what, keys in (
        ("missing", missing), ("unexpected", unexpected), ("mis-shaped", shapes)) if keys)


def _shape(tensor: torch.Tensor) -> str:
    return "x".join(map(str, tensor.shape)) or "scalar"


@dataclass
class Planner:
    """Greedy DQN policy + sign-following cruise control; `act` returns a DiscreteMetaAction index."""

    network: QNetwork
    follow_signs: bool = True
    training: dict | None = None  # the trainer's metadata (save_checkpoint); None: a checkpoint saved without any

    @classmethod
    def load(cls, path: Path | str | None = None, follow_signs: bool = True) -> "Planner":
        torch.set_num_threads(1)
        path = Path(path) if path else default_weights()
        if path.is_dir():
            raise IsADirectoryError(f"planner weights {path}: a directory, not a weights file")
        if not path.is_file():
            raise FileNotFoundError(
                f"planner weights not found at {path}: train them with "
                "`python -m discern.scenarios.highway.train --out PATH` or reinstall the package"
            )
        network = QNetwork()
        try:
            state = torch.load(path, map_location="cpu", weights_only=True)
        except OSError as exc:
            raise RuntimeError(f"planner weights {path}: cannot read: {exc.strerror or exc}") from None
        except Exception:
            # torch's unpickler raises whatever a file whose first bytes happen to be pickle opcodes leads it to
            # (UnpicklingError, IndexError, KeyError, ...); its own reason advises weights_only=False, which would run
            # whatever code the file holds.
            raise RuntimeError(f"{path} is not a planner weights file (a torch state dict from the trainer)") from None
        training = None
        if isinstance(state, dict) and state.keys() == {"state_dict", "training"} and isinstance(state["training"], dict):
            # save_checkpoint's; anything else is bare weights (the shipped checkpoint's) or none at all
            state, training = state["state_dict"], state["training"]
        mismatch = _mismatch(state, network.state_dict())
        if mismatch:
            raise RuntimeError(f"{path} does not hold this planner's weights: {mismatch}")
        network.load_state_dict(state)
        if not all(torch.isfinite(tensor).all() for tensor in network.state_dict().values()):
            raise RuntimeError(f"{path} holds NaN or infinite weights: a diverged training run, not a planner")
        network.eval()
        return cls(network=network, follow_signs=follow_signs, training=training)

    def q_values(self, ego: EgoTruth, lanes: int, tracks: list[Track]) -> np.ndarray:
        with torch.no_grad():
            x = torch.from_numpy(observation(ego, lanes, tracks)).unsqueeze(0)
            return self.network(x)[0].numpy()

    def act(self, ego: EgoTruth, lanes: int, tracks: list[Track], read_limit: float | None) -> int:
        q = self.q_values(ego, lanes, tracks)
        ranked = [int(a) for a in np.argsort(-q) if available(int(a), ego, lanes)]
        action = ranked[0]
        return follow_sign(action, ego.speed, read_limit) if self.follow_signs else action

    def __call__(self, perceived: Perceived) -> int:
        """The evaluation's policy interface (policy.py): the camera's tracks and the sign it read, faults included."""
        truth = perceived.truth
        return self.act(truth.ego, max(l.id for l in truth.lanes), perceived.camera_tracks(), perceived.sign.limit)
