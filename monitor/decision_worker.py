"""A decision worker: the process that judges one share of the vehicles' proposals (decision_pool.py runs them).

A worker decides in batches: when it frees up it takes every proposal waiting
on its pipe and grounds as many as can still meet their deadlines in one clingo
Control (`Reasoner.decide_many`). Most of a frame's cost is paid per rule, not
per fact, so a batch pays it once (8 small frames: about 3 frames' time); under
load the backlog is decided instead of timing out. When idle a batch is one
proposal, so batching adds no latency; and while it waits, a worker readies
the clingo Controls its next proposals will need (rules/controls.py).

Every proposal a vehicle sends enters its window, decided or not: the window is
perception history (a light seen flashing, an object seen before, a sign read
twice), and a frame shed under load is still a frame the planner saw. A job
too late to decide, or answered by the watchdog before the worker took it, is
only decoded and admitted (about 0.3 ms for a 50-object scene, measured,
against about 5 ms for its decision), and never gets a second answer. A job shed
for lack of time that is no proposal, or out of order, is refused by name as a
decided one would be: bad input is bad input, however busy the worker. Every job
handed to a worker comes back as exactly one Outcome (a `lost` one when the
worker dies with it), so the monitor learns of each payload whether it was a
proposal at all: the log needs to know.

A vehicle's window is dropped once the vehicle has been silent for longer than
the window (VehicleState.expired), so a worker holds the windows of the
vehicles heard from lately, not of every vehicle it ever served.
"""

from __future__ import annotations

import gc
import logging
import os
import random
import signal
import time
from collections import deque
from dataclasses import dataclass
from typing import Callable, Iterator, Optional

from discern.rules.engine import Reasoner, Request
from discern.rules.facts import Params
from discern.rules.scene import Proposal, Scene
from discern.sanity import WindowConfig, default_providers

from .entry import STOP_SIGNALS
from .protocol import RULE_BAD_INPUT, InputError, decode_proposal, encode, failsafe_verdict, peek_frame
from .vehicle_state import EXPIRY_SWEEP_S, VehicleState

log = logging.getLogger(__name__)

DEADLINE_MARGIN = 1.5  # decide only with this many predicted decision times left: decision times vary
# A batch's proposals all wait for its last verdict, and per frame a batch of 32 gains little over 16
# (8-object highway frames, measured: 1.8 ms vs 1.45 ms a frame); the cap bounds one grounding's memory too.
MAX_BATCH = 32
# At most this often, when idle: a safety net. Decisions leave no reference cycles (a test checks), so a full
# collection frees nothing, yet it rescans every scene in the vehicles' windows: 135 ms for 10 vehicles' 2 s
# windows of 50-object scenes at 20 Hz (measured), a stall for whatever proposal arrives meanwhile.
FULL_COLLECTION_S = 300.0
NO_AUTOMATIC_FULL_COLLECTION = 1_000_000  # young collections between full ones: in effect, never
STOP = None  # sent down a worker's pipe: finish what was sent, then exit


@dataclass(frozen=True)
class WorkerSettings:
    window_s: float
    shadow: bool
    jurisdiction: str = "us"  # the rule pack: traffic side, limits
    params: tuple[tuple[str, float], ...] = ()  # reasoning parameters (rules.facts.Params) set by `serve --param`
    test_delay_s: float = 0.0  # test-only: sleep before deciding each batch


@dataclass(frozen=True)
class Job:
    """One proposal sent to a worker; times are time.monotonic(), one clock for all processes."""

    rid: int
    vehicle: str
    payload: bytes
    arrived: float
    deadline: float
    answered: bool = False  # answered before the worker took it: only its scene enters the window


@dataclass(frozen=True)
class Outcome:
    """A worker's answer to a Job: a verdict, or why there is none (then the monitor sends a fail-safe).

    Or, for a job already answered (`receipt`) or lost with its worker (`lost`), no answer at all: only
    whether the payload was a proposal, which the monitor needs to log it.
    """

    rid: int
    verdict: Optional[bytes] = None  # JSON, sent as is
    decision: Optional[str] = None
    failsafe: bool = False
    latency_ms: float = 0.0
    error_kind: Optional[str] = None  # the proposal was refused as bad input of this kind
    error: Optional[str] = None  # ... and why
    permitted: tuple[str, ...] = ()
    frame_id: Optional[int] = None
    action: Optional[str] = None
    no_verdict: Optional[str] = None  # why the worker gave no verdict
    internal: bool = False  # ... because the engine failed (else: no time left)
    decoded: bool = False  # the payload is a valid proposal of its vehicle (error says why not, if not)
    receipt: bool = False  # the job was answered before the worker took it: its scene only entered the window
    lost: bool = False  # the worker died with the job (no_verdict says so): nobody read the payload


