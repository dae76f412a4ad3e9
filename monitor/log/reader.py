"""Read Discern MCAP logs back, including files cut short by a crash.

`read_log(paths)` yields one `LogRecord` per message, typed with the same
models the monitor wrote. A file without its summary (the monitor was killed)
is read chunk by chunk up to the last complete one; `RecoveryReport` says how
much of each file that was. A damaged chunk (or other record) is skipped and
named, and reading goes on after it: at the end of the record when its length
is intact, else at the next chunk the file's summary indexes. A file is complete
only when it ends with its footer and the closing magic, as the standard MCAP
reader needs. Channels this log does not know are skipped with a
warning, an empty file yields nothing. A file whose `discern` metadata names a
schema version other than this reader's is not read at all (its messages would
each fail the models, or worse, pass them meaning something else) and is
reported as unreadable, with the reason. A file without that metadata (another
recorder's copy) tells its version by its messages: the first that names
another schema version ends the reading the same way.
"""

from __future__ import annotations

import heapq
import io
import json
import logging
import os
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable, Iterator, Optional, Union

from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, ChunkIndex, Footer, Header, Message, MessageIndex, Metadata, Schema, Statistics
from mcap.stream_reader import StreamReader, breakup_chunk
from mcap.summary import Summary
from pydantic import ValidationError

from discern.rules.scene import SCHEMA_VERSION, Proposal
from discern.rules.verdict import Verdict

from ..status import MonitorStatus
from .channels import CHANNEL_KINDS, MESSAGE_ENCODING, SCHEMA_NAMES, RejectedInput, parse_topic

log = logging.getLogger(__name__)

PathLike = Union[str, os.PathLike]
RECORD_SIZE_LIMIT = 1 << 30
METADATA_NAME = "discern"  # the writer's metadata record: monitor_id, schema_version, pid, run, index, params, ...
MAGIC = b"\x89MCAP0\r\n"  # at both ends of an MCAP file
RECORD_HEADER = 9  # opcode (1 byte) and record length (8)
FOOTER_BYTES = RECORD_HEADER + 20  # the footer record: summary start, summary offset start, summary CRC
OPCODES = {int(op) for op in Opcode}
DAMAGE_SHOWN = 3  # damaged records named in a file's line; the rest are counted


@dataclass(frozen=True)
class DamagedRecord:
    """A stretch of a file that could not be read and was skipped."""

    offset: int  # where it starts in the file
    length: int  # bytes skipped
    reason: str
    # chunk | record | bytes (up to the next indexed chunk) | messages (where, unknown) | summary (nothing skipped)
    kind: str = "chunk"
    messages: Optional[int] = None  # messages a damaged chunk held, from its message index; None when unknown

    def describe(self) -> str:
        if self.kind in ("messages", "summary"):  # missed somewhere unknown, or nothing missed: the reason says
            return self.reason
        if self.kind == "bytes":
            return f"bytes {self.offset}-{self.offset + self.length} skipped: {self.reason}"
        held = f", {self.messages} message{'s' if self.messages != 1 else ''}" if self.messages is not None else ""
        return f"{self.kind} at byte {self.offset} ({self.length} bytes{held}) skipped: {self.reason}"


@dataclass(frozen=True)
class LogRecord:
    """One logged message; exactly one of the payload fields is set, named by `kind`."""

    log_time_ns: int
    vehicle: Optional[str]  # None for monitor-wide topics (status)
    topic: str
    kind: str  # proposal | verdict | rejected | status
    proposal: Optional[Proposal] = None
    verdict: Optional[Verdict] = None
    rejected: Optional[RejectedInput] = None
    status: Optional[MonitorStatus] = None
    path: Optional[Path] = None


