"""What the verdict and the proofs read of a frame's grounded program, and how they read it cheaply."""

from __future__ import annotations

from typing import Iterable, Iterator, Optional

from clingo import Control, Symbol, parse_term

from .catalog import TRACE_PREFIX
from .clingo_calls import AtomReader
from .fact_text import fact_names, facts_of, facts_with_first, is_plain
from .terms import Shape


def show_statements(names: Iterable[str], arity: int) -> str:
    """`#show` statements for the predicates whose atoms `shown_atoms` reads."""
    return "".join(f"#show {name}/{arity}." for name in names)


def shown_atoms(control: Control, names: frozenset[str]) -> Iterator[tuple[str, str]]:
    """(name, arguments as text) of the shown atoms of these predicates in the grounded program's unique model.

    Reading atoms one by one through clingo's symbolic atoms costs about 5 us
    each; the model's shown symbols, a fraction of it. The program is
    stratified, so the one model is found without search. What else a catalog
    may `#show` is passed over.
    """
    with control.solve(yield_=True) as models:
        for model in models:
            for text in map(str, model.symbols(shown=True)):
                name, paren, arguments = text.partition("(")
                if paren and name in names:
                    yield name, arguments[:-1]


def first_argument(text: str) -> str:
    """The first argument of an atom's text, `name(first,...)`: up to the first comma outside brackets and quotes."""
    start = text.index("(") + 1
    comma = text.find(",", start)
    end = comma if comma != -1 else len(text) - 1
    if "(" not in text[start:end] and '"' not in text[start:end]:
        return text[start:end]
    depth, quoted, escaped = 0, False, False
    for i in range(start, len(text) - 1):
        c = text[i]
        if quoted:
            escaped, quoted = (False, True) if escaped else (c == "\\", c != '"')
        elif c == '"':
            quoted = True
        elif c == "(":
            depth += 1
        elif c == ")":
            depth -= 1
        elif c == "," and depth == 0:
            return text[start:i]
    return text[start:-1]


