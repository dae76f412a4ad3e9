"""The sidecar monitor: proposals in over zenoh, a verdict out for every one, within the budget.

Who does what:
- zenoh callbacks only copy the payload and enqueue it, so they never block;
- decision worker processes judge proposals (decision_worker.py, run by
  decision_pool.py); the monitor's own process does no reasoning, so nothing
  holds it up;
- a watchdog thread answers any proposal still unanswered at its deadline with
  a fail-safe verdict, so a slow rule set, a backlog or a dead worker never
  leaves a planner without an answer (a late decision is then discarded);
- the MCAP writer runs on its own thread (log/writer.py).
Every proposal is answered exactly once: whoever claims the request first sends.
Every answer is logged after the payload it answered: on the proposal channel if
the payload is a proposal, on the rejected channel if not. A fail-safe sent
before the worker read the payload is logged once the worker has, or after
HOLD_S unread, read by the monitor itself then (_AnswerLog): a stalled worker
does not keep it from the log.
What the monitor keeps per vehicle (its verdict publisher, its last permitted
actions) goes once the vehicle has been silent for longer than its window and
budget: memory follows the vehicles heard from lately, not every one ever seen.
"""

from __future__ import annotations

import itertools
import json
import logging
import math
import threading
import time
from collections import OrderedDict, deque
from dataclasses import dataclass, field
from typing import Optional

import zenoh
from pydantic import ValidationError

from discern.rules.catalog import catalog_digest
from discern.rules.engine import jurisdiction_pack
from discern.rules.scene import Action, valid_id

from . import keys
from .config import DEFAULT_ENDPOINT, MonitorConfig, check_listen_ports, listen_endpoints, listens_by_default
from .decision_pool import DecisionPool
from .decision_worker import Job, Outcome, WorkerSettings
from .log import McapLogWriter, RejectedInput, vehicle_topic
from .log.channels import STATUS_TOPIC
from .protocol import (
    RULE_BAD_INPUT, RULE_DEADLINE, RULE_INTERNAL_ERROR, InputError, decode_proposal, encode, failsafe_verdict,
    invalid_vehicle, peek_frame,
)
from .status import LOG_FILES_LISTED, MonitorStatus, StatusCounters
from .vehicle_state import EXPIRY_MARGIN_S, EXPIRY_SWEEP_S, PermittedMemory

log = logging.getLogger(__name__)

JSON = zenoh.Encoding.APPLICATION_JSON
EXCERPT_BYTES = 512
UTF8_BOM = b"\xef\xbb\xbf"
READ_HERE_BYTES = 256 * 1024  # a held payload up to this size is read by the monitor itself (a 200-object one: about 60 KB)
EXPIRED_KEPT = 10_000  # answers logged unread whose worker's late word is still expected
# Longest a sent answer waits for its worker's word before it is logged, and how often that is checked. A held answer,
# once placed, is flushed within the writer's SOON_S (0.1 s): a kill -9 loses at most about 0.7 s of held answers,
# the log's flush period (0.5 s by default) of the others.
HOLD_S = 0.5
HOLD_CHECK_S = 0.1
# Bounds on stderr: a flood of 1,000 bad payloads wrote 1,000 warnings, while fail-safe brakes wrote none.
REFUSAL_LOG_PERIOD_S = 1.0  # at most one refusal warning a second per kind (every one with -v), then a count
FAILSAFE_REPORT_S = 10.0  # deadline and internal fail-safes: one warning with their counts this often, if any
OVERLAP_CHECK_S = 3.0  # how long a starting monitor listens for running ones whose vehicles it would serve too


@dataclass(eq=False)
class Request:
    """One proposal in flight, from its arrival to its single answer."""

    rid: int
    key: str
    vehicle: str
    payload: Optional[bytes]  # None when empty or over the size limit
    head: bytes  # an oversized payload's first EXCERPT_BYTES, all the log shows of it; else empty
    size: int
    arrived: float  # time.monotonic(), the clock the workers share
    arrived_ns: int  # wall clock, for the log
    deadline: float
    query: Optional[zenoh.Query] = None
    _once: threading.Lock = field(default_factory=threading.Lock)

    def claim(self) -> bool:
        """True for the one thread allowed to answer."""
        return self._once.acquire(blocking=False)

    @property
    def answered(self) -> bool:
        return self._once.locked()

    def still_open(self) -> bool:
        return not self._once.locked()