@dataclass
class FileRecovery:
    path: Path
    size_bytes: int = 0
    recovered_bytes: int = 0  # up to the end of the last complete record
    records: int = 0
    complete: bool = False  # read through its footer and the closing magic: it was closed cleanly
    closed: bool = False  # the file ends with a footer and the closing magic, whatever lies before them
    stopped_by: Optional[str] = None  # why reading stopped early, for a cut or damaged file
    skipped: int = 0  # messages on unknown channels or that failed validation
    damaged: list[DamagedRecord] = field(default_factory=list)  # skipped, and read on after
    stopped_by_damage: bool = False  # reading stopped at damage it could not read past

    @property
    def state(self) -> str:
        """complete, damaged, truncated, empty or unreadable.

        complete: read whole, footer and closing magic included. damaged: closed (it ends with its
        footer and magic) but some of it could not be read. truncated: cut short, read up to the cut.
        empty: zero bytes. unreadable: nothing read.
        """
        if self.complete and not self.damaged:
            return "complete"
        if self.size_bytes == 0:
            return "empty" if self.stopped_by is None else "unreadable"
        if self.recovered_bytes == 0:
            return "unreadable"
        if self.closed and (self.damaged or self.stopped_by_damage):
            return "damaged"
        return "truncated"

    @property
    def damage(self) -> Optional[str]:
        """The damaged records skipped, one line's worth: the first few named, the rest counted."""
        if not self.damaged:
            return None
        text = "; ".join(d.describe() for d in self.damaged[:DAMAGE_SHOWN])
        more = len(self.damaged) - DAMAGE_SHOWN
        return text + (f"; and {more} more" if more > 0 else "")

    def add_share(self, other: "FileRecovery") -> None:
        """Another reader's share of the same file (read_log's `vehicles`): records and skips add up.

        The file was read as far as the share that stopped first: only the share holding a message of
        another schema version sees it.
        """
        self.records += other.records
        self.skipped += other.skipped
        seen = {d.offset for d in self.damaged}  # every share reads the whole file: the same damage
        self.damaged = sorted(self.damaged + [d for d in other.damaged if d.offset not in seen], key=lambda d: d.offset)
        if other.recovered_bytes < self.recovered_bytes:
            self.recovered_bytes, self.complete = other.recovered_bytes, other.complete
            self.stopped_by, self.stopped_by_damage = other.stopped_by, other.stopped_by_damage


@dataclass
class RecoveryReport:
    files: list[FileRecovery] = field(default_factory=list)

    @property
    def records(self) -> int:
        return sum(f.records for f in self.files)

    @property
    def skipped(self) -> int:
        return sum(f.skipped for f in self.files)

    def summary(self) -> str:
        lines = []
        for f in self.files:
            line = (
                f"{f.path}: {f.state}, {f.records} records, "
                f"{f.recovered_bytes}/{f.size_bytes} bytes recovered"
            )
            if f.skipped:
                line += f", {f.skipped} skipped"
            if f.damaged:
                line += f" (damaged: {f.damage})"
            if f.stopped_by:
                line += f" (stopped: {f.stopped_by})"
            lines.append(line)
        return "\n".join(lines)


def log_files(paths: Union[PathLike, Iterable[PathLike]], strict: bool = False) -> list[Path]:
    """Expand a file, a directory (its *.mcap, by name: rotation names sort in time) or a list of both.

    A directory among a directory's *.mcap entries is expanded in turn, as when the shell expands
    DIR/*.mcap; a file or directory named twice (or linked back up) is read once, where it first appears.
    `strict`: a path that is missing, no regular file, or a directory with no *.mcap raises ValueError
    naming it, so that a long audit does not pass over what it was given; otherwise such a file is
    reported unreadable when it is read.
    """
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    files: list[Path] = []
    seen: set[Path] = set()

    def add(p: Path) -> None:
        key = p.resolve()
        if key in seen:
            return
        seen.add(key)
        if p.is_dir():
            try:
                entries = sorted(e for e in p.iterdir() if e.name.endswith(".mcap"))
            except OSError as exc:
                if strict:
                    raise ValueError(f"{p}: cannot list the directory: {exc.strerror or exc}") from None
                entries = []
            if strict and not entries:
                raise ValueError(f"{p}: directory holds no *.mcap files")
            for entry in entries:
                add(entry)
        elif strict and not p.exists():
            raise ValueError(f"{p}: no such file or directory")
        elif strict and not p.is_file():
            raise ValueError(f"{p}: not a regular file")
        else:
            files.append(p)

    for p in map(Path, paths):
        add(p)
    return files


