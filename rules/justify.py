"""Goal-directed proof trees over clingo's answer set, in the style of s(CASP).

clingo computes the model bottom-up; people want the story top-down. The
program is stratified, so its answer set is unique and every atom in it has a
derivation by some catalog rule whose body holds in the model. The prover
replays rule bodies against the model: for an atom that holds it finds the
rule instance that derives it; for one that does not, it shows, rule by rule,
the body literal that fails ("there is no evidence that ...").
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator, Optional

from clingo import Symbol

from .answer_set import AnswerSet
from .catalog import DEFINITION_PREFIXES, SETTING_PREFIX, TRACED, Catalog, CompiledRule, frame_predicates
from .phrases import Phrasebook
from .terms import Env, Literal, Term, Unbound, Undefined, check_comparison, evaluate, is_assignment, match
from .verdict import JustificationNode

# Replaying a predicate's rules for one object costs about 0.1-0.3 ms; reading the predicate whole, about 4 us an
# object. Measured on verdicts (each frame's fastest of 7, 2026-11-27): reading was the faster up to 20 objects
# (5 objects 0.47-0.50 against 0.52-0.54 ms, 10 objects 1.31-1.32 against 1.40-1.44, the heaviest KITTI approvals
# 0.42-0.48 against 0.72-0.82), even at 30 objects (850-920 atoms) and replaying the faster at 50 (2.76-2.93
# against 3.02-3.12 ms). A frame has about 240 atoms without objects and 19 more per object. With atoms read through
# clingo's C calls (clingo_calls.py, about 1.6 us an atom), 900 was as good as any of 2000, 5000 and never replaying
# (random overrides' verdicts, 2026-11-27: 50 objects 2.38 against 2.44-2.48 ms; 200 objects 2.93 against 2.89 with
# 2000 and 3.96 with 5000 or never).
REPLAY_ABOVE_ATOMS = 900


@dataclass
class _Failure:
    depth: int
    literal: Literal
    env: Env
    witness: Optional[Symbol] = None  # the atom that holds when a negated literal fails


class Prover:
    """Builds justification trees for one solved frame."""

    def __init__(self, catalog: Catalog, answer: AnswerSet, max_depth: int = 12, negative_depth: int = 2,
                 alternatives: int = 3, static_atoms: Optional[dict[tuple[str, int, Symbol], list[Symbol]]] = None,
                 given: frozenset[tuple[str, int]] = frame_predicates()):
        """`static_atoms`: what the proofs of earlier frames of the same catalog and parameters found of the
        static predicates (`Catalog.static`), to share between them: the same in every such frame. `given`: the
        predicates a frame's facts may give (`Reasoner.frame_predicates`, its fact providers' too)."""
        self.catalog = catalog
        self.given = given
        self.answer = answer
        self.max_depth = max_depth
        self.negative_depth = negative_depth
        self.alternatives = alternatives
        self.phrases = Phrasebook(catalog, answer)
        self._replayed: dict[tuple[str, int, Symbol], list[Symbol]] = {}
        self._replays: Optional[bool] = None  # whether this frame is big enough to replay rules (REPLAY_ABOVE_ATOMS)
        self._replaying: set[int] = set()  # the recursive components (Catalog.recursion) being replayed
        # An atom's proof, built once: a veto's reasons, and the recommended action's, lean on the same facts (an
        # object's lane, the gap it needs, the hazard) again and again. A proof built nearer the root goes deeper,
        # so it serves a deeper request as well. Proof nodes are not changed once built: sharing them is safe.
        self._proved: dict[Symbol, tuple[int, JustificationNode]] = {}
        self._derivations: dict[Symbol, list[tuple[CompiledRule, Env]]] = {}
        self._static_atoms = static_atoms
        self._nothing_gives: dict[tuple, bool] = {}  # a negated literal's pattern -> whether nothing can give it

    # -- derivations --
    def derivations(self, sym: Symbol) -> Iterator[tuple[CompiledRule, Env]]:
        """Every catalog rule instance (one per rule) whose body holds and derives `sym`.

        Found once when a caller reads them all: a veto's reasons are its `forbidden` atom's derivations, and the
        replacement's proof reaches that atom again (about a tenth of a 50-object override's verdict).
        """
        found = self._derivations.get(sym)
        if found is not None:
            yield from found
            return
        found = []
        for derivation in self._derive(sym):
            found.append(derivation)
            yield derivation
        self._derivations[sym] = found  # not reached by a caller that stopped at the first

    def _derive(self, sym: Symbol) -> Iterator[tuple[CompiledRule, Env]]:
        _, name, args = self.answer.shape(sym)
        for rule in self.catalog.rules_deriving(name, len(args), args[0] if args else None):
            env = match(rule.head, sym, {}, self.answer.shape)
            if env is None:
                continue
            for solution in self._solve(list(rule.body), env, 0, None):
                yield rule, solution
                break

    def instances(self, sym: Symbol, limit: int) -> Iterator[tuple[CompiledRule, list[Env], bool]]:
        """Each catalog rule deriving `sym` with up to `limit` instances of it whose body holds, not only the first,
        and whether it has more.

        A veto names all its reasons: three hazards forbid cruising three times over, and a proof of the first
        alone would hide the red light behind the pedestrian. Counting them all replayed every object's rules on
        dense frames (200 objects: a third of the verdict), so the search stops one past the limit.
        """
        _, name, args = self.answer.shape(sym)
        for rule in self.catalog.rules_deriving(name, len(args), args[0] if args else None):
            env = match(rule.head, sym, {}, self.answer.shape)
            if env is None:
                continue
            found: list[Env] = []
            shown: set[tuple] = set()
            more = False
            for solution in self._solve(list(rule.body), env, 0, None):
                key = tuple(str(solution.get(id(lit))) for lit in rule.body if lit.is_atom and not lit.negated)
                if key in shown:  # instances that differ only in bound values no literal shows read alike
                    continue
                if len(found) == limit:
                    more = True
                    break
                shown.add(key)
                found.append(solution)
            if found:
                yield rule, found, more

    def deriving_rules(self, sym: Symbol) -> list[str]:
        """Ids of the rules with an instance that derives `sym`, an atom of the model, as `derivations` finds them.

        An atom that no fact gives, of which one catalog rule's head is capable, was derived by that rule: its
        body need not be replayed to name it (the sanity notes' rules, named with every verdict: 0.66 against
        0.09 ms on 50-object frames).
        """
        fact_rule = self.catalog.fact_rule.get(sym)
        if fact_rule:
            return [fact_rule]
        if sym.name in TRACED:  # clingo recorded which rules did: no body to replay
            return list(dict.fromkeys(rule.info.id for rule, record in self.catalog.records(sym) if self.answer.holds(record)))
        sole = self._sole_rule(sym)
        if sole is not None:
            return [sole]
        return list(dict.fromkeys(rule.info.id for rule, _ in self.derivations(sym)))  # one id, two bodies: named once

    def _sole_rule(self, sym: Symbol) -> Optional[str]:
        """The rule that derived `sym`, an atom of the model, when no fact gives it and every catalog rule whose head
        is capable of it has one id (def.safe_gap's two bodies); None where only replaying their bodies can tell."""
        _, name, args = self.answer.shape(sym)
        if name in self.catalog.fact_predicates or not self.answer.not_given(name):
            return None
        ids = {rule.info.id for rule in self.catalog.rules_deriving(name, len(args), args[0] if args else None)
               if match(rule.head, sym, {}, self.answer.shape) is not None}
        return ids.pop() if len(ids) == 1 else None

    def fired_rules(self) -> set[str]:
        """Ids of the catalog rules with at least one instance whose body holds in the model."""
        fired = set(self.catalog.fact_rule.get(sym) for sym in self.answer.all()) - {None}
        for rule in self.catalog.compiled:
            if rule.info.id not in fired and next(self._solve(list(rule.body), {}, 0, None), None) is not None:
                fired.add(rule.info.id)
        return fired

    # -- holds --
    def why(self, sym: Symbol, depth: int = 0, path: frozenset = frozenset()) -> JustificationNode:
        if sym in path:
            return JustificationNode(literal=str(sym), holds=True, text=self.phrases.atom(sym), kind="loop")
        proved = self._proved.get(sym)
        if proved is not None and proved[0] <= depth:
            return proved[1]
        node = self._why(sym, depth, path)
        self._proved[sym] = (depth, node)
        return node

    def _why(self, sym: Symbol, depth: int, path: frozenset) -> JustificationNode:
        fact_rule = self.catalog.fact_rule.get(sym)
        if fact_rule is None and depth >= self.max_depth:  # a leaf: its rule named, its body not shown
            sole = self._sole_rule(sym)
            if sole is not None:
                return JustificationNode(literal=str(sym), holds=True, text=self.phrases.atom(sym, sole), rule=sole)
        derivation = None if fact_rule else next(self.derivations(sym), None)
        if derivation is None:
            return JustificationNode(literal=str(sym), holds=True, text=self.phrases.atom(sym), kind="fact",
                                     rule=fact_rule)
        rule, env = derivation
        return self.node_for(rule, env, sym, depth, path)

    def node_for(self, rule: CompiledRule, env: Env, sym: Symbol, depth: int = 0,
                 path: frozenset = frozenset()) -> JustificationNode:
        children: list[JustificationNode] = []
        if depth < self.max_depth:
            for position, lit in enumerate(rule.body):
                if position in rule.assignments or (lit.is_atom and not lit.negated and self._hidden(lit)):
                    continue
                if lit.is_atom and lit.negated and self._never(lit.atom, env):
                    continue  # an exception this catalog has no rule for (right on red, in the UK pack): no reason
                children.append(self._literal_holds(rule, lit, env, depth + 1, path | {sym}))
        return JustificationNode(literal=str(sym), holds=True, text=self.phrases.atom(sym, rule.info.id),
                                 rule=rule.info.id, children=children)

    def _never(self, term: Term, env: Env) -> bool:
        """Whether nothing can give an atom of this pattern: no rule of the loaded catalog can derive it (none has a
        head that matches), no catalog fact and no frame fact is of its predicate. `not ab(turn_on_red(right))` under
        the UK pack, which has no right on red, holds in every frame: it is no reason, and no exception to name."""
        name, args = self._pattern(term, env)
        key = (name, tuple(args))
        found = self._nothing_gives.get(key)
        if found is None:
            found = (name, len(args)) not in self.given and name not in self.catalog.fact_predicates and not any(
                self._capable(rule, args) for rule in self.catalog.by_head.get((name, len(args)), ()))
            self._nothing_gives[key] = found
        return found

    def _capable(self, rule: CompiledRule, args: list[Optional[Symbol]]) -> bool:
        """Whether the rule's head matches the pattern's known arguments."""
        if rule.head[0] != "f":
            return True
        env: Optional[Env] = {}
        for sub, value in zip(rule.head[2], args):
            if value is not None:
                env = match(sub, value, env, self.answer.shape)
                if env is None:
                    return False
        return True

    def _hidden(self, lit: Literal) -> bool:
        atom = lit.atom
        arity = len(atom[2]) if atom[0] == "f" else len(atom[1].arguments)
        return (lit.predicate, arity) in self.catalog.hidden

    def _literal_holds(self, rule: CompiledRule, lit: Literal, env: Env, depth: int,
                       path: frozenset) -> JustificationNode:
        if not lit.is_atom:
            return JustificationNode(literal=lit.source, holds=True, text=self.phrases.comparison(rule, lit, env),
                                     kind="builtin")
        if not lit.negated:
            atom = env.get(id(lit))
            if atom is None:
                atom = next((ground for ground, _ in self._matches(lit.atom, env)), None)
            if atom is None:  # the model changed under us; say so rather than crash
                return JustificationNode(literal=lit.source, holds=True, text=lit.source, kind="builtin")
            return self.why(atom, depth, path)
        return self.why_not(lit.atom, env, depth)

    # -- does not hold --
    def why_not(self, term: Term, env: Env, depth: int = 0, negative_left: Optional[int] = None) -> JustificationNode:
        negative_left = self.negative_depth if negative_left is None else negative_left
        name, args = self._pattern(term, env)
        shown = ", ".join("_" if a is None else str(a) for a in args)
        goal = f"{name}({shown})" if args else name
        literal = f"not {goal}"
        text = self.phrases.denial(name, args)
        rules = self.catalog.by_head.get((name, len(args)), [])
        if not rules:
            return JustificationNode(literal=literal, holds=True, text=text, kind="absent")
        children: list[JustificationNode] = []
        if negative_left > 0 and depth < self.max_depth and name not in self.catalog.static:
            for rule in rules:
                blocked = self._blocked(rule, goal, args, depth + 1, negative_left - 1)
                if blocked is not None and blocked not in children:  # one id's two bodies may miss the same fact
                    children.append(blocked)
        return JustificationNode(literal=literal, holds=True, text=text, kind="negation", children=children)

    def _pattern(self, term: Term, env: Env) -> tuple[str, list[Optional[Symbol]]]:
        if term[0] == "s":
            return term[1].name, list(term[1].arguments)
        args: list[Optional[Symbol]] = []
        for arg in term[2]:
            try:
                args.append(evaluate(arg, env))
            except Unbound:
                args.append(None)
        return term[1], args

    def _blocked(self, rule: CompiledRule, goal: str, args: list[Optional[Symbol]], depth: int,
                 negative_left: int) -> Optional[JustificationNode]:
        """Why `rule` does not derive `goal` (its text, `_` for what any value would do): the node, a blocked
        one, is about that goal, which does not hold; its reasons, each about a literal of the rule's body."""
        env: Optional[Env] = {}
        head_args = rule.head[2] if rule.head[0] == "f" else ()
        for sub, value in zip(head_args, args):
            if value is not None:
                env = match(sub, value, env, self.answer.shape)
                if env is None:
                    return None  # this rule cannot derive the goal at all
        failures: list[_Failure] = []
        for _ in self._solve(list(rule.body), env, 0, failures):
            return None  # its body holds, so it does not block anything
        if not failures:
            return None
        deepest = max(f.depth for f in failures)
        worst = [f for f in failures if f.depth == deepest]
        reasons: list[JustificationNode] = []
        witnessed: list[bool] = []
        for failure in worst[: self.alternatives]:  # bindings that fail alike read alike: each reason once
            reason = self._failure_node(rule, failure, depth, negative_left)
            if reason not in reasons:
                reasons.append(reason)
                witnessed.append(failure.witness is not None)
        single = len(reasons) == 1 and len(worst) <= self.alternatives
        for reason, witness in zip(reasons, witnessed):
            subject = f"rule {rule.info.id}" if single else "it"
            # A need that fails reads as the need; an atom that holds where the rule needs its absence, as what
            # rules the rule out (not "needs that it is not so that X, but it is").
            reason.text = (f"{subject} is ruled out, because {reason.text}" if witness
                           else f"{subject} needs {reason.text}")
            reason.rule_tried = rule.info.id
        if single:
            only = reasons[0]
            if only.kind == "blocked":  # a need that fails, or a fact that rules it out: the rule that needed otherwise
                only.rule = rule.info.id
            return only
        if len(worst) > self.alternatives:  # say that the list is cut, not that it is all
            more = len(worst) - self.alternatives
            text = (f"and {more} other ways it could apply, each failing as well" if more > 1
                    else "and 1 other way it could apply, failing as well")
            reasons.append(JustificationNode(literal=goal, holds=False, kind="blocked", text=text))
        return JustificationNode(literal=goal, holds=False, text=f"rule {rule.info.id} does not apply",
                                 rule=rule.info.id, rule_tried=rule.info.id, kind="blocked", children=reasons)

    def _failure_node(self, rule: CompiledRule, failure: _Failure, depth: int, negative_left: int) -> JustificationNode:
        lit = failure.literal
        if not lit.is_atom:
            text = f"that {self.phrases.comparison(rule, lit, failure.env)}, which is false"
            return JustificationNode(literal=lit.source, holds=False, text=text, kind="blocked",
                                     children=self._sources_of(rule, lit, failure.env))
        if failure.witness is None:  # a positive literal with nothing to match
            child = self.why_not(lit.atom, failure.env, depth, negative_left)
            name, args = self._pattern(lit.atom, failure.env)
            child.text = "that " + self.phrases.sentence(name, args) + ", and there is no evidence of it"
            child.literal = child.literal.removeprefix("not ")  # the atom the rule needs, which does not hold
            child.holds = False
            child.kind = "blocked"
            return child
        # The atom that holds where the rule needs its absence: the node says it ("ruled out, because X").
        node = JustificationNode(literal=str(failure.witness), holds=True, text=self.phrases.atom(failure.witness),
                                 kind="blocked")
        if negative_left > 0:
            proof = self.why(failure.witness, depth)
            node.text, node.children, node.rule = proof.text, proof.children, proof.rule
            if proof.rule is not None:  # an exception that holds, tagged with its rule as in s(CASP)
                node.kind = proof.kind
        return node

    def _sources_of(self, rule: CompiledRule, comparison: Literal, env: Env) -> list[JustificationNode]:
        """The atoms a failed comparison's numbers came from: '12.0 m < 0.0 m' alone does not say whose
        distance it is. Each is a leaf: a fact, or a derived atom with the rule that derived it."""
        wanted = set(comparison.variables)
        for position in sorted(rule.assignments, reverse=True):  # a computed value comes from its inputs
            if rule.body[position].variables & wanted:
                wanted |= rule.body[position].variables
        sources: dict[Symbol, JustificationNode] = {}  # one line per fact, however many literals it matched
        for lit in rule.body:
            if not lit.is_atom or lit.negated or self._hidden(lit) or not lit.variables & wanted:
                continue
            ground = next(self._matches(lit.atom, env), None)
            if ground is None or ground[0] in sources:
                continue
            sym = ground[0]
            fact_rule = self.catalog.fact_rule.get(sym)
            derived = [] if fact_rule else self.deriving_rules(sym)  # none: the frame gives it
            rule_id = derived[0] if derived else fact_rule
            sources[sym] = JustificationNode(literal=str(sym), holds=True, text=self.phrases.atom(sym, rule_id),
                                             kind="derived" if derived else "fact", rule=rule_id)
        return list(sources.values())

    def _solve(self, body: list[Literal], env: Env, done: int,
               failures: Optional[list[_Failure]]) -> Iterator[Env]:
        """Backtracking evaluation of a rule body against the model, recording where it fails."""
        if not body:
            yield env
            return
        chosen = _next_ready(body, env)
        lit = body[chosen]
        rest = body[:chosen] + body[chosen + 1:]
        if not lit.is_atom:
            result = check_comparison(lit, env)
            if result is None:
                return
            if result is False:
                if failures is not None:
                    failures.append(_Failure(done, lit, env))
                return
            yield from self._solve(rest, result, done + 1, failures)
            return
        if not lit.negated:
            found = False
            for ground, bound in self._matches(lit.atom, env):
                found = True
                # The atom it matched goes with the solution, keyed by the literal: the literal's proof node shows
                # it without building the atom and looking it up again. Among the atoms that agree with the
                # solution's named variables it is the first, as a lookup would find. A match that bound a variable
                # made its own env already; one that bound none is the caller's, which must not change.
                if bound is env:
                    bound = dict(env)
                bound[id(lit)] = ground
                yield from self._solve(rest, bound, done + 1, failures)
            if not found and failures is not None:
                failures.append(_Failure(done, lit, env))
            return
        witness = next(self._matches(lit.atom, env), None)
        if witness is not None:
            if failures is not None:
                failures.append(_Failure(done, lit, env, witness[0]))
            return
        yield from self._solve(rest, env, done + 1, failures)

    def _matches(self, term: Term, env: Env) -> Iterator[tuple[Symbol, Env]]:
        if term[0] == "s":
            if self.answer.holds(term[1]):
                yield term[1], env
            return
        try:
            ground = evaluate(term, env)
        except Undefined:
            return  # no atom has an undefined argument
        except Unbound:
            ground = None
        if ground is not None:
            if self.answer.holds(ground):
                yield ground, env
            return
        args = term[2]
        candidates = None
        if args:
            try:
                candidates = self._with_first(term[1], len(args), evaluate(args[0], env))
            except Unbound:
                pass
        for sym in candidates if candidates is not None else self.answer.of(term[1], len(args)):
            bound = match(term, sym, env, self.answer.shape)
            if bound is not None:
                yield sym, bound

    def _with_first(self, name: str, arity: int, first: Symbol) -> list[Symbol]:
        """The model's atoms of name/arity with this first argument."""
        if self._static_atoms is not None and name in self.catalog.static:
            return self._static_with_first(name, arity, first)
        return self._derived_with_first(name, arity, first)

    def _static_with_first(self, name: str, arity: int, first: Symbol) -> list[Symbol]:
        """A static predicate's atoms with this first argument, found once for all frames and checked after.

        Which action ranks below which is the same in every frame, and replaying its rules in every proof
        was about 7 % of a 50-object override's verdict. A frame whose slice left a static predicate's
        rules out has none of its atoms: that the atoms found before hold is the check, and a frame where
        they do not reads its own.
        """
        key = (name, arity, first)
        known = self._static_atoms.get(key)
        if known is not None and all(self.answer.holds(atom) for atom in known):
            return known
        found = self._derived_with_first(name, arity, first)
        if found:
            self._static_atoms[key] = found
        return found

    def _derived_with_first(self, name: str, arity: int, first: Symbol) -> list[Symbol]:
        """A derived predicate's atoms are found top-down, as s(CASP) would: replaying the rules that can
        derive them with that first argument. The closing speed of the one object a proof is about then
        costs a few lookups of that object's facts, not reading the closing speed of every object in the
        frame from clingo (about 4 us an atom: 2.4 ms of a 200-object veto's proof went there).
        """
        if self._replays is None:
            self._replays = self.answer.size() > REPLAY_ABOVE_ATOMS
        replay = self._replays and (name, arity) in self.catalog.replayable and self.answer.unread(name, arity)
        group = self.catalog.recursion.get(name) if replay else None
        if not replay or group in self._replaying:
            return self.answer.with_first(name, arity, first)
        key = (name, arity, first)
        found = self._replayed.get(key)
        if found is None:
            if group is not None:
                self._replaying.add(group)
            try:
                found = self._replayed[key] = self._replay(name, arity, first)
            finally:
                self._replaying.discard(group)
        return found

    def _replay(self, name: str, arity: int, first: Symbol) -> list[Symbol]:
        """The atoms with this first argument, and each one's `derivations` on the way.

        A replayed atom is mostly one the proof then explains (an object's gap needed, its closing speed), and
        `_derive` would solve its rules' bodies once more. Its first solution per rule is the one found here:
        both take the body's positive atoms in the order written and their candidates in the same order, the
        head's bindings only pruning.
        """
        derived: dict[str, tuple[Symbol, list[tuple[CompiledRule, Env]]]] = {}  # text -> atom, its derivations
        try:
            for rule in self.catalog.rules_deriving(name, arity, first):
                env = {} if rule.head[0] == "s" else match(rule.head[2][0], first, {}, self.answer.shape)
                if env is None:
                    continue
                for solution in self._solve(list(rule.body), env, 0, None):
                    atom = evaluate(rule.head, solution)
                    by_rule = derived.setdefault(str(atom), (atom, []))[1]
                    if not by_rule or by_rule[-1][0] is not rule:
                        by_rule.append((rule, solution))
        except Unbound:  # a head the body does not bind: read clingo's atoms instead
            return self.answer.with_first(name, arity, first)
        for fact in self.answer.given_with_first(name, arity, first):  # obj_lane: given, and derived where not
            derived.setdefault(str(fact), (fact, []))
        found = [derived[text] for text in sorted(derived)]  # the order AnswerSet reads atoms in
        if all(self.answer.holds(atom) for atom, _ in found):
            for atom, derivations in found:
                if derivations:
                    self._derivations.setdefault(atom, derivations)
            return [atom for atom, _ in found]
        return self.answer.with_first(name, arity, first)  # not as clingo derived them: read clingo's


def _next_ready(body: list[Literal], env: Env) -> int:
    """Positive atoms bind variables; comparisons and negations wait until theirs are bound."""
    for i, lit in enumerate(body):
        if lit.is_atom and not lit.negated:
            return i
        if lit.variables <= env.keys() or is_assignment(lit, env):
            return i
    return 0


_NOT_CITED = (*DEFINITION_PREFIXES, SETTING_PREFIX)


def rule_ids(node: JustificationNode) -> list[str]:
    """Decision-level rules used in a proof, first use first; rules that did not fire are not counted, nor definitions
    and a jurisdiction's settings, which the proof shows but which forbid nothing themselves."""
    seen: list[str] = []
    pending = [node]  # depth first, children in order; no recursive closure, which would be a reference cycle
    while pending:
        n = pending.pop()
        if n.kind in ("negation", "blocked", "absent"):
            continue
        if n.rule and not n.rule.startswith(_NOT_CITED) and n.rule not in seen:
            seen.append(n.rule)
        pending.extend(reversed(n.children))
    return seen
