"""The scenario file format: a sequence of frames with the verdicts they should get."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from discern.rules.engine import jurisdiction_pack
from discern.rules.scene import JSON_AS_SCHEMA, Action, Scene
from discern.rules.verdict import Decision


class Expectation(BaseModel):
    model_config = ConfigDict(extra="forbid")

    decision: Optional[Decision] = None
    action: Optional[Action] = Field(None, description="the action the verdict executes")
    recommended: Optional[Action] = None
    rules: list[str] = Field(default_factory=list, description="rule ids that must appear in verdict.rules")
    text_contains: list[str] = Field(default_factory=list, description="phrases the justification must contain")
    absent_rules: list[str] = Field(default_factory=list, description=(
        "rule ids that must not be in verdict.rules: a note, which changes no decision, may misstate what happened"))

    @property
    def empty(self) -> bool:
        """Expects nothing: its frame is history for the frames after it, not checked."""
        return not (self.decision or self.action or self.recommended or self.rules or self.text_contains
                    or self.absent_rules)


class ScenarioFrame(BaseModel):
    model_config = ConfigDict(extra="forbid")

    scene: Scene
    proposed: Action
    expect: Expectation


class Scenario(BaseModel):
    """Frames run in order; earlier frames are the history of later ones."""

    model_config = ConfigDict(extra="forbid")

    name: str
    description: str
    source: str
    jurisdiction: str = "us"
    frames: list[ScenarioFrame] = Field(min_length=1)

    @field_validator("jurisdiction")
    @classmethod
    def _known_jurisdiction(cls, name: str) -> str:
        """Checked as the file is read, so the file is named and the others still run: met only when its frames
        were decided, an unknown pack stopped the whole run without saying which file named it."""
        jurisdiction_pack(name)
        return name

    @model_validator(mode="after")
    def _checks_something(self) -> "Scenario":
        """A scenario whose frames expect nothing passes whatever the rules decide."""
        if all(frame.expect.empty for frame in self.frames):
            raise ValueError("no frame expects anything (an empty `expect` marks a history frame): it would always pass")
        return self

    @classmethod
    def load(cls, path: Path) -> "Scenario":
        """Read as `discern check` reads a scene: a byte-order mark, as some Windows editors write, is no error."""
        return cls.model_validate_json(Path(path).read_text(encoding="utf-8-sig"), **JSON_AS_SCHEMA)