def read_log(
    paths: Union[PathLike, Iterable[PathLike]],
    report: Optional[RecoveryReport] = None,
    *,
    merge: bool = False,
    since_ns: Optional[int] = None,
    vehicles: Optional[Callable[[Optional[str]], bool]] = None,
) -> Iterator[LogRecord]:
    """Every record of the given files, file after file (or merged by log time with `merge=True`, which keeps
    every file open at once and takes each file's records in the order written: docs/protocol.md).

    Pass a `RecoveryReport` to learn, once iteration ends, how much of each file was read.
    A missing or unreadable file is reported and skipped, never raised. With `since_ns`,
    earlier messages are skipped undecoded (their chunks still are read: they declare the channels).
    With `vehicles`, only the messages of the vehicles it picks are decoded and counted
    (`vehicles(None)` picks the monitor-wide ones and those of unknown channels): readers
    that split a file between them by vehicle each decode their share, and their counts add up.
    """
    report = report if report is not None else RecoveryReport()
    streams = []
    for path in log_files(paths):
        recovery = FileRecovery(path=path)
        report.files.append(recovery)
        streams.append(_read_file(path, recovery, since_ns, vehicles))
    if merge:
        yield from heapq.merge(*streams, key=lambda r: r.log_time_ns)
    else:
        for stream in streams:
            yield from stream


def first_log_time_ns(path: PathLike) -> Optional[int]:
    """Log time of a file's first message, from its first chunk's header; None when it has none."""
    try:
        with open(path, "rb") as f:
            for record in StreamReader(f, emit_chunks=True, record_size_limit=RECORD_SIZE_LIMIT).records:
                if isinstance(record, Chunk):
                    return record.message_start_time
                if isinstance(record, Message):
                    return record.log_time
    except Exception:  # unreadable or cut before its first message: nothing to anchor on
        return None
    return None


def log_metadata(path: PathLike) -> dict[str, str]:
    """The writer's `discern` metadata of a file (monitor_id, schema_version, pid, run, index, params, code,
    catalog, jurisdiction, window_s); {} when it has none.

    The writer puts it right after the header, so only the file's first records are read.
    """
    try:
        with open(path, "rb") as f:
            for record in StreamReader(f, emit_chunks=True, record_size_limit=RECORD_SIZE_LIMIT).records:
                if isinstance(record, Metadata):
                    if record.name == METADATA_NAME:
                        return dict(record.metadata)
                elif not isinstance(record, Header):
                    break
    except Exception:  # unreadable or cut short: no metadata to go by
        pass
    return {}


def _unsupported_version(metadata: dict[str, str]) -> Optional[str]:
    """Why a file of this metadata cannot be read, if its schema version is not this reader's."""
    version = metadata.get("schema_version")
    if version is None or version == str(SCHEMA_VERSION):
        return None
    return f"schema version {version}; this discern reads version {SCHEMA_VERSION}"


