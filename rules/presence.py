"""Ground a frame with only the rules that can fire, learning which those are from earlier frames.

clingo charges for every rule it is given, about 5 to 10 us each, whether or not the rule fires, and
most rules of a frame's slice (`Catalog.program_for`) never do: on the KITTI frames, 45 to 168 of
their 85 to 219 rule statements. A rule cannot fire when its positive body needs a predicate with no
atoms in the answer set, or an atom of a pattern that none matches (`obj_lane(_,oncoming,_)`,
`intent(merge_into_right_lane)`). Where the pattern's predicate has exactly the frame's facts as its
atoms, the fact text tells which patterns match before grounding: frames are of one kind when their
facts use the same predicates and match the same such patterns. Facts of a predicate that rules derive
too (`obj_lane`: a sanity rule moves a mislabelled object into the ego's lane) cannot tell that, but
frames whose facts match different patterns of it still learn apart: one with no object in the ego's
lane is not grounded with the rules of the frames that have one. A frame is grounded with the rules that
need only predicates and patterns seen with atoms in earlier frames of its kind (`Catalog.rules_within`),
and its answer set is then checked: if none of the predicates those rules derive outside that set and a rule
left out needs got atoms, and no atom matches a pattern left out (the frame's guard rules derive `__unseen` when
one does), every rule left out has a false body, and the answer set is the one the whole slice gives (the catalog is
stratified: rules whose bodies are false in its answer set change nothing). If not, the frame is
grounded again with the whole slice, and what got atoms there is remembered for the next frames.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Optional

import clingo
from clingo import ast

from .catalog import Catalog, static_fact_refused, static_model, static_predicates
from .clingo_calls import AtomReader, add_facts
from .controls import PreparedControls
from .fact_text import is_plain
from .specialize import Specializer
from .terms import ANY, Term, match, pattern_signature, pattern_text

UNSEEN = clingo.Function("__unseen")  # derived by a frame's guard rules when an atom matches a pattern left out


@dataclass(frozen=True)
class Slice:
    """What a frame's program is cut to: the rules needing only `present` predicates, no `absent` pattern (guarded:
    none matched in earlier frames) and no `unmatched` one (no guard: the frame's facts match none)."""

    present: frozenset[str]
    absent: frozenset[Term] = frozenset()
    unmatched: frozenset[Term] = frozenset()


# A frame's fact predicates; the patterns its facts match none of, of predicates that only facts give; and of those
# that rules derive too.
Kind = tuple[frozenset[str], frozenset[Term], frozenset[Term]]


class PresenceSlicer:
    def __init__(self, catalog: Catalog, constant: str = "", shared: frozenset[str] = frozenset()):
        """`constant`: text every frame's program has (the parameters), whose predicates are `shared`."""
        self.catalog = catalog
        # What no frame changes is grounded once, and its atoms given to every Control as facts (controls.py).
        self._shared = shared
        self.static = static_predicates(catalog, shared)
        ahead = catalog.facts + [rule.statement for rule in catalog.compiled if rule.signature[0] in self.static]
        self._ahead = {id(statement) for statement in ahead}
        self.static_atoms = static_atoms = static_model(ahead, constant)
        self.specializer = Specializer(static_atoms, self.static)
        self.controls = PreparedControls(self.program, static_atoms)
        self._learned: dict[Kind, Slice] = {}  # a kind of frame -> its learned slice
        self._programs: dict[Slice, list[ast.AST]] = {}
        self._fact_patterns: dict[frozenset[str], tuple[list[tuple[Term, re.Pattern]], ...]] = {}
        self.regrounds = 0  # frames grounded twice: a predicate or pattern their kind never had got atoms

    def kind(self, names: frozenset[str], text: str) -> Kind:
        """Frames of one kind share a learned slice: their facts (`text`, using predicates `names`) use the same
        predicates and match none of the same patterns that rules require of the predicates the facts give.

        The facts may not give a static predicate: its atoms are grounded before the facts come.
        """
        checks = self._fact_patterns.get(names)
        if checks is None:  # the first frame whose facts use these predicates
            given = (names - self._shared) & self.static
            if given:
                raise static_fact_refused(min(given))
            patterns = self.catalog.patterns_within(self.catalog.derivable(names))
            derived = self.catalog.defined_in(names)
            checks = self._fact_patterns[names] = tuple(
                [(p, _fact_regex(p)) for p in patterns if pattern_signature(p)[0] in among]
                for among in (names - self._shared - derived, (names - self._shared) & derived))
        if not any(checks) or not is_plain(text):  # other text is left to the guards
            return names, frozenset(), frozenset()
        facts = "." + text  # every fact then follows a '.': a search starting with a literal is fast (40 against 1.4 us)
        exact, also_derived = (frozenset(p for p, regex in among if regex.search(facts) is None) for among in checks)
        return names, exact, also_derived

    def kind_count(self) -> int:
        """How many kinds of frame it has learned a slice for."""
        return len(self._learned)

    def learned(self, kind: Kind) -> Optional[Slice]:
        """The slice learned for frames of this kind (None before the first such frame)."""
        return self._learned.get(kind)

    def program(self, cut: Slice) -> list[ast.AST]:
        """The statements of a frame cut to a slice: the rules within it, and guards for the patterns left out."""
        found = self._programs.get(cut)
        if found is None:
            guards = _guards(sorted(pattern_text(p) for p in cut.absent))
            within = self.catalog.rules_within(cut.present, cut.absent | cut.unmatched)
            found = self._programs[cut] = self.specializer.program([s for s in within if id(s) not in self._ahead] + guards)
        return found

    def ground(self, names: frozenset[str], text: str) -> clingo.Control:
        """A Control with the frame's facts (`text`, using predicates `names`) grounded: its answer set is the slice's."""
        kind = self.kind(names, text)
        unmatched = kind[1]
        learned = self._learned.get(kind)
        if learned is not None:
            control = self._grounded(learned, text)
            if not self._unexpected(control, learned):
                return control
            self.controls.retire(control)
            self.regrounds += 1
        # The first frame of its kind, or one with a predicate or pattern its kind never had: the whole slice,
        # then remember what had atoms; idle time readies the learned slice for the kind's next frame instead.
        derivable = self.catalog.derivable(names)
        whole = Slice(derivable, unmatched=unmatched)
        control = self._grounded(whole, text)
        if learned is None:
            seen, matched_before = names, frozenset()
        else:
            seen, matched_before = learned.present, self.catalog.patterns_within(learned.present) - learned.absent
        present = seen | self._with_atoms(control, self.catalog.derived_outside(seen, derivable))
        candidates = self.catalog.patterns_within(present) - matched_before - unmatched
        self._learned[kind] = Slice(present, candidates - _matched(control, candidates), unmatched)
        self.controls.succeed([whole] if learned is None else [whole, learned], self._learned[kind])
        return control

    def _grounded(self, cut: Slice, text: str) -> clingo.Control:
        control = self.controls.take(cut)
        _add_facts(control, text)
        control.ground([("base", [])])
        return control

    def _unexpected(self, control: clingo.Control, cut: Slice) -> bool:
        reader = AtomReader(control)
        return reader.holds(UNSEEN) or any(reader.any_of(name, arity)
                                           for name, arity in self.catalog.enabling_outside(cut.present))

    @staticmethod
    def _with_atoms(control: clingo.Control, signatures: list[tuple[str, int]]) -> frozenset[str]:
        reader = AtomReader(control)
        return frozenset(name for name, arity in signatures if reader.any_of(name, arity))


def _add_facts(control: clingo.Control, text: str) -> None:
    """The frame's facts into the Control: plain fact text (fact_text.py) parsed as one term and given to clingo's
    backend as facts, other text to its parser.

    Given as statements, facts are grounded with the rules; as backend facts they are already there when the rules
    are. Measured on readied Controls (2026-11-27, the KITTI frames' average): adding them costs more (75 against
    57 us), adding and grounding less (0.88 against 0.91 ms). The atoms are the same.
    """
    if is_plain(text):
        try:
            facts = clingo.parse_term(f"({text[:-1].replace('.', ',')},)").arguments
        except RuntimeError:  # a number past clingo's: its parser says so below
            facts = None
        if facts is not None:
            add_facts(control, facts)
            return
    control.add("base", [], text)


def _matched(control: clingo.Control, patterns: frozenset[Term]) -> frozenset[Term]:
    """The patterns that some atom of the grounded program matches."""
    by_signature: dict[tuple[str, int], list[Term]] = {}
    for pattern in patterns:
        by_signature.setdefault(pattern_signature(pattern), []).append(pattern)
    found = set()
    reader = AtomReader(control)
    for (name, arity), waiting in by_signature.items():
        for atom in reader.of(name, arity):
            hits = [p for p in waiting if match(p, atom, {}) is not None]
            found.update(hits)
            waiting = [p for p in waiting if p not in hits]
            if not waiting:
                break
    return frozenset(found)


def _fact_regex(pattern: Term) -> re.Pattern:
    """What finds an atom matching the pattern in plain fact text (fact_text.py) after a '.', the atoms' arguments
    being atomic there: a pattern with a compound argument finds none, as none matches."""
    if pattern[0] == "s":
        name, arguments = pattern[1].name, [re.escape(str(a)) for a in pattern[1].arguments]
    else:
        name = pattern[1]
        arguments = [r"[^,().]*+" if a == ANY else re.escape(pattern_text(a)) for a in pattern[2]]
    return re.compile(rf"\.{re.escape(name)}" + (rf"\({','.join(arguments)}\)" if arguments else "") + r"\.")


def _guards(patterns: list[str]) -> list[ast.AST]:
    statements: list[ast.AST] = []
    if patterns:
        ast.parse_string("".join(f"{UNSEEN} :- {p}.\n" for p in patterns), statements.append)
    return [s for s in statements if s.ast_type == ast.ASTType.Rule]
