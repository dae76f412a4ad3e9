"""What the monitor remembers per vehicle between frames.

The sanity layer reasons over time (a car that vanished, a speed that jumped),
so each vehicle keeps a short window of its recent scenes; frame ids must rise
so the window is never fed a stale or replayed frame. The window lives in the
vehicle's decision worker; the permitted-action memory in the monitor process.
"""

from __future__ import annotations

from collections import deque
from typing import Optional

from discern.rules.scene import Action, Scene

from .protocol import InputError

MAX_FRAMES = 256  # bounds memory whatever the frame rate
PERMITTED_MEMORY_S = 0.5  # how long a verdict's permitted set may guide a fail-safe


class VehicleState:
    def __init__(self, window_s: float):
        self.window_s = window_s
        self.frames: deque[tuple[float, Scene]] = deque(maxlen=MAX_FRAMES)
        self.last_frame_id: Optional[int] = None
        self.last_arrival = float("-inf")

    def admit(self, scene: Scene, now: float) -> tuple[Scene, ...]:
        """Check the frame id, return the history (oldest first) and remember the scene.

        A vehicle silent for longer than the window starts afresh, so a planner
        that restarts with frame 0 is accepted again after the window.
        """
        if now - self.last_arrival > self.window_s:
            self.frames.clear()
            self.last_frame_id = None
        last = self.last_frame_id
        if last is not None and scene.frame_id <= last:
            what = "duplicate" if scene.frame_id == last else "out-of-order"
            raise InputError(
                f"frame_id: {what} frame {scene.frame_id}, the last frame judged for this vehicle was {last}",
                "order",
            )
        self._evict(scene, now)
        history = tuple(s for _, s in self.frames)
        self.frames.append((now, scene))
        self.last_frame_id = scene.frame_id
        self.last_arrival = now
        return history

    def _evict(self, scene: Scene, now: float) -> None:
        frames = self.frames
        if scene.timestamp > 0:
            # Scene time when the planner gives it: a simulation may run faster than the wall clock.
            if frames and frames[-1][1].timestamp > scene.timestamp:
                frames.clear()  # the clock went back: a new episode
            oldest = scene.timestamp - self.window_s
            while frames and not (oldest <= frames[0][1].timestamp <= scene.timestamp):
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
