"""Which monitor run wrote a log file, and where among the run's files it lies.

A file's `discern` metadata names its monitor and run and (since 2026-11-28) its index among the run's
files: that, not the file's name, says which files continue one another, so a run's files renamed by an
uploader (drive_part01.mcap, ...) or copied into another folder still read as the sequence the monitor
wrote. A file of that metadata without the index takes it from its name, where its name is still the one
the monitor gave it; else the run's files go by the time of their first message. A file whose metadata
names no run (older logs, another recorder's copies) goes by its name in its directory, as before.

Two files of one run and index are one file given twice (a run pulled into two folders): read once.
And what a run's files read leave out of it, every one of them complete: the files its index has no file
read for, and the records its monitor's own status records say it could not log (gaps).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Optional, Sequence

from discern.monitor.log import LOG_NAME, first_log_time_ns, log_files, log_metadata
from discern.monitor.log.writer import RUN_CHARS


@dataclass(frozen=True)
class Place:
    monitor: str
    run: Optional[str]  # the run id: whole from the metadata, its first digits from a name; None: named without one
    index: Optional[int]  # among the run's files, from 0; None: not recorded, and the file renamed
    directory: Optional[Path] = None  # of a file known by its name only: its run is its directory's
    pid: Optional[str] = None  # the process its metadata names, if any: older logs' only mark of a restart

    @property
    def run_key(self) -> tuple:
        return self.directory, self.monitor, self.run

    @property
    def short_run(self) -> str:
        return (self.run or "-")[:RUN_CHARS]


def place_of(path: str) -> Optional[Place]:
    """Where the file lies among its run's, from its metadata, else its name; None when neither says."""
    metadata = log_metadata(path)
    named = LOG_NAME.match(Path(path).name)
    monitor, run = metadata.get("monitor_id"), metadata.get("run")
    if monitor and run:
        index = _index(metadata.get("index"))
        if index is None and named is not None and named.group(1, 2) == (monitor, run[:RUN_CHARS]):
            index = int(named.group(3))  # written before the metadata recorded it, under the name it was given
        return Place(monitor, run, index)
    if named is None:
        return None
    return Place(named.group(1), named.group(2), int(named.group(3)), Path(path).parent.resolve(), metadata.get("pid"))


def _index(text: Optional[str]) -> Optional[int]:
    return int(text) if text is not None and text.isdigit() else None


class Places:
    """place_of, each file looked up once: planning asks again for the same files and their neighbours."""

    def __init__(self):
        self._known: dict[str, Optional[Place]] = {}

    def __call__(self, path: str) -> Optional[Place]:
        if path not in self._known:
            self._known[path] = place_of(path)
        return self._known[path]


def copies(paths: list[str], places: Optional[Places] = None) -> list[tuple[str, str, Place]]:
    """(copy, first, place) for each file that is a run's file given before under another path: the same monitor,
    run and index. Older logs named without a run number their files from 0000 at each start: none is a copy."""
    places = places or Places()
    first: dict[tuple, str] = {}
    found = []
    for path in paths:
        place = places(path)
        if place is None or place.run is None or place.index is None:
            continue
        key = (place.run_key, place.index)
        if key in first:
            found.append((path, first[key], place))
        else:
            first[key] = path
    return found


def in_order(paths: list[str], places: Places) -> list[str]:
    """One run's files in the order its monitor wrote them: by index (a clock set back does not reorder them), by
    name for older logs named without a run, by their first message's time where an index is not known."""
    found = [places(p) for p in paths]
    if all(p.run is None for p in found):
        return sorted(paths, key=lambda p: Path(p).name)
    if all(p.index is not None for p in found):
        return [path for _, path in sorted(zip((p.index for p in found), paths))]
    return sorted(paths, key=_first_message)


def _first_message(path: str) -> tuple:
    """A file's place by the time of its first message; those with none last."""
    t = first_log_time_ns(path)
    return (t is None, t or 0, path)


def continues(before: Place, after: Place) -> bool:
    """Whether `after` is the file its monitor run wrote next after `before` (files of one run, in order)."""
    if before.index is None or after.index is None:
        return True  # files ordered by time: a file missing between them cannot be told
    if after.index != before.index + 1:  # a restarted monitor numbers its files from 0 again
        return False
    # named without a run: an older log, whose metadata names its process where the writer wrote one
    return before.run is not None or None in (before.pid, after.pid) or before.pid == after.pid


@dataclass(frozen=True)
class RunGap:
    """What the files read leave out of a monitor run: its files not read, and the records its monitor lost."""

    monitor: str
    run: str
    read: int  # the run's files read
    missing: int  # its files not read
    indices: Optional[tuple[int, ...]]  # which: None where the files' indices are not known
    opened: Optional[int]  # the files it opened, as its last status record read says (log_files_opened)
    dropped: Optional[int]  # the records it could not log, as that record says (log_dropped)

    def describe(self) -> str:
        said = []
        if self.missing:
            if self.indices is not None:
                files = "file" + ("s" if self.missing > 1 else "") + " " + _spans(self.indices)
                said.append(f"{files} {'are' if self.missing > 1 else 'is'} not among the files read")
            else:
                said.append(f"{self.missing} of its files are not among the files read")
            if self.opened is not None:
                said[-1] += f" (its last status record says it opened {self.opened})"
        if self.dropped:
            said.append(f"its monitor dropped {self.dropped} log record{'s' if self.dropped != 1 else ''} "
                        "(log_dropped in its last status record: a full queue or a disk error)")
        return f"run {self.run[:RUN_CHARS]} of monitor {self.monitor}: " + "; ".join(said)


def _spans(indices: tuple[int, ...]) -> str:
    """0000-0002, 0005: consecutive indices as one span."""
    spans: list[list[int]] = []
    for i in indices:
        if spans and i == spans[-1][-1] + 1:
            spans[-1].append(i)
        else:
            spans.append([i])
    return ", ".join(f"{s[0]:04d}" + (f"-{s[-1]:04d}" if len(s) > 1 else "") for s in spans)


def gaps(paths: Sequence[str], last_status: dict[str, tuple[int, int, int]]) -> list[RunGap]:
    """Each run the files given come from that they leave incomplete: a file missing from its sequence (from the
    first, 0000, to the last read or the last its monitor said it opened), or records its monitor said it dropped.

    `last_status`: per file, its last status record's (log time, log_files_opened, log_dropped); a run's latest
    counts. Older logs named without a run are left out: each start numbers them from 0000 again.
    """
    places = Places()
    given = [str(p) for p in log_files(paths)]
    twice = {copy for copy, _, _ in copies(given, places)}
    runs: dict[tuple, tuple[list[Place], list[tuple[int, int, int]]]] = {}  # run -> its files, their last statuses
    for path in given:
        place = places(path)
        if place is not None and place.run is not None and path not in twice:
            files, marks = runs.setdefault(place.run_key, ([], []))
            files.append(place)
            if path in last_status:
                marks.append(last_status[path])
    found = []
    for files, marks in runs.values():
        _, opened, dropped = max(marks) if marks else (None, None, None)
        opened = opened or None  # 0: a status record older than the count
        indices = {p.index for p in files}
        if None in indices:
            missing, which = max(0, (opened or 0) - len(files)), None
        else:
            top = max(max(indices), (opened or 0) - 1)
            which = tuple(i for i in range(top + 1) if i not in indices)
            missing = len(which)
        if missing or dropped:
            found.append(RunGap(files[0].monitor, files[0].run, len(files), missing, which, opened, dropped))
    return found