@dataclass(frozen=True)
class Answer:
    """A verdict ready to send, with what the counters and the log need to know about it."""

    verdict: bytes
    decision: str
    failsafe: bool
    latency_ms: float
    error_kind: Optional[str] = None  # refused as bad input of this kind
    error: Optional[str] = None
    read: bool = True  # the payload was read before this answer (False: a fail-safe at the deadline or at shutdown)
    not_proposal: Optional[str] = None  # why the payload is not a proposal, when it is not


class MonitorServer:
    """Serve verdicts until `stop()`; use as a context manager."""

    def __init__(self, config: MonitorConfig):
        self.config = config.validate()
        self.vehicles_chunk = keys.vehicle_selector(config.vehicles)
        self.counters = StatusCounters(config.monitor_id, self.vehicles_chunk, config.budget_ms)
        self._budget_s = config.budget_ms / 1000
        self._rids = itertools.count()
        self._open: dict[int, Request] = {}
        self._pending: deque[Request] = deque()  # in arrival order, hence deadline order
        self._refusals: deque[tuple[Request, str, str]] = deque()  # (request, reason, kind): bad input seen on arrival
        self._wake = threading.Event()
        self._stopping = threading.Event()
        self._threads: list[threading.Thread] = []
        self._publishers: dict[str, zenoh.Publisher] = {}
        self._publishers_lock = threading.Lock()
        self._permitted = PermittedMemory()
        self._vehicles: dict[str, float] = {}  # vehicle -> arrival of its latest proposal
        self._vehicles_lock = threading.Lock()  # between the zenoh threads and the sweep; never held with the other
        # No proposal is still open this long after a vehicle's last one, and its window has lapsed.
        self._expiry_s = config.window_s + self._budget_s + EXPIRY_MARGIN_S
        self._declared: list = []
        self._read_here: OrderedDict[int, None] = OrderedDict()  # answered at the deadline after a read here (_shadow_deadline)
        self._report = _TrafficReport(self.counters, config.budget_ms)
        self._probe_answer = json.dumps({"monitor_id": config.monitor_id, "vehicles_filter": self.vehicles_chunk}).encode()
        self.pool = DecisionPool(
            config.workers,
            WorkerSettings(config.window_s, config.shadow, config.jurisdiction,
                           params=tuple(sorted(config.param_values().items())),
                           test_delay_s=config.test_decision_delay_ms / 1000),
            self._on_outcome,
            self._on_worker_lost,
        )
        self.session: Optional[zenoh.Session] = None
        self.listen_endpoints: list[str] = []
        self.log: Optional[McapLogWriter] = None
        self.answers: Optional[_AnswerLog] = None

    # -- lifecycle -----------------------------------------------------------

    def start(self) -> "MonitorServer":
        """Go live; on any failure nothing is left running and the error propagates."""
        try:
            self._open_all()
        except BaseException:
            self.stop()
            raise
        return self

    def _open_all(self) -> None:
        zenoh_config = self.config.zenoh.to_zenoh(default_listen=[DEFAULT_ENDPOINT])
        self.listen_endpoints = listen_endpoints(zenoh_config)
        check_listen_ports(self.listen_endpoints, defaulted=listens_by_default(zenoh_config))
        self.pool.start()  # workers load the rules before zenoh starts any thread
        self.session = zenoh.open(zenoh_config)
        if self.config.log is not None:
            self.log = McapLogWriter(self.config.log, self.config.monitor_id, self.config.param_values(),
                                     self.config.jurisdiction, self.config.window_s,
                                     catalog_digest(extra_files=[jurisdiction_pack(self.config.jurisdiction)]))
            self.answers = _AnswerLog(self.log)
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
        self._spawn("discern-overlap-check", self._warn_of_overlaps)

    def stop(self) -> None:
        if self._stopping.is_set():
            return
        for entity in self._declared:
            _quietly(entity.undeclare)
        self._declared = []
        self.pool.stop()  # workers finish what they were sent
        self._stopping.set()
        self._wake.set()
        for t in self._threads:
            t.join(timeout=10)
        for req in list(self._open.values()):
            self._answer(req, self._failsafe(req, "the monitor is shutting down", RULE_INTERNAL_ERROR))
        self._report.tick(time.monotonic(), final=True)
        if self.log is not None:
            self.answers.flush("not read: the monitor stopped before its decision worker read it")
            self.log.write(STATUS_TOPIC, "status", self.status())
            self.log.close()
        if self.session is not None:
            _quietly(self.session.close)

    def __enter__(self) -> "MonitorServer":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    def status(self) -> MonitorStatus:
        waiting = list(self._open.values())  # a copy in one step: the zenoh threads add to it meanwhile
        oldest = min((req.arrived for req in waiting), default=None)
        extra = dict(
            vehicles=len(self._vehicles), open_proposals=len(waiting),
            oldest_open_ms=None if oldest is None else round((time.monotonic() - oldest) * 1000, 3),
        )
        if self.log is not None:
            extra.update(
                # The last few, not every file of a run that may last months (it grew by a file an hour, and each
                # was looked for on disk at every status); still on disk: one deleted from outside (an operator, a
                # cleaner) is no longer this run's log.
                log_files=[str(p.resolve()) for p in self.log.files[-LOG_FILES_LISTED:] if p.exists()],
                log_files_opened=self.log.opened, log_records=self.log.records, log_dropped=self.log.dropped,
            )
        return self.counters.snapshot(**extra)

    def _warn_of_overlaps(self) -> None:
        """Warn of each running monitor whose vehicle filter meets this one's: zenoh routes a vehicle both serve to
        both, and its planner takes whichever verdict comes first. Asked in the background for OVERLAP_CHECK_S, as a
        fresh session learns its routes over a moment: start-up does not wait for it."""
        own, seen = str(self.session.zid()), set()
        deadline = time.monotonic() + OVERLAP_CHECK_S
        while not self._stopping.wait(0.2) and time.monotonic() < deadline:
            try:
                replies = list(self.session.get(keys.status_key("*"), consolidation=zenoh.ConsolidationMode.NONE,
                                                timeout=max(0.1, deadline - time.monotonic())))
            except zenoh.ZError:  # the session closing: stopped meanwhile
                return
            for reply in replies:
                replier = str(reply.replier_id.zid) if reply.replier_id else None
                if reply.ok is None or replier in (own, None) or replier in seen:
                    continue
                try:
                    other = MonitorStatus.model_validate_json(reply.ok.payload.to_bytes(), strict=True)
                except ValidationError:  # not a monitor of this version: `discern status` names it
                    continue
                seen.add(replier)
                if keys.filters_overlap(other.vehicles_filter, self.vehicles_chunk):
                    log.warning(keys.overlap_warning(other.monitor_id, other.vehicles_filter, self.config.monitor_id,
                                                     self.vehicles_chunk))

    def _spawn(self, name: str, target, *args) -> None:
        t = threading.Thread(target=target, args=args, name=name, daemon=True)
        t.start()
        self._threads.append(t)

    # -- zenoh callbacks: copy, enqueue, return ----------------------------------

    def _on_sample(self, sample: zenoh.Sample) -> None:
        try:
            self._submit(str(sample.key_expr), sample.payload, None)
        except Exception:  # an exception would vanish inside zenoh: make it visible
            log.exception("could not take a proposal on %s", sample.key_expr)

    def _on_query(self, query: zenoh.Query) -> None:
        try:
            key = str(query.key_expr)
            if keys.PROBE in query.parameters and query.payload is None and not keys.is_wild(key):
                with query:
                    query.reply(key, self._probe_answer, encoding=JSON)
                return
            self._submit(key, query.payload, query)
        except Exception:
            log.exception("could not take a query on %s", query.key_expr)

    def _submit(self, key: str, payload: Optional[zenoh.ZBytes], query: Optional[zenoh.Query]) -> None:
        now = time.monotonic()
        size = len(payload) if payload is not None else 0
        limit = self.config.max_payload_bytes
        # Copied over the limit too, for its first bytes (zenoh offers no cheaper way at them); never parsed.
        # A byte-order mark before the JSON is ignored, as RFC 8259 allows and `discern check` reads a file: it goes
        # before the workers read the payload and the log keeps it, where JSON readers (Foxglove's) would refuse it.
        raw = payload.to_bytes().removeprefix(UTF8_BOM) if size else b""
        data = raw if 0 < size <= limit else None
        vehicle = keys.vehicle_of(key)
        wild = keys.is_wild(key)
        req = Request(
            next(self._rids), key, vehicle or "", data, raw[:EXCERPT_BYTES] if data is None else b"", size, now,
            time.time_ns(), now + self._budget_s, query,
        )
        if wild or vehicle is None:
            # Not a vehicle: no per-vehicle state, and no verdict but a query's reply (a put's would be broadcast).
            reason = (
                f"key {key[:200]!r} has a wildcard: a proposal's key names its vehicle, discern/<vehicle>/..."
                if wild
                else f"key {key[:200]!r} is not discern/<vehicle>/proposal or discern/<vehicle>/check"
            )
            if query is None:
                req.claim()
                self.counters.input_refused("vehicle")
                self._report.refused("vehicle", "refused a proposal, no verdict sent: %s", reason)
                if self.answers is not None:
                    self.answers.rejected(req, reason)
                return
            refusal = (reason, "vehicle")
        elif not valid_id(vehicle):
            refusal = (invalid_vehicle(vehicle), "vehicle")
        elif data is None:
            refusal = (
                (f"payload of {size} bytes exceeds the limit of {limit} bytes", "size")
                if size > limit
                else ("empty payload: expected a Proposal as JSON", "json")
            )
        else:
            refusal = None
        if refusal is None or refusal[1] != "vehicle":  # a key naming no valid vehicle is no vehicle
            with self._vehicles_lock:
                self._vehicles[vehicle] = now
        self._open[req.rid] = req
        if refusal is not None:
            # Cheap to decide, but answered from the watchdog's thread, never from a zenoh thread.
            self._refusals.append((req, *refusal))
        else:
            self.pool.submit(Job(req.rid, vehicle, data, now, req.deadline), req.still_open)
        self._pending.append(req)
        self._wake.set()

    def _on_status_query(self, query: zenoh.Query) -> None:
        with query:
            query.reply(keys.status_key(self.config.monitor_id), encode(self.status()), encoding=JSON)

    # -- outcomes from the decision workers -------------------------------------

    def _on_outcome(self, outcome: Outcome) -> None:
        req = self._open.get(outcome.rid)
        if outcome.lost:  # its worker died: a fail-safe saying so now, rather than at the deadline
            if req is not None and req.still_open():
                self._answer(req, self._failsafe(req, outcome.no_verdict, RULE_INTERNAL_ERROR))
            self._read_late(outcome)
            return
        if outcome.receipt:  # no answer to give: only word on the payload, for the log
            self._read_late(outcome)
            return
        if req is None or req.answered:
            if _decided(outcome):
                self.counters.count("late_decisions")
            self._read_late(outcome)
            return
        not_proposal = None if outcome.decoded else (outcome.error or outcome.no_verdict)
        if outcome.verdict is None:
            rule = RULE_INTERNAL_ERROR if outcome.internal else RULE_DEADLINE
            if outcome.internal:
                self.counters.count("internal_errors")
            reason = (
                outcome.no_verdict if outcome.internal
                else f"no decision within the {self.config.budget_ms:g} ms budget: {outcome.no_verdict}"
            )
            answer = self._failsafe(
                req, reason, rule, frame_id=outcome.frame_id, action=outcome.action, read=True,
                not_proposal=not_proposal,
            )
            if not self._answer(req, answer):
                self._read_late(outcome)
            elif not outcome.internal:
                self.counters.count("deadline_misses")
            return
        if not outcome.failsafe and outcome.permitted:
            self._permitted.remember(req.vehicle, tuple(Action(a) for a in outcome.permitted), time.monotonic())
        answer = Answer(
            outcome.verdict,
            outcome.decision,
            outcome.failsafe,
            outcome.latency_ms,
            outcome.error_kind,
            outcome.error,
            not_proposal=not_proposal,
        )
        if not self._answer(req, answer):
            if _decided(outcome):
                self.counters.count("late_decisions")
            self._read_late(outcome)

    def _read_late(self, outcome: Outcome) -> None:
        """The worker's word on a payload whose answer went before it was read (at the deadline, at shutdown)."""
        if self._read_here.pop(outcome.rid, 0) is None:  # read by the monitor itself: counted and logged then
            return
        if outcome.error_kind is not None and not outcome.decoded:  # bad input all the same, as the log records it
            self.counters.input_refused(outcome.error_kind)
        if self.answers is not None:
            self.answers.read(outcome.rid, None if outcome.decoded else (outcome.error or outcome.no_verdict))

    def _on_worker_lost(self, index: int, exitcode: Optional[int]) -> None:
        self.counters.count("internal_errors")
        log.error("decision worker %d died (exit code %s): starting a new one", index, exitcode)

    # -- deadline --------------------------------------------------------------

    def _watch(self) -> None:
        """Send refusals, and at its deadline a fail-safe for every request still open; forget silent vehicles."""
        pending = self._pending
        next_sweep = time.monotonic() + EXPIRY_SWEEP_S
        next_hold_check = time.monotonic() + HOLD_CHECK_S
        while not self._stopping.is_set():
            if time.monotonic() >= next_sweep:
                self._forget_silent(time.monotonic())
                next_sweep = time.monotonic() + EXPIRY_SWEEP_S
            self._report.tick(time.monotonic())
            if self.answers is not None and time.monotonic() >= next_hold_check:
                self.answers.expire(time.time_ns() - int(HOLD_S * 1e9))
                next_hold_check = time.monotonic() + HOLD_CHECK_S
            while self._refusals:
                req, reason, kind = self._refusals.popleft()
                self._answer(req, self._refuse(req, reason, kind))
            if not pending:
                self._wake.clear()
                if not pending and not self._refusals:
                    self._wake.wait(HOLD_CHECK_S)
                continue
            req = pending[0]
            if req.answered:
                pending.popleft()
                continue
            delay = req.deadline - time.monotonic()
            if delay > 0:
                # Later requests have later deadlines; a refusal or stop() wakes us early.
                self._wake.clear()
                if not self._refusals:
                    self._wake.wait(min(delay, HOLD_CHECK_S))
                continue
            pending.popleft()
            reason = f"no decision within the {self.config.budget_ms:g} ms budget"
            if self.config.shadow:
                self._shadow_deadline(req, reason)
            # Perhaps not read yet: the monitor's process never parses a payload (see _AnswerLog), so a malformed one
            # is named in the log's rejected record once its worker reads it, not here.
            elif self._answer(req, self._failsafe(req, reason, RULE_DEADLINE)):
                self.counters.count("deadline_misses")

    def _shadow_deadline(self, req: Request, reason: str) -> None:
        """A shadow monitor's fail-safe at the deadline keeps the proposed action, so it reads the payload here first
        (as _AnswerLog.expire does, up to READ_HERE_BYTES): one that fails the schema has no action to keep and is
        refused by name, as its worker would; one too large to read here brakes. The worker's later word is ignored."""
        self._read_here[req.rid] = None
        if len(self._read_here) > EXPIRED_KEPT:  # a worker that died with them never answers
            self._read_here.popitem(last=False)
        if req.payload is None or len(req.payload) > READ_HERE_BYTES:
            answer = self._failsafe(req, reason, RULE_DEADLINE, frame_id=peek_frame(req.payload)[0], read=True,
                                    not_proposal=_not_proposal(req))
        else:
            try:
                proposal = decode_proposal(req.payload, req.vehicle)
            except InputError as exc:
                answer = self._refuse(req, str(exc), exc.kind)
            else:
                answer = self._failsafe(req, reason, RULE_DEADLINE, frame_id=proposal.scene.frame_id,
                                        action=proposal.action.value, read=True)
        if not self._answer(req, answer):
            self._read_here.pop(req.rid, None)
        elif answer.error_kind is None:
            self.counters.count("deadline_misses")

    def _forget_silent(self, now: float) -> None:
        """Drop the state of the vehicles silent for `_expiry_s`: a vehicle coming back is a new episode anyway."""
        with self._vehicles_lock:
            silent = [v for v, last in self._vehicles.items() if now - last > self._expiry_s]
            for vehicle in silent:
                del self._vehicles[vehicle]
        for vehicle in silent:
            self._permitted.forget(vehicle)
            with self._publishers_lock:
                publisher = self._publishers.pop(vehicle, None)
            if publisher is not None:
                _quietly(publisher.undeclare)

    # -- answers ---------------------------------------------------------------

    def _failsafe(
        self,
        req: Request,
        reason: str,
        rule: str,
        *,
        frame_id: Optional[int] = None,
        action: Optional[str] = None,
        read: bool = False,
        not_proposal: Optional[str] = None,
    ) -> Answer:
        """A fail-safe answer. `read`: the worker read the payload; it is a proposal unless `not_proposal` says why."""
        if frame_id is None:  # not parsed yet: label the answer with what a glance at the payload gives
            frame_id, proposed = peek_frame(req.payload)
        else:
            proposed = Action(action) if action else None
        verdict = failsafe_verdict(
            req.vehicle,
            reason,
            rule,
            proposed=proposed,
            frame_id=frame_id,
            permitted=self._permitted.recent(req.vehicle, time.monotonic()),
            shadow=self.config.shadow,
        )
        verdict.latency_ms = round((time.monotonic() - req.arrived) * 1000, 3)
        return Answer(
            encode(verdict), verdict.decision.value, True, verdict.latency_ms, error=verdict.error, read=read,
            not_proposal=not_proposal,
        )

    def _refuse(self, req: Request, reason: str, kind: str) -> Answer:
        """The answer to a payload refused on arrival, before any worker saw it.

        Labelled with the payload's frame id when a glance finds one: a planner waiting over
        publish/subscribe matches a verdict to its frame. An oversized payload is glanced at in its head.
        """
        frame_id, _ = peek_frame(req.payload or req.head)  # the action stays unread: refused, it is not kept
        verdict = failsafe_verdict(req.vehicle, reason, RULE_BAD_INPUT, frame_id=frame_id, shadow=self.config.shadow)
        verdict.latency_ms = round((time.monotonic() - req.arrived) * 1000, 3)
        return Answer(
            encode(verdict), verdict.decision.value, True, verdict.latency_ms, kind, error=reason, not_proposal=reason
        )

    def _answer(self, req: Request, answer: Answer) -> bool:
        if not (req.claim() if self.answers is None else self.answers.claim(req, answer)):
            return False
        self._open.pop(req.rid, None)
        try:
            if req.query is not None:
                with req.query as query:
                    query.reply(req.key, answer.verdict, encoding=JSON)
            elif valid_id(req.vehicle):
                self._publisher(req.vehicle).put(answer.verdict)
            else:  # no vehicle, so none of its state: no publisher kept for a key nobody will use again
                self.session.put(keys.verdict_key(req.vehicle), answer.verdict, encoding=JSON)
        except Exception as exc:  # the session is closing, or the querier gave up
            log.warning("could not send the verdict for %s: %s", req.key, exc)
            self.counters.count("unsent")
        finally:
            if self.answers is not None:
                self.answers.release()  # after the verdict is on its way (_AnswerLog.claim)
        self.counters.verdict_sent(answer.decision, answer.failsafe, answer.latency_ms, answer.error_kind)
        if answer.error_kind is not None:
            self._report.refused(answer.error_kind, "refused a proposal on %s: %s", req.key, answer.error or "see the log")
        return True

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


