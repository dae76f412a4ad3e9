"""The MCAP channels of the Discern log: topics, message models and their JSON Schemas.

Shared by the writer and the reader so the two cannot drift. Every channel is
JSON with a JSON Schema generated from the same pydantic model the zenoh
protocol uses, which is what Foxglove needs to open the file.
"""

from __future__ import annotations

import copy
import json
from functools import lru_cache
from typing import Optional

from pydantic import BaseModel, Field

from discern.rules.scene import Proposal
from discern.rules.verdict import Verdict

from ..status import MonitorStatus

MESSAGE_ENCODING = "json"
SCHEMA_ENCODING = "jsonschema"
STATUS_TOPIC = "/discern/status"


class RejectedInput(BaseModel):
    """A payload the monitor refused: kept (cut short) so an audit can see what was sent."""

    vehicle: str
    key: str = Field(description="zenoh key it arrived on")
    size: int = Field(description="payload size in bytes")
    error: str
    excerpt: str = Field(description="the payload's first bytes, decoded leniently")


# kind -> (schema name, model)
CHANNEL_KINDS: dict[str, tuple[str, type[BaseModel]]] = {
    "proposal": ("discern.Proposal", Proposal),
    "verdict": ("discern.Verdict", Verdict),
    "rejected": ("discern.RejectedInput", RejectedInput),
    "status": ("discern.MonitorStatus", MonitorStatus),
}
SCHEMA_NAMES = {name: kind for kind, (name, _) in CHANNEL_KINDS.items()}


def vehicle_topic(vehicle: str, kind: str) -> str:
    return f"/discern/{vehicle}/{kind}"


def parse_topic(topic: str) -> Optional[tuple[Optional[str], str]]:
    """(vehicle, kind) of a Discern topic, or None for a topic this log does not write."""
    if topic == STATUS_TOPIC:
        return None, "status"
    parts = topic.split("/")
    if len(parts) == 4 and parts[0] == "" and parts[1] == "discern" and parts[3] in CHANNEL_KINDS and parts[2]:
        return parts[2], parts[3]
    return None


@lru_cache(maxsize=None)
def schema_bytes(kind: str) -> bytes:
    """The model's JSON Schema with references inlined: Foxglove reads plain nested objects best.

    A recursive reference (the justification tree's children) is left as a
    generic object rather than expanded forever.
    """
    _, model = CHANNEL_KINDS[kind]
    schema = model.model_json_schema(by_alias=True)
    defs = schema.pop("$defs", {})

    def inline(node, stack: tuple[str, ...]):
        if isinstance(node, dict):
            ref = node.get("$ref")
            if isinstance(ref, str) and ref.startswith("#/$defs/"):
                name = ref.split("/")[-1]
                if name in stack:
                    return {"type": "object", "title": name, "description": f"a {name} (recursive)"}
                target = copy.deepcopy(defs[name])
                target.update({k: v for k, v in node.items() if k != "$ref"})
                return inline(target, stack + (name,))
            return {k: inline(v, stack) for k, v in node.items()}
        if isinstance(node, list):
            return [inline(v, stack) for v in node]
        return node

    return json.dumps(inline(schema, ()), separators=(",", ":")).encode()
