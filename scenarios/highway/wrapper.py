"""`DiscernWrapper`: shield a highway-env policy with one line.

    from discern.adapters.highway.envs import make_env
    from discern.adapters.highway.perception import Faults
    env = DiscernWrapper(make_env("highway-fast-v0"), faults=Faults.preset("signs,missed"))
    obs, info = env.reset(seed=10_000)
    obs, reward, terminated, truncated, info = env.step(policy(env.perceived))

`make_env` makes highway-fast-v0, highway-v0 or merge-v0 with the target speeds the vehicle parameters assume
(envs.TARGET_SPEEDS, 10..40 m/s); `gym.make("highway-fast-v0")` keeps highway-env's 20..30 m/s, which the wrapper
refuses unless given a checker whose Params.accel_step is half that grid's step.

Every step the wrapper turns the simulator's state into a Discern scene (through the perception layer,
faults included), asks the checker about the agent's action, executes the approved or overriding
action, and reports the verdict in info["discern"]. The checker is Discern's reasoner in-process by
default, the zenoh monitor with monitor=True, or any object with the `Checker` shape (the RSS peer).

What the policy sees: `step` and `reset` return highway-env's own observation, the simulator's ground truth, which
no injected fault touches. A policy meant to meet the faults reads `env.perceived` instead (perception.Perceived:
`camera_tracks()`, `sign.limit`, the ego's own state in `truth.ego`), as the evaluation's planners do
(policy.py); `env.scene` is the scene Discern judges.
"""

from __future__ import annotations

from collections import deque
from typing import Protocol, Sequence

import gymnasium as gym
from highway_env.envs.common.action import DiscreteMetaAction
from highway_env.envs.highway_env import HighwayEnv, HighwayEnvFast
from highway_env.envs.merge_env import MergeEnv

from discern.rules.scene import Action, Proposal, Scene
from discern.rules.verdict import Decision, Verdict
from discern.sanity import WindowConfig

from discern.adapters.highway.actions import from_catalog, to_catalog
from discern.adapters.highway.envs import SPEED_STEP, SUPPORTED, TARGET_SPEEDS, policy_period
from discern.adapters.highway.perception import Faults, Perceived, Perception
from discern.adapters.highway.scene import build_scene
from discern.adapters.highway.truth import VehicleIds, read_truth


# highway-env's MDPVehicle sheds 4.3-5 m/s in the second after a SLOWER (measured in the closed loop):
# Discern's stopping gaps must assume what this vehicle can brake, not the catalog's 6 m/s^2 default.
# A FASTER aims one step of TARGET_SPEEDS above the target speed nearest the current speed, so it passes a
# limit on that grid when the speed is less than half a step below it (at exactly half, numpy's rounding
# decides): acc.at_limit's accel_step.
VEHICLE_PARAMS = {"decel": 4.0, "accel_step": SPEED_STEP / 2}

# The roads of envs.SUPPORTED; the scene conversion gets curved, two-way and exit geometry wrong.
SUPPORTED_CLASSES = (HighwayEnv, HighwayEnvFast, MergeEnv)


class Checker(Protocol):
    name: str

    def check(self, scene: Scene, proposed: Action, history: Sequence[Scene]) -> Verdict: ...


class ReasonerChecker:
    """Discern in-process: the rules catalog and the sanity layer on clingo, deciding for `vehicle` (whom its
    verdicts name, as a monitor's name the vehicle that asked)."""

    name = "discern"

    def __init__(self, reasoner=None, explain: bool = False, shadow: bool = False, params=None, vehicle: str = "ego"):
        if reasoner is None:
            from discern.sanity import window_reasoner
            from discern.rules.facts import Params

            reasoner = window_reasoner(params=params or Params(**VEHICLE_PARAMS))
        self.reasoner = reasoner
        self.explain = explain
        self.shadow = shadow
        self.vehicle = vehicle

    def check(self, scene: Scene, proposed: Action, history: Sequence[Scene]) -> Verdict:
        return self.reasoner.decide(scene, proposed, history=tuple(history), explain=self.explain, shadow=self.shadow,
                                    vehicle=self.vehicle)


class MonitorChecker:
    """Discern as a sidecar: the proposal travels over zenoh to a running `discern monitor`."""

    name = "discern-monitor"

    def __init__(self, timeout: float = 0.5, vehicle: str = "ego", **client_options):
        try:
            from discern.monitor.client import Monitor
        except ImportError as exc:
            raise RuntimeError(
                "the zenoh monitor client (discern.monitor.client) is not available in this install; "
                "use the in-process reasoner (monitor=False)"
            ) from exc
        self.client = Monitor(vehicle, timeout=timeout, **client_options)
        self.vehicle = vehicle
        self.timeout = timeout

    def check(self, scene: Scene, proposed: Action, history: Sequence[Scene]) -> Verdict:
        return self.client.check(scene, proposed, timeout=self.timeout)

    def close(self) -> None:
        close = getattr(self.client, "close", None)
        if close:
            close()


