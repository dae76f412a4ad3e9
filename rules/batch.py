"""Many frames in one grounding: the catalog with a frame argument.

clingo pays about 10 us per rule to build and ground a program, whatever the
facts: most of a small frame's time. Grounding a batch of frames at once pays
it once per batch. Every atom that depends on a frame gets the frame number as
its first argument (`ego_speed(3,500)`), rules carry a frame variable through
their bodies, and what depends on no frame (the class hierarchy, ranks,
parameters) is grounded once and shared. Frames cannot see each other's
atoms, so each frame's answer set is exactly its own solo answer set; the
prover reads it through `FrameAnswers` with the frame argument stripped.
"""

from __future__ import annotations

import re
from typing import Iterable

from clingo import Control, Function, Number, Symbol, ast

from .catalog import Catalog
from .justify import AnswerSet, shown_atoms
from .terms import Shape

FRAME_PREDICATE = "discern_frame"  # discern_frame(K): frame K is in the batch
_FRAME_VAR = "DiscernFrame"
_LOC = ast.Location(ast.Position("<batch>", 1, 1), ast.Position("<batch>", 1, 1))

# A fact's name starts the text or follows the '.' that ends the previous fact;
# quoted strings are matched whole first, so nothing inside them is touched.
_FACT_START = re.compile(r'"(?:[^"\\]|\\.)*"|(?:^|(?<=\.))([a-z_][A-Za-z0-9_]*)([(.])')
# Text where every '.' ends a fact and every fact starts with its name: none of quotes, comments,
# whitespace, intervals, classical negation. Such text (all the generated facts) is split on '.'.
_NOT_PLAIN = re.compile(r'["%\s]|\.\.|(?:^|\.)-')


def static_predicates(catalog: Catalog, shared: Iterable[str] = ()) -> frozenset[str]:
    """Predicates whose atoms are the same in every frame: defined by the catalog from such predicates alone.

    `shared` names predicates given once for the whole batch (the reasoner's parameters).
    """
    static = set(catalog.fact_predicates) | {rule.signature[0] for rule in catalog.compiled} | set(shared)
    changed = True
    while changed:
        changed = False
        for rule in catalog.compiled:
            head = rule.signature[0]
            if head in static and any(lit.predicate not in static for lit in rule.body if lit.is_atom):
                static.discard(head)
                changed = True
    return frozenset(static)


class FrameTagger:
    """Adds the frame argument to the catalog's frame-dependent atoms and to a frame's fact text."""

    def __init__(self, catalog: Catalog, shared: Iterable[str] = ()):
        self.static = static_predicates(catalog, shared)
        self._var = ast.Variable(_LOC, _FRAME_VAR)
        # tagged once, up front: tagging on first use made a process's first batches several times slower
        self._tagged = {id(stm): self._rule(stm) for stm in catalog.facts + [rule.statement for rule in catalog.compiled]}

    def program(self, statements: Iterable[ast.AST]) -> list[ast.AST]:
        """The catalog statements given (a slice of the catalog), tagged."""
        return [self._tagged[id(stm)] for stm in statements]

    def facts(self, text: str, frame: int) -> str:
        """A frame's facts with its number first in every atom, and its discern_frame fact."""
        if text.endswith(".") and _NOT_PLAIN.search(text) is None:
            return f"{FRAME_PREDICATE}({frame})." + self._split_facts(text, frame)

        def tag(match: re.Match) -> str:
            name = match.group(1)
            if name is None:
                return match.group(0)
            if name in self.static:
                raise ValueError(f"frame fact {name} is defined by the catalog and cannot be given per frame")
            return f"{name}({frame}," if match.group(2) == "(" else f"{name}({frame})."

        return f"{FRAME_PREDICATE}({frame})." + _FACT_START.sub(tag, text)

    def _split_facts(self, text: str, frame: int) -> str:
        """Plain fact text tagged by splitting on '.': a quarter of the regular expression's time."""
        nullary, first = f"({frame}).", f"({frame},"
        out = []
        for fact in text[:-1].split("."):
            name, paren, rest = fact.partition("(")
            if name in self.static:
                raise ValueError(f"frame fact {name} is defined by the catalog and cannot be given per frame")
            out.append(f"{name}{first}{rest}." if paren else name + nullary)
        return "".join(out)

    def _rule(self, stm: ast.AST) -> ast.AST:
        if _predicate(stm.head.atom) in self.static:
            return stm
        body, anchored = [], False
        for lit in stm.body:
            if lit.ast_type == ast.ASTType.Literal and lit.atom.ast_type == ast.ASTType.SymbolicAtom:
                if _predicate(lit.atom) not in self.static:
                    anchored = anchored or lit.sign == ast.Sign.NoSign
                    lit = lit.update(atom=self._atom(lit.atom))
            body.append(lit)
        if not anchored:  # the frame variable needs a positive atom to range over
            frame = ast.SymbolicAtom(ast.Function(_LOC, FRAME_PREDICATE, [self._var], 0))
            body.insert(0, ast.Literal(_LOC, ast.Sign.NoSign, frame))
        return stm.update(head=stm.head.update(atom=self._atom(stm.head.atom)), body=body)

    def _atom(self, atom: ast.AST) -> ast.AST:
        return atom.update(symbol=self._term(atom.symbol))

    def _term(self, term: ast.AST) -> ast.AST:
        if term.ast_type == ast.ASTType.Pool:
            return term.update(arguments=[self._term(t) for t in term.arguments])
        if term.ast_type == ast.ASTType.Function:
            return term.update(arguments=[self._var, *term.arguments])
        return ast.Function(term.location, term.symbol.name, [self._var], 0)


