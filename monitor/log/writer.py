"""The monitor's MCAP recorder: every proposal, verdict, refusal and status, off the decision path.

Records go through a queue to one writer thread, so a slow disk never delays
a verdict (a full queue drops records and counts them instead). The current
chunk is closed and handed to the OS every `flush_seconds`, so a `kill -9`
loses at most that much and the file stays readable up to its last chunk
(see reader.py). Files rotate by size and age; by age only once they hold a
proposal, verdict or refusal: the monitor's periodic status records alone do
not make an idle period worth a file.

A disk error (a full disk, a log directory gone) loses the current file, never
the monitor: the records it held since the last flush and those written while
no file can be opened are counted as dropped, the error is logged once, and a
new file is tried at once and then at every flush until one opens. A deleted
file (or directory) raises no error of its own: writes would go on into the
unlinked file, lost. So every flush first checks that the file is still the one
at its path, and treats it as a disk error if not; the directory is recreated.

Files are named discern-<monitor id>-<UTC stamp>-<run>-<index>.mcap: the run
(one writer's life) keeps a restarted monitor from overwriting a file of the same
second, and an audit from reading its files as the continuation of the previous
run's; the index counts the run's files from 0000. The file's `discern` metadata
records both too (`run` whole, `index`), so that a file renamed or copied away
still says where it belongs.

Each vehicle has channels of its own in a file, and a file holds at most MAX_CHANNELS (about
32,000 vehicles): a record that would need one more starts the next file, so no record is lost
to a fleet that large.

With `keep_bytes` set, each new file makes room: the oldest files named with the
monitor's id (this run's that hold nothing but status records first, then earlier
runs', then this run's by index; never the file being written) are deleted until
its files take at most that, so that they pass it by at most the one file filling
up. An idle monitor's status records still fill files, by size; they do not
displace the files of the drive before them. A writer holds a lock on the file it
writes, so that no other writer's keep_bytes deletes it: two monitors started with
the same id in one directory (a mistake, said so at start) lose no file being
written.
"""

from __future__ import annotations

import errno
import fcntl
import json
import logging
import os
import queue
import re
import threading
import time
import uuid
from datetime import datetime, timezone
from pathlib import Path
from typing import Mapping, Optional, Union

from mcap.writer import CompressionType, Writer
from pydantic import BaseModel

from discern.rules.code_digest import reasoning_code_digest
from discern.rules.scene import SCHEMA_VERSION

from ..config import LogSettings
from .channels import CHANNEL_KINDS, MESSAGE_ENCODING, SCHEMA_ENCODING, schema_bytes

log = logging.getLogger(__name__)

MAX_QUEUED = 100_000
SOON_S = 0.1  # a flush asked for (flush_soon) comes at most this long after the one before: chunks stay whole
MAX_CHANNELS = 65_535  # MCAP channel ids are 16-bit, from 1; schemas, one per kind of record, never come near
CHUNK_BYTES = 512 * 1024
RUN_CHARS = 8  # of the run id in file names: 32 random bits, unique among one monitor id's runs
# discern-<monitor id>-<UTC stamp>-<run>-<index>.mcap (files of older versions: no run); groups monitor, run, index
LOG_NAME = re.compile(r"^discern-(.+)-\d{8}T\d{6}-(?:([0-9a-f]{8})-)?(\d{4,})\.mcap$")
_STOP = object()
_SOON = object()

Payload = Union[bytes, BaseModel]


