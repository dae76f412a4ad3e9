"""Log times for people: the log stamps wall-clock nanoseconds, people read and type UTC."""

from __future__ import annotations

import math
from datetime import datetime, timezone

# What a log time can be: MCAP stamps unsigned nanoseconds, and people read them as dates up to year 9999.
MAX_EPOCH_S = int(datetime(9999, 12, 31, 23, 59, 59, tzinfo=timezone.utc).timestamp())
# An integer this large is no epoch second (it would be past year 9999): it is epoch nanoseconds,
# as in the CSV's log_time_ns column. The smallest is in 1973, the largest in year 2554 (uint64).
MIN_EPOCH_NS, MAX_EPOCH_NS = 10**17, 2**64 - 1


def iso(ns: int) -> str:
    return datetime.fromtimestamp(ns / 1e9, tz=timezone.utc).isoformat(timespec="milliseconds").replace("+00:00", "Z")


def parse_time(text: str, option: str = "time") -> int:
    """Nanoseconds since the epoch from ISO 8601 (UTC unless it says otherwise), epoch seconds or epoch nanoseconds.

    A mistake raises ValueError naming `option` (the command-line flag) and the value.
    """
    value = text.strip()
    try:
        number = float(value)
    except ValueError:
        number = None
    if number is not None:
        if not math.isfinite(number):
            raise ValueError(f"{option} {text}: not a finite time")
        if value.isdigit() and MIN_EPOCH_NS <= int(value) <= MAX_EPOCH_NS:
            return int(value)
        if not 0 <= number <= MAX_EPOCH_S:
            raise ValueError(
                f"{option} {text}: out of range: epoch seconds go from 0 to {MAX_EPOCH_S} (year 9999), "
                f"epoch nanoseconds (a whole number) from {MIN_EPOCH_NS} to {MAX_EPOCH_NS}"
            )
        return int(round(number * 1e9))
    try:
        moment = datetime.fromisoformat(value.replace("Z", "+00:00"))
    except ValueError:
        raise ValueError(
            f"{option}: time {text!r} is neither ISO 8601 (2026-11-21T15:20:00Z) nor seconds since the epoch"
        ) from None
    if moment.tzinfo is None:
        moment = moment.replace(tzinfo=timezone.utc)
    seconds = moment.timestamp()
    if not 0 <= seconds <= MAX_EPOCH_S:
        raise ValueError(f"{option} {text}: out of range: a log holds times from 1970 to the end of year 9999 UTC")
    return int(round(seconds * 1e9))
