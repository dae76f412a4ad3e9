"""Log records paired into frames: one proposal and the verdict it got.

The monitor logs a proposal and its verdict on two channels
(`/discern/<vehicle>/proposal` and `.../verdict`) when the verdict is sent, so
the pair is matched here by vehicle and frame id. A proposal refused before it
parsed has no proposal record: its frame carries the verdict alone.

The inputs the monitor refused (its status's `errors`) are counted per vehicle:
each payload that was no proposal by its record on `.../rejected`, and each
proposal refused for its frame order (a duplicate frame id, a frame out of
order), which parsed and is logged on `.../proposal`, by its `monitor.bad_input`
verdict.

Files continue one another only when one monitor process wrote them in turn:
the same monitor and run in their `discern` metadata, wherever they lie and
whatever they are called, and the index one up (runs.py; older logs, whose
metadata names no run, by their names: same directory, monitor id and run,
not two processes in their metadata). A restarted monitor starts a sequence
of its own, so no pair, no history and no odometry carries across a restart;
nor across a file missing from a run.

A task reads a stretch of consecutive files of one sequence (that is what runs
in parallel), pairing across their rotations. The files before the stretch are
read first, back from the nearest until they cover the history window plus a
slack far longer than any decision takes: a lead-in, so that a pair cut by a
rotation still meets and the replay gets the same history window the monitor
had, however short the files. Only that span of the lead-in is decoded.
"""

from __future__ import annotations

from collections import Counter, deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterator, Optional

from discern.monitor.log import LogRecord, RecoveryReport, first_log_time_ns, log_files, read_log
from discern.monitor.protocol import RULE_BAD_INPUT, InputError
from discern.monitor.vehicle_state import VehicleState
from discern.rules.scene import Proposal, Scene
from discern.rules.verdict import Verdict

from .runs import Places, continues, copies, in_order

LEAD_IN_SLACK_S = 10.0  # of the earlier files read beyond the window: a verdict is never this late
PENDING_PER_VEHICLE = 256  # proposals waiting for their verdict; more means the log lost verdicts


@dataclass
class Frame:
    file: str
    log_time_ns: int  # when the verdict was logged
    vehicle: str
    verdict: Verdict
    proposal: Optional[Proposal] = None  # None when the payload was refused before it parsed
    arrived_ns: Optional[int] = None  # log time of the proposal: when it reached the monitor
    history: Optional[tuple[Scene, ...]] = None  # the monitor's window, when rebuilt; None if it refused the frame
    lead_in: bool = False  # from the earlier files: context for the task's frames, not one of them


@dataclass
class FrameTask:
    """Consecutive files of one sequence to read, with the earlier files of it that lead in (in order)."""

    paths: tuple[str, ...]
    lead_in: tuple[str, ...] = ()
    audited_lead_in: tuple[str, ...] = ()  # the lead-in files audited too: their own tasks counted their leftovers


@dataclass
class PairingCounts:
    records: int = 0
    proposals: int = 0
    verdicts: int = 0
    refused_by_vehicle: Counter = field(default_factory=Counter)  # the inputs the monitor refused, per vehicle
    status: int = 0
    unanswered: int = 0  # proposals left without a verdict at the end of their file
    carried: int = 0  # verdicts paired with a proposal an audited lead-in file counted: not unanswered after all
    # per file, its last status record's (log time, log_files_opened, log_dropped): what its monitor lost (runs.py)
    last_status: dict[str, tuple[int, int, int]] = field(default_factory=dict)

    def merge(self, other: "PairingCounts") -> None:
        for name in self.__dataclass_fields__:
            if name != "last_status":
                setattr(self, name, getattr(self, name) + getattr(other, name))
        for path, mark in other.last_status.items():
            self.last_status[path] = max(mark, self.last_status.get(path, mark))

    @property
    def refused(self) -> int:
        return sum(self.refused_by_vehicle.values())


