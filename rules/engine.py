"""The reasoner: scene + proposal -> verdict with its justification.

One clingo Control per frame, fed the catalog's pre-parsed AST: measured
faster and flatter in memory than a long-lived multi-shot Control. Callers
with many frames at hand (a busy sidecar worker, the audit replay) ground
them together in one Control (batch.py): same answers, a fraction of the
per-frame cost.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Iterable, Mapping, Optional, Sequence, Union

import clingo
from clingo import Function
from clingo import ast

from .answer_set import AnswerSet, show_statements
from .batch import BatchAnswers, FrameAnswers, FrameTagger
from .catalog import VERDICT_CONSTANTS, Catalog, frame_predicates, load_catalog, static_fact_refused
from .fact_text import fact_names
from .facts import FactProvider, Params, scene_facts
from .justify import Prover, rule_ids
from .presence import PresenceSlicer
from .render import render_text
from .scene import Action, Scene
from .verdict import Decision, Justification, JustificationNode, Verdict

VETO_DEPTH = 4  # levels of a veto's proof when no explanation was asked for
# A rule that forbids the proposal for several reasons (three hazards) shows each: the first ones proved, the next
# ones named with the rules they rest on, and that there are more (a 200-object frame may hold dozens).
REASONS_PROVED = 1
REASONS_NAMED = 4

RANK = [
    Action.turn_left,
    Action.turn_right,
    Action.pull_over,
    Action.change_lane_left,
    Action.change_lane_right,
    Action.brake,
    Action.accelerate,
    Action.cruise,
]


JURISDICTIONS = ("us", "uk")


def jurisdiction_pack(name: str) -> Path:
    """The rule pack of a jurisdiction (rules/jurisdictions/<name>.lp): traffic side, zone limits, turn on red."""
    key = str(name).strip().lower()
    if key not in JURISDICTIONS:
        raise ValueError(f"unknown jurisdiction {name!r}: choose from {', '.join(JURISDICTIONS)}")
    return Path(str(resources.files("discern.rules") / "jurisdictions" / f"{key}.lp"))


class SolvedFrame:
    """The solved frame: model plus what the verdict needs from it."""

    READS = VERDICT_CONSTANTS

    def __init__(self, answer: AnswerSet, proposed: Action, owns: Optional[clingo.Control] = None):
        self.answer = answer
        self.proposed = proposed
        self.owns = owns  # the Control that only this frame uses, to retire once its verdict is made
        permitted = answer.constants("permitted")
        self.permitted = [a for a in Action if a.value in permitted]
        self.recommended = _best_ranked(answer.constants("recommended"))
        self.replacement = _best_ranked(answer.constants("replacement"))  # only where the proposal is forbidden


@dataclass(frozen=True)
class Request:
    """One frame to decide: what `Reasoner.decide` takes, for `decide_many`."""

    scene: Scene
    proposed: Action
    history: Sequence[Scene] = ()
    explain: bool = False
    shadow: bool = False
    vehicle: str = "ego"


class Reasoner:
    def __init__(
        self,
        catalog: Optional[Catalog] = None,
        params: Params = Params(),
        providers: Iterable[FactProvider] = (),
        jurisdiction: str = "us",
    ):
        """`jurisdiction` picks the rule pack loaded with the shipped catalog; a given catalog is used as is.

        `providers` add facts beyond the scene's (the sanity layer's window: `discern.sanity.default_providers`);
        without them the sanity rules that read the window never fire."""
        self.jurisdiction = jurisdiction
        self.providers = list(providers)
        self.catalog = catalog if catalog is not None else load_catalog(
            extra_files=[jurisdiction_pack(jurisdiction)], providers=self.providers)
        # what a frame may give, once: a veto's proof asks it of every exception it meets
        self.frame_predicates = frame_predicates(self.providers)
        self.params = params
        self._param_facts = params.facts()
        self._param_names = fact_names(self._param_facts)
        self.slicer = PresenceSlicer(self.catalog, self._param_facts, self._param_names)
        for provider in self.providers:
            bind = getattr(provider, "bind", None)
            if bind is not None:  # what the catalog says of things the frames do not (sanity.window.Bodies)
                bind(self.slicer.static_atoms, params)
        self._tagger = FrameTagger(self.catalog, shared=self._param_names, specializer=self.slicer.specializer)
        self._controls = self.slicer.controls
        self._static_atoms: dict = {}  # shared by the proofs of all its frames (justify.Prover)

    def solve(self, scene: Scene, proposed: Action, history: Sequence[Scene] = ()) -> SolvedFrame:
        proposed = Action(proposed)
        return self._solve_text(self.frame_facts(scene, proposed, history), proposed)

    def solve_many(self, frames: Sequence[tuple[Scene, Action, Sequence[Scene]]]) -> list[SolvedFrame]:
        """Solve (scene, proposed, history) frames in one grounding; each answer is the frame's solo answer."""
        return self.solve_facts(
            [self.frame_facts(scene, Action(proposed), history) for scene, proposed, history in frames],
            [Action(proposed) for _, proposed, _ in frames],
        )

    def solve_facts(self, texts: Sequence[str], proposed: Sequence[Action]) -> list[SolvedFrame]:
        """Solve frames given by their `frame_facts` in one grounding (for callers that keyed frames on them)."""
        if len(texts) == 1:
            return [self._solve_text(texts[0], Action(proposed[0]))]
        facts = self._tagger.batch(texts)
        ctl = clingo.Control(["--warn=none"])
        with ast.ProgramBuilder(ctl) as builder:
            for statement in self._tagger.program(self.catalog.program_for(self._param_names.union(facts.names))):
                builder.add(statement)
        ctl.add("base", [], self._param_facts + facts.program() + show_statements(SolvedFrame.READS, 2))
        ctl.ground([("base", [])], context=facts)
        batch = BatchAnswers(ctl, self._tagger.static, SolvedFrame.READS)
        defined = self.catalog.defined_in(self._param_names.union(facts.names))
        return [
            SolvedFrame(FrameAnswers(batch, k, text, defined), Action(action))
            for k, (text, action) in enumerate(zip(texts, proposed))
        ]

    def _solve_text(self, text: str, proposed: Action) -> SolvedFrame:
        names = self.predicates_of(text)
        given = names - self._param_names  # the frame's own: the parameters are not in its fact text
        ctl = self.slicer.ground(names, text)
        # A single frame's few permitted and recommended atoms are read one by one: a solve call to read them
        # shown would first prepare the whole ground program (measured: 0.27 against 0.17 ms on KITTI frames,
        # 0.67 against 0.13 ms at 200 objects). A batch reads them shown, all frames in one solve.
        return SolvedFrame(AnswerSet(ctl, text, self.catalog.defined_in(names), given), proposed, owns=ctl)

    def predicates_of(self, text: str) -> frozenset[str]:
        """The predicates a frame's program uses: its facts' (`frame_facts`) and the parameters'.

        The facts may not give a parameter: the rules clingo grounds have the reasoner's put in (specialize.py).
        """
        own = fact_names(text)
        given = own & self._param_names
        if given:
            raise static_fact_refused(min(given))
        return own | self._param_names

    def frame_facts(self, scene: Scene, proposed: Action, history: Sequence[Scene]) -> str:
        """The frame's own facts: the scene, the proposal, and what the providers read from the history.

        With the catalog and the parameters, they are all the solver sees: equal facts, equal answer sets.
        """
        return scene_facts(scene, proposed) + "".join(p.facts(scene, history) for p in self.providers)

    def decide_many(self, requests: Sequence[Request], facts: Optional[Sequence[str]] = None) -> list[Verdict]:
        """Decide many frames with one grounding; each verdict's latency runs from the batch's start to it.

        `facts`: the requests' `frame_facts`, when the caller has them already.
        """
        start = time.perf_counter()
        if facts is None:
            solved = self.solve_many([(r.scene, Action(r.proposed), r.history) for r in requests])
        else:
            solved = self.solve_facts(facts, [Action(r.proposed) for r in requests])
        verdicts = [self._verdict(r, s, start) for r, s in zip(requests, solved)]
        for s in solved:
            if s.owns is not None:
                self._controls.retire(s.owns)
        return verdicts

    def decide(
        self,
        scene: Union[Scene, Mapping],
        proposed: Action,
        history: Sequence[Scene] = (),
        explain: bool = False,
        shadow: bool = False,
        vehicle: str = "ego",
    ) -> Verdict:
        """Takes a scene as JSON (a dict) too, as `Monitor.check` does: validated first, refused by field."""
        if not isinstance(scene, Scene):
            scene = Scene.model_validate(scene)
        return self.decide_many([Request(scene, Action(proposed), history, explain, shadow, vehicle)])[0]

    def prepare(self, limit: Optional[int] = None) -> int:
        """Use idle time: ready up to `limit` Controls the next frames will likely need (controls.py); returns how many."""
        return self._controls.prepare(limit)

    def _verdict(self, request: Request, solved: SolvedFrame, start: float) -> Verdict:
        scene, proposed, explain, shadow = request.scene, solved.proposed, request.explain, request.shadow
        # A veto always carries its proof; the full depth (every definition down to the facts) on request.
        static_atoms, given = self._static_atoms, self.frame_predicates
        prover = Prover(self.catalog, solved.answer, static_atoms=static_atoms, given=given) if explain else Prover(
            self.catalog, solved.answer, max_depth=VETO_DEPTH, negative_depth=1, static_atoms=static_atoms, given=given
        )
        allowed = proposed in solved.permitted
        recommended = solved.recommended
        if allowed:
            decision, action = Decision.approve, proposed
        elif shadow:
            decision, action = Decision.veto, proposed
        else:
            # A catalog written before replacement/1 (an edited copy given with --rules) overrides as it did then.
            decision, action = Decision.override, solved.replacement or recommended or Action.brake

        tree: list[JustificationNode] = []
        rules: list[str] = []
        vetoing: list[str] = []  # the rules that forbid the proposal itself; the rest of `rules` feed them
        if allowed:
            rules = self._approval_rules(solved, prover)
            if explain:  # every rule the approval cites, proved: permitted, and each reason calling for it
                tree.append(prover.why(_atom("permitted", proposed)))
                applicable = _atom("applicable", proposed)
                if applicable in self.catalog.fact_rule:  # called for by a fact of the catalog (cruise.default)
                    tree.append(prover.why(applicable))
                tree.extend(prover.node_for(rule, env, applicable) for rule, env in prover.derivations(applicable))
        else:
            forbidden = _atom("forbidden", proposed)
            for rule, envs, more in prover.instances(forbidden, REASONS_NAMED):
                if rule.info.id not in vetoing:  # one id, two bodies (acc.lane_not_clear)
                    vetoing.append(rule.info.id)
                for k, env in enumerate(envs):
                    node = prover.node_for(rule, env, forbidden, 0 if k < REASONS_PROVED else prover.max_depth - 1)
                    tree.append(node)
                    rules.extend(r for r in rule_ids(node) if r not in rules)
                if more:
                    tree.append(JustificationNode(literal=str(forbidden), holds=True, rule=rule.info.id,
                                                  text=f"and more instances of rule {rule.info.id}"))
            rules = vetoing + [r for r in rules if r not in vetoing]
        if decision is Decision.override and solved.replacement is not None:
            tree.append(prover.why(_atom("replacement", solved.replacement)))
        elif recommended is not None and (explain or not allowed):
            tree.append(prover.why(_atom("recommended", recommended)))
        elif decision is Decision.override:  # the rules recommend nothing: say what the brake rests on
            tree.append(JustificationNode(
                literal="not recommended(_)", holds=True, kind="absent",
                text="there is no evidence that any action is recommended: the monitor brakes, the most cautious action"))

        noted_from = len(rules)  # the notes' own rules follow: the summary names them apart
        notes = solved.answer.of("noted", 1)
        brief = (Prover(self.catalog, solved.answer, negative_depth=0, static_atoms=static_atoms, given=given)
                 if notes and explain else prover)
        for note in notes:
            # What the sanity layer set aside or doubted (noted/1): its rules with every verdict, its proof on request;
            # a veto's tree states it as a leaf, so that every rule the verdict cites is in its justification.
            atom = note.arguments[0]
            if explain:
                node = brief.why(atom)
                tree.append(node)
                found = rule_ids(node)
            else:
                found = prover.deriving_rules(atom)
                if tree:
                    rule_id = found[0] if found else None
                    tree.append(JustificationNode(literal=str(atom), holds=True, text=prover.phrases.atom(atom, rule_id),
                                                  rule=rule_id))
            rules.extend(r for r in found if r not in rules)
        # after the notes: the one line names every rule the verdict cites (the audit lists it alone)
        summary = _summary(decision, proposed, action, recommended, rules, len(vetoing), noted_from)
        justification = Justification(summary=summary, tree=tree)
        justification.text = render_text(justification)
        return Verdict(
            vehicle=request.vehicle,
            frame_id=scene.frame_id,
            timestamp=scene.timestamp,
            decision=decision,
            proposed=proposed,
            action=action,
            recommended=recommended,
            permitted=solved.permitted,
            rules=rules,
            vetoed_by=vetoing,
            justification=justification,
            latency_ms=(time.perf_counter() - start) * 1000.0,
            notes=list(scene.notes),
            shadow=shadow,
        )

    def _approval_rules(self, solved: SolvedFrame, prover: Prover) -> list[str]:
        """An approval rests on dec.permitted, plus whatever called for the action."""
        rules = ["dec.permitted"]
        applicable = _atom("applicable", solved.proposed)
        if solved.answer.holds(applicable):
            rules.extend(r for r in prover.deriving_rules(applicable) if r not in rules)
        return rules