def worker_main(conn, settings: WorkerSettings) -> None:
    # Ctrl-C, and a service manager's SIGTERM (systemd signals the whole group), reach us too: the monitor stops us
    # once we have decided what it sent, so that no proposal in flight loses its decision or its log record.
    for sig in STOP_SIGNALS:
        signal.signal(sig, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP_SIGNALS)  # blocked from birth (decision_pool.py): now ignored
    try:
        judge = Judge(settings)
    except Exception as exc:
        conn.send(("failed", f"{type(exc).__name__}: {exc}"))
        return
    try:
        judge.warm_up()
    except Exception as exc:
        conn.send(("failed", f"warming up: {type(exc).__name__}: {exc}"))
        return
    defer_full_collections()
    idle = IdleWork(judge.reasoner)
    conn.send(("ready", os.getpid()))
    backlog: deque[Job] = deque()
    stopping = False
    while backlog or not stopping:  # told to stop, finish what was sent
        try:
            if not stopping:
                stopping = _take_waiting(conn, backlog, idle, judge)
            for outcome in judge.next_batch(backlog):
                conn.send(outcome)
            if not conn.poll(0):  # a job that came during the batch is taken first: its vehicle's window kept
                judge.forget_silent(backlog)  # a worker that is never idle must drop them too
        except (EOFError, OSError):  # the monitor is gone
            return


def _take_waiting(conn, backlog: deque, idle: "IdleWork", judge: "Judge") -> bool:
    """Move every job waiting on the pipe to the backlog, waiting for one if there is none; True once told to stop.

    While it waits, the worker does its idle work, and drops the windows of the vehicles that fall silent.
    """
    while not backlog or conn.poll(0):
        if not backlog and not conn.poll(0):
            idle.run(busy=lambda: conn.poll(0))
            while not conn.poll(EXPIRY_SWEEP_S):
                judge.forget_silent(backlog)
        job = conn.recv()
        if job is STOP:
            return True
        backlog.append(job)
    return False


def defer_full_collections() -> None:
    """The garbage-collection policy of a process that decides: full collections wait for idle time.

    The loaded catalog is tens of thousands of objects that live as long as the
    process: frozen, the collector stops rescanning them, which cut the slowest
    200-object decisions from ~150 ms to ~40 (measured). Full collections still
    rescan every scene in the vehicles' windows (tens of milliseconds with
    50-object scenes, finding nothing to free: decisions leave no reference
    cycles): automatic ones are off, and IdleWork runs one now and then while
    the worker waits for work, never in the middle of a batch.
    """
    gc.freeze()
    gc.set_threshold(*gc.get_threshold()[:2], NO_AUTOMATIC_FULL_COLLECTION)


class IdleWork:
    """What a worker does while it waits: work a decision would otherwise pay for on its way to the verdict.

    That is readying the next frames' clingo Controls, one at a time until a proposal comes, and a full
    garbage collection at most every FULL_COLLECTION_S.
    """

    def __init__(self, reasoner: Reasoner):
        self.reasoner = reasoner
        self.last = time.monotonic()
        self.preparing = True  # until readying a Control fails: decisions then make their own, as they can

    def run(self, busy: Callable[[], bool] = lambda: False) -> None:
        try:
            while self.preparing and not busy() and self.reasoner.prepare(limit=1):
                pass
        except Exception:
            log.exception("readying clingo Controls in idle time failed: decisions make their own from now on")
            self.preparing = False
        now = time.monotonic()
        if now - self.last >= FULL_COLLECTION_S and not busy():
            gc.collect()
            self.last = time.monotonic()