class DiscernWrapper(gym.Wrapper):
    """Intercepts the agent's DiscreteMetaAction and executes what the checker permits.

    checker=None uses Discern in-process; monitor=True goes through a running `discern serve` instead
    (monitor_options go to discern.monitor.client.Monitor, e.g. {"connect": ["tcp/127.0.0.1:7447"]});
    passthrough=True records scenes but checks nothing (the unshielded baseline).
    """

    def __init__(
        self,
        env: gym.Env,
        checker: Checker | None = None,
        *,
        faults: Faults | None = None,
        monitor: bool = False,
        monitor_options: dict | None = None,
        timeout: float = 0.5,
        history_seconds: float = WindowConfig().seconds,
        explain: bool = False,
        shadow: bool = False,
        passthrough: bool = False,
        recorder=None,
        vehicle: str = "ego",
    ):
        super().__init__(env)
        actions = getattr(getattr(env.unwrapped, "action_type", None), "actions", None)
        if actions != DiscreteMetaAction.ACTIONS_ALL:
            raise ValueError(
                "DiscernWrapper needs highway-env's DiscreteMetaAction with all five meta-actions "
                f"(LANE_LEFT, IDLE, LANE_RIGHT, FASTER, SLOWER); this environment acts with {actions!r}"
            )
        if type(env.unwrapped) not in SUPPORTED_CLASSES:  # exact: ExitEnv subclasses HighwayEnv
            spec = getattr(env.unwrapped, "spec", None)
            raise ValueError(
                f"DiscernWrapper cannot convert {spec.id if spec else type(env.unwrapped).__name__}'s road into "
                f"scenes (straight multi-lane roads only): use one of {', '.join(SUPPORTED)}"
            )
        speeds = tuple(float(v) for v in getattr(env.unwrapped.action_type, "target_speeds", ()))
        if checker is None and not passthrough and speeds != TARGET_SPEEDS:
            raise ValueError(
                f"DiscernWrapper's vehicle parameters (accel_step {VEHICLE_PARAMS['accel_step']:g} m/s) assume the target "
                f"speeds {list(TARGET_SPEEDS)} (envs.make_env); this environment's are {list(speeds)}: make it with "
                "make_env, or pass a checker whose Params.accel_step is half its speed step"
            )
        named = getattr(checker, "vehicle", vehicle)
        if named != vehicle:  # its verdicts would name another vehicle than the proposals and topics recorded with them
            raise ValueError(f"the checker decides for vehicle {named!r}, the wrapper's vehicle is {vehicle!r}: "
                             "give both the same")
        self._owns_checker = checker is None
        self.vehicle = vehicle
        if passthrough:
            self.checker = None
        elif checker is not None:
            self.checker = checker
        elif monitor:
            self.checker = MonitorChecker(timeout=timeout, vehicle=vehicle, **(monitor_options or {}))
        else:
            self.checker = ReasonerChecker(explain=explain, shadow=shadow, vehicle=vehicle)
        self.recorder = recorder  # a discern.monitor.log.writer.McapLogWriter: proposals and verdicts to MCAP
        self._episodes = 0
        self.perception = Perception(faults)
        self.history_seconds = history_seconds
        self.history: deque[Scene] = deque()
        self.perceived: Perceived | None = None
        self.scene: Scene | None = None
        self._ids = VehicleIds()
        self._frames = 0  # scene frame ids: never reset, a monitor refuses a frame id it has judged already

    def _frame_id(self) -> int:
        frame, self._frames = self._frames, self._frames + 1
        return frame

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        obs, info = self.env.reset(seed=seed, options=options)
        self._ids = VehicleIds()
        self.history.clear()
        self._episodes += 1
        episode = seed if seed is not None else self._episodes  # keys the injected faults
        self.perceived = self.perception.reset(episode, read_truth(self.env, self._ids))
        self.scene = build_scene(self.perceived, period=policy_period(self.env), frame_id=self._frame_id())
        return obs, info

    def judge(self, action: int) -> Verdict | None:
        """The checker's verdict on `action` in the current scene (None when nothing checks)."""
        if self.scene is None:
            raise RuntimeError("call reset() before step()")
        proposed = to_catalog(action)
        if self.checker is None:
            return None
        try:
            verdict = self.checker.check(self.scene, proposed, tuple(self.history))
        except Exception as exc:  # a checker failure must never take the vehicle down with it
            from discern.monitor.protocol import RULE_INTERNAL_ERROR, failsafe_verdict

            verdict = failsafe_verdict(self.vehicle, f"{type(exc).__name__}: {exc}", RULE_INTERNAL_ERROR,
                                       proposed=proposed, frame_id=self.scene.frame_id, timestamp=self.scene.timestamp,
                                       shadow=getattr(self.checker, "shadow", False))
        if self.recorder is not None:
            self._record(proposed, verdict)
        return verdict

    def _record(self, proposed: Action, verdict: Verdict) -> None:
        from discern.monitor.log.channels import vehicle_topic

        proposal = Proposal(vehicle=self.vehicle, action=proposed, scene=self.scene)
        self.recorder.write(vehicle_topic(self.vehicle, "proposal"), "proposal", proposal)
        self.recorder.write(vehicle_topic(self.vehicle, "verdict"), "verdict", verdict)

    def execute(self, action: int, verdict: Verdict | None):
        executed = int(action)
        if verdict is not None and verdict.decision is Decision.override:
            executed = from_catalog(verdict.action)
        obs, reward, terminated, truncated, info = self.env.step(executed)
        info = dict(info)
        info["proposed_action"] = int(action)
        info["executed_action"] = executed
        if verdict is not None:
            info["discern"] = verdict.model_dump(mode="json")
        self._advance()
        return obs, reward, terminated, truncated, info

    def step(self, action):
        return self.execute(action, self.judge(action))

    def _advance(self) -> None:
        previous = self.scene
        self.history.append(previous)
        self.perceived = self.perception.step(read_truth(self.env, self._ids))
        self.scene = build_scene(
            self.perceived, previous_speed=previous.ego.speed, period=policy_period(self.env), frame_id=self._frame_id()
        )
        while self.history and self.history[0].timestamp < self.scene.timestamp - self.history_seconds:
            self.history.popleft()

    def close(self):
        """Closes the checker too when the wrapper made it (a zenoh session must not outlive us)."""
        close = getattr(self.checker, "close", None)
        if close and self._owns_checker:
            close()
        return super().close()
