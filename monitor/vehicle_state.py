"""What the monitor remembers per vehicle between frames.

The sanity layer reasons over time (a car that vanished, a speed that jumped),
so each vehicle keeps a short window of its recent scenes; frame ids must rise
within an episode so the window is never fed a stale or replayed frame. The
window lives in the vehicle's decision worker; the permitted-action memory in
the monitor process.

A frame counter may also start again in the middle of a drive: a 16-bit one
wraps from 65535 to 0, a restarted planner counts from 0 on the drive's clock.
A frame id that goes back while the scene time moves on, by no more than the
window, starts the count again and keeps the window's history (_counts_again).

A new episode (a restarted planner, a reset simulation) starts the window
afresh and its frame ids may start again. It is recognised by a frame that goes
back in both frame id and scene time from past the episode's first frame to
that first frame or before it: a replayed or late frame of the episode went out
after its first frame, in both id and time, so it stays refused. A frame whose
clock alone goes back is admitted with the history: the sanity window tells a
late frame, one stamped ahead of its time and a new run apart. (A replay of
the episode's very first frame cannot be told from a restart that repeats it
exactly, and is admitted.) Scene time 0 is a time like any other once the
vehicle's clock has moved past it: episodes often start at 0.0. Without scene
timestamps only a silence longer than the window starts afresh.

A vehicle silent for longer than its window would start afresh anyway, so its
state is dropped a little after that (`expired`): memory follows the vehicles
heard from lately, not every vehicle ever seen.
"""

from __future__ import annotations

from collections import deque
from typing import Optional

from discern.rules.scene import Action, Scene

from .protocol import InputError

MAX_FRAMES = 256  # bounds memory whatever the frame rate
PERMITTED_MEMORY_S = 0.5  # how long a verdict's permitted set may guide a fail-safe
# Past its window a silent vehicle starts afresh; its state is dropped this much later, once nothing in transit
# can still be one of its frames from before the silence.
EXPIRY_MARGIN_S = 1.0
EXPIRY_SWEEP_S = 1.0  # how often the monitor and its workers look for vehicles gone silent: a scan of every vehicle


