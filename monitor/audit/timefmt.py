"""Log times for people: the log stamps wall-clock nanoseconds, people read and type UTC."""

from __future__ import annotations

import re
from datetime import datetime, timedelta, timezone
from decimal import Decimal, InvalidOperation

EPOCH = datetime(1970, 1, 1, tzinfo=timezone.utc)
# What a log time can be: MCAP stamps unsigned nanoseconds, and people read them as dates up to year 9999.
MAX_EPOCH_S = int(datetime(9999, 12, 31, 23, 59, 59, tzinfo=timezone.utc).timestamp())
# An integer this large is no epoch second (it would be past year 9999): it is epoch nanoseconds,
# as in the CSV's log_time_ns column. The smallest is in 1973, the largest in year 2554 (uint64).
MIN_EPOCH_NS, MAX_EPOCH_NS = 10**17, 2**64 - 1


def iso(ns: int) -> str:
    """The millisecond the time falls in, floored in integers.

    A float rounds a time late in its millisecond up into the next, and that shown time given back
    as --since would leave out the record it was shown for.
    """
    seconds, rest = divmod(ns, 10**9)
    return f"{EPOCH + timedelta(seconds=seconds):%Y-%m-%dT%H:%M:%S}.{rest // 10**6:03d}Z"


def parse_time(text: str, option: str = "time", through: bool = False) -> int:
    """Nanoseconds since the epoch from ISO 8601 (UTC unless it says otherwise), epoch seconds or epoch nanoseconds.

    Exact, in integers (a float of today's times in nanoseconds is 256 ns coarse): ISO 8601 to the
    microsecond, as datetime reads it, epoch seconds to the nanosecond. A mistake raises ValueError
    naming `option` (the command-line flag) and the value. `through`: the last nanosecond of the unit the
    time is given to (an `--until`): reports show times cut to the millisecond, and one copied from a report
    keeps the record it was shown for.
    """
    start = _parse_time(text, option)
    return start + _unit_ns(text.strip()) - 1 if through else start


def _unit_ns(value: str) -> int:
    """The unit a time is written to, in ns: 1 for epoch nanoseconds; for epoch seconds, that of their last digit,
    however written (`1795816272`, `+1_795_816_272`, `1.795816272e9`: a second; `1.5e9`: 10^8 s); in ISO 8601, that
    of its last field (a day, week, hour, minute, second or decimal of a second, however written)."""
    if value.isdigit() and MIN_EPOCH_NS <= int(value) <= MAX_EPOCH_NS:
        return 1
    try:
        return 10 ** max(0, 9 + Decimal(value).as_tuple().exponent)
    except InvalidOperation:
        pass
    date, separator, clock = value.replace(" ", "T", 1).partition("T")
    if not separator:  # a date alone: the whole day, or the whole week of a week date without its day
        return (7 if _WEEK.fullmatch(date) else 1) * 86_400 * 10**9
    written = _CLOCK.match(_ZONE.sub("", clock))
    if written is None:
        return 10**9
    whole, fraction = written.group(1).replace(":", ""), written.group(2)
    if fraction:
        return 10 ** (9 - min(len(fraction), 9))
    return {2: 3600, 4: 60}.get(len(whole), 1) * 10**9


_WEEK = re.compile(r"\d{4}-?W\d{2}")
_ZONE = re.compile(r"([Zz]|[+-]\d{2}(:?\d{2}(:?\d{2}(\.\d+)?)?)?)$")
_CLOCK = re.compile(r"([\d:]+)(?:[.,](\d+))?")


def _parse_time(text: str, option: str) -> int:
    value = text.strip()
    try:
        number = Decimal(value)
    except InvalidOperation:
        number = None
    if number is not None:
        if not number.is_finite():
            raise ValueError(f"{option} {text}: not a finite time")
        if value.isdigit() and MIN_EPOCH_NS <= int(value) <= MAX_EPOCH_NS:
            return int(value)
        if not 0 <= number < MAX_EPOCH_S + 1:  # to the last nanosecond of 9999
            raise ValueError(
                f"{option} {text}: out of range: epoch seconds go from 0 to {MAX_EPOCH_S} (year 9999), "
                f"epoch nanoseconds (a whole number) from {MIN_EPOCH_NS} to {MAX_EPOCH_NS}"
            )
        return int(number.scaleb(9).to_integral_value())
    try:
        moment = datetime.fromisoformat(re.sub(r"[Zz]$", "+00:00", value))  # RFC 3339 allows a lowercase z
    except ValueError:
        raise ValueError(
            f"{option}: time {text!r} is neither ISO 8601 (2026-11-21T15:20:00Z) nor seconds since the epoch"
        ) from None
    if moment.tzinfo is None:
        moment = moment.replace(tzinfo=timezone.utc)
    ns = (moment - EPOCH) // timedelta(microseconds=1) * 1000
    if not 0 <= ns < (MAX_EPOCH_S + 1) * 10**9:
        raise ValueError(f"{option} {text}: out of range: a log holds times from 1970 to the end of year 9999 UTC")
    return ns