class _TrafficReport:
    """The monitor's warnings on stderr about what it answers, bounded whatever comes in.

    A refusal is warned of at once, then at most once per REFUSAL_LOG_PERIOD_S per kind: those in between are
    counted and said in one line when the period is over (each is still counted in the status and logged in the MCAP
    log). With INFO logging (`serve -v`) every refusal is warned of. Fail-safes sent for lack of a decision
    (deadline, internal error), brakes that no line reported, are summed up every FAILSAFE_REPORT_S, when there were
    any. `tick` is called often (the watchdog's loop) to say what was held back.
    """

    def __init__(self, counters: StatusCounters, budget_ms: float):
        self._counters = counters
        self._budget_ms = budget_ms
        self._lock = threading.Lock()
        self._refusals: dict[str, list] = {}  # kind -> [time of its last line, held back since, the latest held back]
        self._failsafes = (0, 0)  # deadline misses and internal errors at the last report
        self._next_report = time.monotonic() + FAILSAFE_REPORT_S

    def refused(self, kind: str, message: str, *args) -> None:
        now = time.monotonic()
        if not log.isEnabledFor(logging.INFO):
            with self._lock:
                last = self._refusals.setdefault(kind, [-math.inf, 0, ""])
                if now - last[0] < REFUSAL_LOG_PERIOD_S:
                    last[1] += 1
                    last[2] = message % args
                    return
                last[0] = now
        log.warning(message, *args)

    def tick(self, now: float, final: bool = False) -> None:
        """Say what is due; `final`: all that is left to say, as the monitor stops."""
        with self._lock:
            held = [(kind, last[1], now - last[0], last[2]) for kind, last in self._refusals.items()
                    if last[1] and (final or now - last[0] >= REFUSAL_LOG_PERIOD_S)]
            for kind, *_ in held:
                self._refusals[kind][:2] = [now, 0]
        for kind, count, seconds, latest in held:
            log.warning("%s; and %d more like it (%s) in the last %.1f s", latest, count - 1, kind, seconds)
        if now < self._next_report and not final:
            return
        seconds = now - self._next_report + FAILSAFE_REPORT_S
        self._next_report = now + FAILSAFE_REPORT_S
        counts = self._counters.counts("deadline_misses", "internal_errors")
        deadline, internal = (n - before for n, before in zip(counts, self._failsafes))
        self._failsafes = counts
        if deadline or internal:
            log.warning("fail-safe verdicts in the last %.0f s: %d with no decision within the %g ms budget, %d for "
                        "an internal error (discern status counts them all)", seconds, deadline, self._budget_ms, internal)


