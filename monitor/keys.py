"""Zenoh key expressions of the Discern protocol (docs/protocol.md).

One vehicle, one key chunk: ``discern/<vehicle>/proposal`` (publish) and
``discern/<vehicle>/check`` (query) in, ``discern/<vehicle>/verdict`` out.
The vehicle is always read from the key, so a verdict can be addressed even
when the payload is garbage; a key of any other shape names no vehicle.
"""

from __future__ import annotations

from typing import Optional

import zenoh

from discern.rules.scene import valid_id

from .config import without_rust_locations

PREFIX = "discern"


def proposal_key(vehicle: str) -> str:
    return f"{PREFIX}/{vehicle}/proposal"


def check_key(vehicle: str) -> str:
    return f"{PREFIX}/{vehicle}/check"


def verdict_key(vehicle: str) -> str:
    return f"{PREFIX}/{vehicle}/verdict"


def status_key(monitor_id: str) -> str:
    return f"{PREFIX}/monitor/{monitor_id}/status"


PROPOSAL_KINDS = ("proposal", "check")
# A query on a check key with this parameter and no payload asks whether a monitor answers for the vehicle, through
# whatever access control lies between (Monitor.wait_for_monitor): it is answered with the monitor's id, not judged.
PROBE = "probe"


def vehicle_of(key: str) -> Optional[str]:
    """The vehicle chunk of ``discern/<vehicle>/proposal`` or ``discern/<vehicle>/check``; None for any other key."""
    parts = key.split("/")
    return parts[1] if len(parts) == 3 and parts[0] == PREFIX and parts[2] in PROPOSAL_KINDS else None


def is_wild(key: str) -> bool:
    """Whether a key expression has a wildcard chunk ('*', '**', 'a$*'): then it names no one vehicle."""
    return "*" in key  # a concrete zenoh key never holds one


def vehicle_selector(pattern: str) -> str:
    """Turn a shell-style vehicle filter ('fleet_a_*') into one zenoh key chunk ('fleet_a_$*')."""
    return _chunk_selector(pattern, "vehicle filter")


def filters_overlap(first: str, second: str) -> bool:
    """Whether two monitors' vehicle chunks (vehicle_selector's) both match some vehicle: it would get verdicts from
    either, frame to frame."""
    try:
        return zenoh.KeyExpr(check_key(first)).intersects(zenoh.KeyExpr(check_key(second)))
    except zenoh.ZError:  # a status from a monitor of another version or make, its filter no key chunk: no telling
        return False


def overlap_warning(first: str, first_filter: str, second: str, second_filter: str) -> str:
    return (f"monitors {first} (vehicles {first_filter}) and {second} (vehicles {second_filter}) both serve some "
            "vehicles: a planner that reaches both gets verdicts from either, frame to frame; keep the --vehicles "
            "filters disjoint")


def monitor_selector(pattern: str) -> str:
    """The same for monitor ids: `discern status --id 'shard_*'` asks every shard."""
    return _chunk_selector(pattern, "monitor id")


def _chunk_selector(pattern: str, what: str) -> str:
    """One zenoh key chunk from a shell-style pattern; ValueError, naming `what`, if it cannot be one.

    A chunk that is already a zenoh wildcard ('*', or using '$*') is kept, so
    both spellings work on the command line.
    """
    pattern = pattern.strip()
    if not pattern:  # an unset shell variable, most likely
        raise ValueError(f"{what} is empty: give one key chunk, or '*' for all")
    if "/" in pattern:
        raise ValueError(f"{what} {pattern!r} must be one key chunk (no '/')")
    if "**" in pattern:  # zenoh's '**' spans any number of chunks: discern/a/b/check would match it
        raise ValueError(f"{what} {pattern!r} must be one key chunk: '**' matches several, use '*'")
    if not all(valid_id(part) for part in pattern.replace("$*", "*").split("*") if part):
        # '?' or '[12]' would be taken literally, and no id holds them: a filter that matches nothing
        raise ValueError(f"{what} {pattern!r} may hold only letters, digits, '_', '-' and the wildcard '*'")
    if pattern != "*" and "$*" not in pattern:
        pattern = pattern.replace("*", "$*")
    try:
        return str(zenoh.KeyExpr.autocanonize(f"{PREFIX}/{pattern}/x")).split("/")[1]
    except zenoh.ZError as exc:
        reason = without_rust_locations(str(exc).rpartition("`: ")[2])  # after zenoh's quote of the whole key
        raise ValueError(f"{what} {pattern!r} is not a valid key chunk: {reason}") from None
