"""Planner side: wire Discern into an ML planner in a few lines.

    from discern.monitor.client import Monitor
    with Monitor(vehicle="car_7") as monitor:            # connects to tcp/127.0.0.1:7447
        verdict = monitor.check(scene, "change_lane_left", timeout=0.1)
        execute(verdict.action)

`check` never raises for a missing or slow monitor: it returns a fail-safe
verdict (brake, failsafe=True, `error` saying why), exactly as the monitor
itself does, so the planner's loop has one code path.
"""

from __future__ import annotations

import atexit
import logging
import threading
import time
from pathlib import Path
from typing import Callable, Iterable, Optional, Union

import zenoh

from discern.rules.scene import Action, Proposal, Scene
from discern.rules.verdict import Verdict

from . import keys
from .config import DEFAULT_ENDPOINT, ZenohSettings
from .protocol import RULE_NO_ANSWER, decode_verdict, encode, failsafe_verdict

log = logging.getLogger(__name__)
JSON = zenoh.Encoding.APPLICATION_JSON
STYLES = ("query", "pubsub")
ZENOH_TIMEOUT = "Timeout"  # the error reply zenoh itself gives a query whose timeout expired


class Monitor:
    """A connection to the monitor(s) serving one vehicle.

    Connects to `connect` (default tcp/127.0.0.1:7447) or as the zenoh `config_file` says;
    `mode` is peer unless given or set in the file.
    style="query": `check` queries ``discern/<vehicle>/check`` and takes the first reply.
    style="pubsub": `check` publishes on ``discern/<vehicle>/proposal`` and waits for the
    verdict of that frame on ``discern/<vehicle>/verdict``. `publish` sends without waiting.
    In either style `on_verdict` sees every monitor verdict of the vehicle once: the replies
    to `check` (before `check` returns them) and the verdicts on ``discern/<vehicle>/verdict``;
    not the fail-safes the client makes up when no verdict comes.
    """

    def __init__(
        self,
        vehicle: str = "ego",
        *,
        connect: Optional[Iterable[str]] = None,
        mode: Optional[str] = None,
        config_file: Optional[Union[str, Path]] = None,
        style: str = "query",
        timeout: float = 0.1,
        on_verdict: Optional[Callable[[Verdict], None]] = None,
    ):
        if not keys.VEHICLE_PATTERN.match(vehicle):
            raise ValueError(f"vehicle {vehicle!r} must match [A-Za-z0-9_-]{{1,128}}")
        if style not in STYLES:
            raise ValueError(f"style {style!r} is not one of {', '.join(STYLES)}")
        self.vehicle = vehicle
        self.style = style
        self.timeout = timeout
        self._on_verdict = on_verdict
        if connect is None and config_file is None:
            connect = [DEFAULT_ENDPOINT]
        settings = ZenohSettings(  # explicit arguments override the config file; a planner need not listen
            mode=mode,
            connect=list(connect) if connect is not None else None,
            config_file=Path(config_file) if config_file else None,
        )
        self.session = zenoh.open(settings.to_zenoh())
        atexit.register(self.close)  # an unclosed zenoh session can hang interpreter exit
        self._closed = False
        self._waiting: dict[int, list] = {}  # frame_id -> [event, verdict]
        self._lock = threading.Lock()
        self._publisher = self.session.declare_publisher(keys.proposal_key(vehicle), encoding=JSON)
        self._querier = self.session.declare_querier(keys.check_key(vehicle))
        self._subscriber = None
        if style == "pubsub" or on_verdict is not None:
            self._subscriber = self.session.declare_subscriber(keys.verdict_key(vehicle), self._on_sample)

    def check(
        self,
        scene: Union[Scene, dict],
        action: Union[Action, str],
        *,
        timeout: Optional[float] = None,
        explain: bool = False,
    ) -> Verdict:
        """The monitor's verdict on doing `action` in `scene`; a fail-safe one if none arrives in time."""
        proposal = self._proposal(scene, action, explain)
        timeout = self.timeout if timeout is None else timeout
        if self.style == "query":
            verdict = self._query(proposal, timeout)
            if isinstance(verdict, Verdict) and self._on_verdict is not None:
                self._on_verdict(verdict)  # a reply is not published: pubsub's verdicts reach it in _on_sample
        else:
            verdict = self._publish_and_wait(proposal, timeout)
        if isinstance(verdict, Verdict):
            return verdict
        reason = verdict or f"no verdict from a monitor on {self._key()} within {timeout * 1000:g} ms"
        return failsafe_verdict(
            self.vehicle,
            reason,
            RULE_NO_ANSWER,
            proposed=proposal.action,
            frame_id=proposal.scene.frame_id,
            timestamp=proposal.scene.timestamp,
        )

    def publish(self, scene: Union[Scene, dict], action: Union[Action, str], *, explain: bool = False) -> None:
        """Send a proposal without waiting; its verdict goes to `on_verdict`."""
        self._publisher.put(encode(self._proposal(scene, action, explain)))

    def wait_for_monitor(self, timeout: float = 2.0) -> bool:
        """True once a monitor serving this vehicle is reachable; for a planner's start-up check."""
        entity = self._querier if self.style == "query" else self._publisher
        deadline = time.monotonic() + timeout
        while not entity.matching_status.matching:
            if time.monotonic() >= deadline:
                return False
            time.sleep(0.02)
        return True

    def close(self) -> None:
        if getattr(self, "_closed", True):
            return
        self._closed = True
        atexit.unregister(self.close)
        try:
            self.session.close()
        except zenoh.ZError:
            pass

    def __enter__(self) -> "Monitor":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- internals -------------------------------------------------------------

    def _key(self) -> str:
        return keys.check_key(self.vehicle) if self.style == "query" else keys.proposal_key(self.vehicle)

    def _proposal(self, scene: Union[Scene, dict], action: Union[Action, str], explain: bool) -> Proposal:
        if isinstance(scene, dict):
            scene = Scene.model_validate(scene)
        return Proposal(vehicle=self.vehicle, action=Action(action), scene=scene, explain=explain)

    def _query(self, proposal: Proposal, timeout: float) -> Union[Verdict, str, None]:
        """The first verdict that arrives, else why none did (None: nothing in time)."""
        replies = self.session.get(
            keys.check_key(self.vehicle), payload=encode(proposal), encoding=JSON, timeout=timeout
        )
        problem = None
        try:
            for reply in replies:
                if reply.ok is None:
                    error = reply.err.payload.to_string()
                    if error != ZENOH_TIMEOUT:  # zenoh's own reply when `timeout` expires: no answer
                        problem = f"the monitor replied with an error: {error[:200]}"
                    continue
                try:
                    return decode_verdict(reply.ok.payload.to_bytes())
                except ValueError as exc:
                    problem = f"unreadable verdict from the monitor: {str(exc).splitlines()[0]}"
        except zenoh.ZError:
            pass
        return problem

    def _publish_and_wait(self, proposal: Proposal, timeout: float) -> Optional[Verdict]:
        frame = proposal.scene.frame_id
        slot = [threading.Event(), None]
        with self._lock:
            self._waiting[frame] = slot
        try:
            self._publisher.put(encode(proposal))
            slot[0].wait(timeout)
            return slot[1]
        finally:
            with self._lock:
                self._waiting.pop(frame, None)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        try:
            verdict = decode_verdict(sample.payload.to_bytes())
        except ValueError:
            log.warning("ignored an unreadable verdict on %s", sample.key_expr)
            return
        with self._lock:
            slot = self._waiting.get(verdict.frame_id) if verdict.frame_id is not None else None
        if slot is not None:
            slot[1] = verdict
            slot[0].set()
        elif verdict.frame_id is None and self._waiting:
            # A refused proposal the monitor could not read a frame from: it answers the oldest wait.
            with self._lock:
                first = next(iter(self._waiting.values()), None)
            if first is not None:
                first[1] = verdict
                first[0].set()
        if self._on_verdict is not None:
            self._on_verdict(verdict)
