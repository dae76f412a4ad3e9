"""Which monitor run wrote a log file, and where among the run's files it lies.

A file's `discern` metadata names its monitor and run and (since 2026-11-28) its index among the run's
files: that, not the file's name, says which files continue one another, so a run's files renamed by an
uploader (drive_part01.mcap, ...) or copied into another folder still read as the sequence the monitor
wrote. A file of that metadata without the index takes it from its name, where its name is still the one
the monitor gave it; else the run's files go by the time of their first message. A file whose metadata
names no run (older logs, another recorder's copies) goes by its name in its directory, as before.

Two files of one run and index are one file given twice (a run pulled into two folders): read once.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Optional

from discern.monitor.log import LOG_NAME, first_log_time_ns, log_metadata
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
