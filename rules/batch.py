"""Many frames in one grounding: the catalog with a frame argument.

clingo pays about 10 us per rule to build and ground a program, whatever the
facts: most of a small frame's time. Grounding a batch of frames at once pays
it once per batch. Every atom that depends on a frame gets the frame number as
its first argument (`ego_speed(3,500)`), rules carry a frame variable through
their bodies, and what depends on no frame (the class hierarchy, ranks,
parameters) is grounded once and shared. Frames cannot see each other's
atoms, so each frame's answer set is exactly its own solo answer set; the
prover reads it through `FrameAnswers` with the frame argument stripped. The
frames' facts reach clingo as one term per predicate (`BatchFacts`), not as
program text to parse.
"""

from __future__ import annotations

import re
from typing import Iterable, Optional

from clingo import Control, Function, Number, Symbol, ast, parse_term

from .answer_set import AnswerSet, first_argument, shown_atoms
from .catalog import TRACE_PREFIX, Catalog, static_fact_refused, static_predicates
from .fact_text import QUOTED, fact_names, is_plain
from .specialize import Specializer

FRAME_PREDICATE = "discern_frame"  # discern_frame(K): frame K is in the batch
_FRAME_VAR = "DiscernFrame"
_LOC = ast.Location(ast.Position("<batch>", 1, 1), ast.Position("<batch>", 1, 1))

# A fact's name starts the text or follows the '.' that ends the previous fact;
# quoted strings are matched whole first, so nothing inside them is touched.
_FACT_START = re.compile(rf'{QUOTED}|(?:^|(?<=\.))([a-z_][A-Za-z0-9_]*)([(.])')


class FrameTagger:
    """Adds the frame argument to the catalog's frame-dependent atoms and to a frame's fact text."""

    def __init__(self, catalog: Catalog, shared: Iterable[str] = (), specializer: Optional[Specializer] = None):
        """`specializer`: the catalog's rules specialised to its static atoms (specialize.py), as grounded."""
        self.static = static_predicates(catalog, shared)
        self._var = ast.Variable(_LOC, _FRAME_VAR)
        # tagged once, up front: tagging on first use made a process's first batches several times slower
        self._tagged: dict[int, Optional[ast.AST]] = {}
        for stm in catalog.facts + [rule.statement for rule in catalog.compiled] + list(catalog.traces.values()):
            special = stm if specializer is None else specializer.statement(stm)
            self._tagged[id(stm)] = None if special is None else self._rule(special)

    def program(self, statements: Iterable[ast.AST]) -> list[ast.AST]:
        """The catalog statements given (a slice of the catalog), tagged; a rule that cannot fire left out."""
        tagged = (self._tagged[id(stm)] for stm in statements)
        return [stm for stm in tagged if stm is not None]

    def batch(self, texts: Iterable[str]) -> "BatchFacts":
        """The frames' facts, frame k's with k first in every atom, and the discern_frame fact of each."""
        facts = BatchFacts()
        frames = facts.groups[(FRAME_PREDICATE, 1)] = []
        for frame, text in enumerate(texts):
            frames.append(str(frame))
            if is_plain(text):
                self._group_facts(text, frame, facts)
            else:
                facts.text.append(self.tag_text(text, frame))
                facts.names.update(fact_names(text))
        for name, _ in facts.groups:
            self._check(name)
        facts.names.update(name for name, _ in facts.groups)
        facts.names.discard(FRAME_PREDICATE)
        return facts

    def tag_text(self, text: str, frame: int) -> str:
        """Any fact text with the frame's number first in every atom, for clingo to parse."""

        def tag(match: re.Match) -> str:
            name = match.group(1)
            if name is None:
                return match.group(0)
            self._check(name)
            return f"{name}({frame}," if match.group(2) == "(" else f"{name}({frame})."

        return _FACT_START.sub(tag, text)

    def _group_facts(self, text: str, frame: int, facts: "BatchFacts") -> None:
        """Plain fact text split on '.' into the batch's groups: a fraction of the regular expression's time."""
        first, number, groups = f"({frame},", str(frame), facts.groups
        for fact in text[:-1].split("."):
            name, paren, rest = fact.partition("(")
            signature = (name, rest.count(",") + 2) if paren else (name, 1)
            items = groups.get(signature)
            if items is None:
                items = groups[signature] = []
            items.append(first + rest if paren else number)

    def _check(self, name: str) -> None:
        if name in self.static:
            raise static_fact_refused(name)

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