def _best_ranked(names: set[str]) -> Optional[Action]:
    return next((a for a in RANK if a.value in names), None)


def _atom(name: str, action: Action) -> clingo.Symbol:
    return Function(name, [Function(action.value)])


def _summary(decision: Decision, proposed: Action, action: Action, recommended: Optional[Action], rules: list[str],
             vetoing: int, noted_from: int) -> str:
    """A veto names the rules that forbid the proposal, then those its proof uses (a hazard, a limit's reading), and
    last, apart, the rules of what the sanity layer noted (`rules[noted_from:]`): a car set aside elsewhere in the
    scene is no reason for the decision."""
    decided, noted = rules[:noted_from], rules[noted_from:]
    cited = ", ".join(decided[:vetoing] if vetoing else decided) if decided else "no rule"
    if vetoing and len(decided) > vetoing:
        cited += f", using {', '.join(decided[vetoing:])}"
    if decision is Decision.approve:
        line = f"approve {proposed.value}: permitted ({cited})"
    elif decision is Decision.veto:
        line = f"veto {proposed.value}: forbidden by {cited} (shadow mode, not enforced)"
    else:
        line = f"override {proposed.value} with {action.value}: {proposed.value} is forbidden by {cited}"
    if recommended is not None and recommended is not action:
        line += f"; recommended: {recommended.value}"
    if noted:
        line += f"; noted: {', '.join(noted)}"
    return line