class VehicleState:
    def __init__(self, window_s: float):
        self.window_s = window_s
        self.frames: deque[tuple[float, Scene]] = deque(maxlen=MAX_FRAMES)
        self.last_frame_id: Optional[int] = None
        self.last_timestamp = 0.0
        self.last_arrival = float("-inf")
        self.episode_start = (0, 0.0)  # frame id and scene time of the episode's first frame

    def admit(self, scene: Scene, now: float) -> tuple[Scene, ...]:
        """Check the frame id, return the history (oldest first) and remember the scene.

        A vehicle silent for longer than the window, or starting a new episode,
        starts afresh: its frame ids may start again.
        """
        if now - self.last_arrival > self.window_s or self._restarts(scene):
            self.frames.clear()
            self.last_frame_id = None
        elif self._counts_again(scene):
            self._renumber(self.last_frame_id + 1 - scene.frame_id)
            self.last_frame_id = None  # the order starts again from this frame, the history kept
        last = self.last_frame_id
        if last is not None and scene.frame_id <= last:
            what = "duplicate" if scene.frame_id == last else "out-of-order"
            raise InputError(
                f"frame_id: {what} frame {scene.frame_id}, the last frame received for this vehicle was {last}"
                + (self._untimed_hint() if scene.timestamp == 0 else ""),
                "order",
            )
        if last is None or scene.timestamp < self.last_timestamp:  # the clock going back is a new episode too
            self.episode_start = (scene.frame_id, scene.timestamp)
        self._evict(scene, now)
        history = tuple(s for _, s in self.frames)
        self.frames.append((now, scene))
        self.last_frame_id = scene.frame_id
        self.last_timestamp = scene.timestamp
        self.last_arrival = now
        return history

    def expired(self, now: float) -> bool:
        """Silent for so long that its next frame starts afresh whatever it is: the state can go."""
        return now - self.last_arrival > self.window_s + EXPIRY_MARGIN_S

    def _untimed_hint(self) -> str:
        """How to avoid the refusal a planner restarted without scene timestamps gets: told only that its frame 0 was
        out of order, it braked for a window without knowing why."""
        return (f" (without a scene timestamp a restarted planner cannot be told from a replay, and is refused until"
                f" it has been silent for {self.window_s:g} s: set Scene.timestamp, see docs/protocol.md"
                f" \"Per-vehicle state\")")

    def _restarts(self, scene: Scene) -> bool:
        """Does the scene begin a new episode? From past the episode's first frame back to it, in id and time.

        The episode's clock must have moved on from its first frame, so a planner without timestamps (all 0)
        never restarts this way, while one whose episodes start at 0.0 does.
        """
        first_id, first_time = self.episode_start
        return (
            self.last_frame_id is not None
            and scene.frame_id <= first_id < self.last_frame_id
            and scene.timestamp <= first_time < self.last_timestamp
        )

    def _counts_again(self, scene: Scene) -> bool:
        """Does the frame counter start again in the same drive? Its id goes back while its scene time moves on, by
        no more than the window: a counter that wrapped (65535, then 0) or a planner restarted on the drive's clock.

        A replayed or late frame goes back in time too, and stays refused, as does one without timestamps; one
        stamped more than a window ahead may be a clock glitch, as `_evict` takes it. Refused, a wrapped counter
        got fail-safes for a whole window, until the silence it made started the vehicle afresh.
        """
        return (
            self.last_frame_id is not None
            and scene.frame_id < self.last_frame_id
            and 0 < scene.timestamp - self.last_timestamp <= self.window_s
        )

    def _renumber(self, shift: int) -> None:
        """Number the frames kept `shift` lower, so that they go before the frame that starts the count again, in
        their order. The sanity window orders frames by id as well as time (WindowProvider.window): with their own
        ids it took the new count for a restart, and left the frame no history. Ids below 0 are for the window only:
        no verdict names them. Copies, as a batch in flight holds the frames themselves."""
        self.frames = deque(
            ((at, s.model_copy(update={"frame_id": s.frame_id - shift})) for at, s in self.frames), maxlen=MAX_FRAMES
        )

    def _evict(self, scene: Scene, now: float) -> None:
        """Forget frames too old to be in any window; which of the rest are this frame's past is the sanity
        window's to tell (WindowProvider.window), as it is for the scenario runner and the replay, so that a late
        frame or one odd timestamp costs the sidecar no more history than it costs them."""
        frames = self.frames
        if scene.timestamp > 0:
            # Scene time when the planner gives it: a simulation may run faster than the wall clock. A frame stamped
            # more than a window ahead of the last may be a clock glitch, and evicts nothing.
            if frames and scene.timestamp - frames[-1][1].timestamp > self.window_s:
                return
            oldest = scene.timestamp - self.window_s
            while frames and frames[0][1].timestamp < oldest:
                frames.popleft()
        else:
            while frames and frames[0][0] < now - self.window_s:
                frames.popleft()


class PermittedMemory:
    """What each vehicle's last verdict permitted, briefly: the fail-safe's menu when a decision is late."""

    def __init__(self, memory_s: float = PERMITTED_MEMORY_S):
        self.memory_s = memory_s
        self._last: dict[str, tuple[float, tuple[Action, ...]]] = {}

    def remember(self, vehicle: str, permitted: tuple[Action, ...], now: float) -> None:
        self._last[vehicle] = (now, permitted)

    def recent(self, vehicle: str, now: float) -> tuple[Action, ...]:
        at, permitted = self._last.get(vehicle, (float("-inf"), ()))
        return permitted if now - at <= self.memory_s else ()

    def forget(self, vehicle: str) -> None:
        self._last.pop(vehicle, None)