def _read_file(
    path: Path,
    recovery: FileRecovery,
    since_ns: Optional[int] = None,
    vehicles: Optional[Callable[[Optional[str]], bool]] = None,
) -> Iterator[LogRecord]:
    try:
        f = open(path, "rb")
    except OSError as exc:
        recovery.stopped_by = f"cannot open: {exc.strerror or exc}"
        return
    with f:
        size = recovery.size_bytes = os.fstat(f.fileno()).st_size
        if size == 0:
            return
        fd = f.fileno()
        f = _Snapshot(f, size)
        head = os.pread(fd, len(MAGIC), 0)
        if head != MAGIC:
            recovery.stopped_by = (
                f"cut short inside its opening magic, at byte {len(head)}"
                if MAGIC.startswith(head)
                else "not an MCAP file: it does not start with the MCAP magic"
            )
            return
        recovery.closed = _ends_closed(fd, size)
        summary = _Summary(path, size)
        decoder = _ChannelDecoder(path, recovery, vehicles, summary.declare)
        f.seek(len(MAGIC))
        records = _records(f)
        end = len(MAGIC)  # of the last record read whole
        lost = 0  # bytes of damaged records skipped
        pending: Optional[int] = None  # index in recovery.damaged of a damaged chunk whose message index may follow
        start: Optional[int] = None  # of the last record read whole
        chunks_read: set[int] = set()  # where the chunks read (whole or damaged) start
        messages = 0  # message records read, on any channel

        def skip(offset: int, resume: int, reason: str, kind: str, restart: bool) -> None:
            """Name the damage from `offset` to `resume` and read on from there (`restart`: with a new reader)."""
            nonlocal records, end, lost
            if not recovery.damaged:  # a lost chunk may have declared channels that later chunks use
                summary.declare(decoder)
            recovery.damaged.append(DamagedRecord(offset, resume - offset, reason, kind))
            lost += resume - offset
            if restart or f.tell() != resume:
                f.seek(resume)
                records = _records(f)
            end = resume

        while True:
            try:
                record = next(records)
            except StopIteration:
                break
            except Exception as exc:  # a record cut short (the tail of a killed writer) or damaged
                at_eof = f.tell() >= size
                if at_eof and not recovery.closed:
                    recovery.stopped_by = (
                        f"cut short at byte {end}, before its footer (the monitor was killed, or is still writing it)"
                        if end >= size
                        else f"cut short inside a record at byte {end}"
                    )
                    break
                reason = "the end of the file came before its footer" if at_eof else _describe(exc)
                resume, kind = _resume_at(fd, end, size, summary)
                offset = end
                if resume is None and start is not None:
                    # no record starts here: the last record's length ran past what it held (in a closed file, up
                    # to its end), swallowing the records after it; read those from the next indexed chunk
                    resume = next((o for o in summary.chunk_offsets() if start < o < end), None)
                    if resume is not None:
                        offset, kind, reason = start, "bytes", f"{reason}, at byte {end}"
                if resume is None:
                    recovery.stopped_by = f"damaged at byte {end}, not read past: {reason}"
                    recovery.stopped_by_damage = True
                    break
                skip(offset, resume, reason, kind, restart=True)  # the reader that raised is spent
                start = None
                pending = len(recovery.damaged) - 1 if kind == "chunk" else None
                continue
            start, end = end, f.tell()
            if isinstance(record, MessageIndex):
                if pending is not None:  # the damaged chunk's index: how many messages it held
                    damage = recovery.damaged[pending]
                    recovery.damaged[pending] = DamagedRecord(
                        damage.offset, damage.length, damage.reason, damage.kind,
                        (damage.messages or 0) + len(record.records),
                    )
            else:
                pending = None
            if isinstance(record, Metadata) and record.name == METADATA_NAME:
                why = _unsupported_version(record.metadata)
                if why is not None:
                    recovery.stopped_by = why
                    recovery.recovered_bytes = 0  # nothing of it is read: an unreadable file
                    break
            if isinstance(record, Chunk):
                chunks_read.add(start)
                try:
                    inner = breakup_chunk(record, validate_crc=True)
                except Exception as exc:
                    # its record length says where the next record starts, however the chunk inside is damaged
                    skip(start, end, _describe(exc), "chunk", restart=False)
                    pending = len(recovery.damaged) - 1
                    recovery.recovered_bytes = end - lost
                    continue
            else:
                inner = [record]
            read_before = recovery.recovered_bytes
            recovery.recovered_bytes = end - lost
            for item in inner:
                messages += isinstance(item, Message)
                if since_ns is not None and isinstance(item, Message) and item.log_time < since_ns:
                    continue
                out = decoder.feed(item)
                if out is not None:
                    recovery.records += 1
                    yield out
                elif decoder.other_version is not None:
                    break
            if decoder.other_version is not None:
                recovery.stopped_by = decoder.other_version
                # unreadable when nothing came before it, as with the metadata's version
                recovery.recovered_bytes = read_before if recovery.records else 0
                break
            if isinstance(record, Footer):
                if summary.get() is not None:
                    lost += _unread(summary, chunks_read, messages, recovery, fd)
                elif record.summary_start:  # it points at a summary no reader can read: no standard reader opens it
                    recovery.damaged.append(DamagedRecord(
                        start, end - start, f"the footer at byte {start} points to a summary at byte "
                        f"{record.summary_start} that cannot be read ({summary.error}); every record was read without "
                        "it", "summary"))
                rest = os.pread(fd, len(MAGIC) + 1, end)
                if rest == MAGIC:
                    recovery.complete = True
                    recovery.recovered_bytes = size - lost
                elif MAGIC.startswith(rest):
                    recovery.stopped_by = f"cut short after its footer, inside the closing magic at byte {end}"
                else:
                    recovery.stopped_by = f"damaged after its footer: no closing MCAP magic alone at byte {end}"
                break


