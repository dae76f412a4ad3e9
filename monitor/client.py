"""Planner side: wire Discern into an ML planner in a few lines.

    from discern.monitor.client import Monitor
    with Monitor(vehicle="car_7") as monitor:            # connects to tcp/127.0.0.1:7447
        verdict = monitor.check(scene, "change_lane_left", timeout=0.1)
        execute(verdict.action)

`check` never raises for a missing or slow monitor, nor for a bad scene, nor
once closed: it returns a verdict (a fail-safe brake with `error` saying why, if
need be), exactly as the monitor itself does, so the planner's loop has one code path.
"""

from __future__ import annotations

import functools
import itertools
import json
import logging
import threading
import time
import weakref
from pathlib import Path
from typing import Callable, Iterable, Optional, Union

import zenoh
from pydantic import ValidationError

from discern.rules.scene import ID_RULE, JSON_AS_SCHEMA, SCHEMA_VERSION, Action, Proposal, Scene, valid_id
from discern.rules.verdict import Verdict

from . import keys
from .callback_thread import CallbackThread
from .config import BUDGET_MAX_MS, DEFAULT_ENDPOINT, ZenohSettings, check_number, uses_tls, without_rust_locations
from .protocol import (
    RULE_BAD_INPUT,
    RULE_NO_ANSWER,
    decode_verdict,
    describe_validation_error,
    encode,
    failsafe_verdict,
    invalid_proposal,
    peek_frame,
)

log = logging.getLogger(__name__)
JSON = zenoh.Encoding.APPLICATION_JSON
STYLES = ("query", "pubsub")
ZENOH_TIMEOUT = "Timeout"  # the error reply zenoh itself gives a query whose timeout expired
TIMEOUT_MAX_S = 2 * BUDGET_MAX_MS / 1000  # twice the longest budget a monitor may have: no verdict comes later
# Proposals, queried or published, are dropped rather than waited on when the link to the monitor is full: a check
# keeps its timeout (and returns its fail-safe) however stuck the monitor. Zenoh's default for queries, BLOCK, waited
# for room: 5 s (its wait before closing the link) for a check of 50 ms, once a monitor stopped reading. The monitor's
# reply takes its query's.
CONGESTION = zenoh.CongestionControl.DROP
CLOSED = "not sent: this Monitor is closed"
# Each reply as it comes, for check to take the first: zenoh's default consolidation, for a key without time
# selectors, kept the latest reply and handed it over only once every answerer had replied, so a check served by two
# monitors waited for the slower one (or its whole timeout) and took its verdict.
FIRST_REPLY = zenoh.ConsolidationMode.NONE


def check_timeout(timeout) -> float:
    """A wait zenoh and threading can take: finite, positive and bounded (inf or 1e12 overflow them)."""
    check_number("timeout", timeout, 0, TIMEOUT_MAX_S, unit=" s", above=True)
    return float(timeout)


