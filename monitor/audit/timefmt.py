"""Log times for people: the log stamps wall-clock nanoseconds, people read and type UTC."""

from __future__ import annotations

from datetime import datetime, timezone


def iso(ns: int) -> str:
    return datetime.fromtimestamp(ns / 1e9, tz=timezone.utc).isoformat(timespec="milliseconds").replace("+00:00", "Z")


def parse_time(text: str) -> int:
    """Nanoseconds since the epoch from ISO 8601 (UTC unless it says otherwise) or epoch seconds."""
    value = text.strip()
    try:
        return int(round(float(value) * 1e9))
    except ValueError:
        pass
    try:
        moment = datetime.fromisoformat(value.replace("Z", "+00:00"))
    except ValueError:
        raise ValueError(
            f"time {text!r} is neither ISO 8601 (2026-11-21T15:20:00Z) nor seconds since the epoch"
        ) from None
    if moment.tzinfo is None:
        moment = moment.replace(tzinfo=timezone.utc)
    return int(round(moment.timestamp() * 1e9))