class Pairing:
    """Matches each verdict with its vehicle's proposal of the same frame id, in log order.

    With `window_s`, it also rebuilds each frame's history the way the monitor
    did, with the monitor's own VehicleState, timed by the proposal's arrival.
    """

    def __init__(
        self,
        window_s: Optional[float] = None,
        lead_in: tuple[str, ...] = (),
        counted: Optional[Callable[[Optional[str], int], bool]] = None,
        audited_lead_in: tuple[str, ...] = (),
    ):
        """`lead_in`: the files read for context only, whose leftover proposals are not this task's to count;
        `audited_lead_in`, those of them the audit reads as its own files too, whose tasks counted them.

        `counted(vehicle, log_time_ns)`: the refusals and unanswered proposals counted, as the audit's
        vehicle and time filters count frames (default: all).
        """
        self.window_s = window_s
        self.lead_in = frozenset(lead_in)
        self.audited_lead_in = frozenset(audited_lead_in)
        self.counted = counted or (lambda vehicle, log_time_ns: True)
        self.pending: dict[str, deque[LogRecord]] = {}
        self.states: dict[str, VehicleState] = {}
        self.counts = PairingCounts()

    def feed(self, record: LogRecord) -> Optional[Frame]:
        self.counts.records += 1
        kind = record.kind
        if kind == "proposal":
            self.counts.proposals += 1
            queue = self.pending.setdefault(record.vehicle, deque())
            if len(queue) >= PENDING_PER_VEHICLE:
                self.counts.unanswered += self._unanswered(queue.popleft())
            queue.append(record)
            return None
        if kind == "verdict":
            self.counts.verdicts += 1
            return self._frame(record)
        if kind == "rejected":
            self._refused(record)
        elif kind == "status":
            self.counts.status += 1
            path, status = str(record.path), record.status
            mark = (record.log_time_ns, status.log_files_opened, status.log_dropped)
            self.counts.last_status[path] = max(mark, self.counts.last_status.get(path, mark))
        return None

    def finish(self) -> None:
        """Count the proposals left without a verdict (the lead-in's were counted with their own task)."""
        self.counts.unanswered += sum(self._unanswered(r) for q in self.pending.values() for r in q)
        self.pending.clear()

    def _counts(self, record: LogRecord) -> bool:
        return self.counted(record.vehicle, record.log_time_ns)

    def _refused(self, record: LogRecord) -> None:
        if self._counts(record):
            self.counts.refused_by_vehicle[record.vehicle] += 1

    def _unanswered(self, proposal: LogRecord) -> bool:
        """Whether a proposal given up on counts here: not one of the lead-in's, its own task's to count (no task's,
        where that file is not audited)."""
        return str(proposal.path) not in self.lead_in and self._counts(proposal)

    def _frame(self, record: LogRecord) -> Frame:
        verdict = record.verdict
        vehicle = record.vehicle or verdict.vehicle
        proposal_record = self._take(vehicle, verdict.frame_id)
        frame = Frame(file=str(record.path), log_time_ns=record.log_time_ns, vehicle=vehicle, verdict=verdict)
        if proposal_record is not None:
            if str(proposal_record.path) in self.audited_lead_in:  # counted unanswered by its own task: not so
                self.counts.carried += self._counts(proposal_record)
            frame.proposal = proposal_record.proposal
            frame.arrived_ns = proposal_record.log_time_ns
            if RULE_BAD_INPUT in verdict.rules:  # refused for its frame order: no record on .../rejected says so
                self._refused(record)
            if self.window_s is not None:
                frame.history = self._admit(vehicle, frame.proposal.scene, proposal_record.log_time_ns)
        return frame

    def _take(self, vehicle: str, frame_id: Optional[int]) -> Optional[LogRecord]:
        queue = self.pending.get(vehicle)
        if not queue or frame_id is None:
            return None
        for i in range(len(queue) - 1, -1, -1):
            if queue[i].proposal.scene.frame_id == frame_id:
                found = queue[i]
                del queue[i]
                return found
        return None

    def _admit(self, vehicle: str, scene: Scene, arrived_ns: int) -> Optional[tuple[Scene, ...]]:
        state = self.states.get(vehicle)
        if state is None:
            state = self.states[vehicle] = VehicleState(self.window_s)
        try:
            return state.admit(scene, arrived_ns / 1e9)
        except InputError:  # the monitor refused this frame too (duplicate or out of order)
            return None


def plan_tasks(paths: list[str], parts: int = 1, lead_in_s: float = LEAD_IN_SLACK_S) -> list[FrameTask]:
    """Each sequence of one monitor process's files cut into at most `parts` tasks of consecutive files,
    even in bytes.

    A task's lead-in is the files before its first one in the sequence, back from the nearest, as
    many as it takes to reach `lead_in_s` seconds before the task's first message; for the first task,
    the files its monitor run wrote just before the first one given, where they lie beside it: a rotated
    file audited alone still has the history its frames were decided with. Fewer, longer tasks read
    fewer lead-ins. A run's file given twice (a copy elsewhere) is read where it is first given.
    """
    tasks = []
    places = Places()
    given = [str(p) for p in log_files(paths)]
    twice = {copy for copy, _, _ in copies(given, places)}
    given = [p for p in given if p not in twice]
    audited = set(given)
    for sequence in _sequences(given, places):
        before = _earlier_in_run(sequence[0], places)
        for stretch in _even_runs(sequence, parts):
            lead_in = _lead_in(before, stretch, lead_in_s)
            tasks.append(FrameTask(tuple(stretch), lead_in, tuple(f for f in lead_in if f in audited)))
            before = before + stretch
    return tasks