class Monitor:
    """A connection to the monitor(s) serving one vehicle.

    Connects to `connect` (an endpoint or a list of them; default tcp/127.0.0.1:7447) or as the zenoh `config_file`
    says; `mode` is peer unless given or set in the file. Raises ValueError for an endpoint zenoh cannot take.
    style="query": `check` queries ``discern/<vehicle>/check`` and takes the first reply.
    style="pubsub": `check` publishes on ``discern/<vehicle>/proposal`` and waits for the
    verdict of that frame on ``discern/<vehicle>/verdict``. `publish` sends without waiting.
    In either style `on_verdict` sees every monitor verdict of the vehicle once: the replies
    to `check` and the verdicts on ``discern/<vehicle>/verdict``; not the fail-safes the client makes up
    when no verdict comes. It is called on a thread of its own, in the order the verdicts came, so that
    `check` waits for no callback; `close` returns once it has seen those that came before. An exception
    it raises is logged with its traceback and changes nothing.
    """

    def __init__(
        self,
        vehicle: str = "ego",
        *,
        connect: Union[str, Iterable[str], None] = None,
        mode: Optional[str] = None,
        config_file: Optional[Union[str, Path]] = None,
        style: str = "query",
        timeout: float = 0.1,
        on_verdict: Optional[Callable[[Verdict], None]] = None,
    ):
        if not valid_id(vehicle):
            raise ValueError(f"vehicle {vehicle!r} must match {ID_RULE}")
        if style not in STYLES:
            raise ValueError(f"style {style!r} is not one of {', '.join(STYLES)}")
        self.vehicle = vehicle
        self.style = style
        self.timeout = check_timeout(timeout)
        self._on_verdict = on_verdict
        if connect is None and config_file is None:
            connect = [DEFAULT_ENDPOINT]
        elif isinstance(connect, str):  # one endpoint: iterated, its letters were taken for endpoints ('t', 'c', ...)
            connect = [connect]
        settings = ZenohSettings(  # explicit arguments override the config file; a planner need not listen
            mode=mode,
            connect=list(connect) if connect is not None else None,
            config_file=Path(config_file) if config_file else None,
        )
        zenoh_config = settings.to_zenoh()
        self._tls = uses_tls(zenoh_config)
        try:
            self.session = zenoh.open(zenoh_config)
        except zenoh.ZError as exc:  # an unknown protocol, or no router to be had in client mode
            where = ", ".join(connect) if connect else f"the endpoints of {config_file}"
            raise ValueError(f"cannot connect to {where}: {without_rust_locations(str(exc))}") from None
        self._declared: list = []  # what the session declares, undeclared before it closes
        self._entities = threading.Lock()  # held to use the publisher or querier, and to undeclare them: see _put
        self._callbacks = CallbackThread(f"on_verdict {vehicle}") if on_verdict is not None else None
        # Closes the session on close(), when the Monitor is collected unclosed, or at exit (an unclosed zenoh session
        # can hang interpreter exit); it holds no reference to the Monitor, so that a dropped one is collected.
        key = next(_KEYS)
        self._finalizer = _OPEN[key] = weakref.finalize(
            self, _close_session, self.session, self._declared, self._entities, self._callbacks, key)
        self._waiting: dict[int, list] = {}  # frame_id -> [event, verdict]
        self._unreadable: Optional[tuple[float, str]] = None  # when the last unreadable verdict came, and why
        self._lock = threading.Lock()
        self._publisher = self.session.declare_publisher(keys.proposal_key(vehicle), encoding=JSON,
                                                         congestion_control=CONGESTION)
        self._querier = self.session.declare_querier(keys.check_key(vehicle))
        self._subscriber = None
        if style == "pubsub" or on_verdict is not None:
            self._subscriber = self.session.declare_subscriber(keys.verdict_key(vehicle), _weakly(self._on_sample))
        self._declared.extend(e for e in (self._subscriber, self._querier, self._publisher) if e is not None)

    def check(
        self,
        scene: Union[Scene, dict],
        action: Union[Action, str],
        *,
        timeout: Optional[float] = None,
        explain: bool = False,
    ) -> Verdict:
        """The monitor's verdict on doing `action` in `scene`; a fail-safe one if none arrives in time.

        An invalid proposal is sent all the same: the monitor refuses it by name, counts it and logs it. Should the
        monitor answer it with another fail-safe (its deadline, before it read it), the verdict is the refusal made
        here: a fail-safe brake naming the problem, then the monitor's reason.
        Only one that cannot even be sent, a bad `timeout` or a closed Monitor gets a fail-safe made here, unasked.
        """
        try:
            proposal, payload, problem = self._encode(scene, action, explain)
        except ValueError as exc:
            return failsafe_verdict(self.vehicle, str(exc), RULE_BAD_INPUT)
        if proposal is not None:
            labels = dict(frame_id=proposal.scene.frame_id, proposed=proposal.action, timestamp=proposal.scene.timestamp)
        else:  # what a glance at the payload gives, so that a fail-safe still names its frame
            frame_id, proposed = peek_frame(payload)
            labels = dict(frame_id=frame_id, proposed=proposed)
        try:
            timeout = self.timeout if timeout is None else check_timeout(timeout)
        except ValueError as exc:
            return failsafe_verdict(self.vehicle, f"not sent: {exc}", RULE_NO_ANSWER, **labels)
        if self._closed:
            return failsafe_verdict(self.vehicle, CLOSED, RULE_NO_ANSWER, **labels)
        try:
            if self.style == "query":
                verdict = self._query(payload, timeout, labels["frame_id"])
            else:
                verdict = self._publish_and_wait(payload, labels["frame_id"], timeout)
        except zenoh.ZError as exc:
            verdict = CLOSED if self._closed else f"not sent: {exc}"  # closed meanwhile, from another thread
        if self.style == "query" and isinstance(verdict, Verdict):
            self._notify(verdict)  # a reply is not published: pubsub's verdicts reach it in _on_sample
        if isinstance(verdict, Verdict):
            if problem is not None and verdict.failsafe and RULE_BAD_INPUT not in verdict.rules:
                # answered before it was read (its deadline) or not judged at all: the refusal owed comes first
                reason = f"{problem}; and the monitor answered with a {', '.join(verdict.rules)} fail-safe: {verdict.error}"
                return failsafe_verdict(self.vehicle, reason, RULE_BAD_INPUT, **labels)
            return verdict
        if problem is not None:  # the monitor would have refused it: say why first
            return failsafe_verdict(self.vehicle, f"{problem}; and {verdict}", RULE_BAD_INPUT, **labels)
        return failsafe_verdict(self.vehicle, verdict, RULE_NO_ANSWER, **labels)

    def publish(self, scene: Union[Scene, dict], action: Union[Action, str], *, explain: bool = False) -> None:
        """Send a proposal without waiting; its verdict (a refusal, if it is invalid) goes to `on_verdict`.

        Raises ValueError only for one that cannot be written as JSON at all, and once the Monitor is closed
        (with the error `check` then puts in its fail-safe): never zenoh's own error.
        """
        if not self._put(self._encode(scene, action, explain)[1]):
            raise ValueError(CLOSED)

    def wait_for_monitor(self, timeout: float = 2.0) -> bool:
        """True once a monitor serving this vehicle answers; for a planner's start-up check. False once closed.
        Raises ValueError for a `timeout` `check` would refuse (NaN and inf waited for good).

        Once zenoh knows of a monitor for the vehicle's key, a probe is sent on the vehicle's check key (keys.PROBE:
        answered, not judged): a monitor declares its key to planners whose proposals its access control then refuses
        (car_1's certificate asking about car_2), so a known route alone said True, and every check failed.
        """
        deadline = time.monotonic() + check_timeout(timeout)
        entity = self._querier if self.style == "query" else self._publisher
        try:
            while not (self._matching(entity) and self._probe(deadline - time.monotonic())):
                if self._closed or time.monotonic() >= deadline:
                    return False
                time.sleep(0.02)
        except zenoh.ZError:  # the session closed under the probe, from another thread
            return False
        return True

    @property
    def _closed(self) -> bool:
        """Whether the session is closed or closing: by close(), or as the Monitor was collected, or at exit."""
        return not self._finalizer.alive

    def close(self) -> None:
        """Undeclare and close the zenoh session, once, whatever other threads are doing with this Monitor (a Monitor
        dropped unclosed is closed when collected)."""
        self._finalizer()

    def __enter__(self) -> "Monitor":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- internals -------------------------------------------------------------

    def _encode(
        self, scene: Union[Scene, dict], action: Union[Action, str], explain: bool
    ) -> tuple[Optional[Proposal], bytes, Optional[str]]:
        """The proposal, its JSON, and why it is invalid (proposal None); ValueError if it cannot be JSON.

        The JSON is checked as the monitor reads it (JSON_AS_SCHEMA): a dict's "25" for a speed is sent
        as it is and refused by name, never converted here into a valid proposal the planner did not write.
        """
        if isinstance(scene, Scene):
            if isinstance(explain, bool):
                try:  # typed already, but a field set after the scene was built went unchecked: read back as sent
                    proposal = Proposal(vehicle=self.vehicle, action=action, scene=scene, explain=explain)
                    payload = encode(proposal)
                    Proposal.model_validate_json(payload, **JSON_AS_SCHEMA)
                    return proposal, payload, None
                except ValidationError:
                    pass  # an unknown action or a bad field: sent as a dict's would be, below, and refused by name
            scene = scene.model_dump(by_alias=True)  # its JSON dump writes a NaN as null, refused as "got None"
        data = dict(version=SCHEMA_VERSION, vehicle=self.vehicle, action=action, scene=scene, explain=explain)
        try:
            text = json.dumps(data, default=_numpy_value)
        except (TypeError, ValueError, RecursionError) as exc:  # a dict nested past the encoder's depth too
            try:  # name the field that holds it, where the schema can
                Proposal(vehicle=self.vehicle, action=action, scene=scene, explain=explain)
                problem = ""
            except ValidationError as invalid:
                problem = f"schema violation: {describe_validation_error(invalid)}; "
            raise ValueError(f"{problem}not sent: it cannot be written as JSON: {exc}") from None
        try:
            return Proposal.model_validate_json(text, **JSON_AS_SCHEMA), text.encode(), None
        except ValidationError as exc:
            return None, text.encode(), str(invalid_proposal(exc, text.encode()))

    def _query(self, payload: bytes, timeout: float, frame: Optional[int]) -> Union[Verdict, str]:
        """The first verdict on this proposal, whose frame is `frame` (None: unreadable), else why none came.

        A reply about another vehicle or frame (a misrouted or misbehaving answerer) is no verdict on this
        proposal: acting on it would act on another frame's judgement.
        """
        key = keys.check_key(self.vehicle)
        started = time.monotonic()
        replies = self.session.get(key, payload=payload, encoding=JSON, timeout=timeout, congestion_control=CONGESTION,
                                   consolidation=FIRST_REPLY)
        problem = None
        timed_out = False
        try:
            for reply in replies:
                if reply.ok is None:
                    error = reply.err.payload.to_string()
                    if error == ZENOH_TIMEOUT:  # zenoh's own reply when `timeout` expires: no answer
                        timed_out = True
                    else:
                        problem = f"the monitor replied with an error: {error[:200]}"
                    continue
                try:
                    verdict = decode_verdict(reply.ok.payload.to_bytes())
                except ValidationError as exc:
                    problem = f"unreadable verdict from the monitor: {describe_validation_error(exc)}"
                    continue
                if verdict.vehicle == self.vehicle and _about(verdict, frame):
                    return verdict
                problem = (f"the monitor's reply is about vehicle {verdict.vehicle!r} frame {verdict.frame_id},"
                           f" not this proposal (vehicle {self.vehicle!r} frame {frame})")
        except zenoh.ZError as exc:  # the session closing under the query: its own words, not a guess
            problem = problem or f"the zenoh query failed: {str(exc).splitlines()[0] if str(exc) else exc!r}"
        if problem is not None:
            return problem
        if timed_out or time.monotonic() - started >= timeout:
            return _too_late(key, timeout)
        return self._unserved(key)  # zenoh ends a query at once when nothing on its route serves the key

    def _publish_and_wait(self, payload: bytes, frame: Optional[int], timeout: float) -> Union[Verdict, str]:
        """The verdict of this frame (None: of a payload whose frame id cannot be read), else why none came."""
        slot = [threading.Event(), None]
        started = time.monotonic()
        with self._lock:
            self._waiting[frame] = slot
        try:
            if not self._put(payload):
                return CLOSED
            slot[0].wait(timeout)
        finally:
            with self._lock:
                self._waiting.pop(frame, None)
        if slot[1] is not None:
            return slot[1]
        with self._lock:
            unreadable = self._unreadable
        if unreadable is not None and unreadable[0] >= started:
            return f"unreadable verdict from the monitor: {unreadable[1]}"
        if self._closed:
            return CLOSED
        key = keys.proposal_key(self.vehicle)
        return _too_late(key, timeout) if self._matching(self._publisher) else self._unserved(key)

    def _put(self, payload: bytes) -> bool:
        """Publish a proposal; False, unsent, once closed. Under the lock close() undeclares the publisher with:
        pyo3 refused to undeclare it while another thread's put held it ("Already borrowed"), and close() raised,
        leaving the session open and the publisher putting."""
        with self._entities:
            if self._closed:
                return False
            self._publisher.put(payload)
            return True

    def _matching(self, entity) -> bool:
        """Whether zenoh knows of a monitor for the publisher's or querier's key; False once closed (see _put)."""
        with self._entities:
            return not self._closed and entity.matching_status.matching

    def _probe(self, timeout: float) -> bool:
        """Whether a monitor answers a probe for this vehicle within `timeout` (one refused by access control never
        does: the query then takes the whole of it)."""
        replies = self.session.get(f"{keys.check_key(self.vehicle)}?{keys.PROBE}", timeout=max(0.05, timeout),
                                   congestion_control=CONGESTION, consolidation=FIRST_REPLY)
        return any(reply.ok is not None for reply in replies)

    def _unserved(self, key: str) -> str:
        """Why no verdict came, where zenoh knew of no monitor for the key. A refused TLS handshake or an access
        rule denying the vehicle looks just like that, and is said to be possible where it is: in a session with
        TLS configured, or linked to nothing at all."""
        reason = f"no monitor answered on {key}: none that serves vehicle {self.vehicle!r} is reachable"
        info = self.session.info
        if not (list(info.peers_zid()) or list(info.routers_zid())):
            return (f"{reason}; this session is linked to no peer or router: nothing listens at its endpoints, or, "
                    "where TLS or access control is configured, its certificate is refused")
        if self._tls:
            return (f"{reason}; where TLS or access control is configured, the certificate or the access rules may be "
                    "refusing this vehicle's proposals")
        return reason

    def _on_sample(self, sample: zenoh.Sample) -> None:
        try:
            verdict = decode_verdict(sample.payload.to_bytes())
        except ValidationError as exc:
            # which frame it answers cannot be told: a wait that gets no verdict reports it, as a query does
            reason = describe_validation_error(exc)
            log.warning("ignored an unreadable verdict on %s: %s", sample.key_expr, reason)
            with self._lock:
                self._unreadable = (time.monotonic(), reason)
            return
        if verdict.vehicle != self.vehicle:  # on this vehicle's key, but about another: no verdict of its frames
            log.warning("ignored a verdict about vehicle %r on %s", verdict.vehicle, sample.key_expr)
            return
        with self._lock:
            # A verdict naming no frame (a refusal of a payload with no frame id to read) is only for a wait
            # whose payload had none either: another frame's late refusal must not pass for its verdict.
            slot = self._waiting.get(verdict.frame_id)
        if slot is not None:
            slot[1] = verdict
            slot[0].set()
        self._notify(verdict)

    def _notify(self, verdict: Verdict) -> None:
        """Hand a verdict to `on_verdict`, on its own thread."""
        if self._callbacks is not None:
            self._callbacks.put(functools.partial(_call_on_verdict, self._on_verdict, verdict))


