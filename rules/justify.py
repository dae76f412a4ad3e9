"""Goal-directed proof trees over clingo's answer set, in the style of s(CASP).

clingo computes the model bottom-up; people want the story top-down. The
program is stratified, so its answer set is unique and every atom in it has a
derivation by some catalog rule whose body holds in the model. The prover
replays rule bodies against the model: for an atom that holds it finds the
rule instance that derives it; for one that does not, it shows, rule by rule,
the body literal that fails ("there is no evidence that ...").
"""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass
from typing import Iterable, Iterator, Optional

from clingo import Control, Symbol, SymbolType, parse_term

from .catalog import PLACEHOLDER, Catalog, CompiledRule
from .fact_text import FACT_NAME, facts_of, facts_with_first, is_plain
from .terms import (CMP_TEXT, Env, Literal, Shape, Term, Unbound, check_comparison, evaluate, is_assignment, match,
                    shape_of, term_vars)
from .verdict import JustificationNode

# Replaying a rule for one object costs about 0.1-0.2 ms; reading a per-object predicate whole, about 4 us an
# object. Measured on proofs: replaying was about 10 % slower on frames of 0-6 objects (150-240 atoms), about
# even at 10 objects (~290 atoms), 8 % faster at 50 and 30 % at 200 (docs/reasoning.md).
REPLAY_ABOVE_ATOMS = 250


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

    Reading an atom from clingo costs about 4 us (iterating, the symbol, its
    text), and more the first time a predicate is read. A predicate whose atoms
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
        self._by_sig: dict[tuple[str, int], list[Symbol]] = {}
        self._texts: dict[tuple[str, int], list[str]] = {}  # of each atom of _by_sig, in the same order
        self._by_first: dict[tuple[str, int], dict[str, list]] = {}  # symbols, or texts not yet made symbols
        self._shapes: dict[Symbol, Shape] = {}
        self._facts = facts
        self._defined = defined
        self._fact_names_given = fact_names
        self._names: Optional[frozenset[str]] = None  # the predicates `facts` gives, when it is plain
        self._scanned = False
        self._exactly_given: dict[tuple[str, int], Optional[list[str]]] = {}
        self._given_first: dict[tuple[str, int, str], list[Symbol]] = {}

    def holds(self, sym: Symbol) -> bool:
        atom = self._atoms[sym]
        return atom is not None and atom.is_fact

    def of(self, name: str, arity: int) -> list[Symbol]:
        found = self._by_sig.get((name, arity))
        if found is None:
            # sorted (by text: one C call an atom) so that a proof does not depend on the order the grounder
            # happened to derive atoms in; every ground atom is a fact, the catalog being stratified
            pairs = sorted((str(sym), sym) for sym in (a.symbol for a in self._atoms.by_signature(name, arity)))
            self._texts[(name, arity)] = [text for text, _ in pairs]
            found = self._by_sig[(name, arity)] = [sym for _, sym in pairs]
        return found

    def constants(self, name: str) -> set[str]:
        """The constants c with name(c) true: the verdict's permitted and recommended actions."""
        return {sym.arguments[0].name for sym in self.of(name, 1)}

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
        key = str(first)
        if self._is_given(name):
            found = self._given_first.get((name, arity, key))
            if found is None:
                texts = sorted(facts_with_first(self._facts, name, arity, key))
                found = self._given_first[(name, arity, key)] = [parse_term(text) for text in texts]
            return found
        index = self._by_first.get((name, arity))
        if index is None:
            # keyed by the first argument's text, cut from the atom's text: an atom's structure is a few C
            # calls more (about 2 us), and on a 200-object frame most of a veto's proof went to the
            # structure of atoms it never matched
            index = self._by_first[(name, arity)] = {}
            for text, sym in zip(self.texts(name, arity), self.of(name, arity)):
                index.setdefault(first_argument(text), []).append(sym)
        return index.get(key, [])

    def only_derived(self, name: str, arity: int) -> bool:
        """Whether none of the predicate's atoms is a frame fact, and they are not read from clingo yet.

        Then the prover may find those with a given first argument by replaying the catalog's rules.
        """
        return self.not_given(name) and (name, arity) not in self._by_first

    def not_given(self, name: str) -> bool:
        """Whether the frame's fact text gives no atom of the predicate (False when there is no text to tell)."""
        names = self._fact_names()
        return names is not None and name not in names

    def size(self) -> int:
        """How many atoms the grounded program has: what reading a whole predicate costs grows with it."""
        return len(self._atoms)

    def _is_given(self, name: str) -> bool:
        """Whether the predicate's atoms are exactly the frame's facts of it, so the fact text can serve them."""
        names = self._fact_names()
        return names is not None and name in names and name not in self._defined

    def _fact_names(self) -> Optional[frozenset[str]]:
        """The predicates the fact text gives, once it is known to be plain; None when there is no such text."""
        if self._names is None and not self._scanned:  # on first use: an approval's proof may read no fact at all
            self._scanned = True
            if self._facts and is_plain(self._facts):
                given = self._fact_names_given
                self._names = given if given is not None else frozenset(FACT_NAME.findall(self._facts))
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
            found = self._shapes[sym] = shape_of(sym)
        return found

    def arguments(self, sym: Symbol) -> tuple[Symbol, ...]:
        return self.shape(sym)[2]

    def all(self) -> list[Symbol]:
        return [a.symbol for a in self._atoms if a.is_fact]