class BatchTime:
    """How long deciding a batch of n proposals takes: a fixed part plus a part per proposal, learnt as it runs.

    Every proposal of a batch waits for the whole batch, so the deadline check needs the batch's
    time, not a per-proposal average; and a batch is not n single decisions (the fixed part, most
    of a small frame's grounding, is paid once). Fitted by normalised least mean squares: each
    timed batch moves the prediction for its own size a tenth of the way to what it took.
    """

    STEP = 0.1

    def __init__(self):
        self.fixed_s = 0.0
        self.per_proposal_s = 0.0
        self.known = False  # nothing timed yet: no grounds to batch on

    def predict(self, n: int) -> float:
        return self.fixed_s + n * self.per_proposal_s

    def most_within(self, seconds: float) -> int:
        """The largest batch predicted to take at most `seconds` (0 when not even an empty one would)."""
        if seconds < self.fixed_s:
            return 0
        if self.per_proposal_s <= 0.0:
            return MAX_BATCH
        return int((seconds - self.fixed_s) / self.per_proposal_s)

    def learn(self, n: int, took_s: float) -> None:
        step = self.STEP if self.known else 1.0  # the first batch timed sets the estimate outright
        error, norm = took_s - self.predict(n), 1 + n * n
        self.fixed_s = max(0.0, self.fixed_s + step * error / norm)
        self.per_proposal_s = max(0.0, self.per_proposal_s + step * error * n / norm)
        self.known = True


WARM_UP_FRAMES = 12  # a second of highway traffic at 12 Hz: enough kinds of frame that a planner's first ones are known


def warm_up_frames() -> list[Scene]:
    """Highway frames of a vehicle among cars and trucks in three lanes, the same on every start."""
    rng = random.Random(0)
    frames = []
    for frame in range(WARM_UP_FRAMES):
        lanes = [rng.randint(1, 3) for _ in range(8)]
        objects = [{"id": i, "class": rng.choice(["car", "car", "truck"]),
                    "position": {"x": 3.5 * (lane - 2), "y": rng.uniform(-40.0, 80.0)},
                    "lane": {"kind": "current", "id": lane}, "velocity": {"x": 0.0, "y": rng.uniform(18.0, 30.0)}}
                   for i, lane in enumerate(lanes, start=1)]
        frames.append(Scene.model_validate({
            "frame_id": frame, "timestamp": frame / WARM_UP_FRAMES, "ego": {"speed": 25.0, "lane": 2, "zone": "highway"},
            "speed_limit": 31.0, "lanes": [{"kind": "current", "id": i} for i in (1, 2, 3)], "objects": objects}))
    return frames