def _unread(summary: "_Summary", chunks_read: set[int], messages: int, recovery: FileRecovery, fd: int) -> int:
    """Name what a closed file's summary indexes or counts but the read never met; returns the bytes lost.

    mcap's StreamReader passes over a record of an unknown opcode without a word, so a chunk whose opcode
    byte is damaged would vanish from a file that still reads as complete.
    """
    damaged_at = {d.offset for d in recovery.damaged}
    lost = 0
    for index in summary.get().chunk_indexes:
        if index.chunk_start_offset not in chunks_read and index.chunk_start_offset not in damaged_at:
            recovery.damaged.append(DamagedRecord(
                index.chunk_start_offset, index.chunk_length,
                "indexed in the file's summary but not read: its record header is damaged", "chunk",
                _indexed_messages(fd, index.message_index_offsets.values())))
            lost += index.chunk_length
    statistics = summary.get().statistics
    if not recovery.damaged and statistics is not None and messages < statistics.message_count:
        missing = statistics.message_count - messages
        recovery.damaged.append(DamagedRecord(
            0, 0, f"{missing} of the {statistics.message_count} messages its summary counts were not read", "messages"))
    recovery.damaged.sort(key=lambda d: d.offset)
    return lost


_MESSAGE_INDEX = 0x07  # MCAP opcode


def _indexed_messages(fd: int, offsets) -> Optional[int]:
    """How many messages a chunk's message index records list (None if one of them is unreadable too): each is its
    opcode, its length, a channel id and a byte length of 16-byte (log time, offset) entries."""
    count = 0
    for offset in offsets:
        head = os.pread(fd, 15, offset)
        if len(head) < 15:
            return None
        opcode, _, _, length = struct.unpack("<BQHI", head)
        if opcode != _MESSAGE_INDEX or length % 16:
            return None
        count += length // 16
    return count


class _Snapshot:
    """A file as it was when opened: a running monitor may still be appending to it. What is read of it and its size
    then describe the same bytes (read on, 101 % of a log being written was "recovered"). No io.RawIOBase: mcap's
    reader would buffer one, and read ahead of where a record ends."""

    def __init__(self, f, size: int):
        self._f, self._size = f, size

    def tell(self) -> int:
        return self._f.tell()

    def seek(self, offset: int, whence: int = io.SEEK_SET) -> int:
        if whence == io.SEEK_END:
            offset, whence = self._size + offset, io.SEEK_SET
        return self._f.seek(offset, whence)

    def read(self, n: int = -1) -> bytes:
        left = max(0, self._size - self._f.tell())
        return self._f.read(left if n is None or n < 0 else min(n, left))


def _records(f) -> Iterator:
    """The records of `f` from where it stands (past the opening magic), chunks whole."""
    return StreamReader(f, skip_magic=True, emit_chunks=True, record_size_limit=RECORD_SIZE_LIMIT).records


def _plain_records(f) -> Iterator:
    """The records of `f` from where it stands, a chunk's broken up."""
    return StreamReader(f, skip_magic=True, record_size_limit=RECORD_SIZE_LIMIT).records


def _ends_closed(fd: int, size: int) -> bool:
    """Whether the file ends with a footer record and the closing magic, as a cleanly closed file does."""
    return size >= 2 * len(MAGIC) + FOOTER_BYTES and _footer_at(fd, size) == size - FOOTER_BYTES - len(MAGIC)