# --- English ---------------------------------------------------------------


@functools.lru_cache(maxsize=None)
def _template_parts(template: str) -> tuple[str, ...]:
    """A template cut at its placeholders, once: text, then (parameter, format, unknown words, text) per placeholder."""
    return tuple(PLACEHOLDER.split(template))


def _words(sym: Symbol) -> str:
    if sym.type == SymbolType.Number:
        return str(sym.number)
    if sym.type == SymbolType.String:
        return sym.string
    if sym.type == SymbolType.Function and sym.arguments:
        inner = ", ".join(_words(a) for a in sym.arguments)
        return f"{sym.name.replace('_', ' ')} ({inner})" if sym.name else f"({inner})"
    return str(sym).replace("_", " ")


def _article(found: re.Match) -> str:
    return found.group(2) if found.group(2) else found.group(1) + "n "


def _ordinal(n: int) -> str:
    suffix = "th" if 10 <= n % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(n % 10, "th")
    return f"{n}{suffix}"


_LOOSE_SPACE = re.compile(r" +(?=[,.;:)]|$)| (?= )")  # left where an unknown value reads as no words
# "a" before a value: "an" before a vowel sound; none before a mass noun ("debris can be swerved around")
_ARTICLE = re.compile(r"\b([aA]) (?:(debris)\b|(?=(?!uni|use|usu|one\b)[aeiou]|8|1[18]\b))")
_PARAM_UNITS = {"reaction_ms": ("s", 1000), "headway_ms": ("s", 1000), "turn_gap_ms": ("s", 1000),
                "decel": ("m/s²", 100), "speed_margin": ("m/s", 100), "turn_speed": ("m/s", 100),
                "stopped_speed": ("m/s", 100)}
_UNKNOWN = {"obj": "some object", "m": "some distance", "mps": "some speed", "limit": "some speed", "ms": "some time",
            "ahead": "somewhere", "right": "somewhere", "lane": "a lane", "detail": "", "paren": ""}
_SIGN_UNITS = {"mph": 44.704}  # cm/s per unit a pack's speed_unit/1 may name
_WRAPPED = {"lane": "lane {}", "detail": ": {}", "paren": " ({})"}  # a value with the words around it, unknown: none


