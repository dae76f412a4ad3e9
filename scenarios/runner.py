"""Run scenario files against the rules and report where verdicts differ from expectations."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable, Optional

from pydantic import ValidationError

from discern.monitor.protocol import MAX_ERRORS_NAMED
from discern.rules.engine import Reasoner
from discern.rules.scene import describe_errors
from discern.rules.verdict import Verdict

from .model import Expectation, Scenario


class ScenarioError(ValueError):
    """A scenario file that cannot be read."""


@dataclass
class FrameOutcome:
    scenario: str
    index: int
    verdict: Optional[Verdict]  # None: deciding the frame raised, which `problems` says
    problems: list[str] = field(default_factory=list)
    checked: bool = True  # False: a history frame, whose `expect` is empty

    @property
    def passed(self) -> bool:
        return not self.problems


def check(verdict: Verdict, expect: Expectation) -> list[str]:
    problems = []
    if expect.decision is not None and verdict.decision is not expect.decision:
        problems.append(f"decision {verdict.decision.value}, expected {expect.decision.value}")
    if expect.action is not None and verdict.action is not expect.action:
        problems.append(f"action {verdict.action.value}, expected {expect.action.value}")
    if expect.recommended is not None and verdict.recommended is not expect.recommended:
        got = verdict.recommended.value if verdict.recommended else "none"
        problems.append(f"recommended {got}, expected {expect.recommended.value}")
    for rule in expect.rules:
        if rule not in verdict.rules:
            problems.append(f"rule {rule} not among {verdict.rules}")
    problems.extend(f"rule {rule} among {verdict.rules}, expected absent" for rule in expect.absent_rules
                    if rule in verdict.rules)
    full = None  # what the proof says, every line: the text folds and cuts what does not decide
    for phrase in expect.text_contains:
        if phrase in verdict.justification.text:
            continue
        if full is None:
            full = verdict.justification.full_text()
        if phrase not in full:
            problems.append(f"justification lacks {phrase!r}")
    return problems


def load(path: Path) -> Scenario:
    try:
        return Scenario.load(path)
    except ValidationError as exc:
        # the first problems, as `discern check` and the monitor name them: a scene given here fails on every field
        raise ScenarioError(_other_kind(path) or f"{path}:\n{describe_errors(exc, limit=MAX_ERRORS_NAMED)}") from None
    except OSError as exc:
        raise ScenarioError(f"{path}: {exc.strerror}") from None
    except UnicodeDecodeError as exc:
        raise ScenarioError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None


def _other_kind(path: Path) -> Optional[str]:
    """What to do with a scene or a proposal given as a scenario file, which `discern check` judges; None for others."""
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8-sig"))
    except (OSError, UnicodeDecodeError, ValueError, RecursionError):
        return None
    if not isinstance(data, dict) or "frames" in data:
        return None
    if "scene" in data:  # as `discern check` tells the two apart
        return f"{path}: a proposal, not a scenario file: `discern check {path}` judges it"
    if "ego" in data:
        return f"{path}: a scene, not a scenario file: `discern check {path} --proposed ACTION` judges it"
    return None


def run(scenario: Scenario, reasoner: Reasoner) -> list[FrameOutcome]:
    outcomes = []
    history = []
    for index, frame in enumerate(scenario.frames):
        try:
            verdict = reasoner.decide(frame.scene, frame.proposed, history=tuple(history), explain=True)
        except Exception as exc:  # a frame the engine cannot judge is a failed frame, not the end of the run
            outcomes.append(FrameOutcome(scenario.name, index, None, [f"deciding the frame raised {type(exc).__name__}: {exc}"]))
        else:
            outcomes.append(FrameOutcome(scenario.name, index, verdict, check(verdict, frame.expect),
                                         not frame.expect.empty))
        history.append(frame.scene)
    return outcomes


def scenario_files(directory: Path) -> list[Path]:
    """The scenario files a directory holds, subdirectories too."""
    return sorted(Path(directory).rglob("*.json"))


def run_files(files: Iterable[Path], reasoner_for: Callable[[str], Reasoner]) -> tuple[list[FrameOutcome], list[str]]:
    """The outcomes of the files that can be read, and why each other one cannot: a broken file does not hide the
    verdicts of the rest, nor the next broken file."""
    outcomes: list[FrameOutcome] = []
    unreadable: list[str] = []
    for path in files:
        try:
            scenario = load(path)
        except ScenarioError as exc:
            unreadable.append(str(exc))
            continue
        outcomes.extend(run(scenario, reasoner_for(scenario.jurisdiction)))
    return outcomes, unreadable