def _footer_at(fd: int, size: int) -> Optional[int]:
    """Where the footer record that ends the file starts (None: no footer ends it): before the closing magic, or
    before what is left of it. A file cut inside its closing magic still has its summary where its footer says."""
    for kept in range(len(MAGIC), -1, -1):
        at = size - FOOTER_BYTES - kept
        if at < len(MAGIC):
            continue
        tail = os.pread(fd, FOOTER_BYTES + kept, at)
        opcode, length = struct.unpack_from("<BQ", tail)
        if opcode == Opcode.FOOTER and length == FOOTER_BYTES - RECORD_HEADER and tail[FOOTER_BYTES:] == MAGIC[:kept]:
            return at
    return None


def _resume_at(fd: int, offset: int, size: int, summary: "_Summary") -> tuple[Optional[int], str]:
    """Where reading can go on past a damaged record at `offset` (None when nowhere is known), and what is skipped.

    At the record's end when its header is whole (a known opcode, a length that fits in the file): a chunk
    or another record; else at the next chunk the file's summary indexes: bytes.
    """
    header = os.pread(fd, RECORD_HEADER, offset)
    if len(header) == RECORD_HEADER:
        opcode, length = struct.unpack("<BQ", header)
        if opcode in OPCODES and offset + RECORD_HEADER + length <= size:
            return offset + RECORD_HEADER + length, "chunk" if opcode == Opcode.CHUNK else "record"
    return next((o for o in summary.chunk_offsets() if o > offset), None), "bytes"


class _Summary:
    """A file's summary section, read only when damage calls for it (None when it has none or it is damaged too).

    Found from the footer that ends the file, as mcap's reader finds it, but also where the closing magic is
    cut short: mcap's reader looks for the footer a whole magic before the end, and read garbage there.
    """

    def __init__(self, path: Path, size: int):
        self.path, self.size = path, size
        self._summary: Optional[Summary] = None
        self._read = False
        self.error: Optional[str] = None  # why it could not be read

    def get(self) -> Optional[Summary]:
        if not self._read:
            self._read = True
            try:
                with open(self.path, "rb") as f:
                    self._summary = self._read_summary(f.fileno(), _Snapshot(f, self.size))
            except Exception as exc:  # cut short, or its summary is damaged as well
                self._summary = None
                self.error = _describe(exc)
        return self._summary

    def _read_summary(self, fd: int, f: "_Snapshot") -> Optional[Summary]:
        at = _footer_at(fd, self.size)
        if at is None:
            return None
        f.seek(at)
        footer = next(_plain_records(f))
        if footer.summary_start == 0:
            return None
        f.seek(footer.summary_start)
        summary = Summary()
        for record in _plain_records(f):
            if isinstance(record, Footer):
                return summary
            if isinstance(record, Statistics):
                summary.statistics = record
            elif isinstance(record, Schema):
                summary.schemas[record.id] = record
            elif isinstance(record, Channel):
                summary.channels[record.id] = record
            elif isinstance(record, ChunkIndex):
                summary.chunk_indexes.append(record)
        raise ValueError("the summary runs to the end of the file without its footer")

    def chunk_offsets(self) -> list[int]:
        summary = self.get()
        return sorted(c.chunk_start_offset for c in summary.chunk_indexes) if summary is not None else []

    def declare(self, decoder: "_ChannelDecoder") -> None:
        """Declare the summary's schemas and channels, so a lost chunk's declarations do not lose later messages."""
        summary = self.get()
        if summary is None:
            return
        for schema in summary.schemas.values():
            decoder.feed(schema)
        for channel in summary.channels.values():
            decoder.feed(channel)


def _other_version(data: bytes) -> Optional[str]:
    """Why a message that failed its model cannot be read, if it names a schema version not this reader's."""
    try:
        version = json.loads(data).get("version")
    except (ValueError, AttributeError, RecursionError):  # not a JSON object
        return None
    if isinstance(version, int) and not isinstance(version, bool) and version != SCHEMA_VERSION:
        return f"schema version {version}; this discern reads version {SCHEMA_VERSION}"
    return None