class Phrasebook:
    """Renders atoms and comparisons as English with the catalog's templates."""

    def __init__(self, catalog: Catalog, answer: AnswerSet):
        self.catalog = catalog
        self._answer = answer
        self._classes: dict[int, str] = {}  # object id -> its class in words ("" when it has none)
        self._formats: dict[int, dict[str, str]] = {}
        self._sign_unit: Optional[str] = None  # read from the answer set when a limit is first shown

    def value(self, sym: Optional[Symbol], fmt: Optional[str], param: str) -> str:
        if sym is None:
            return _UNKNOWN.get(fmt or "", f"some {param}")
        if fmt in _WRAPPED:
            return _WRAPPED[fmt].format(self.value(sym, None, param))
        kind = sym.type
        if kind != SymbolType.Number:
            args = sym.arguments if kind == SymbolType.Function else ()
            if args and (sym.name, len(args)) in self.catalog.templates:  # a term with words of its own
                return self.sentence(sym.name, list(args))
            if kind == SymbolType.Function and not args and sym.name in self.catalog.words:
                return self.catalog.words[sym.name]
            return _words(sym)
        n = sym.number
        if fmt == "m":
            return f"{n / 100:.1f} m"
        if fmt == "mps":
            return f"{n / 100:.1f} m/s"
        if fmt == "limit":
            return f"{n / 100:.1f} m/s" + self._in_sign_unit(n)
        if fmt == "ahead":
            return "level with the ego" if n == 0 else f"{n / 100:.1f} m ahead" if n > 0 else f"{-n / 100:.1f} m behind"
        if fmt == "right":
            return "in line with the ego" if n == 0 else f"{n / 100:.1f} m to the right" if n > 0 else f"{-n / 100:.1f} m to the left"
        if fmt == "ms":
            return f"{n / 1000:g} s"
        if fmt == "ordinal":
            return _ordinal(n)
        if fmt == "frames":
            return "1 frame" if n == 1 else f"{n} frames"
        if fmt == "obj":
            cls = self._classes.get(n)
            if cls is None:
                found = self._answer.with_first("object", 2, sym)
                cls = self._classes[n] = _words(found[0].arguments[1]) if found else ""
            return f"{cls} {n}" if cls else f"object {n}"
        return str(n)

    def _in_sign_unit(self, cms: int) -> str:
        """A limit as its sign shows it, in the unit the jurisdiction pack names: a reader checks '85 mph', not 38.0 m/s."""
        if self._sign_unit is None:
            units = [unit.arguments[0].name for unit in self._answer.of("speed_unit", 1)]
            self._sign_unit = units[0] if units and units[0] in _SIGN_UNITS else ""
        if not self._sign_unit:
            return ""
        shown = round(cms / _SIGN_UNITS[self._sign_unit], 1)
        return f" ({shown:g} {self._sign_unit})"

    def sentence(self, name: str, args: list[Optional[Symbol]]) -> str:
        if name == "param" and len(args) == 2 and args[0] is not None and args[1] is not None:
            unit, scale = _PARAM_UNITS.get(args[0].name, ("m", 100))
            label = args[0].name.removesuffix("_ms").replace("_dist", "_distance").replace("_", " ")
            return f"the {label} is {args[1].number / scale:g} {unit}"
        template = self.catalog.templates.get((name, len(args)))
        if template is None:
            inner = ", ".join("_" if a is None else str(a) for a in args)
            return f"{name}({inner})" if args else name
        values = dict(zip(template.params, args))
        parts = _template_parts(template.template)
        words = [parts[0]]
        for i in range(1, len(parts), 4):  # (placeholder's parameter, its format, its unknown words, the text after)
            value, unknown = values.get(parts[i]), parts[i + 2]
            words.append(unknown if value is None and unknown is not None else self.value(value, parts[i + 1], parts[i]))
            words.append(parts[i + 3])
        text = _LOOSE_SPACE.sub("", "".join(words))
        return _ARTICLE.sub(_article, text) if "a @(" in template.template else text

    def atom(self, sym: Symbol) -> str:
        _, name, args = self._answer.shape(sym)
        return self.sentence(name, list(args))

    def formats_of(self, rule: CompiledRule) -> dict[str, str]:
        """Units of a rule's variables, read off the templates of the atoms they appear in."""
        formats = self._formats.get(rule.index)
        if formats is not None:
            return formats
        formats = {}
        for term in [rule.head] + [lit.atom for lit in rule.body if lit.is_atom]:
            if term[0] != "f":
                continue
            template = self.catalog.templates.get((term[1], len(term[2])))
            if template is None:
                continue
            by_param = {m.group(1): m.group(2) for m in PLACEHOLDER.finditer(template.template)}
            for param, arg in zip(template.params, term[2]):
                fmt = by_param.get(param)
                if arg[0] == "v" and fmt in ("m", "mps", "limit", "ahead", "right", "ms", "frames", "ordinal"):
                    formats.setdefault(arg[1], "m" if fmt in ("ahead", "right") else fmt)
        self._formats[rule.index] = formats
        return formats

    def comparison(self, rule: CompiledRule, lit: Literal, env: Env) -> str:
        formats = self.formats_of(rule)
        left, guards = lit.comparison
        terms = [left] + [t for _, t in guards]
        fmt = next((formats[v] for t in terms for v in sorted(term_vars(t)) if v in formats), None)

        def show(term: Term) -> str:
            try:
                return self.value(evaluate(term, env), fmt, "")
            except Unbound:
                return lit.source

        parts = [show(left)]
        for op, term in guards:
            parts += [CMP_TEXT.get(op, "?"), show(term)]
        return " ".join(parts)


# --- proofs ----------------------------------------------------------------


@dataclass
class _Failure:
    depth: int
    literal: Literal
    env: Env
    witness: Optional[Symbol] = None  # the atom that holds when a negated literal fails


