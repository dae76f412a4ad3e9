"""Train the planner's DQN on highway-fast-v0 (double DQN, own torch code, CPU, seeded).

    python -m discern.scenarios.highway.train --steps 50000 --seed 0 --out out/dqn_highway_fast.pt
    discern eval highway --weights out/dqn_highway_fast.pt

--out is required; it replaces the shipped checkpoint (planner.default_weights) only with --force. The checkpoint
carries how it was trained (steps, seed, torch and highway-env versions, the environment's configuration digest),
which the evaluation's run.json reports.

The cruise control that follows the (true) speed-limit sign is in the loop while training, as it is when
the planner drives, so the DQN learns to brake and change lanes around it. Hyper-parameters follow
highway-env's published DQN example (256x256 MLP, lr 5e-4, buffer 15k, batch 32, gamma 0.8,
target update every 50 steps, epsilon decayed over 70 % of the steps).
"""

from __future__ import annotations

import argparse
import copy
import random
import time
from importlib import metadata
from pathlib import Path

import numpy as np
import torch
from torch import nn

from discern.adapters.highway.envs import config_digest, make_env
from .planner import (N_ACTIONS, OBSERVATION_SIZE, QNetwork, available, default_weights, follow_sign, observation,
                      save_checkpoint)
from discern.adapters.highway.truth import VehicleIds, read_truth


ENV = "highway-fast-v0"


def lanes_of(truth) -> int:
    return max(l.id for l in truth.lanes)


def train(steps: int, seed: int, out: Path, log_every: int = 1000) -> None:
    torch.set_num_threads(1)
    torch.manual_seed(seed)
    np.random.seed(seed)
    random.seed(seed)
    rng = np.random.default_rng(seed)
    env = make_env(ENV)
    trained = {"env": ENV, "env_config_sha256": config_digest(env), "seed": seed, "torch": str(torch.__version__),
               "highway_env": metadata.version("highway-env")}
    q = QNetwork()
    target = copy.deepcopy(q)
    optimiser = torch.optim.Adam(q.parameters(), lr=5e-4)
    buffer_size, batch, gamma = 15000, 32, 0.8
    learning_starts, target_every, explore = 200, 50, 0.7
    obs_buf = np.zeros((buffer_size, OBSERVATION_SIZE), np.float32)
    next_buf = np.zeros((buffer_size, OBSERVATION_SIZE), np.float32)
    act_buf = np.zeros(buffer_size, np.int64)
    rew_buf = np.zeros(buffer_size, np.float32)
    done_buf = np.zeros(buffer_size, np.float32)

    episode, started = 0, time.time()
    ids = VehicleIds()
    env.reset(seed=seed * 100_000 + episode)
    truth = read_truth(env, ids)
    obs = observation(truth.ego, lanes_of(truth), truth.tracks)
    returns, crashes, ep_return = [], [], 0.0
    for step in range(steps):
        epsilon = max(0.05, 1.0 - step / (explore * steps) * 0.95)
        if rng.random() < epsilon:
            action = int(rng.integers(N_ACTIONS))
        else:
            with torch.no_grad():
                action = int(q(torch.from_numpy(obs).unsqueeze(0)).argmax())
        executed = action if available(action, truth.ego, lanes_of(truth)) else 1
        executed = follow_sign(executed, truth.ego.speed, truth.lane_limit(truth.ego.lane))
        _, reward, terminated, truncated, info = env.step(executed)
        truth = read_truth(env, ids)
        next_obs = observation(truth.ego, lanes_of(truth), truth.tracks)
        i = step % buffer_size
        obs_buf[i], next_buf[i], act_buf[i], rew_buf[i], done_buf[i] = obs, next_obs, action, reward, terminated
        obs, ep_return = next_obs, ep_return + reward
        if terminated or truncated:
            returns.append(ep_return)
            crashes.append(bool(info.get("crashed")))
            episode += 1
            ids = VehicleIds()
            env.reset(seed=seed * 100_000 + episode)
            truth = read_truth(env, ids)
            obs, ep_return = observation(truth.ego, lanes_of(truth), truth.tracks), 0.0

        if step >= learning_starts:
            idx = rng.integers(min(step + 1, buffer_size), size=batch)
            o, a = torch.from_numpy(obs_buf[idx]), torch.from_numpy(act_buf[idx])
            r, d, o2 = torch.from_numpy(rew_buf[idx]), torch.from_numpy(done_buf[idx]), torch.from_numpy(next_buf[idx])
            with torch.no_grad():
                best = q(o2).argmax(dim=1, keepdim=True)
                y = r + gamma * (1 - d) * target(o2).gather(1, best).squeeze(1)
            loss = nn.functional.smooth_l1_loss(q(o).gather(1, a.unsqueeze(1)).squeeze(1), y)
            optimiser.zero_grad()
            loss.backward()
            nn.utils.clip_grad_norm_(q.parameters(), 10.0)
            optimiser.step()
            if step % target_every == 0:
                target.load_state_dict(q.state_dict())

        if (step + 1) % log_every == 0 and returns:
            recent = slice(-20, None)
            print(
                f"step {step + 1} episodes {episode} eps {epsilon:.2f} "
                f"return(last20) {np.mean(returns[recent]):.2f} crash-rate(last20) {np.mean(crashes[recent]):.2f} "
                f"elapsed {time.time() - started:.0f}s",
                flush=True,
            )
            save_checkpoint(out, q, {"steps": step + 1, "episodes": episode, **trained})
    save_checkpoint(out, q, {"steps": steps, "episodes": episode, **trained})
    print(f"saved {out} after {steps} steps, {episode} episodes, {time.time() - started:.0f}s", flush=True)


def _at_least(low: int):
    def whole(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
        if value < low:
            raise argparse.ArgumentTypeError(f"must be at least {low}, got {value}")
        return value

    return whole


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=_at_least(1), default=50_000,
                        help="training steps, at least 1 (default: 50000, as the shipped weights)")
    parser.add_argument("--seed", type=_at_least(0), default=0, help="seed, at least 0 (the environment's seeds are)")
    parser.add_argument("--out", type=Path, required=True,
                        help=f"where to write the trained weights (required); the shipped ones ({default_weights()}) "
                             "only with --force")
    parser.add_argument("--force", action="store_true", help="let --out replace the shipped weights")
    args = parser.parse_args(argv)
    # Checked before training, which would otherwise fail at its first save, minutes or hours in.
    if args.out.resolve() == default_weights().resolve() and not args.force:
        parser.error(f"--out {args.out} is the shipped planner's weights: give --force to replace them")
    if args.out.is_dir():
        parser.error(f"--out {args.out}: a directory, not a weights file")
    if args.out.parent.exists() and not args.out.parent.is_dir():
        parser.error(f"--out {args.out}: {args.out.parent} is not a directory")
    try:
        args.out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        parser.error(f"--out {args.out}: cannot create its folder: {exc.strerror or exc}")
    train(args.steps, args.seed, args.out)


if __name__ == "__main__":
    main()