class BatchFacts:
    """A batch's frame facts as clingo gets them: plain facts as one term per predicate, other text as text.

    clingo parses a fact statement in about 3.5 us. Given as the elements of
    one term per predicate (`clingo.parse_term`), each predicate's facts are
    instantiated by one rule, `obj_pos(F,O,X,Y) :- (F,O,X,Y) = @discern_facts(3).`:
    the same atoms, all facts, for a third of that (measured on highway frames
    of 52 facts, a frame's facts and grounding: 0.38 ms as text, 0.29 as terms).
    This object is the grounding's context, which clingo asks for the terms.
    """

    def __init__(self) -> None:
        self.names: set[str] = set()  # the predicates the frames' facts use, for the catalog slice
        self.groups: dict[tuple[str, int], list[str]] = {}  # (name, arity): each fact's arguments as "(a,b,...)"
        self.text: list[str] = []  # facts that are not plain, tagged
        self._terms: list[list[Symbol]] = []

    def program(self) -> str:
        """The input rule of each group, and the text; a group that is not a valid term goes as text for clingo
        to report."""
        rules, text = [], list(self.text)
        for (name, arity), items in self.groups.items():
            try:
                terms = parse_term(f"({','.join(items)},)").arguments
            except RuntimeError:
                text.extend(f"{name}{item}." if arity > 1 else f"{name}({item})." for item in items)
                continue
            variables = ",".join(f"V{i}" for i in range(arity))
            pattern = f"({variables})" if arity > 1 else variables
            rules.append(f"{name}({variables}):-{pattern}=@discern_facts({len(self._terms)}).")
            self._terms.append(terms)
        return "".join(rules + text)

    def discern_facts(self, index: Symbol) -> list[Symbol]:
        """What `@discern_facts(i)` in the input rules stands for: the elements of group i's term."""
        return self._terms[index.number]


def _predicate(atom: ast.AST) -> str:
    term = atom.symbol
    if term.ast_type == ast.ASTType.Pool:
        term = term.arguments[0]
    return term.name if term.ast_type == ast.ASTType.Function else term.symbol.name


class BatchAnswers:
    """The grounded batch: each predicate's atoms split by frame once, on first use.

    The constants of the frame predicates `shown` (name(F,c), given `#show`
    statements) are read from one solve (answer_set.shown_atoms).
    """

    def __init__(self, control: Control, static: frozenset[str], shown: Iterable[str] = ()):
        self.control = control
        self.static = static
        self.shown = frozenset(shown)
        self._split: dict[tuple[str, int], dict[int, list[str]]] = {}
        self._constants: dict[str, dict[int, set[str]]] = {}

    def of_frame(self, name: str, arity: int, frame: int) -> list[str]:
        """The texts of the frame's atoms of name/arity with the frame argument stripped, sorted (as AnswerSet.of
        reads a solo frame's).

        Split by frame once, from each atom's text alone: making every frame's symbols here cost about 11 us an
        atom, most of a highway batch's proofs, and a frame's proof needs a few of its own.
        """
        split = self._split.get((name, arity))
        if split is None:
            split = self._split[(name, arity)] = {}
            start = len(name) + 1
            # every ground atom of a stratified program is a fact (load_catalog checks it): no is_fact calls
            for atom in self.control.symbolic_atoms.by_signature(name, arity + 1):
                text = str(atom.symbol)
                comma = text.find(",", start)  # the frame number is a plain integer
                untagged = f"{name}({text[comma + 1:]}" if comma != -1 else name
                split.setdefault(int(text[start:comma if comma != -1 else -1]), []).append(untagged)
            for found in split.values():
                found.sort()
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
    """One frame of a batch, read as if it had been grounded alone.

    As for a solo frame, `facts` (the frame's untagged fact text) serves the
    predicates that no rule or catalog fact of the batch's slice defines:
    reading them from the batch's atoms instead made a 50-object batch's proofs
    cost more than its grounding saved.
    """

    def __init__(self, batch: BatchAnswers, frame: int, facts: str = "", defined: frozenset[str] = frozenset()):
        super().__init__(batch.control, facts, defined)
        self._batch = batch
        self._frame = Number(frame)
        self._number = frame

    def holds(self, sym: Symbol) -> bool:
        found = self._holds.get(sym)  # by the frame's own atom: tagging it is a symbol made, several C calls
        if found is None:
            _, name, args = self.shape(sym)
            tagged = sym if name in self._batch.static else Function(name, [self._frame, *args])
            found = self._holds[sym] = self._reader.holds(tagged)
        return found

    def texts(self, name: str, arity: int) -> list[str]:
        if name in self._batch.static:
            return super().texts(name, arity)
        found = self._texts.get((name, arity))
        if found is None:
            found = self._texts[(name, arity)] = self._batch.of_frame(name, arity, self._number)
        return found

    def of(self, name: str, arity: int) -> list[Symbol]:
        if name in self._batch.static:
            return super().of(name, arity)
        found = self._by_sig.get((name, arity))
        if found is None:
            found = self._by_sig[(name, arity)] = [parse_term(text) for text in self.texts(name, arity)]
        return found

    def with_first(self, name: str, arity: int, first: Symbol) -> list[Symbol]:
        """As for a solo frame, but only the atoms looked up become symbols: of a batch predicate's atoms, a frame's
        proof reads those of a few objects."""
        if name in self._batch.static or self._is_given(name):
            return super().with_first(name, arity, first)
        index = self._by_first.get((name, arity))
        if index is None:
            index = self._by_first[(name, arity)] = {}
            for text in self.texts(name, arity):
                index.setdefault(first_argument(text), []).append(text)
        key = str(first)
        found = index.get(key)
        if found is None:
            return []
        if isinstance(found[0], str):  # looked up for the first time: made symbols now
            found = index[key] = [parse_term(text) for text in found]
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
            elif sym.name.startswith(TRACE_PREFIX):
                continue  # as AnswerSet.all: the answer set of the catalog as written
            elif sym.name != FRAME_PREDICATE and sym.arguments[0] == self._frame:
                out.append(Function(sym.name, sym.arguments[1:], sym.positive))
        return out