class Prover:
    """Builds justification trees for one solved frame."""

    def __init__(self, catalog: Catalog, answer: AnswerSet, max_depth: int = 12, negative_depth: int = 2,
                 alternatives: int = 3, static_atoms: Optional[dict[tuple[str, int, Symbol], list[Symbol]]] = None):
        """`static_atoms`: what the proofs of earlier frames of the same catalog and parameters found of the
        static predicates (`Catalog.static`), to share between them: the same in every such frame."""
        self.catalog = catalog
        self.answer = answer
        self.max_depth = max_depth
        self.negative_depth = negative_depth
        self.alternatives = alternatives
        self.phrases = Phrasebook(catalog, answer)
        self._replayed: dict[tuple[str, int, Symbol], list[Symbol]] = {}
        self._replays: Optional[bool] = None  # whether this frame is big enough to replay rules (REPLAY_ABOVE_ATOMS)
        # An atom's proof, built once: a veto's reasons, and the recommended action's, lean on the same facts (an
        # object's lane, the gap it needs, the hazard) again and again. A proof built nearer the root goes deeper,
        # so it serves a deeper request as well. Proof nodes are not changed once built: sharing them is safe.
        self._proved: dict[Symbol, tuple[int, JustificationNode]] = {}
        self._static_atoms = static_atoms

    # -- derivations --
    def derivations(self, sym: Symbol) -> Iterator[tuple[CompiledRule, Env]]:
        """Every catalog rule instance (one per rule) whose body holds and derives `sym`."""
        _, name, args = self.answer.shape(sym)
        for rule in self.catalog.rules_deriving(name, len(args), args[0] if args else None):
            env = match(rule.head, sym, {}, self.answer.shape)
            if env is None:
                continue
            for solution in self._solve(list(rule.body), env, 0, None):
                yield rule, solution
                break

    def deriving_rules(self, sym: Symbol) -> list[str]:
        """Ids of the rules with an instance that derives `sym`, an atom of the model, as `derivations` finds them.

        An atom that no fact gives, of which one catalog rule's head is capable, was derived by that rule: its
        body need not be replayed to name it (the sanity notes' rules, named with every verdict: 0.66 against
        0.09 ms on 50-object frames).
        """
        fact_rule = self.catalog.fact_rule.get(sym)
        if fact_rule:
            return [fact_rule]
        sole = self._sole_rule(sym)
        if sole is not None:
            return [sole]
        return [rule.info.id for rule, _ in self.derivations(sym)]

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
                return JustificationNode(literal=str(sym), holds=True, text=self.phrases.atom(sym), rule=sole)
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
                children.append(self._literal_holds(rule, lit, env, depth + 1, path | {sym}))
        return JustificationNode(literal=str(sym), holds=True, text=self.phrases.atom(sym), rule=rule.info.id,
                                 children=children)

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
            ground = next(self._matches(lit.atom, env), None)
            if ground is None:  # the model changed under us; say so rather than crash
                return JustificationNode(literal=lit.source, holds=True, text=lit.source, kind="builtin")
            return self.why(ground[0], depth, path)
        return self.why_not(lit.atom, env, depth)

    # -- does not hold --
    def why_not(self, term: Term, env: Env, depth: int = 0, negative_left: Optional[int] = None) -> JustificationNode:
        negative_left = self.negative_depth if negative_left is None else negative_left
        name, args = self._pattern(term, env)
        shown = ", ".join("_" if a is None else str(a) for a in args)
        literal = f"not {name}({shown})" if args else f"not {name}"
        text = "there is no evidence that " + self.phrases.sentence(name, args)
        rules = self.catalog.by_head.get((name, len(args)), [])
        if not rules:
            return JustificationNode(literal=literal, holds=True, text=text, kind="absent")
        children: list[JustificationNode] = []
        if negative_left > 0 and depth < self.max_depth and name not in self.catalog.static:
            for rule in rules:
                blocked = self._blocked(rule, args, depth + 1, negative_left - 1)
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

    def _blocked(self, rule: CompiledRule, args: list[Optional[Symbol]], depth: int,
                 negative_left: int) -> Optional[JustificationNode]:
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
        for failure in worst[: self.alternatives]:  # bindings that fail alike read alike: each reason once
            reason = self._failure_node(rule, failure, depth, negative_left)
            if reason not in reasons:
                reasons.append(reason)
        if len(reasons) == 1 and len(worst) <= self.alternatives:
            only = reasons[0]
            only.text = f"rule {rule.info.id} needs {only.text}"
            only.rule = rule.info.id
            return only
        for reason in reasons:
            reason.text = f"it needs {reason.text}"
        if len(worst) > self.alternatives:  # say that the list is cut, not that it is all
            more = len(worst) - self.alternatives
            text = f"and {more} other way{'s' if more > 1 else ''} it could apply, each failing as well"
            reasons.append(JustificationNode(literal=rule.info.id, holds=False, kind="blocked", text=text))
        return JustificationNode(literal=rule.info.id, holds=False, text=f"rule {rule.info.id} does not apply",
                                 rule=rule.info.id, kind="blocked", children=reasons)

    def _failure_node(self, rule: CompiledRule, failure: _Failure, depth: int, negative_left: int) -> JustificationNode:
        lit = failure.literal
        if not lit.is_atom:
            text = self.phrases.comparison(rule, lit, failure.env) + ", which is false"
            return JustificationNode(literal=lit.source, holds=False, text=text, kind="blocked",
                                     children=self._sources_of(rule, lit, failure.env))
        if failure.witness is None:  # a positive literal with nothing to match
            child = self.why_not(lit.atom, failure.env, depth, negative_left)
            child.text = "that " + child.text.removeprefix("there is no evidence that ") + ", and there is no evidence of it"
            child.holds = False
            child.kind = "blocked"
            return child
        node = JustificationNode(literal=str(failure.witness), holds=False,
                                 text=f"that it is not so that {self.phrases.atom(failure.witness)}, but it is",
                                 kind="blocked")
        if negative_left > 0:
            proof = self.why(failure.witness, depth)
            node.children, node.rule = proof.children, proof.rule
        return node

    def _sources_of(self, rule: CompiledRule, comparison: Literal, env: Env) -> list[JustificationNode]:
        """The facts a failed comparison's numbers came from: '12.0 m < 0.0 m' alone does not say whose
        distance it is."""
        wanted = set(comparison.variables)
        for position in sorted(rule.assignments, reverse=True):  # a computed value comes from its inputs
            if rule.body[position].variables & wanted:
                wanted |= rule.body[position].variables
        sources: dict[Symbol, JustificationNode] = {}  # one line per fact, however many literals it matched
        for lit in rule.body:
            if not lit.is_atom or lit.negated or self._hidden(lit) or not lit.variables & wanted:
                continue
            ground = next(self._matches(lit.atom, env), None)
            if ground is not None and ground[0] not in sources:
                sources[ground[0]] = JustificationNode(literal=str(ground[0]), holds=True,
                                                       text=self.phrases.atom(ground[0]), kind="fact")
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
            for _, bound in self._matches(lit.atom, env):
                found = True
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
        replay = self._replays and (name, arity) in self.catalog.replayable and self.answer.only_derived(name, arity)
        if not replay:
            return self.answer.with_first(name, arity, first)
        key = (name, arity, first)
        found = self._replayed.get(key)
        if found is None:
            found = self._replayed[key] = self._replay(name, arity, first)
        return found

    def _replay(self, name: str, arity: int, first: Symbol) -> list[Symbol]:
        derived: dict[str, Symbol] = {}
        try:
            for rule in self.catalog.rules_deriving(name, arity, first):
                env = {} if rule.head[0] == "s" else match(rule.head[2][0], first, {}, self.answer.shape)
                if env is None:
                    continue
                for solution in self._solve(list(rule.body), env, 0, None):
                    atom = evaluate(rule.head, solution)
                    derived.setdefault(str(atom), atom)
        except Unbound:  # a head the body does not bind: read clingo's atoms instead
            return self.answer.with_first(name, arity, first)
        atoms = [derived[text] for text in sorted(derived)]  # the order AnswerSet reads atoms in
        if all(self.answer.holds(atom) for atom in atoms):
            return atoms
        return self.answer.with_first(name, arity, first)  # not as clingo derived them: read clingo's


def _next_ready(body: list[Literal], env: Env) -> int:
    """Positive atoms bind variables; comparisons and negations wait until theirs are bound."""
    for i, lit in enumerate(body):
        if lit.is_atom and not lit.negated:
            return i
        if lit.variables <= env.keys() or is_assignment(lit, env):
            return i
    return 0


def rule_ids(node: JustificationNode, skip_prefixes: tuple[str, ...] = ("def.", "ent.")) -> list[str]:
    """Decision-level rules used in a proof, first use first; rules that did not fire are not counted."""
    seen: list[str] = []
    pending = [node]  # depth first, children in order; no recursive closure, which would be a reference cycle
    while pending:
        n = pending.pop()
        if n.kind in ("negation", "blocked", "absent"):
            continue
        if n.rule and not n.rule.startswith(skip_prefixes) and n.rule not in seen:
            seen.append(n.rule)
        pending.extend(reversed(n.children))
    return seen