def _first_error(exc: ValidationError) -> str:
    """The first reason a message failed its model."""
    error = exc.errors()[0]
    where = ".".join(str(p) for p in error["loc"])
    return f"{where}: {error['msg']}" if where else error["msg"]


def _describe(exc: Exception) -> str:
    text = str(exc)
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


class _ChannelDecoder:
    """Turns schema, channel and message records of one file into LogRecords."""

    def __init__(self, path: Path, recovery: FileRecovery, vehicles: Optional[Callable[[Optional[str]], bool]] = None,
                 declare_all: Optional[Callable[["_ChannelDecoder"], None]] = None):
        """`declare_all`: declares every schema and channel of the file (its summary's), once a message comes on a
        channel no record read declared: the chunk that did may have been passed over unseen (a damaged opcode)."""
        self.path = path
        self.recovery = recovery
        self.vehicles = vehicles
        self._declare_all = declare_all
        self.schemas: dict[int, Schema] = {}
        self.channels: dict[int, Optional[tuple[Optional[str], str, str]]] = {}
        self.elsewhere: set[int] = set()  # channels of vehicles another reader decodes
        self.invalid: set[int] = set()  # channels warned about for a message that failed its schema
        self.other_version: Optional[str] = None  # set by a message of another schema version: the file's

    def feed(self, record) -> Optional[LogRecord]:
        if isinstance(record, Schema):
            self.schemas[record.id] = record
        elif isinstance(record, Channel):
            first = record.id not in self.channels  # a summary section declares the channels again
            known = self.channels[record.id] = self._known(record)
            if not self._mine(known[0] if known is not None else None):
                self.elsewhere.add(record.id)
            elif known is None and first:  # warned by one reader only: the one that counts what is skipped
                schema = self.schemas.get(record.schema_id)
                log.warning(
                    "%s: skipping unknown channel %r (schema %r, encoding %r)",
                    self.path,
                    record.topic,
                    schema.name if schema else None,
                    record.message_encoding,
                )
        elif isinstance(record, Message):
            if record.channel_id not in self.channels and self._declare_all is not None:
                declare, self._declare_all = self._declare_all, None
                declare(self)
            if record.channel_id in self.elsewhere:
                return None
            if record.channel_id not in self.channels and not self._mine(None):
                return None  # an undeclared channel: counted by the reader of monitor-wide records
            return self._message(record)
        return None

    def _mine(self, vehicle: Optional[str]) -> bool:
        """Whether this reader decodes the vehicle's records (None: monitor-wide and unknown channels)."""
        return self.vehicles is None or self.vehicles(vehicle)

    def _known(self, channel: Channel) -> Optional[tuple[Optional[str], str, str]]:
        schema = self.schemas.get(channel.schema_id)
        parsed = parse_topic(channel.topic)
        kind = SCHEMA_NAMES.get(schema.name) if schema is not None else None
        if parsed is None or kind is None or parsed[1] != kind or channel.message_encoding != MESSAGE_ENCODING:
            return None
        return parsed[0], kind, channel.topic

    def _message(self, message: Message) -> Optional[LogRecord]:
        known = self.channels.get(message.channel_id)
        if known is None:
            self.recovery.skipped += 1
            return None
        vehicle, kind, topic = known
        try:
            value = CHANNEL_KINDS[kind][1].model_validate_json(message.data)
        except ValidationError as exc:
            self.other_version = _other_version(message.data)
            if self.other_version is not None:  # one writer writes one version: the whole file is of it
                return None
            self.recovery.skipped += 1
            if message.channel_id not in self.invalid:  # once per channel: the file line counts them all
                self.invalid.add(message.channel_id)
                log.warning(
                    "%s: skipping %s messages that fail their schema (counted in the file's skipped), first: %s",
                    self.path,
                    topic,
                    _first_error(exc),
                )
            return None
        if kind == "proposal" and "vehicle" not in value.model_fields_set and vehicle:
            value.vehicle = vehicle  # the key named it, as on the wire
        return LogRecord(
            log_time_ns=message.log_time,
            vehicle=vehicle,
            topic=topic,
            kind=kind,
            path=self.path,
            **{kind: value},
        )