_OPEN: dict[int, weakref.finalize] = {}  # the finalizers of the Monitors not closed yet, by key
_KEYS = itertools.count()


def _close_unclosed() -> None:
    """Close the Monitors still open as the interpreter exits, before it waits for its threads: zenoh runs a
    subscriber's Python callback on a thread of its own that is not a daemon, so waiting for it first hung the
    exit of a planner that never closed its Monitor, and atexit's hooks, run after that wait, came too late."""
    for finalizer in list(_OPEN.values()):
        finalizer()


threading._register_atexit(_close_unclosed)  # the hook concurrent.futures uses for the same reason


def _close_session(
    session: zenoh.Session, declared: list, entities: threading.Lock, callbacks: Optional[CallbackThread], key: int
) -> None:
    """Undeclare what the session declared, then close it, and end the on_verdict thread. A session closed with its
    publisher, querier or subscriber still declared kept a shared-memory mapping (/dev/shm) open: one file descriptor
    per Monitor. The thread ends outside the `entities` lock: a callback that publishes takes it."""
    _OPEN.pop(key, None)
    with entities:
        for entity in declared:
            try:
                entity.undeclare()
            except zenoh.ZError:  # already gone with the session
                pass
        try:
            session.close()
        except zenoh.ZError:
            pass
    if callbacks is not None:
        callbacks.stop()