class McapLogWriter:
    """Append-only recorder; `write` never blocks, `close` finishes the file cleanly."""

    def __init__(self, settings: LogSettings, monitor_id: str, params: Optional[Mapping[str, float]] = None,
                 jurisdiction: Optional[str] = None, window_s: Optional[float] = None, catalog: Optional[str] = None):
        """`params`: the reasoning parameters the verdicts are decided with (rules.facts.Params overrides),
        `jurisdiction` the rule pack, `window_s` the history window and `catalog` the rules' digest
        (rules.catalog.catalog_digest), kept in every file's metadata so that a replay decides alike, or says why
        it cannot."""
        if settings.compression not in ("zstd", "none"):
            raise ValueError(f"log compression {settings.compression!r} is not 'zstd' or 'none'")
        self.settings = settings
        self.monitor_id = monitor_id
        self.params = dict(params or {})
        self.setup = {name: str(value) for name, value in
                      (("jurisdiction", jurisdiction), ("window_s", window_s), ("catalog", catalog)) if value is not None}
        self.directory = Path(settings.directory)
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
        except FileExistsError:
            raise OSError(f"the log directory {self.directory} is a file, not a directory") from None
        except OSError as exc:
            raise OSError(f"cannot create the log directory {self.directory}: {exc.strerror}") from None
        if not os.access(self.directory, os.W_OK | os.X_OK):  # not found out at the first file's odd temporary name
            raise OSError(f"cannot write into the log directory {self.directory}")
        self.files: list[Path] = []  # this run's files still on disk, the one being written last
        self._status_only: set[Path] = set()  # those of them finished with no record but status records
        self.opened = 0  # files this run opened: the next one's index
        self.deleted = 0  # files deleted to keep within keep_bytes
        self.records = 0
        self.dropped = 0
        self._queue: queue.SimpleQueue = queue.SimpleQueue()
        self._stream = None
        self._writer: Optional[Writer] = None
        self._channels: dict[str, int] = {}
        self._schemas: dict[str, int] = {}
        self._opened_at = 0.0
        self._traffic = 0  # records in the current file other than status records: proposals, verdicts, refusals
        self._pending = 0  # records added since the last flush: lost if the file fails
        self._failing = False  # since a disk error, until a new file opens
        self.run = uuid.uuid4().hex
        self._open_file()  # fail now, in the caller, if the directory is not writable
        self._warn_if_shared()
        self._thread = threading.Thread(target=self._run, name="discern-mcap-writer", daemon=True)
        self._thread.start()

    def write(self, topic: str, kind: str, payload: Payload, log_time_ns: Optional[int] = None) -> None:
        """Queue one message; `payload` is JSON bytes or a model serialised on the writer thread."""
        if self._queue.qsize() >= MAX_QUEUED:
            self.dropped += 1
            return
        self._queue.put((topic, kind, payload, log_time_ns or time.time_ns()))

    def flush_soon(self) -> None:
        """Flush what was written so far within about SOON_S, not at the next `flush_seconds`: for records written
        late (a held answer), so that a kill -9 still loses only about the last second of answers."""
        self._queue.put(_SOON)

    def close(self) -> None:
        if self._thread.is_alive():
            self._queue.put(_STOP)
            self._thread.join(timeout=30)

    # -- writer thread ---------------------------------------------------------

    def _run(self) -> None:
        flush_every = self.settings.flush_seconds
        flushed = time.monotonic()
        next_flush = flushed + flush_every
        while True:
            timeout = max(0.0, next_flush - time.monotonic())
            try:
                item = self._queue.get(timeout=timeout)
            except queue.Empty:
                item = None
            if item is _STOP:
                self._on_disk(self._check_file)
                self._on_disk(self._finish_file)
                return
            if item is _SOON:
                next_flush = min(next_flush, flushed + SOON_S)
            elif item is not None:
                if self._writer is None:
                    self.dropped += 1
                else:
                    self._on_disk(lambda: self._add_one(item))
            now = time.monotonic()
            if now >= next_flush:
                flushed, next_flush = now, now + flush_every
                if self._writer is not None:
                    self._on_disk(lambda: self._flush_and_maybe_rotate(now))
                if self._writer is None:  # lost to a disk error, now or earlier: try a new file
                    self._on_disk(self._open_file)

    def _add_one(self, item) -> None:
        try:
            self._add(*item)
        except OSError:
            self.dropped += 1  # this record; the file's unflushed ones are counted by _on_disk
            raise
        except Exception:  # a record that cannot be written must not stop the log
            self.dropped += 1
            log.exception("dropped a log record")

    def _on_disk(self, step) -> None:
        """Run a step that writes to the file; a disk error drops the file and its unflushed records."""
        try:
            step()
        except OSError as exc:
            self.dropped += self._pending
            self.records -= self._pending
            self._pending = 0
            if self._stream is not None:
                try:
                    self._stream.close()
                except OSError:
                    pass  # its buffer cannot reach the disk either
            self._stream = self._writer = None
            if not self._failing:
                log.error(
                    "cannot write the log in %s (%s): records are dropped until a new file opens; "
                    "trying at every flush",
                    self.directory,
                    exc.strerror or exc,
                )
            self._failing = True
            return
        if self._failing and self._writer is not None:
            log.warning("logging again, to %s", self.files[-1])
            self._failing = False

    def _add(self, topic: str, kind: str, payload: Payload, log_time_ns: int) -> None:
        data = payload if isinstance(payload, bytes) else payload.model_dump_json(by_alias=True).encode()
        channel = self._channels.get(topic)
        if channel is None:
            if len(self._channels) >= MAX_CHANNELS:  # the file's channel ids are used up: the next file's
                self._finish_file()
                self._open_file()
            channel = self._register(topic, kind)
        self._writer.add_message(channel, log_time=log_time_ns, data=data, publish_time=log_time_ns)
        self.records += 1
        self._pending += 1
        if kind != "status":
            self._traffic += 1

    def _register(self, topic: str, kind: str) -> int:
        schema = self._schemas.get(kind)
        if schema is None:
            name, _ = CHANNEL_KINDS[kind]
            schema = self._writer.register_schema(name=name, encoding=SCHEMA_ENCODING, data=schema_bytes(kind))
            self._schemas[kind] = schema
        channel = self._writer.register_channel(topic=topic, message_encoding=MESSAGE_ENCODING, schema_id=schema)
        self._channels[topic] = channel
        return channel

    def _check_file(self) -> None:
        """Raise if the file in hand is no longer at its path (deleted, its directory gone): writes to it are lost.

        Checked before each flush, so what went into a deleted file since the last check is counted as dropped.
        """
        if self._writer is None:
            return
        path = self.files[-1]
        try:
            there = os.path.samestat(os.stat(path), os.fstat(self._stream.fileno()))
        except FileNotFoundError:
            there = False
        if not there:
            self.files.remove(path)
            raise FileNotFoundError(errno.ENOENT, f"{path.name} was deleted or moved away")

    def _flush_and_maybe_rotate(self, now: float) -> None:
        self._check_file()
        if self._pending:
            self._writer.flush()
            self._pending = 0
        too_big = self._stream.tell() >= self.settings.rotate_bytes
        too_old = now - self._opened_at >= self.settings.rotate_seconds
        # An idle monitor does not leave a trail of files: its periodic status records alone make no period worth
        # a file of its own (a monitor idle for 100 s at --log-rotate-s 1 left 69 files of them).
        if too_old and not self._traffic:
            self._opened_at, too_old = now, False
        if too_big or too_old:
            self._finish_file()
            self._open_file()

    def _open_file(self) -> None:
        self.directory.mkdir(parents=True, exist_ok=True)  # it may have been deleted since the last file
        stamp = datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%S")
        path = self.directory / f"discern-{self.monitor_id}-{stamp}-{self.run[:RUN_CHARS]}-{self.opened:04d}.mcap"
        opening = path.with_name(path.name + ".opening")  # no log's name: no keep cap looks at it unlocked
        stream = open(opening, "wb")
        try:
            fcntl.flock(stream.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)  # being written: see _being_written
            os.replace(opening, path)
            compression = CompressionType.ZSTD if self.settings.compression == "zstd" else CompressionType.NONE
            writer = Writer(stream, chunk_size=CHUNK_BYTES, compression=compression)
            writer.start(profile="", library="discern")
            writer.add_metadata(
                "discern",
                {
                    "monitor_id": self.monitor_id,
                    "schema_version": str(SCHEMA_VERSION),
                    "pid": str(os.getpid()),
                    "run": self.run,
                    "index": str(self.opened),
                    "params": json.dumps(self.params, sort_keys=True),
                    "code": reasoning_code_digest(),
                    **self.setup,
                },
            )
            stream.flush()
        except BaseException:
            # Not a log file: remove it, as the index only moves on with a file opened.
            for undo in (stream.close, lambda: opening.unlink(missing_ok=True), lambda: path.unlink(missing_ok=True)):
                try:
                    undo()
                except OSError:
                    pass
            raise
        self._stream, self._writer = stream, writer
        self._channels.clear()
        self._schemas.clear()
        self._opened_at = time.monotonic()
        self._traffic = 0
        self.files.append(path)
        self.opened += 1
        log.info("logging to %s", path)
        if self.settings.keep_bytes is not None:
            self._make_room(self.settings.keep_bytes)

    def _make_room(self, budget: int) -> None:
        """Delete this monitor's oldest files, never the one being written, until its files take at most `budget`
        bytes. A file that cannot be deleted is left, and said so; logging goes on."""
        current = self.files[-1]
        mine = []
        try:
            entries = list(self.directory.iterdir())
        except OSError as exc:  # the new file is open: not reading the directory must not cost it
            log.warning("could not list %s to keep within --log-keep-mb: %s", self.directory, exc.strerror or exc)
            return
        for entry in entries:
            named = LOG_NAME.match(entry.name)
            if named is None or named.group(1) != self.monitor_id or entry == current:
                continue
            this_run = named.group(2) == self.run[:RUN_CHARS]
            if not this_run and _being_written(entry):
                continue  # another live monitor's current file: its own cap is its own
            try:
                stat = entry.stat()
            except OSError:
                continue  # gone meanwhile
            # an idle stretch's status records go first: they must not cost the drive logged before them its files
            status_only = this_run and entry in self._status_only
            order = int(named.group(3)) if this_run else stat.st_mtime
            mine.append(((not status_only, this_run, order), stat.st_size, entry))
        mine.sort(key=lambda found: found[0])
        total = sum(size for _, size, _ in mine) + self._stream.tell()
        for _, size, entry in mine:
            if total <= budget:
                break
            try:
                entry.unlink()
            except FileNotFoundError:
                pass  # gone meanwhile: its room is free all the same
            except OSError as exc:
                log.warning("could not delete the old log file %s to keep within --log-keep-mb: %s", entry,
                            exc.strerror or exc)
                continue
            else:
                self.deleted += 1
                log.info("deleted the old log file %s to keep within --log-keep-mb", entry)
            total -= size
            if entry in self.files:
                self.files.remove(entry)
            self._status_only.discard(entry)

    def _warn_if_shared(self) -> None:
        """Two monitors with one id in one directory cannot be told apart in the log or the status: say so."""
        try:
            entries = list(self.directory.iterdir())
        except OSError:
            return
        for entry in entries:
            named = LOG_NAME.match(entry.name)
            if (named is not None and named.group(1) == self.monitor_id and named.group(2) != self.run[:RUN_CHARS]
                    and _being_written(entry)):
                log.warning("another monitor with the id %r is logging in %s (%s): give each monitor its own --id",
                            self.monitor_id, self.directory, entry.name)
                return

    def _finish_file(self) -> None:
        if self._writer is None:
            return
        self._writer.finish()
        self._stream.close()
        self._stream = self._writer = None
        self._pending = 0
        if not self._traffic:
            self._status_only.add(self.files[-1])


def _being_written(path: Path) -> bool:
    """Whether a live writer holds the file (the lock _open_file takes; the OS drops it when its process dies)."""
    try:
        with open(path, "rb") as stream:
            fcntl.flock(stream.fileno(), fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    except OSError:
        return False  # gone meanwhile, or unreadable: as before the lock
    return False