class AnswerSet:
    """The frame's unique answer set, read lazily from the grounder.

    The catalog is stratified (checked when it loads), so grounding alone
    derives every true atom as a fact: no solving, and no copying thousands of
    atoms into Python unless a justification asks for them.

    Reading an atom from clingo costs about 1.6 us (iterating, the symbol, its
    text, through clingo's C calls: clingo_calls.py), and more the first time a
    predicate is read. A predicate whose atoms
    are exactly the frame's own facts (the scene's objects, positions, lanes:
    half of what a veto's proof reads on a dense frame) is served from `facts`,
    the frame's fact text, unless it is in `defined`, the predicates the
    grounded program's rules or catalog facts define; a lookup by first
    argument is a substring search, and only the atoms a proof uses become
    symbols.
    """

    def __init__(self, control: Control, facts: str = "", defined: frozenset[str] = frozenset(),
                 fact_names: Optional[frozenset[str]] = None):
        """`fact_names`: the predicate names in `facts`, when the caller has them already."""
        self._control = control  # owns the atoms: they must not outlive it
        self._atoms = control.symbolic_atoms
        self._reader = AtomReader(control)
        self._by_sig: dict[tuple[str, int], list[Symbol]] = {}
        self._texts: dict[tuple[str, int], list[str]] = {}  # of each atom of _by_sig, in the same order
        self._by_first: dict[tuple[str, int], dict[str, list]] = {}  # symbols, or texts not yet made symbols
        self._shapes: dict[Symbol, Shape] = {}
        self._holds: dict[Symbol, bool] = {}
        self._facts = facts
        self._defined = defined
        self._fact_names_given = fact_names
        self._names: Optional[frozenset[str]] = None  # the predicates `facts` gives, when it is plain
        self._scanned = False
        self._exactly_given: dict[tuple[str, int], Optional[list[str]]] = {}
        self._given_first: dict[tuple[str, int, str], list[Symbol]] = {}

    def holds(self, sym: Symbol) -> bool:
        # A proof asks about the same atoms again and again (an object's lane, the ego's speed): a dict lookup
        # is one C call (the symbol's hash), clingo's three.
        found = self._holds.get(sym)
        if found is None:
            found = self._holds[sym] = self._reader.holds(sym)
        return found

    def of(self, name: str, arity: int) -> list[Symbol]:
        found = self._by_sig.get((name, arity))
        if found is None:
            # sorted (by text: one C call an atom) so that a proof does not depend on the order the grounder
            # happened to derive atoms in; every ground atom is a fact, the catalog being stratified
            text = self._reader.text
            pairs = sorted((text(sym), sym) for sym in self._reader.of(name, arity))
            self._texts[(name, arity)] = [text for text, _ in pairs]
            found = self._by_sig[(name, arity)] = [sym for _, sym in pairs]
        return found

    def constants(self, name: str) -> set[str]:
        """The constants c with name(c) true: the verdict's permitted, recommended and replacing actions.

        Cut from the atoms' text, which reading them makes anyway: the symbols' structure is more C calls."""
        start = len(name) + 1
        return {text[start:-1] for text in self.texts(name, 1)}

    def texts(self, name: str, arity: int) -> list[str]:
        """The text of each atom of a predicate, in the order of `of`."""
        found = self._texts.get((name, arity))
        if found is None:
            found = self._given_exactly(name, arity)
            if found is None:
                self.of(name, arity)
                found = self._texts[(name, arity)]
        return found

    def with_first(self, name: str, arity: int, first: Symbol) -> list[Symbol]:
        """Atoms of a predicate whose first argument is given: the prover's common lookup."""
        if self._is_given(name):
            return self.given_with_first(name, arity, first)
        index = self._by_first.get((name, arity))
        if index is None:
            # keyed by the first argument's text, cut from the atom's text: an atom's structure is a few C
            # calls more (about 2 us), and on a 200-object frame most of a veto's proof went to the
            # structure of atoms it never matched
            index = self._by_first[(name, arity)] = {}
            for text, sym in zip(self.texts(name, arity), self.of(name, arity)):
                index.setdefault(first_argument(text), []).append(sym)
        return index.get(str(first), [])

    def unread(self, name: str, arity: int) -> bool:
        """Whether the predicate's atoms are neither served from the fact text alone nor read from clingo yet.

        Then the prover may find those with a given first argument by replaying the catalog's rules.
        """
        return self._fact_names() is not None and not self._is_given(name) and (name, arity) not in self._by_first

    def given_with_first(self, name: str, arity: int, first: Symbol) -> list[Symbol]:
        """The frame's own facts of a predicate with this first argument, in text order, whether or not rules add
        to them."""
        if not self._is_named(name):
            return []
        key = (name, arity, str(first))
        found = self._given_first.get(key)
        if found is None:
            texts = sorted(facts_with_first(self._facts, name, arity, key[2]))
            found = self._given_first[key] = [parse_term(text) for text in texts]
        return found

    def _is_named(self, name: str) -> bool:
        names = self._fact_names()
        return names is not None and name in names

    def not_given(self, name: str) -> bool:
        """Whether the frame's fact text gives no atom of the predicate (False when there is no text to tell)."""
        names = self._fact_names()
        return names is not None and name not in names

    def size(self) -> int:
        """How many atoms the grounded program has: what reading a whole predicate costs grows with it."""
        return len(self._atoms)

    def _is_given(self, name: str) -> bool:
        """Whether the predicate's atoms are exactly the frame's facts of it, so the fact text can serve them."""
        return self._is_named(name) and name not in self._defined

    def _fact_names(self) -> Optional[frozenset[str]]:
        """The predicates the fact text gives, once it is known to be plain; None when there is no such text."""
        if self._names is None and not self._scanned:  # on first use: an approval's proof may read no fact at all
            self._scanned = True
            if self._facts and is_plain(self._facts):
                given = self._fact_names_given
                self._names = given if given is not None else fact_names(self._facts)
        return self._names

    def _given_exactly(self, name: str, arity: int) -> Optional[list[str]]:
        """The texts of a predicate's atoms, sorted, when they are exactly the frame's facts of it; else None."""
        signature = (name, arity)
        if signature in self._exactly_given:
            return self._exactly_given[signature]
        texts = facts_of(self._facts, name, arity) if self._is_given(name) else None
        found = self._exactly_given[signature] = sorted(texts) if texts else None
        return found

    def shape(self, sym: Symbol) -> Shape:
        found = self._shapes.get(sym)
        if found is None:
            found = self._shapes[sym] = self._reader.shape(sym)
        return found

    def arguments(self, sym: Symbol) -> tuple[Symbol, ...]:
        return self.shape(sym)[2]

    def all(self) -> list[Symbol]:
        """The answer set of the catalog as written: without the records of which rule derived what (TRACED)."""
        return [a.symbol for a in self._atoms if a.is_fact and not a.symbol.name.startswith(TRACE_PREFIX)]

