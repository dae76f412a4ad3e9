"""Decisions run in worker processes, so the monitor's own process never stalls.

The rules engine holds the GIL for long stretches (grounding, garbage
collection: up to ~80 ms measured on a 50-object scene). In one process that
would stall the zenoh callbacks and the deadline watchdog with it, and a
second thread would not add a core. So each worker is a process with its own
Reasoner (decision_worker.py); each vehicle always goes to the same worker,
which keeps its frame window and checks its frame order. A worker that dies is
replaced: what it had in hand is answered at once with a fail-safe, what is
queued for it goes to its replacement.
"""

from __future__ import annotations

import logging
import multiprocessing
import multiprocessing.resource_tracker
import queue
import signal
import threading
import zlib
from dataclasses import replace
from typing import Callable, Optional

from .decision_worker import STOP, Job, Outcome, WorkerSettings, worker_main
from .entry import STOP_SIGNALS

log = logging.getLogger(__name__)

START_TIMEOUT_S = 120.0
STOP_TIMEOUT_S = 10.0


class WorkerStartError(RuntimeError):
    """A decision worker that could not start: the monitor cannot decide, and says so as itself, not as zenoh."""


class DecisionPool:
    """Worker processes fed through per-worker queues; outcomes come back on `on_outcome`."""

    def __init__(
        self,
        workers: int,
        settings: WorkerSettings,
        on_outcome: Callable[[Outcome], None],
        on_worker_lost: Callable[[int, Optional[int]], None],
    ):
        self.settings = settings
        self._on_outcome = on_outcome
        self._on_worker_lost = on_worker_lost
        self._context = multiprocessing.get_context("spawn")  # never fork a process running zenoh threads
        self._queues: list[queue.SimpleQueue] = [queue.SimpleQueue() for _ in range(workers)]
        self._slots: list[Optional[_Slot]] = [None] * workers  # None: died and could not be replaced
        self._changed = threading.Condition()  # a slot was replaced or given up, or the pool is stopping
        self._stopping = False

    def start(self) -> None:
        """Start every worker and wait until each has loaded its rules; raises if one cannot."""
        slots = [_Slot.spawn(self._context, self.settings) for _ in self._queues]
        for index, slot in enumerate(slots):
            self._slots[index] = slot
            slot.wait_ready()
            self._listen(index, slot)
            threading.Thread(target=self._send, args=(index,), name=f"discern-send-{index}", daemon=True).start()

    def worker_of(self, vehicle: str) -> int:
        return zlib.crc32(vehicle.encode()) % len(self._queues)

    def submit(self, job: Job, still_open: Callable[[], bool]) -> None:
        self._queues[self.worker_of(job.vehicle)].put((job, still_open))

    def stop(self) -> None:
        with self._changed:
            self._stopping = True
            self._changed.notify_all()
        for q in self._queues:
            q.put(STOP)
        for slot in self._slots:
            if slot is not None:
                slot.stop()

    # -- per worker: a sender thread for the pool's life, a receiver thread per process ---------

    def _listen(self, index: int, slot: "_Slot") -> None:
        slot.receiver = threading.Thread(
            target=self._receive, args=(index, slot), name=f"discern-recv-{index}", daemon=True
        )
        slot.receiver.start()

    def _send(self, index: int) -> None:
        """Feed worker `index`, whichever process it is now; blocks on its pipe instead of the zenoh threads.

        The one thread that takes the worker's jobs off its queue, across replacements: a job taken
        while a dead worker is replaced waits for the replacement, never goes down with the dead one.
        A job already answered still goes, flagged: its scene belongs in the vehicle's window.
        """
        work = self._queues[index]
        while True:
            item = work.get()
            if item is STOP:
                slot = self._slots[index]
                if slot is not None:
                    _quietly(lambda: slot.conn.send(STOP))
                return
            job, still_open = item
            while True:
                slot = self._live(index)
                if slot is None:
                    self._on_outcome(_lost(job.rid, f"decision worker {index} died and was not replaced"))
                    break
                if self._hand(slot, job if still_open() else replace(job, answered=True)):
                    break

    def _live(self, index: int) -> Optional["_Slot"]:
        """Worker `index`, once replaced if it died; None if no replacement is coming (it failed, or the pool stops)."""
        with self._changed:
            self._changed.wait_for(
                lambda: self._stopping or self._slots[index] is None or not self._slots[index].lost.is_set()
            )
            slot = self._slots[index]
            return slot if slot is not None and not slot.lost.is_set() else None

    @staticmethod
    def _hand(slot: "_Slot", job: Job) -> bool:
        """Send the job to the slot's worker; False if that worker was found dead first (the job is not sent)."""
        with slot.lock:
            if slot.lost.is_set():
                return False
            slot.in_hand.add(job.rid)
        try:
            slot.conn.send(job)
        except (OSError, EOFError, ValueError):
            pass  # the worker died with the job in hand: its receiver reports it lost
        return True

    def _receive(self, index: int, slot: "_Slot") -> None:
        while True:
            try:
                outcome = slot.conn.recv()
            except (EOFError, OSError):
                break
            slot.in_hand.discard(outcome.rid)
            self._on_outcome(outcome)
        with slot.lock:
            slot.lost.set()
            lost, slot.in_hand = slot.in_hand, set()
        slot.process.join(1)
        exitcode = slot.process.exitcode
        for rid in sorted(lost):
            self._on_outcome(_lost(rid, f"decision worker {index} died (exit code {exitcode}) before deciding it"))
        if self._stopping:
            return
        self._on_worker_lost(index, exitcode)
        try:
            replacement = _Slot.spawn(self._context, self.settings)
            replacement.wait_ready()
        except Exception:
            log.exception("could not replace decision worker %d: its proposals get fail-safe verdicts", index)
            replacement = None
        with self._changed:
            stopping = self._stopping
            if not stopping:
                self._slots[index] = replacement
            self._changed.notify_all()
        if replacement is None:
            return
        if stopping:  # stop() did not see it: nothing was sent to it
            _quietly(lambda: replacement.conn.send(STOP))
            replacement.stop()
            return
        self._listen(index, replacement)


