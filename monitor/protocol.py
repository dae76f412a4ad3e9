"""Wire format of the sidecar: the core's Proposal in, the core's Verdict out, as JSON.

There is no second copy of the format here: the pydantic models of
`discern.rules.scene` and `discern.rules.verdict` are the schema. This module
only turns bytes into a Proposal with an error message a person can act on,
and builds the fail-safe verdicts the monitor owes when it cannot judge.

Messages off the wire are decoded strictly, as the published JSON Schema
reads them: pydantic's lax mode would take `"25"` for a speed, `true` or `"7"`
for a frame id and `"yes"` for a flag, which the schema refuses (a JSON integer
is still a number wherever one is expected).
"""

from __future__ import annotations

import re
from typing import Iterable, Optional

from pydantic import BaseModel, ValidationError

from discern.rules.scene import ID_RULE, JSON_AS_SCHEMA, MAX_FRAME_ID, MAX_ID_LENGTH, Action, Proposal, describe_errors, valid_id
from discern.rules.verdict import Decision, Justification, Verdict


# Most cautious first: what a fail-safe verdict picks among the permitted actions.
CAUTION_ORDER = (
    Action.brake,
    Action.cruise,
    Action.pull_over,
    Action.change_lane_right,
    Action.change_lane_left,
    Action.turn_right,
    Action.turn_left,
    Action.accelerate,
)

RULE_BAD_INPUT = "monitor.bad_input"
RULE_DEADLINE = "monitor.deadline"
RULE_INTERNAL_ERROR = "monitor.internal_error"
RULE_NO_ANSWER = "monitor.no_answer"
# What each fail-safe rule says, as the catalog's rules say it: the audit's per-rule table shows them alike.
FAILSAFE_RULES = {
    RULE_BAD_INPUT: "A proposal the monitor cannot read or refuses (malformed, out of order, too large) gets a "
                    "fail-safe brake, with the problem named.",
    RULE_DEADLINE: "A proposal the rules did not decide within the budget gets the most cautious permitted "
                   "action, else brake.",
    RULE_INTERNAL_ERROR: "A proposal whose decision failed inside Discern gets the most cautious permitted action, "
                         "else brake.",
    RULE_NO_ANSWER: "A planner that gets no readable verdict in time (no monitor, a lost reply) brakes.",
}

MAX_ERRORS_NAMED = 5


class InputError(ValueError):
    """A proposal the monitor refuses to judge; the message names the problem."""

    def __init__(self, message: str, kind: str):
        super().__init__(message)
        self.kind = kind  # short tag for counting: json, schema, size, vehicle, order


def describe_validation_error(exc: ValidationError) -> str:
    """The core's one-line-per-problem description, first few problems, on one line."""
    return "; ".join(describe_errors(exc, limit=MAX_ERRORS_NAMED).splitlines())


def invalid_vehicle(vehicle: str) -> str:
    """Why a key's vehicle is no vehicle id, the id shown short: it may be thousands of characters."""
    shown = repr(vehicle) if len(vehicle) <= 40 else f"{vehicle[:40]!r}... ({len(vehicle)} characters)"
    if len(vehicle) > MAX_ID_LENGTH:
        return f"vehicle {shown} in the key is not a valid vehicle id: longer than {MAX_ID_LENGTH} characters"
    return f"vehicle {shown} in the key is not a valid vehicle id ({ID_RULE})"


def invalid_proposal(exc: ValidationError, payload: bytes) -> InputError:
    """Why a payload is no proposal, as the monitor refuses it (and the client, checking before it sends)."""
    first = exc.errors(include_url=False, include_input=False)[0] if exc.error_count() == 1 else None
    if first is not None and first["type"] == "json_invalid":  # malformed JSON is one error, never more
        return InputError(f"malformed JSON: {_json_problem(first['msg'].removeprefix('Invalid JSON: '), payload)}",
                          "json")
    return InputError(f"schema violation: {describe_validation_error(exc)}", "schema")