def _predicate(atom: ast.AST) -> str:
    term = atom.symbol
    if term.ast_type == ast.ASTType.Pool:
        term = term.arguments[0]
    return term.name if term.ast_type == ast.ASTType.Function else term.symbol.name


class BatchAnswers:
    """The grounded batch: each predicate's atoms split by frame once, on first use.

    The constants of the frame predicates `shown` (name(F,c), given `#show`
    statements) are read from one solve (justify.shown_atoms).
    """

    def __init__(self, control: Control, static: frozenset[str], shown: Iterable[str] = ()):
        self.control = control
        self.static = static
        self.shown = frozenset(shown)
        self._split: dict[tuple[str, int], dict[int, list[Symbol]]] = {}
        self._constants: dict[str, dict[int, set[str]]] = {}

    def of_frame(self, name: str, arity: int, frame: int) -> list[tuple[str, Symbol, Shape]]:
        """The frame's atoms of name/arity with the frame argument stripped: text, atom and shape, by text."""
        split = self._split.get((name, arity))
        if split is None:
            split = self._split[(name, arity)] = {}
            # every ground atom of a stratified program is a fact (load_catalog checks it): no is_fact calls
            for atom in self.control.symbolic_atoms.by_signature(name, arity + 1):
                args = atom.symbol.arguments
                sym = Function(name, args[1:])
                split.setdefault(args[0].number, []).append((str(sym), sym, (True, name, tuple(args[1:]))))
            for found in split.values():
                found.sort(key=lambda entry: entry[0])  # the order AnswerSet.of reads a solo frame in
        return split.get(frame, [])

    def constants_of_frame(self, name: str, frame: int) -> set[str]:
        split = self._constants.get(name)
        if split is None:
            if name in self.shown:
                self._read_shown()
                split = self._constants[name]
            else:
                split = self._constants[name] = {}
                for atom in self.control.symbolic_atoms.by_signature(name, 2):
                    number, constant = atom.symbol.arguments
                    split.setdefault(number.number, set()).add(constant.name)
        return split.get(frame, set())

    def _read_shown(self) -> None:
        for name in self.shown:
            self._constants[name] = {}
        for name, arguments in shown_atoms(self.control, self.shown):
            number, _, constant = arguments.partition(",")
            self._constants[name].setdefault(int(number), set()).add(constant)


class FrameAnswers(AnswerSet):
    """One frame of a batch, read as if it had been grounded alone."""

    def __init__(self, batch: BatchAnswers, frame: int):
        super().__init__(batch.control)
        self._batch = batch
        self._frame = Number(frame)
        self._number = frame

    def holds(self, sym: Symbol) -> bool:
        _, name, args = self.shape(sym)
        if name not in self._batch.static:
            sym = Function(name, [self._frame, *args])
        return super().holds(sym)

    def of(self, name: str, arity: int) -> list[Symbol]:
        if name in self._batch.static:
            return super().of(name, arity)
        found = self._by_sig.get((name, arity))
        if found is None:
            entries = self._batch.of_frame(name, arity, self._number)
            self._shapes.update((sym, shape) for _, sym, shape in entries)
            self._texts[(name, arity)] = [text for text, _, _ in entries]
            found = self._by_sig[(name, arity)] = [sym for _, sym, _ in entries]
        return found

    def constants(self, name: str) -> set[str]:
        if name in self._batch.static:
            return super().constants(name)
        return self._batch.constants_of_frame(name, self._number)

    def all(self) -> list[Symbol]:
        out = []
        for atom in self._atoms:
            if not atom.is_fact:
                continue
            sym = atom.symbol
            if sym.name in self._batch.static:
                out.append(sym)
            elif sym.name != FRAME_PREDICATE and sym.arguments[0] == self._frame:
                out.append(Function(sym.name, sym.arguments[1:], sym.positive))
        return out
