"""A stand-in ML planner wired to Discern in a few lines; run `python -m discern.monitor.example_planner`.

It drives a made-up highway scene (the ego closing in on a slower car, with
traffic around) and asks the monitor about a proposed action each frame,
printing what the monitor decided and why. The scene builder doubles as the
load generator of bench/bench_zenoh.py.
"""

from __future__ import annotations

import argparse
import math
import random
import sys
import time
from typing import Optional, Sequence

from discern.rules.scene import Action, DetectedObject, Ego, Lane, LaneKind, LaneRef, ObjectClass, Scene, Vec2, Velocity

from .client import Monitor
from .config import DEFAULT_ENDPOINT

LANE_WIDTH = 3.5
# A fail-safe is the monitor's answer when it decided nothing within its budget (50 ms by default) or none answered:
# on a busy machine some frames get one, since the monitor waits for a core (docs/protocol.md).
EXIT_STATUS = ("exit status: 0 every verdict came from the rules; 1 some were fail-safe (monitor.deadline: no decision "
               "within the monitor's budget, which a loaded machine misses now and then; monitor.no_answer: no monitor "
               "answered); 2 a usage error")


def highway_scene(frame_id: int, n_objects: int = 8, *, lanes: int = 3, seed: int = 0, dt: float = 0.05) -> Scene:
    """A deterministic highway frame: the ego in the middle lane, `n_objects` cars around it.

    `dt`: seconds of scene time per frame (its timestamp is 1 + frame_id * dt); `run` passes its frame period.
    """
    rng = random.Random(seed * 1_000_003 + frame_id)
    t = frame_id * dt
    ego_lane = (lanes + 1) // 2
    objects = []
    for i in range(n_objects):
        lane, row = 1 + i % lanes, i // lanes
        # Rows of traffic alternately ahead of and behind the ego, 35 m apart;
        # the car ahead in the ego's lane is slowly being caught up.
        ahead = (row // 2 + 1) * 35.0 * (1 if row % 2 == 0 else -1)
        speed = 22.0 + rng.uniform(-3, 3)
        if lane == ego_lane and row == 0:
            ahead = max(6.0, 60.0 - t * 3.0)
        if lane == ego_lane and ahead > 0:  # caught up at about 1 m/s: followed past the two-second headway for the first 2 s
            speed = 24.0 + rng.uniform(-0.5, 0.5)
        objects.append(
            DetectedObject(
                id=i + 1,
                cls=ObjectClass.truck if i % 7 == 3 else ObjectClass.car,
                position=Vec2(x=(lane - ego_lane) * LANE_WIDTH + rng.uniform(-0.2, 0.2), y=ahead),
                lane=LaneRef(kind=LaneKind.current, id=lane),
                velocity=Velocity(x=0.0, y=speed),
            )
        )
    return Scene(
        frame_id=frame_id,
        timestamp=round(1.0 + t, 6),
        ego=Ego(speed=25.0, lane=ego_lane, zone="highway"),
        speed_limit=33.3,
        lanes=[Lane(kind=LaneKind.current, id=i + 1, speed_limit=33.3) for i in range(lanes)],
        objects=objects,
    )


def planner_action(frame_id: int) -> Action:
    """What our pretend network proposes: mostly cruise, now and then something bolder."""
    return (Action.cruise, Action.accelerate, Action.change_lane_left, Action.cruise, Action.change_lane_right)[
        frame_id % 5
    ]


def run(
    vehicle: str = "ego",
    frames: int = 20,
    rate_hz: float = 10.0,
    connect: Sequence[str] = (DEFAULT_ENDPOINT,),
    style: str = "query",
    explain: bool = False,
    out=sys.stdout,
) -> int:
    """Drive `frames` frames; returns how many verdicts were fail-safe (0 when all went well).

    Raises ValueError, before driving, for a rate, vehicle or endpoint it cannot use.
    """
    if not (math.isfinite(rate_hz) and rate_hz > 0):
        raise ValueError(f"--rate must be a finite number of frames per second above 0, got {rate_hz:g}")
    if frames < 1:
        raise ValueError(f"--frames must be at least 1, got {frames}")
    failsafes = 0
    period = 1.0 / rate_hz
    with Monitor(vehicle, connect=list(connect), style=style, timeout=0.5) as monitor:
        if not monitor.wait_for_monitor(timeout=3.0):
            print(f"no monitor serves vehicle {vehicle!r} at {', '.join(connect)}: expect fail-safe verdicts",
                  file=sys.stderr)
        for frame in range(frames):
            started = time.monotonic()
            proposed = planner_action(frame)
            # the scene's clock runs at the frame rate, as a real planner's would: the audit's rates per hour and km
            # and its odometry go by it
            verdict = monitor.check(highway_scene(frame, dt=period), proposed, explain=explain)
            failsafes += verdict.failsafe
            print(
                f"frame {frame:4d}: proposed {proposed.value:<18} -> {verdict.decision.value:<8} "
                f"execute {verdict.action.value:<18} {verdict.latency_ms or 0:6.2f} ms  {verdict.justification.summary}",
                file=out,
                flush=True,
            )
            if explain and verdict.justification.text:
                print(verdict.justification.text, file=out)
            time.sleep(max(0.0, period - (time.monotonic() - started)))
    return failsafes


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--vehicle", default="ego", help="vehicle id (default: ego)")
    parser.add_argument("--frames", type=int, default=20, help="frames to drive (default: 20)")
    parser.add_argument("--rate", type=float, default=10.0, help="frames per second (default: 10)")
    parser.add_argument(
        "--connect", action="append", metavar="ENDPOINT", help=f"monitor or router endpoint (default: {DEFAULT_ENDPOINT})"
    )
    parser.add_argument("--style", choices=("query", "pubsub"), default="query",
                        help="query/reply or publish/subscribe (default: %(default)s)")
    parser.add_argument("--explain", action="store_true", help="ask for and print the full justification")


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m discern.monitor.example_planner", description=__doc__.split("\n")[0],
                                     epilog=EXIT_STATUS)
    add_arguments(parser)
    args = parser.parse_args(argv)
    try:
        failsafes = run_arguments(args)
    except ValueError as exc:
        print(f"{parser.prog}: error: {exc}", file=sys.stderr)
        return 2
    return 1 if failsafes else 0


def run_arguments(args: argparse.Namespace) -> int:
    """`run` with the arguments of `add_arguments`."""
    return run(args.vehicle, args.frames, args.rate, args.connect or [DEFAULT_ENDPOINT], args.style, args.explain)


if __name__ == "__main__":
    sys.exit(main())