class _AnswerLog:
    """Each answer into the MCAP log, after the payload it answered.

    The payload goes on the proposal channel if it is a valid proposal, else on the rejected
    channel with the reason, so every logged proposal satisfies its schema. An answer sent before
    the decision worker read its payload (a fail-safe at the deadline, or at shutdown) waits for
    the worker's word on it: the monitor's own process never parses a proposal, which would stall
    the threads that answer. The worker's word may also come first; then it waits for the answer.
    Claiming a request and placing its answer's records in the log's order are one step, so a vehicle's
    records keep its order; they reach the writer once the verdict is sent (`release`): handed over before,
    they woke the writer thread, which then held the interpreter while the reply waited for it (about 1 ms
    more on a round trip, measured at 1 vehicle × 20 Hz).
    """

    def __init__(self, writer: McapLogWriter):
        self.writer = writer
        self._lock = threading.Lock()
        self._placed: list[tuple] = []  # records in the log's order, not handed to the writer yet
        self._unread: dict[int, tuple[Request, Answer, int]] = {}  # answered, payload not read yet (oldest first)
        self._read: dict[int, Optional[str]] = {}  # read, answer not sent yet: why it is no proposal (None: it is)
        # held past HOLD_S and logged, oldest first: their worker's later word is ignored (a set, as a stall makes many)
        self._logged_unread: dict[int, None] = {}

    def claim(self, req: Request, answer: Answer) -> bool:
        """Claim the request for this answer (Request.claim) and place the answer in the log, or hold it for the
        worker's word. The caller sends the verdict, then calls `release`."""
        with self._lock:
            if not req.claim():
                return False
            sent_ns = time.time_ns()
            if answer.read:
                self._place(req, answer, answer.not_proposal, sent_ns)
            elif req.rid in self._read:
                self._place(req, answer, self._read.pop(req.rid), sent_ns)
            else:
                self._unread[req.rid] = (req, answer, sent_ns)
            return True

    def release(self) -> None:
        """Hand the records placed so far to the writer, in their order."""
        with self._lock:
            self._hand_over()

    def read(self, rid: int, not_proposal: Optional[str]) -> None:
        """The worker read the payload of an answer that did not wait for it."""
        with self._lock:
            waiting = self._unread.pop(rid, None)
            if waiting is None:
                if rid in self._logged_unread:
                    del self._logged_unread[rid]
                else:
                    self._read[rid] = not_proposal
            else:
                req, answer, sent_ns = waiting
                self._place(req, answer, not_proposal, sent_ns)
            self._hand_over()
            if waiting is not None:
                self.writer.flush_soon()  # held, so late already

    def expire(self, older_than_ns: int) -> None:
        """Log the answers sent before `older_than_ns` whose payloads are still unread: a worker stalled for seconds
        would otherwise keep every fail-safe it caused out of the log until it woke. Such a payload is read here, as
        its worker would (rare, and bounded by READ_HERE_BYTES); a larger one is logged as not read in time."""
        with self._lock:
            held = False
            while self._unread:
                rid, (req, answer, sent_ns) = next(iter(self._unread.items()))
                if sent_ns >= older_than_ns:
                    break
                del self._unread[rid]
                self._place(req, answer, _not_proposal(req), sent_ns)
                held = True
                self._logged_unread[rid] = None
                if len(self._logged_unread) > EXPIRED_KEPT:  # a worker that died with them never answers
                    del self._logged_unread[next(iter(self._logged_unread))]
            self._hand_over()
            if held:
                self.writer.flush_soon()  # held, so late already

    def flush(self, why: str) -> None:
        """Log the answers whose payloads no worker will read, as refused for `why`."""
        with self._lock:
            for req, answer, sent_ns in self._unread.values():
                self._place(req, answer, why, sent_ns)
            self._unread.clear()
            self._hand_over()

    def rejected(self, req: Request, reason: str) -> None:
        """Log a payload that gets no verdict at all (its key names no vehicle)."""
        with self._lock:
            self._place_rejected(req, reason)
            self._hand_over()

    def _place_rejected(self, req: Request, reason: str) -> None:
        excerpt = (req.payload or req.head)[:EXCERPT_BYTES].decode("utf-8", "replace")
        rejected = RejectedInput(vehicle=req.vehicle, key=req.key, size=req.size, error=reason, excerpt=excerpt)
        self._placed.append((vehicle_topic(_topic_safe(req.vehicle), "rejected"), "rejected", rejected, req.arrived_ns))

    def _place(self, req: Request, answer: Answer, not_proposal: Optional[str], sent_ns: int) -> None:
        topic_vehicle = _topic_safe(req.vehicle)
        if not_proposal is None and req.payload is not None:
            self._placed.append((vehicle_topic(topic_vehicle, "proposal"), "proposal", req.payload, req.arrived_ns))
        else:
            self._place_rejected(req, not_proposal or answer.error or "no payload")
        self._placed.append((vehicle_topic(topic_vehicle, "verdict"), "verdict", answer.verdict, sent_ns))

    def _hand_over(self) -> None:
        for record in self._placed:
            self.writer.write(*record)
        self._placed.clear()


