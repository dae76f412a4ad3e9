"""Ground a frame with only the rules that can fire, learning which those are from earlier frames.

clingo charges for every rule it is given, about 5 to 10 us each, whether or not the rule fires, and
most rules of a frame's slice (`Catalog.program_for`) never do: on the KITTI frames, 45 to 168 of
their 85 to 219 rule statements. A rule cannot fire when its positive body needs a predicate with no
atoms in the answer set, or an atom of a pattern that none matches (`obj_lane(_,oncoming,_)`,
`intent(merge_into_right_lane)`). So a frame is grounded with the rules that need only predicates and patterns seen with atoms in earlier
frames whose facts used the same predicates (`Catalog.rules_within`), and its answer set is then
checked: if none of the predicates those rules derive outside that set got atoms, and no atom matches
a pattern left out (the frame's guard rules derive `__unseen` when one does), every rule left out has
a false body, and the answer set is the one the whole slice gives (the catalog is stratified: rules
whose bodies are false in its answer set change nothing). If not, the frame is grounded again with the
whole slice, and what got atoms there is remembered for the next frames.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import clingo
from clingo import ast

from .catalog import Catalog
from .controls import PreparedControls
from .terms import Term, match, pattern_signature, pattern_text

UNSEEN = clingo.Function("__unseen")  # derived by a frame's guard rules when an atom matches a pattern left out


@dataclass(frozen=True)
class Slice:
    """What a frame's program is cut to: the rules needing only `present` predicates and no `absent` pattern."""

    present: frozenset[str]
    absent: frozenset[Term] = frozenset()


class PresenceSlicer:
    def __init__(self, catalog: Catalog, constant: str = ""):
        """`constant`: text every frame's program has (the parameters)."""
        self.catalog = catalog
        self.controls = PreparedControls(self.program, constant)
        self._learned: dict[frozenset[str], Slice] = {}  # a frame's fact predicates -> its learned slice
        self._programs: dict[Slice, list[ast.AST]] = {}
        self.regrounds = 0  # frames grounded twice: a predicate or pattern their kind never had got atoms

    def learned(self, names: frozenset[str]) -> Optional[Slice]:
        """The slice learned for frames whose facts use `names` (None before the first such frame)."""
        return self._learned.get(names)

    def program(self, cut: Slice) -> list[ast.AST]:
        """The statements of a frame cut to a slice: the rules within it, and guards for the patterns left out."""
        found = self._programs.get(cut)
        if found is None:
            guards = _guards(sorted(pattern_text(p) for p in cut.absent))
            found = self._programs[cut] = self.catalog.rules_within(cut.present, cut.absent) + guards
        return found

    def ground(self, names: frozenset[str], text: str) -> clingo.Control:
        """A Control with the frame's facts (`text`, using predicates `names`) grounded: its answer set is the slice's."""
        learned = self._learned.get(names)
        if learned is not None:
            control = self._grounded(learned, text)
            if not self._unexpected(control, learned):
                return control
            self.controls.retire(control)
            self.regrounds += 1
        # The first frame of its kind, or one with a predicate or pattern its kind never had: the whole slice
        # (whose Control is kept ready like any other), then remember what had atoms.
        derivable = self.catalog.derivable(names)
        control = self._grounded(Slice(derivable), text)
        if learned is None:
            seen, matched_before = names, frozenset()
        else:
            seen, matched_before = learned.present, self.catalog.patterns_within(learned.present) - learned.absent
        present = seen | self._with_atoms(control, self.catalog.derived_outside(seen, derivable))
        candidates = self.catalog.patterns_within(present) - matched_before
        self._learned[names] = Slice(present, candidates - _matched(control, candidates))
        return control

    def _grounded(self, cut: Slice, text: str) -> clingo.Control:
        control = self.controls.take(cut)
        control.add("base", [], text)
        control.ground([("base", [])])
        return control

    def _unexpected(self, control: clingo.Control, cut: Slice) -> bool:
        return bool(self._with_atoms(control, self.catalog.derived_outside(cut.present))) or (
            control.symbolic_atoms[UNSEEN] is not None)

    @staticmethod
    def _with_atoms(control: clingo.Control, signatures: list[tuple[str, int]]) -> frozenset[str]:
        atoms = control.symbolic_atoms
        return frozenset(name for name, arity in signatures if next(iter(atoms.by_signature(name, arity)), None) is not None)


def _matched(control: clingo.Control, patterns: frozenset[Term]) -> frozenset[Term]:
    """The patterns that some atom of the grounded program matches."""
    by_signature: dict[tuple[str, int], list[Term]] = {}
    for pattern in patterns:
        by_signature.setdefault(pattern_signature(pattern), []).append(pattern)
    found = set()
    for (name, arity), waiting in by_signature.items():
        for atom in control.symbolic_atoms.by_signature(name, arity):
            hits = [p for p in waiting if match(p, atom.symbol, {}) is not None]
            found.update(hits)
            waiting = [p for p in waiting if p not in hits]
            if not waiting:
                break
    return frozenset(found)


def _guards(patterns: list[str]) -> list[ast.AST]:
    statements: list[ast.AST] = []
    if patterns:
        ast.parse_string("".join(f"{UNSEEN} :- {p}.\n" for p in patterns), statements.append)
    return [s for s in statements if s.ast_type == ast.ASTType.Rule]