class Judge:
    """Everything a worker does to its queued proposals: shed the hopeless, validate, check the frame order, decide."""

    def __init__(self, settings: WorkerSettings):
        self.settings = settings
        # the sanity layer sees the whole window the vehicle's state keeps (`--window-s`), not its own default
        window = default_providers(WindowConfig(seconds=settings.window_s))
        self.reasoner = Reasoner(params=Params(**dict(settings.params)), jurisdiction=settings.jurisdiction,
                                 providers=window)
        self.vehicles: dict[str, VehicleState] = {}
        self.time = BatchTime()
        self._next_sweep = time.monotonic() + EXPIRY_SWEEP_S

    def warm_up(self) -> None:
        """Decide a second of traffic before the worker says it is ready: a fresh worker's first decisions (new kinds
        of frame grounded twice, the first proofs, the code they load) took 25 to 50 ms against 5 ms after, enough
        to miss a 50 ms budget on a planner's first frames (measured: about 11 ms after this, 0.5 s of start-up).
        The reasoner's own state only: no vehicle's window, no batch timing."""
        history: list[Scene] = []
        for scene in warm_up_frames():
            for proposed in ("cruise", "change_lane_left", "accelerate"):
                encode(self.reasoner.decide(scene, proposed, history, vehicle="warm-up"))
            history.append(scene)

    def next_batch(self, backlog: deque) -> Iterator[Outcome]:
        """Take the next batch off the front of the backlog (oldest first) and judge it.

        Outcomes come as soon as each is known: refusals and proposals out of time at once, the
        decided ones together when their batch is done.
        """
        now = time.monotonic()
        while backlog and (backlog[0].answered or not self._in_time(backlog[0], now)):
            # Answered already, or deciding it now would finish after its deadline: say so at once and
            # move on to a proposal that can still make it. Either way its scene enters the window first.
            job = backlog.popleft()
            yield self._receipt(job) if job.answered else self._shed(
                job, f"{max(job.deadline - now, 0) * 1000:.1f} ms of the budget left after queueing, "
                f"a decision takes about {self.time.predict(1) * 1000:.1f} ms"
            )
        if not backlog:
            return
        start, size = self._batch_bounds(backlog, now)
        for _ in range(start):
            job = backlog.popleft()
            yield self._receipt(job) if job.answered else self._shed(
                job, f"shed under overload: {size} younger proposals decided in one batch instead, in time"
            )
        batch = [backlog.popleft() for _ in range(size)]
        started = time.monotonic()
        admitted = []
        for job in batch:  # in arrival order: a vehicle's second frame has its first in its history
            if job.answered:
                yield self._receipt(job)
                continue
            taken = self._admit(job)
            if isinstance(taken, Outcome):
                yield taken
            else:
                admitted.append((job, *taken))
        if not admitted:
            return
        if self.settings.test_delay_s:
            time.sleep(self.settings.test_delay_s)  # once per batch: the batch's time, as a slow engine's would be
        results = self._decide([
            Request(proposal.scene, proposal.action, history, proposal.explain, self.settings.shadow, job.vehicle)
            for job, proposal, history in admitted
        ])
        done = time.monotonic()
        self.time.learn(len(batch), done - started)
        for (job, proposal, _), result in zip(admitted, results):
            yield self._outcome(job, proposal, result, done)

    def _batch_bounds(self, backlog: deque, now: float) -> tuple[int, int]:
        """Where the next batch starts in the backlog and how many proposals it takes.

        A batch grows while its oldest proposal would still make its deadline, and it starts with the
        oldest waiting proposal while the proposals behind that batch can still be decided after it.
        Under overload they cannot: the oldest proposal is always close to its deadline, so batches
        that start with it stay at one proposal, the dearest way to decide (measured, 50-object
        frames: 4.6 ms alone, 2.6 ms a frame in batches of 8), and the backlog sheds most of the rest.
        Then the batch starts where it decides the most proposals in time, and the older ones before
        it are shed at once.
        """
        if not self.time.known:
            return 0, 1
        first = self._fits(backlog, 0, now)
        rest = min(len(backlog) - first, MAX_BATCH)
        if not rest or DEADLINE_MARGIN * (self.time.predict(first) + self.time.predict(rest)) <= (
            backlog[first].deadline - now
        ):
            return 0, first
        best = (0, first)
        for start in range(1, len(backlog)):
            if min(len(backlog) - start, MAX_BATCH) <= best[1]:
                break  # later starts have fewer proposals behind them
            size = self._fits(backlog, start, now)
            if size > best[1]:
                best = (start, size)
        return best

    def _fits(self, backlog: deque, start: int, now: float) -> int:
        """How many proposals from `start` on one batch decides before the first one's deadline (at least one)."""
        room = min(len(backlog) - start, MAX_BATCH)
        return max(1, min(room, self.time.most_within((backlog[start].deadline - now) / DEADLINE_MARGIN)))

    def forget_silent(self, backlog: deque) -> None:
        """Drop the windows of vehicles silent past their window, every EXPIRY_SWEEP_S.

        Measured from the oldest job still waiting, not from now: a job that arrived before the silence
        ran out must still find its vehicle's window.
        """
        now = time.monotonic()
        if now < self._next_sweep:
            return
        self._next_sweep = now + EXPIRY_SWEEP_S
        horizon = backlog[0].arrived if backlog else now
        for vehicle in [v for v, state in self.vehicles.items() if state.expired(horizon)]:
            del self.vehicles[vehicle]

    def _shed(self, job: Job, why: str) -> Outcome:
        """A proposal that gets no decision: its scene enters the window, and the monitor answers it fail-safe.

        One that is no proposal, or out of order, is refused by name instead, as if it had been decided.
        """
        taken = self._admit(job)
        if isinstance(taken, Outcome):
            return taken
        proposal, _ = taken
        return Outcome(
            job.rid, no_verdict=why, frame_id=proposal.scene.frame_id, action=proposal.action.value, decoded=True
        )

    def _in_time(self, job: Job, now: float) -> bool:
        """Could a decision started now, alone, finish before the job's deadline?

        A fresh proposal (over half its budget left) is always tried: the estimate only learns
        from decisions, so it must never lock every proposal out.
        """
        needed = min(DEADLINE_MARGIN * self.time.predict(1), 0.5 * (job.deadline - job.arrived))
        return job.deadline - now >= needed

    def _receipt(self, job: Job) -> Outcome:
        """A job answered before the worker took it: into the window it goes, and no second answer."""
        proposal, error, kind = self._remember(job)
        return Outcome(job.rid, decoded=proposal is not None, error=error, error_kind=kind, receipt=True)

    def _remember(self, job: Job) -> tuple[Optional[Proposal], Optional[str], Optional[str]]:
        """Admit a job answered already into its vehicle's window: the proposal, or why it is none (and, for bad
        input, its kind).

        A frame out of order stays out of the window, as it would if decided; its answer is already
        given, so it is not refused either.
        """
        try:
            proposal = decode_proposal(job.payload, job.vehicle)
        except InputError as exc:
            return None, str(exc), exc.kind
        except Exception as exc:  # nothing a proposal does may take the worker down
            log.exception("internal error reading a proposal of %s", job.vehicle)
            return None, f"internal error: {type(exc).__name__}: {exc}", None
        try:
            self._state(job.vehicle).admit(proposal.scene, job.arrived)
        except InputError:
            pass
        return proposal, None, None

    def _state(self, vehicle: str) -> VehicleState:
        state = self.vehicles.get(vehicle)
        if state is None:
            state = self.vehicles[vehicle] = VehicleState(self.settings.window_s)
        return state

    def _admit(self, job: Job):
        """The job's proposal and history, after it entered its vehicle's window; or the Outcome refusing it."""
        proposal = None
        try:
            proposal = decode_proposal(job.payload, job.vehicle)
            return proposal, self._state(job.vehicle).admit(proposal.scene, job.arrived)
        except InputError as exc:
            verdict = failsafe_verdict(
                job.vehicle,
                str(exc),
                RULE_BAD_INPUT,
                proposed=proposal.action if proposal else None,
                # the planner matches a verdict to its frame: name it even when the payload is no proposal
                frame_id=proposal.scene.frame_id if proposal else peek_frame(job.payload)[0],
                timestamp=proposal.scene.timestamp if proposal else None,
                shadow=self.settings.shadow,
            )
            verdict.latency_ms = round((time.monotonic() - job.arrived) * 1000, 3)
            return Outcome(
                job.rid,
                verdict=encode(verdict),
                decision=verdict.decision.value,
                failsafe=True,
                latency_ms=verdict.latency_ms,
                error_kind=exc.kind,
                error=str(exc),
                decoded=proposal is not None,  # refused for its frame order, not its content
            )
        except Exception as exc:  # nothing a proposal does may take the monitor down
            log.exception("internal error reading a proposal of %s", job.vehicle)
            reason = f"internal error: {type(exc).__name__}: {exc}"
            return Outcome(job.rid, no_verdict=reason, internal=True, decoded=proposal is not None, error=reason)

    def _decide(self, requests: list[Request]) -> list:
        """A verdict, or the exception that stopped it, per request: one grounding for all when possible."""
        try:
            return self.reasoner.decide_many(requests)
        except Exception as exc:
            if len(requests) == 1:
                return [exc]
            log.exception("internal error deciding a batch of %d frames: deciding them one by one", len(requests))
        results = []
        for r in requests:  # so that one poisoned frame cannot fail the others
            try:
                results.append(self.reasoner.decide(r.scene, r.proposed, r.history, r.explain, r.shadow, r.vehicle))
            except Exception as exc:
                results.append(exc)
        return results

    def _outcome(self, job: Job, proposal, result, done: float) -> Outcome:
        if isinstance(result, Exception):
            log.error(
                "internal error judging frame %s of %s", proposal.scene.frame_id, job.vehicle, exc_info=result
            )
            return Outcome(
                job.rid,
                frame_id=proposal.scene.frame_id,
                action=proposal.action.value,
                no_verdict=f"internal error: {type(result).__name__}: {result}",
                internal=True,
                decoded=True,
            )
        result.latency_ms = round((done - job.arrived) * 1000, 3)  # arrival -> verdict: the job waited for its batch
        return Outcome(
            job.rid,
            verdict=encode(result),
            decision=result.decision.value,
            failsafe=result.failsafe,
            latency_ms=result.latency_ms,
            permitted=tuple(a.value for a in result.permitted),
            frame_id=proposal.scene.frame_id,
            action=proposal.action.value,
            decoded=True,
        )
