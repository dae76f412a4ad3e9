"""Publish the message models as JSON Schema files, generated from the one definition."""

from __future__ import annotations

import json
from pathlib import Path

from .scene import Proposal, Scene
from .verdict import Verdict

MODELS = {"scene": Scene, "proposal": Proposal, "verdict": Verdict}


def schema_of(name: str) -> dict:
    schema = MODELS[name].model_json_schema(by_alias=True)
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["$id"] = f"https://discern.dev/schema/v1/{name}.json"
    return schema


def write_schemas(directory: Path) -> list[Path]:
    directory.mkdir(parents=True, exist_ok=True)
    written = []
    for name in MODELS:
        path = directory / f"{name}.schema.json"
        path.write_text(json.dumps(schema_of(name), indent=2) + "\n", encoding="utf-8")
        written.append(path)
    return written
