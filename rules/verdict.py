"""The verdict model: what the monitor answers for one proposal."""

from __future__ import annotations

from typing import Literal, Optional

from pydantic import BaseModel, ConfigDict, Field

from .scene import SCHEMA_VERSION, Action, Named, Version


class Decision(Named):
    approve = "approve"  # the proposal is permitted and executes
    override = "override"  # the proposal is forbidden; `action` replaces it
    veto = "veto"  # the proposal is forbidden; shadow mode, nothing replaced


class JustificationNode(BaseModel):
    """One step of a proof: a literal, whether it holds, why, and the rule used."""

    model_config = ConfigDict(extra="forbid")

    literal: str = Field(description="the atom or comparison this step is about, in clingo syntax with `_` for any "
                         "value; `not a(...)` where the step says there is no evidence of a(...)")
    holds: bool = Field(description="whether `literal` is true in this frame's model, on every kind of step: a "
                        "blocked step's literal is the goal its rule does not derive or the body literal that fails "
                        "(false), or the atom that rules the rule out (true)")
    text: str
    rule: Optional[str] = None
    rule_tried: Optional[str] = Field(None, description="on a reason why a goal does not hold: the id of the rule "
                                      "this reason is about, which does not derive the goal")
    kind: Literal["derived", "fact", "builtin", "absent", "blocked", "negation", "loop"] = "derived"
    children: list["JustificationNode"] = Field(default_factory=list)


class Justification(BaseModel):
    model_config = ConfigDict(extra="forbid")

    summary: str = Field(description="one line naming the deciding rules")
    text: str = Field("", description="the proof rendered as indented prose")
    tree: list[JustificationNode] = Field(default_factory=list)

    def full_text(self) -> str:
        """Every line of the proof as prose: `text` folds long lists of rules that did not apply and cuts the proofs
        that support the verdict without deciding it (`discern check --explain full` prints this)."""
        from .render import render_text  # here: render imports this module

        return render_text(self, full=True)


class Verdict(BaseModel):
    model_config = ConfigDict(extra="forbid")

    version: Version = SCHEMA_VERSION
    vehicle: str = "ego"
    frame_id: Optional[int] = None
    timestamp: Optional[float] = None
    decision: Decision
    proposed: Optional[Action] = None
    action: Action = Field(description="the action to execute")
    recommended: Optional[Action] = None
    permitted: list[Action] = Field(default_factory=list)
    rules: list[str] = Field(default_factory=list, description="ids of the rules that decided (the forbidding proofs' rules, or dec.permitted and what called for the action), then those of the sanity layer's notes: what it doubted or set aside in this frame")
    vetoed_by: list[str] = Field(default_factory=list, description="ids of the rules that forbid the proposed action, first in `rules`; empty where it is permitted")
    justification: Justification
    latency_ms: Optional[float] = None
    failsafe: bool = False
    error: Optional[str] = Field(None, description="what was wrong with the input, if anything")
    notes: list[str] = Field(default_factory=list, description="the scene's warnings: what validation or the adapter assumed or kept (scene.notes)")
    shadow: bool = False