_AT = re.compile(r" at line (\d+) column (\d+)$")
# A key (group 2: its colon), a string, a bracket or a comma: enough of JSON to tell where in the document a key is.
# A string left open runs to the end of the payload, so that each byte is scanned once: tried again from each quote
# inside it, as a plain `"..."` is, a payload of escaped quotes took seconds (17 KB) to hours (1 MB).
_TOKEN = re.compile(rb'"((?:[^"\\]++|\\.)*+)(?:"(\s*:)?|\\?\Z)|[{}\[\],]', re.DOTALL)
_SURROGATE = re.compile(rb"\\u[dD][89a-fA-F][0-9a-fA-F]{2}")


def _json_problem(message: str, payload: bytes) -> str:
    """The decoder's message, and for a bad value the field that holds it: a number past any bound, a lone
    surrogate (half of a UTF-16 pair, no character, which the decoder calls an unexpected end of hex escape)."""
    at = _AT.search(message)
    if at is None or not ("number" in message or "escape" in message):
        return message
    line, column = int(at[1]), int(at[2])
    offset = sum(len(text) + 1 for text in payload.split(b"\n", line - 1)[:line - 1]) + column - 1
    if "hex escape" in message:
        lone = [m for m in _SURROGATE.finditer(payload, max(0, offset - 12), offset + 1)]
        if lone:
            message = f"lone surrogate {lone[-1].group().decode()} in a string, no character{at.group()}"
    where = _field_at(payload, offset)
    return f"{where}: {message}" if where else message


def _field_at(payload: bytes, offset: int) -> str:
    """The field path (`scene.notes.0`) of the value at `offset` in a JSON document."""
    path: list = []  # per open container: its current key, or its current index
    for token in _TOKEN.finditer(payload, 0, offset):
        text = token.group(0)
        if token.group(2) and path:
            path[-1] = token.group(1).decode("utf-8", "replace")[:64]
        elif text in (b"{", b"["):
            path.append(0 if text == b"[" else "")
        elif text in (b"}", b"]") and path:
            path.pop()
        elif text == b"," and path and isinstance(path[-1], int):
            path[-1] += 1
    return ".".join(str(part) for part in path if part != "")


def decode_proposal(payload: bytes, key_vehicle: str) -> Proposal:
    """Validate a proposal that arrived on ``discern/<key_vehicle>/...``.

    The key names the vehicle; a payload that names another one is refused, one
    that names none takes the key's.
    """
    if not valid_id(key_vehicle):
        raise InputError(invalid_vehicle(key_vehicle), "vehicle")
    try:
        proposal = Proposal.model_validate_json(payload, **JSON_AS_SCHEMA)
    except ValidationError as exc:
        raise invalid_proposal(exc, payload) from None
    if "vehicle" not in proposal.model_fields_set:
        proposal.vehicle = key_vehicle
    elif proposal.vehicle != key_vehicle:
        raise InputError(
            f"vehicle: payload names {proposal.vehicle!r} but it was sent on the key of {key_vehicle!r}",
            "vehicle",
        )
    return proposal


# A number ended by what may follow a value: one cut off (an oversized payload's head) is none.
_NUMBER = re.compile(rb'\s*(-?\d{1,20}(?:\.\d{1,20})?(?:[eE][+-]?\d{1,3})?)(?=\s*[,}])')
_WORD = re.compile(rb'\s*"([a-z_]{1,32})"')
PEEK_TOKENS = 4096  # of a payload looked at: a valid proposal names its frame early; a hostile one costs ~1 ms