class _Slot:
    """One worker process and the main end of its pipe."""

    def __init__(self, process, conn):
        self.process = process
        self.conn = conn
        self.lost = threading.Event()
        self.lock = threading.Lock()  # between the sender adding a job and the receiver finding the worker dead
        self.in_hand: set[int] = set()  # rids sent and not answered yet
        self.receiver: Optional[threading.Thread] = None

    @classmethod
    def spawn(cls, context, settings: WorkerSettings) -> "_Slot":
        main_end, worker_end = context.Pipe()
        process = context.Process(target=worker_main, args=(worker_end, settings), name="discern-decider", daemon=True)
        # A stop signal to the whole group would kill a worker still starting, before it ignores such signals: it
        # starts with them blocked (a child inherits the mask), and this thread takes any that came meanwhile.
        # Starting the start method's resource tracker unblocks them in this thread: it goes first.
        multiprocessing.resource_tracker.ensure_running()
        mask = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
        try:
            process.start()
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        worker_end.close()
        return cls(process, main_end)

    def wait_ready(self) -> None:
        if not self.conn.poll(START_TIMEOUT_S):
            self.process.kill()
            raise WorkerStartError(f"decision worker did not start within {START_TIMEOUT_S:g} s")
        try:
            status, detail = self.conn.recv()
        except EOFError:
            self.process.join(timeout=STOP_TIMEOUT_S)  # its pipe closes before it is reaped: wait for its exit code
            raise WorkerStartError(f"decision worker exited at start (exit code {self.process.exitcode})") from None
        if status != "ready":
            raise WorkerStartError(f"decision worker could not start: {detail}")

    def stop(self) -> None:
        """Wait for the worker to finish what it was sent, and for its last outcomes to be delivered."""
        self.process.join(STOP_TIMEOUT_S)
        if self.process.is_alive():
            self.process.kill()
            self.process.join()
        if self.receiver is not None:
            self.receiver.join(STOP_TIMEOUT_S)
        self.conn.close()


def _lost(rid: int, why: str) -> Outcome:
    return Outcome(rid, no_verdict=why, lost=True, error="not read: its decision worker died first")


def _quietly(fn) -> None:
    try:
        fn()
    except Exception:
        pass