def _earlier_in_run(first: str, places: Places) -> list[str]:
    """The files the same monitor run wrote right before `first`, in its directory, oldest first (none for a file
    whose index is not known: an older log named without a run, a renamed one whose metadata has none)."""
    place = places(first)
    if place is None or place.run is None or place.index is None:
        return []
    siblings: dict[int, str] = {}
    try:
        entries = sorted(Path(first).parent.iterdir())
    except OSError:
        return []
    for entry in entries:
        other = places(str(entry)) if entry.name.endswith(".mcap") else None
        if other is not None and other.run_key == place.run_key and other.index is not None:
            siblings.setdefault(other.index, str(entry))
    index = place.index
    earlier: list[str] = []
    while index - 1 in siblings:  # back to the first gap
        index -= 1
        earlier.insert(0, siblings[index])
    return earlier


def _sequences(files: list[str], places: Places) -> list[list[str]]:
    """The files cut into sequences, each in the order its monitor wrote them, whatever order they were given in
    and whatever they are called.

    A monitor run's files are gathered by the run their metadata names and taken in its order (runs.in_order:
    `audit f2 f1` pairs, counts and replays as `audit f1 f2` does), cut where a file is missing. The
    sequences come in the order their first file was given.
    """
    runs: dict[tuple, list[str]] = {}  # run -> its files; a file of no known run alone
    for path in files:
        place = places(path)
        runs.setdefault(place.run_key if place is not None else (path,), []).append(path)
    sequences: list[list[str]] = []
    for run in runs.values():
        start = len(sequences)
        for path in in_order(run, places) if len(run) > 1 else run:
            if len(sequences) > start and continues(places(sequences[-1][-1]), places(path)):
                sequences[-1].append(path)
            else:
                sequences.append([path])
    return sequences


def _lead_in(before: list[str], stretch: list[str], seconds: float) -> tuple[str, ...]:
    """The files of `before` from the last one back to the first that starts `seconds` before the stretch does."""
    if not before:
        return ()
    start = _first_time(stretch)
    if start is None:  # the stretch holds no message: nothing to lead into
        return ()
    reach = start - int(seconds * 1e9)
    first = len(before) - 1
    while first > 0:
        t = first_log_time_ns(before[first])
        if t is not None and t <= reach:
            break
        first -= 1
    return tuple(before[first:])


def _first_time(files) -> Optional[int]:
    """Log time of the first message of these files."""
    return next((t for t in map(first_log_time_ns, files) if t is not None), None)


def _even_runs(files: list[str], parts: int) -> list[list[str]]:
    """Consecutive files cut into at most `parts` runs of about equal size."""
    sizes = [_size(f) for f in files]
    share = max(1, sum(sizes)) / max(1, min(parts, len(files)))
    runs: list[list[str]] = [[]]
    done = 0
    for path, size in zip(files, sizes):
        if runs[-1] and done >= share * len(runs):
            runs.append([])
        runs[-1].append(path)
        done += size
    return runs


def _size(path: str) -> int:
    try:
        return Path(path).stat().st_size
    except OSError:  # missing: read_log reports it
        return 0


def read_frames(
    task: FrameTask,
    report: RecoveryReport,
    window_s: Optional[float] = None,
    keep: Optional[Callable[[Optional[str]], bool]] = None,
    counted: Optional[Callable[[Optional[str], int], bool]] = None,
) -> tuple[Iterator[Frame], Pairing]:
    """The lead-in's frames (flagged), then those whose verdict is in the task's files.

    `keep(vehicle)` picks the vehicles whose records are read (None: the
    monitor-wide ones); the others are skipped undecoded and not counted.
    `counted` picks the refusals and unanswered proposals counted (Pairing).
    The Pairing holds the task's counts once iteration ends.
    """
    pairing = Pairing(window_s, task.lead_in, counted, task.audited_lead_in)

    def frames() -> Iterator[Frame]:
        if task.lead_in:
            start = _first_time(task.paths)
            since = None if start is None else start - int(((window_s or 0.0) + LEAD_IN_SLACK_S) * 1e9)
            for record in read_log(task.lead_in, RecoveryReport(), since_ns=since, vehicles=keep):
                frame = pairing.feed(record)
                if frame is not None:
                    frame.lead_in = True
                    yield frame
            pairing.counts = PairingCounts()
        for record in read_log(task.paths, report, vehicles=keep):
            frame = pairing.feed(record)
            if frame is not None:
                yield frame
        pairing.finish()

    return frames(), pairing
