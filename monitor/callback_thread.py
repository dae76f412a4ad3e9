"""A planner's callback run on a thread of its own, so that however slow it is, it holds up no verdict.

Run on zenoh's subscriber thread, a slow `on_verdict` held up the verdicts behind it, and a `check` over
publish/subscribe waiting for one of them missed it; run in a queried `check`, it made the check overrun its
timeout. One thread fed in arrival order keeps the calls in that order, one at a time, as they were.
"""

from __future__ import annotations

import queue
import threading
from typing import Callable, Optional

_STOP = object()


class CallbackThread:
    """Makes the calls put to it, in order, on one thread started at the first.

    It holds a call only until it is made: what closes a Monitor holds this, and a callback held for good that
    refers back to its Monitor (a planner's method) kept a dropped Monitor from being collected and closed.
    """

    def __init__(self, name: str):
        self._name = name
        self._queue: queue.SimpleQueue = queue.SimpleQueue()
        self._lock = threading.Lock()
        self._thread: Optional[threading.Thread] = None
        self._stopped = False

    def put(self, call: Callable[[], None]) -> None:
        """Queue a call; ignored once stopped."""
        with self._lock:
            if self._stopped:
                return
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name=self._name, daemon=True)
                self._thread.start()
            self._queue.put(call)

    def stop(self) -> None:
        """Make the calls already queued, then end the thread. Waits for them, so that none comes after, unless
        called from a call itself (a callback closing its Monitor), which cannot wait for its own end."""
        with self._lock:
            self._stopped = True
            thread = self._thread
            if thread is not None:
                self._queue.put(_STOP)
        if thread is not None and thread is not threading.current_thread():
            thread.join()

    def _run(self) -> None:
        while (call := self._queue.get()) is not _STOP:
            call()
