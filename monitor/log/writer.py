"""The monitor's MCAP recorder: every proposal, verdict, refusal and status, off the decision path.

Records go through a queue to one writer thread, so a slow disk never delays
a verdict (a full queue drops records and counts them instead). The current
chunk is closed and handed to the OS every `flush_seconds`, so a `kill -9`
loses at most that much and the file stays readable up to its last chunk
(see reader.py). Files rotate by size and age.
"""

from __future__ import annotations

import logging
import os
import queue
import threading
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Optional, Union

from mcap.writer import CompressionType, Writer
from pydantic import BaseModel

from discern.rules.scene import SCHEMA_VERSION

from ..config import LogSettings
from .channels import CHANNEL_KINDS, MESSAGE_ENCODING, SCHEMA_ENCODING, schema_bytes

log = logging.getLogger(__name__)

MAX_QUEUED = 100_000
CHUNK_BYTES = 512 * 1024
_STOP = object()

Payload = Union[bytes, BaseModel]


class McapLogWriter:
    """Append-only recorder; `write` never blocks, `close` finishes the file cleanly."""

    def __init__(self, settings: LogSettings, monitor_id: str):
        if settings.compression not in ("zstd", "none"):
            raise ValueError(f"log compression {settings.compression!r} is not 'zstd' or 'none'")
        self.settings = settings
        self.monitor_id = monitor_id
        self.directory = Path(settings.directory)
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OSError(f"cannot create the log directory {self.directory}: {exc.strerror}") from None
        self.files: list[Path] = []
        self.records = 0
        self.dropped = 0
        self._queue: queue.SimpleQueue = queue.SimpleQueue()
        self._stream = None
        self._writer: Optional[Writer] = None
        self._channels: dict[str, int] = {}
        self._schemas: dict[str, int] = {}
        self._opened_at = 0.0
        self._pending = 0
        self._open_file()  # fail now, in the caller, if the directory is not writable
        self._thread = threading.Thread(target=self._run, name="discern-mcap-writer", daemon=True)
        self._thread.start()

    def write(self, topic: str, kind: str, payload: Payload, log_time_ns: Optional[int] = None) -> None:
        """Queue one message; `payload` is JSON bytes or a model serialised on the writer thread."""
        if self._queue.qsize() >= MAX_QUEUED:
            self.dropped += 1
            return
        self._queue.put((topic, kind, payload, log_time_ns or time.time_ns()))

    def close(self) -> None:
        if self._thread.is_alive():
            self._queue.put(_STOP)
            self._thread.join(timeout=30)

    # -- writer thread ---------------------------------------------------------

    def _run(self) -> None:
        flush_every = self.settings.flush_seconds
        next_flush = time.monotonic() + flush_every
        while True:
            timeout = max(0.0, next_flush - time.monotonic())
            try:
                item = self._queue.get(timeout=timeout)
            except queue.Empty:
                item = None
            if item is _STOP:
                self._finish_file()
                return
            if item is not None:
                try:
                    self._add(*item)
                except Exception:  # a record that cannot be written must not stop the log
                    self.dropped += 1
                    log.exception("dropped a log record")
            now = time.monotonic()
            if now >= next_flush:
                next_flush = now + flush_every
                self._flush_and_maybe_rotate(now)

    def _add(self, topic: str, kind: str, payload: Payload, log_time_ns: int) -> None:
        data = payload if isinstance(payload, bytes) else payload.model_dump_json(by_alias=True).encode()
        channel = self._channels.get(topic)
        if channel is None:
            channel = self._register(topic, kind)
        self._writer.add_message(channel, log_time=log_time_ns, data=data, publish_time=log_time_ns)
        self.records += 1
        self._pending += 1

    def _register(self, topic: str, kind: str) -> int:
        schema = self._schemas.get(kind)
        if schema is None:
            name, _ = CHANNEL_KINDS[kind]
            schema = self._writer.register_schema(name=name, encoding=SCHEMA_ENCODING, data=schema_bytes(kind))
            self._schemas[kind] = schema
        channel = self._writer.register_channel(topic=topic, message_encoding=MESSAGE_ENCODING, schema_id=schema)
        self._channels[topic] = channel
        return channel

    def _flush_and_maybe_rotate(self, now: float) -> None:
        if self._pending:
            self._writer.flush()
            self._pending = 0
        too_big = self._stream.tell() >= self.settings.rotate_bytes
        too_old = now - self._opened_at >= self.settings.rotate_seconds
        if too_big or too_old:
            self._finish_file()
            self._open_file()

    def _open_file(self) -> None:
        stamp = datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%S")
        path = self.directory / f"discern-{self.monitor_id}-{stamp}-{len(self.files):04d}.mcap"
        self._stream = open(path, "wb")
        compression = CompressionType.ZSTD if self.settings.compression == "zstd" else CompressionType.NONE
        self._writer = Writer(self._stream, chunk_size=CHUNK_BYTES, compression=compression)
        self._writer.start(profile="", library="discern")
        self._writer.add_metadata(
            "discern", {"monitor_id": self.monitor_id, "schema_version": str(SCHEMA_VERSION), "pid": str(os.getpid())}
        )
        self._stream.flush()
        self._channels.clear()
        self._schemas.clear()
        self._opened_at = time.monotonic()
        self.files.append(path)
        log.info("logging to %s", path)

    def _finish_file(self) -> None:
        if self._writer is None:
            return
        self._writer.finish()
        self._stream.close()
        self._writer = None
        self._pending = 0