def _call_on_verdict(on_verdict: Callable[[Verdict], None], verdict: Verdict) -> None:
    """A bug in the planner's callback must not cost it the verdict: raised out of `check`, it lost the override it
    had come with."""
    try:
        on_verdict(verdict)
    except Exception:
        log.exception("on_verdict raised on the verdict of vehicle %r frame %s", verdict.vehicle, verdict.frame_id)


def _weakly(method: Callable) -> Callable:
    """A zenoh callback that does not keep its method's Monitor alive: zenoh holds a subscriber's callback until it
    is undeclared, and a Monitor dropped unclosed was never collected, its session never closed."""
    ref = weakref.WeakMethod(method)

    def call(*args) -> None:
        bound = ref()
        if bound is not None:
            bound(*args)

    return call


def _about(verdict: Verdict, frame: Optional[int]) -> bool:
    """Whether a reply to a query answers its proposal: the same frame, or a refusal naming no frame (of a payload
    whose frame id the monitor could not read: cut, too large). A verdict naming no frame is no approval of a
    proposal whose frame is known."""
    return verdict.frame_id == frame or (verdict.frame_id is None and (frame is None or verdict.error is not None))


def _numpy_value(value):
    """A numpy scalar or array, which a planner's scene dict may well hold, as the JSON of its Python value."""
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"Object of type {type(value).__name__} is not JSON serializable")


def _too_late(key: str, timeout: float) -> str:
    return f"no verdict from a monitor on {key} within {timeout * 1000:g} ms"