def peek_frame(payload: Optional[bytes]) -> tuple[Optional[int], Optional[Action]]:
    """Frame id (`scene.frame_id`) and action of a proposal not parsed yet, best effort and in about a millisecond.

    Only labels a fail-safe or a refusal of a payload not parsed (or not a proposal), so the
    planner can match it to its frame; a full parse there would only deepen the backlog. Only the
    fields where the schema has them count: a `frame_id` nested elsewhere labels nothing.
    """
    frame = action = None
    inside: list[Optional[bytes]] = []  # the key of each open object or array (None: an array's item, the top)
    key = None
    for n, token in enumerate(_TOKEN.finditer(payload or b"")):
        if n == PEEK_TOKENS or (frame is not None and action is not None):
            break
        if token.group(2):
            key = token.group(1)
            if key == b"action" and len(inside) == 1:
                word = _WORD.match(payload, token.end())
                action = _action(word.group(1)) if word else None
            elif key == b"frame_id" and inside == [None, b"scene"]:
                number = _NUMBER.match(payload, token.end())
                frame = _frame_id(number.group(1)) if number else None
        elif token.group(0) in (b"{", b"["):
            inside.append(key)
            key = None
        elif token.group(0) in (b"}", b"]"):
            if inside:
                inside.pop()
            key = None
    return frame, action


def _action(word: bytes) -> Optional[Action]:
    try:
        return Action(word.decode())
    except ValueError:
        return None


def _frame_id(text: bytes) -> Optional[int]:
    """As the scene model reads it: a whole number, 8.0 too (rules.scene.WholeNumber), within its bounds."""
    value = float(text) if any(c in text for c in b".eE") else int(text)
    if isinstance(value, float):
        if not value.is_integer():
            return None
        value = int(value)
    return value if 0 <= value <= MAX_FRAME_ID else None


def most_cautious(permitted: Iterable[Action]) -> Action:
    allowed = set(permitted)
    for action in CAUTION_ORDER:
        if action in allowed:
            return action
    return Action.brake


def failsafe_verdict(
    vehicle: str,
    reason: str,
    rule: str,
    *,
    proposed: Optional[Action] = None,
    frame_id: Optional[int] = None,
    timestamp: Optional[float] = None,
    permitted: Iterable[Action] = (),
    shadow: bool = False,
) -> Verdict:
    """The conservative answer owed when no proper decision can be made in time.

    Bad input always brakes; a late or failed decision takes the most cautious
    action known to be permitted for this vehicle, else brakes. In shadow mode the
    monitor judges and never enforces: the proposed action stands (a veto) and the
    fail-safe action is only recommended; where the two are one, the summary says so
    instead of vetoing what it would do. A proposal that could not be read has no
    action to keep, so there the fail-safe action stands, and the summary says why.
    """
    safe = Action.brake if rule == RULE_BAD_INPUT else most_cautious(permitted)
    if shadow and proposed is not None:
        decision, action = Decision.veto, proposed
        summary = (
            # the planner proposed the fail-safe action itself: "veto of brake ... would brake" contradicted itself
            f"fail-safe {safe.value}, as proposed (shadow mode): {reason}" if proposed is safe
            else f"fail-safe veto of {proposed.value} (shadow mode, not enforced; would {safe.value}): {reason}"
        )
    else:
        decision, action = Decision.override, safe
        summary = f"fail-safe {safe.value}: {reason}"
        if shadow:
            summary += " (shadow mode, but no proposed action could be read to keep)"
    return Verdict(
        vehicle=vehicle[:140],
        frame_id=frame_id,
        timestamp=timestamp,
        decision=decision,
        proposed=proposed,
        action=action,
        recommended=safe,
        permitted=list(permitted),
        rules=[rule],
        vetoed_by=[rule],
        justification=Justification(summary=summary, text=summary),
        failsafe=True,
        error=reason,
        shadow=shadow,
    )


def encode(model: BaseModel) -> bytes:
    return model.model_dump_json(by_alias=True).encode()


def decode_verdict(payload: bytes) -> Verdict:
    return Verdict.model_validate_json(payload, **JSON_AS_SCHEMA)