def _not_proposal(req: Request) -> Optional[str]:
    """Why a payload its worker has not read is no proposal (None: it is one), read as the worker reads it."""
    if req.payload is None:
        return "no payload"
    if len(req.payload) > READ_HERE_BYTES:
        return (f"not read in time: its decision worker had not read it {HOLD_S:g} s after the fail-safe was sent, "
                f"and at {len(req.payload)} bytes it is not read outside a worker")
    try:
        decode_proposal(req.payload, req.vehicle)
    except InputError as exc:
        return str(exc)
    return None


def _direct(callback):
    """Run `callback` on the zenoh thread itself: it only enqueues, and skipping the hop to a
    Python thread saves about a millisecond per proposal."""
    return zenoh.handlers.Callback(callback, indirect=False)


INVALID_VEHICLE = "@invalid"  # the log's name for what came on a key naming no vehicle: never a vehicle id itself


def _topic_safe(vehicle: str) -> str:
    return vehicle if valid_id(vehicle) else INVALID_VEHICLE


def _quietly(fn) -> None:
    try:
        fn()
    except Exception as exc:
        log.debug("ignored during shutdown: %s", exc)


def _decided(outcome: Outcome) -> bool:
    """Whether the rules judged it: a shed proposal or a refused payload is no decision, late or not."""
    return outcome.verdict is not None and outcome.error_kind is None
