"""Ground a frame with only the rules that can fire, learning which those are from earlier frames.

clingo charges for every rule it is given, about 5 to 10 us each, whether or not the rule fires, and
most rules of a frame's slice (`Catalog.program_for`) never do: on the KITTI frames, 35 to 60 of
about 140. A rule whose positive body needs a predicate with no atoms in the answer set cannot fire.
So a frame is grounded with the rules that need only predicates seen with atoms in earlier frames
whose facts used the same predicates (`Catalog.rules_within`), and its answer set is then checked:
if none of the predicates those rules derive outside that set got atoms, every rule left out has a
false body, and the answer set is the one the whole slice gives (the catalog is stratified: rules
whose bodies are false in its answer set change nothing). If one did, the frame is grounded again
with the whole slice, and what got atoms there is remembered for the next frames.
"""

from __future__ import annotations

from typing import Optional

import clingo

from .catalog import Catalog
from .controls import PreparedControls


class PresenceSlicer:
    def __init__(self, catalog: Catalog, controls: PreparedControls):
        self.catalog = catalog
        self._controls = controls
        self._present: dict[frozenset[str], frozenset[str]] = {}  # a frame's fact predicates -> those seen with atoms
        self.regrounds = 0  # frames grounded twice: a predicate their kind never had got atoms

    def learned(self, names: frozenset[str]) -> Optional[frozenset[str]]:
        """The predicates seen with atoms in frames whose facts use `names` (None before the first such frame)."""
        return self._present.get(names)

    def ground(self, names: frozenset[str], text: str) -> clingo.Control:
        """A Control with the frame's facts (`text`, using predicates `names`) grounded: its answer set is the slice's."""
        present = self._present.get(names)
        if present is not None:
            control = self._grounded(present, text)
            if not self._with_atoms(control, self.catalog.derived_outside(present)):
                return control
            self._controls.retire(control)
            self.regrounds += 1
        # The first frame of its kind, or one with a predicate its kind never had: the whole slice (whose
        # Control is kept ready like any other), then remember what had atoms.
        derivable = self.catalog.derivable(names)
        control = self._grounded(derivable, text)
        seen = names if present is None else present
        self._present[names] = seen | self._with_atoms(control, self.catalog.derived_outside(seen, derivable))
        return control

    def _grounded(self, present: frozenset[str], text: str) -> clingo.Control:
        control = self._controls.take(present)
        control.add("base", [], text)
        control.ground([("base", [])])
        return control

    @staticmethod
    def _with_atoms(control: clingo.Control, signatures: list[tuple[str, int]]) -> frozenset[str]:
        atoms = control.symbolic_atoms
        return frozenset(name for name, arity in signatures if next(iter(atoms.by_signature(name, arity)), None) is not None)
