"""The sidecar monitor: proposals in over zenoh, a verdict out for every one, within the budget.

Threads and why:
- zenoh callbacks only copy the payload and enqueue it, so they never block;
- worker threads judge proposals; each vehicle always goes to the same worker,
  which keeps its frames in order and its window private to one thread;
- a watchdog answers any proposal still unanswered at its deadline with a
  fail-safe verdict, so a slow rule set or a backlog never leaves a planner
  without an answer (the late decision is then discarded);
- the MCAP writer runs on its own thread (log/writer.py).
Every proposal is answered exactly once: whoever claims the request first sends.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
import zlib
from collections import deque
from dataclasses import dataclass, field
from typing import Optional

import zenoh

from discern.rules.scene import Proposal
from discern.rules.verdict import Verdict

from . import keys
from .config import DEFAULT_ENDPOINT, MonitorConfig, listen_endpoints
from .decider import Decide, DecideFactory, reasoner_factory, with_delay
from .log import McapLogWriter, RejectedInput, vehicle_topic
from .log.channels import STATUS_TOPIC
from .protocol import (
    RULE_BAD_INPUT,
    RULE_DEADLINE,
    RULE_INTERNAL_ERROR,
    InputError,
    decode_proposal,
    encode,
    failsafe_verdict,
)
from .status import MonitorStatus, StatusCounters
from .vehicle_state import VehicleState

log = logging.getLogger(__name__)

JSON = zenoh.Encoding.APPLICATION_JSON
EXCERPT_BYTES = 512


@dataclass(eq=False)
class Request:
    """One proposal in flight, from its arrival to its single answer."""

    key: str
    vehicle: str
    payload: Optional[bytes]  # None when empty or over the size limit
    size: int
    arrived: float  # perf_counter
    arrived_ns: int  # wall clock, for the log
    deadline: float
    query: Optional[zenoh.Query] = None
    proposal: Optional[Proposal] = None
    _once: threading.Lock = field(default_factory=threading.Lock)

    def claim(self) -> bool:
        """True for the one thread allowed to answer."""
        return self._once.acquire(blocking=False)

    @property
    def answered(self) -> bool:
        return self._once.locked()


class MonitorServer:
    """Serve verdicts until `stop()`; use as a context manager."""

    def __init__(self, config: MonitorConfig, decide_factory: DecideFactory = reasoner_factory):
        self.config = config.validate()
        if config.test_decision_delay_ms > 0:
            decide_factory = with_delay(decide_factory, config.test_decision_delay_ms / 1000)
        self._decide_factory = decide_factory
        self.vehicles_chunk = keys.vehicle_selector(config.vehicles)
        self.counters = StatusCounters(config.monitor_id, self.vehicles_chunk, config.budget_ms)
        self._budget_s = config.budget_ms / 1000
        self._states: list[dict[str, VehicleState]] = [{} for _ in range(config.workers)]
        self._queues: list[queue.SimpleQueue] = [queue.SimpleQueue() for _ in range(config.workers)]
        self._pending: deque[Request] = deque()
        self._wake = threading.Event()
        self._stopping = threading.Event()
        self._threads: list[threading.Thread] = []
        self._publishers: dict[str, zenoh.Publisher] = {}
        self._publishers_lock = threading.Lock()
        self._declared: list = []
        self.session: Optional[zenoh.Session] = None
        self.listen_endpoints: list[str] = []
        self.log: Optional[McapLogWriter] = None

    # -- lifecycle -----------------------------------------------------------

    def start(self) -> "MonitorServer":
        deciders = [self._decide_factory() for _ in range(self.config.workers)]  # fail before going live
        if self.config.log is not None:
            self.log = McapLogWriter(self.config.log, self.config.monitor_id)
        zenoh_config = self.config.zenoh.to_zenoh(default_listen=[DEFAULT_ENDPOINT])
        self.listen_endpoints = listen_endpoints(zenoh_config)
        self.session = zenoh.open(zenoh_config)
        for i, decide in enumerate(deciders):
            self._spawn(f"discern-worker-{i}", self._work, i, decide)
        self._spawn("discern-watchdog", self._watch)
        if self.log is not None:
            self._spawn("discern-status-log", self._log_status)
        chunk = self.vehicles_chunk
        s = self.session
        self._declared = [
            s.declare_subscriber(keys.proposal_key(chunk), _direct(self._on_sample)),
            s.declare_queryable(keys.check_key(chunk), _direct(self._on_query)),
            s.declare_queryable(keys.status_key(self.config.monitor_id), self._on_status_query),
        ]
        return self

    def stop(self) -> None:
        if self._stopping.is_set():
            return
        for entity in self._declared:
            _quietly(entity.undeclare)
        self._declared = []
        self._stopping.set()
        self._wake.set()
        for q in self._queues:
            q.put(None)
        for t in self._threads:
            t.join(timeout=10)
        if self.log is not None:
            self.log.write(STATUS_TOPIC, "status", self.status())
            self.log.close()
        if self.session is not None:
            _quietly(self.session.close)

    def __enter__(self) -> "MonitorServer":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    def status(self) -> MonitorStatus:
        extra = dict(vehicles=sum(len(s) for s in self._states))
        if self.log is not None:
            extra.update(
                log_files=[str(p) for p in self.log.files], log_records=self.log.records, log_dropped=self.log.dropped
            )
        return self.counters.snapshot(**extra)

    def _spawn(self, name: str, target, *args) -> None:
        t = threading.Thread(target=target, args=args, name=name, daemon=True)
        t.start()
        self._threads.append(t)

    # -- zenoh callbacks: copy, enqueue, return ----------------------------------

    def _on_sample(self, sample: zenoh.Sample) -> None:
        self._submit(str(sample.key_expr), sample.payload, None)

    def _on_query(self, query: zenoh.Query) -> None:
        self._submit(str(query.key_expr), query.payload, query)

    def _submit(self, key: str, payload: Optional[zenoh.ZBytes], query: Optional[zenoh.Query]) -> None:
        now = time.perf_counter()
        size = len(payload) if payload is not None else 0
        data = payload.to_bytes() if size and size <= self.config.max_payload_bytes else None
        vehicle = keys.vehicle_of(key)
        req = Request(key, vehicle, data, size, now, time.time_ns(), now + self._budget_s, query)
        if query is None and not keys.VEHICLE_PATTERN.match(vehicle) and any(c in vehicle for c in "*$"):
            # A wildcard put names no vehicle: a verdict could only be broadcast. Refuse it quietly.
            req.claim()
            reason = f"vehicle chunk {vehicle!r} of key {key!r} is a wildcard: no verdict sent"
            self.counters.input_refused("vehicle")
            log.warning("refused a proposal: %s", reason)
            self._log_rejected(req, reason)
            return
        self._pending.append(req)
        self._wake.set()
        self._queues[zlib.crc32(vehicle.encode()) % len(self._queues)].put(req)

    def _on_status_query(self, query: zenoh.Query) -> None:
        with query:
            query.reply(keys.status_key(self.config.monitor_id), encode(self.status()), encoding=JSON)

    # -- workers ---------------------------------------------------------------

    def _work(self, index: int, decide: Decide) -> None:
        work = self._queues[index]
        states = self._states[index]
        while True:
            req = work.get()
            if req is None:
                return
            if req.answered:  # the watchdog already sent its fail-safe: shed the backlog
                continue
            error_kind = None
            try:
                verdict = self._judge(req, decide, states)
            except InputError as exc:
                error_kind = exc.kind
                verdict = self._bad_input_verdict(req, str(exc))
            except Exception as exc:  # nothing a proposal does may take the monitor down
                log.exception("internal error judging a proposal from %s", req.vehicle)
                self.counters.count("internal_errors")
                verdict = self._failsafe(req, f"internal error: {type(exc).__name__}: {exc}", RULE_INTERNAL_ERROR)
            if not self._answer(req, verdict, error_kind):
                self.counters.count("late_decisions")

    def _judge(self, req: Request, decide: Decide, states: dict[str, VehicleState]) -> Verdict:
        if req.payload is None:
            if req.size > self.config.max_payload_bytes:
                raise InputError(
                    f"payload of {req.size} bytes exceeds the limit of {self.config.max_payload_bytes} bytes", "size"
                )
            raise InputError("empty payload: expected a Proposal as JSON", "json")
        proposal = decode_proposal(req.payload, req.vehicle)
        req.proposal = proposal
        state = states.get(req.vehicle)
        if state is None:
            state = states[req.vehicle] = VehicleState(self.config.window_s)
        scene = proposal.scene
        history = state.admit(scene, req.arrived)
        verdict = decide(
            scene,
            proposal.action,
            history=history,
            explain=proposal.explain,
            shadow=self.config.shadow,
            vehicle=req.vehicle,
        )
        state.remember_permitted(verdict.permitted, req.arrived)
        return verdict

    # -- deadline --------------------------------------------------------------

    def _watch(self) -> None:
        """Answer, at its deadline, every request still open; deadlines come in arrival order."""
        pending = self._pending
        while not self._stopping.is_set():
            if not pending:
                self._wake.clear()
                if not pending:
                    self._wake.wait(0.5)
                continue
            req = pending[0]
            if req.answered:
                pending.popleft()
                continue
            delay = req.deadline - time.perf_counter()
            if delay > 0:
                time.sleep(delay)
                continue
            pending.popleft()
            reason = (
                f"no decision within the {self.config.budget_ms:g} ms budget"
                + ("" if req.proposal is not None else " (still queued)")
            )
            if self._answer(req, self._failsafe(req, reason, RULE_DEADLINE), None):
                self.counters.count("deadline_misses")

    # -- answers ---------------------------------------------------------------

    def _failsafe(self, req: Request, reason: str, rule: str) -> Verdict:
        p = req.proposal
        state = self._states[zlib.crc32(req.vehicle.encode()) % len(self._states)].get(req.vehicle)
        return failsafe_verdict(
            req.vehicle,
            reason,
            rule,
            proposed=p.action if p else None,
            frame_id=p.scene.frame_id if p else None,
            timestamp=p.scene.timestamp if p else None,
            permitted=state.recent_permitted(time.perf_counter()) if state else (),
            shadow=self.config.shadow,
        )

    def _bad_input_verdict(self, req: Request, reason: str) -> Verdict:
        return self._failsafe(req, reason, RULE_BAD_INPUT)

    def _answer(self, req: Request, verdict: Verdict, error_kind: Optional[str]) -> bool:
        if not req.claim():
            return False
        verdict.latency_ms = round((time.perf_counter() - req.arrived) * 1000, 3)
        data = encode(verdict)
        try:
            if req.query is not None:
                with req.query as query:
                    query.reply(req.key, data, encoding=JSON)
            else:
                self._publisher(req.vehicle).put(data)
        except Exception as exc:  # the session is closing, or the querier gave up
            log.warning("could not send the verdict for %s: %s", req.key, exc)
        self.counters.verdict_sent(verdict, error_kind)
        if error_kind is not None:
            log.warning("refused a proposal on %s: %s", req.key, verdict.error)
        if self.log is not None:
            if req.proposal is not None:
                self.log.write(vehicle_topic(req.vehicle, "proposal"), "proposal", req.proposal, req.arrived_ns)
            elif error_kind is not None:
                self._log_rejected(req, verdict.error or "")
            self.log.write(vehicle_topic(_topic_safe(req.vehicle), "verdict"), "verdict", data)
        return True

    def _log_rejected(self, req: Request, reason: str) -> None:
        if self.log is None:
            return
        excerpt = (req.payload or b"")[:EXCERPT_BYTES].decode("utf-8", "replace")
        rejected = RejectedInput(vehicle=req.vehicle, key=req.key, size=req.size, error=reason, excerpt=excerpt)
        self.log.write(vehicle_topic(_topic_safe(req.vehicle), "rejected"), "rejected", rejected, req.arrived_ns)

    def _publisher(self, vehicle: str) -> zenoh.Publisher:
        pub = self._publishers.get(vehicle)
        if pub is None:
            with self._publishers_lock:
                pub = self._publishers.get(vehicle)
                if pub is None:
                    pub = self.session.declare_publisher(keys.verdict_key(vehicle), encoding=JSON)
                    self._publishers[vehicle] = pub
        return pub

    def _log_status(self) -> None:
        while not self._stopping.wait(self.config.status_period_s):
            self.log.write(STATUS_TOPIC, "status", self.status())


def _direct(callback):
    """Run `callback` on the zenoh thread itself: it only enqueues, and skipping the hop to a
    Python thread saves about a millisecond per proposal."""
    return zenoh.handlers.Callback(callback, indirect=False)


def _topic_safe(vehicle: str) -> str:
    return vehicle if keys.VEHICLE_PATTERN.match(vehicle) else "_invalid"


def _quietly(fn) -> None:
    try:
        fn()
    except Exception as exc:
        log.debug("ignored during shutdown: %s", exc)
