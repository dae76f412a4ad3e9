"""Load the rules catalog: ASP files whose rules carry ids, English and sources.

A catalog file is plain clingo syntax plus `%!` annotation comments:

    %! pred obstacle_ahead(O) :: "@(O:obj) blocks the ego's lane"
    %! rule brake.obstacle_ahead
    %! says An obstacle ... is a hazard.
    %! source AUTO-DISCERN (obstacle ahead); AV-CSR brake_conditions
    hazard(obstacle(O)) :- obstacle_ahead(O).

A `rule` annotation names every statement that follows it up to the next
`rule` annotation. Within a rule block, `%! reads head(Args) :: "..."` is how
an atom reads when that rule derived it, in place of the predicate's template:
a value the rule assumes reads as assumed, not as measured. Rules are also
compiled to plain tuples (terms.py) for the justifier, and indexed by the predicates they need so that a frame grounds
only the rules that can fire on its facts. What breaks the conventions is refused (CatalogError, one line naming the
file, line and rule); what loads but is likely a mistake is kept in `Catalog.warnings`, for the commands to print.
"""

from __future__ import annotations

import difflib
import hashlib
import re
from dataclasses import dataclass, field
from functools import cached_property
from importlib import resources
from pathlib import Path
from typing import Hashable, Iterable, Optional, Sequence

from clingo import Control, Function, Number, Symbol, SymbolType, ast

from .facts import PARAM_NAMES, SCENE_PREDICATES, FactProvider
from .terms import Literal, Term, compile_literal, compile_term, is_fixed, pattern_of, term_vars

# Every line that starts with `%!` is an annotation: a keyword, then (after white space) its value.
_ANNOTATION = re.compile(r"^%!\s*([A-Za-z_]*)(?:\s+(.*?))?\s*$")
_ANNOTATION_KEYS = ("rule", "says", "source", "pred", "term", "hide", "reads", "denies")
_PRED = re.compile(r'^(-?[a-z_][A-Za-z0-9_]*)(?:\(([^)]*)\))?\s*::\s*"(.*)"$')
# A template's placeholder: @(Var), @(Var:format), and either with |words to say when Var is unknown; @(name), a
# constant, reads as that constant's words, so that a pack that words a constant (`%! term yellow :: "amber"`) words
# every template that names it.
PLACEHOLDER = re.compile(r"@\((\w+)(?::(\w+))?(?:\|([^)]*))?\)")
TEMPLATE_FORMATS = frozenset({
    "m", "mps", "ahead", "right",  # centimetres and cm/s as metres; signed positions as "5.0 m behind"
    "along", "across", "closing",  # signed speeds: "12.0 m/s against the ego's heading", "3.0 m/s to the left"
    "decel",  # a deceleration in cm/s²: "3.0 m/s²"
    "limit",  # a speed limit in cm/s: m/s, and the unit of the pack's signs ("15.7 m/s (35 mph)")
    "speed",  # the ego's speed in cm/s: m/s, and the unit of the pack's signs, the limits' ("15.7 m/s (35 mph)")
    "obj", "ordinal", "ms",  # "car 3"; "2nd"; milliseconds as seconds
    "frames",  # a count of frames: "1 frame", "3 frames"
    "percent",  # a whole percentage: "30 %"
    "lane", "detail", "paren",  # "lane 2", ": reason", " (kind)": words that go when the value is unknown
    "id",  # a name the scene gave (a path id): as given, never read as a catalog word
})


DEFINITION_PREFIXES = ("def.", "ent.")  # ids of definitions and entities: they decide nothing themselves
SETTING_PREFIX = "jur."  # a jurisdiction pack's settings (the traffic side, zone limits): no rule forbids by them alone

# Predicates whose atoms' deriving rules every verdict of a kind names: an approval names what called for the action.
# Up to 16 rules can derive one such atom, and finding which did by replaying their bodies cost most of a KITTI
# approval's verdict. So clingo records it: a rule deriving `applicable(brake)` is grounded as
# `__by_applicable(brake,K)`, K its index, and `applicable(A) :- __by_applicable(A,K).` gives the atom
# (`Catalog.traces`). Not `forbidden`: a veto's proof replays its reasons' bodies anyway, and with its rules
# recorded, random overrides took 0.98-1.06 of the time.
TRACED = frozenset({"applicable"})
EXCEPTION_HOOK = "ab"  # `ab(T)`: an exception to a default rule, one hook per functor of T (`_exception_graph`)
TRACE_PREFIX = "__by_"


class CatalogError(ValueError):
    """A catalog file breaks the catalog's own conventions."""


@dataclass(frozen=True)
class RuleInfo:
    id: str
    says: str
    source: str
    file: str
    line: int


@dataclass(frozen=True)
class PredTemplate:
    """English for a predicate, like s(CASP)'s #pred: `@(Var:format)` placeholders."""

    name: str
    params: tuple[str, ...]
    template: str

    @property
    def signature(self) -> tuple[str, int]:
        return (self.name, len(self.params))


@dataclass
class CompiledRule:
    """One normal rule of the catalog with what the justifier needs to replay it."""

    index: int
    info: RuleInfo
    statement: ast.AST  # as clingo grounds it (`_grounding_form`, traced); `body` is the rule as written
    head: Term
    body: tuple[Literal, ...]
    signature: tuple[str, int]
    needs: frozenset[str]  # predicates of the positive body
    requires: frozenset[Term]  # patterns of the positive body's atoms with a constant or functor (terms.pattern_of)
    assignments: frozenset[int]  # body positions of `X = expr` that only compute a value


def _may_have_first(head: Term, first: Symbol) -> bool:
    """Whether a rule head can have this first argument: not when it is another constant."""
    if head[0] == "s":
        arguments = head[1].arguments
        return not arguments or arguments[0] == first
    arguments = head[2]
    return not arguments or arguments[0][0] != "s" or arguments[0][1] == first


def _replays_from_first(rule: CompiledRule) -> bool:
    """Whether the rule, its head's first argument given, starts from a lookup by first argument.

    The head's first argument must bind by unification (no arithmetic), and bind the first argument of the
    first positive body atom, which the prover matches first: otherwise replaying the rule would scan a
    whole predicate.
    """
    head = rule.head
    if head[0] == "s" or not head[2]:
        return True
    if _has_arithmetic(head[2][0]):
        return False
    start = next((lit.atom for lit in rule.body if lit.is_atom and not lit.negated), None)
    if start is None or start[0] == "s" or not start[2]:
        return True
    return term_vars(start[2][0]) <= term_vars(head[2][0])


def _has_arithmetic(term: Term) -> bool:
    if term[0] in ("b", "u"):
        return True
    return term[0] == "f" and any(_has_arithmetic(t) for t in term[2])


@dataclass
class Catalog:
    rules: list[RuleInfo]
    templates: dict[tuple[str, int], PredTemplate]
    compiled: list[CompiledRule]
    facts: list[ast.AST] = field(repr=False)
    fact_rule: dict[Symbol, str] = field(default_factory=dict, repr=False)
    digest: str = ""  # of its files' names and texts: the same rules, the same digest (catalog_digest)
    fact_predicates: set[str] = field(default_factory=set, repr=False)
    fact_atoms: dict[str, list[Symbol]] = field(default_factory=dict, repr=False)  # the catalog's facts by predicate
    hidden: set[tuple[str, int]] = field(default_factory=set, repr=False)
    words: dict[str, str] = field(default_factory=dict, repr=False)  # a constant's English (`%! term name :: "..."`)
    # how a negative proof of a predicate reads where "there is no evidence that" + its words would not read as a
    # denial (`%! denies ab(X) :: "..."`: not "there is no evidence that an exception applies: the light flashes red")
    denials: dict[tuple[str, int], PredTemplate] = field(default_factory=dict, repr=False)
    # (rule id, head signature) -> how an atom reads when that rule derived it (`%! reads`)
    rule_templates: dict[tuple[str, tuple[str, int]], PredTemplate] = field(default_factory=dict, repr=False)
    _slices: dict[frozenset[str], tuple[frozenset[str], frozenset[str]]] = field(default_factory=dict, repr=False)
    _within: dict[tuple[frozenset[str], frozenset[Term]], list[ast.AST]] = field(default_factory=dict, repr=False)
    _patterns: dict[frozenset[str], frozenset[Term]] = field(default_factory=dict, repr=False)
    _outside: dict[tuple[frozenset[str], Optional[frozenset[str]]], list[tuple[str, int]]] = field(
        default_factory=dict, repr=False)
    _enabling: dict[frozenset[str], list[tuple[str, int]]] = field(default_factory=dict, repr=False)
    _deriving: dict[tuple[str, int, Optional[Symbol]], list[CompiledRule]] = field(default_factory=dict, repr=False)
    _records: dict[Symbol, list[tuple[CompiledRule, Symbol]]] = field(default_factory=dict, repr=False)
    # Units of each rule's variables by rule index, read off the templates (phrases.Phrasebook.formats_of): the same
    # in every frame, so kept here rather than worked out again for each proof.
    variable_formats: dict[int, dict[str, str]] = field(default_factory=dict, repr=False)
    # What loads but is likely a mistake (a misspelt predicate): "file:line: rule: ...", for the commands to show.
    warnings: list[str] = field(default_factory=list, repr=False)

    @cached_property
    def by_id(self) -> dict[str, RuleInfo]:
        return {r.id: r for r in self.rules}

    @cached_property
    def by_head(self) -> dict[tuple[str, int], list[CompiledRule]]:
        index: dict[tuple[str, int], list[CompiledRule]] = {}
        for rule in self.compiled:
            index.setdefault(rule.signature, []).append(rule)
        return index

    @cached_property
    def static(self) -> frozenset[str]:
        """Predicates no frame changes: why one of their atoms is absent needs no proof, like a class hierarchy."""
        return static_predicates(self)

    @cached_property
    def traces(self) -> dict[tuple[str, int], ast.AST]:
        """For each TRACED predicate the rules define: the rule that gives its atoms from the rules' records."""
        found = {}
        for name, arity in sorted(s for s in self.by_head if s[0] in TRACED):
            variables = [f"V{i}" for i in range(arity)]
            atom = f"{name}({','.join(variables)})" if variables else name
            found[(name, arity)] = _parsed_rule(f"{atom} :- {TRACE_PREFIX}{name}({','.join([*variables, 'K'])}).")
        return found

    @cached_property
    def replayable(self) -> frozenset[tuple[str, int]]:
        """Predicates whose atoms with a given first argument the prover can find by replaying their rules.

        That is those defined by rules (no catalog facts), each rule starting from a lookup by first argument
        (`_replays_from_first`), so that finding one object's atoms costs a few lookups. The bodies are solved
        against the answer set itself, in which every derived atom is supported by a rule whose body holds: so
        the rules' solutions, with the frame's own facts of the predicate, are exactly its atoms, recursion or not.
        """
        return frozenset(
            (name, arity) for (name, arity), rules in self.by_head.items()
            if name not in self.fact_predicates and all(_replays_from_first(r) for r in rules)
        )

    @cached_property
    def recursion(self) -> dict[str, int]:
        """Predicate -> its strongly connected component, for those defined through themselves (obj_lane and
        lane_label_contradicted): a replay must not wait on a replay of its own component."""
        edges = _dependencies(self.compiled)
        component = _components(edges)
        return {head: component[head] for head, body in edges.items()
                if any(component.get(predicate) == component[head] for predicate, _ in body)}

    @cached_property
    def alternatives(self) -> dict[int, tuple[frozenset[Term], ...]]:
        """Rule index -> groups of patterns: its positive body needs an atom of some pattern of each group.

        `obj_lane(O,K,_), crossing_kind(K)` needs `obj_lane(_,cross_left,_)` or `obj_lane(_,cross_right,_)`:
        the kinds the catalog's facts list, and no rule adds to. A group is kept where other rules require each
        of its patterns too: what a frame learns of those (presence.py) then leaves the rule out, at no cost of
        a check or guard of its own.
        """
        listed = {name: [atom.arguments[0] for atom in atoms] for name, atoms in self.fact_atoms.items()
                  if all(len(atom.arguments) == 1 for atom in atoms) and (name, 1) not in self.by_head}
        required = frozenset().union(*(rule.requires for rule in self.compiled))
        found: dict[int, tuple[frozenset[Term], ...]] = {}
        for rule in self.compiled:
            positive = [lit.atom for lit in rule.body if lit.is_atom and not lit.negated and lit.atom[0] == "f"]
            groups = []
            for kinds in positive:
                if kinds[1] not in listed or len(kinds[2]) != 1 or kinds[2][0][0] != "v":
                    continue
                variable = kinds[2][0]
                for atom in positive:
                    if atom[1] in listed or variable not in atom[2]:
                        continue
                    group = frozenset(pattern_of(("f", atom[1], tuple(("s", value) if a == variable else a
                                                                         for a in atom[2])))
                                      for value in listed[kinds[1]])
                    if group <= required:
                        groups.append(group)
            if groups:
                found[rule.index] = tuple(groups)
        return found

    def rules_deriving(self, name: str, arity: int, first: Optional[Symbol]) -> list[CompiledRule]:
        """The rules whose head can derive name/arity atoms with this first argument, in catalog order.

        A head with a constant first argument (`applicable(brake)`) is left out for any other constant: the
        prover looks for derivations of the same few atoms in every verdict, and most rules for them are
        about another action.
        """
        key = (name, arity, first)
        found = self._deriving.get(key)
        if found is None:
            found = self._deriving[key] = [rule for rule in self.by_head.get((name, arity), [])
                                           if first is None or _may_have_first(rule.head, first)]
        return found

    def records(self, atom: Symbol) -> list[tuple[CompiledRule, Symbol]]:
        """For an atom of a TRACED predicate: each rule that may derive it, with the record clingo has if it did."""
        found = self._records.get(atom)
        if found is None:
            arguments = atom.arguments
            found = self._records[atom] = [
                (rule, Function(TRACE_PREFIX + atom.name, [*arguments, Number(rule.index)]))
                for rule in self.rules_deriving(atom.name, len(arguments), arguments[0] if arguments else None)]
        return found

    def program_for(self, given: frozenset[str]) -> list[ast.AST]:
        """The statements that can matter when the frame's facts use these predicates.

        A rule whose positive body needs a predicate that no fact provides and
        no rule can derive never fires; leaving it out changes no model and
        saves its grounding cost (about 10 us a rule).
        """
        return self.rules_within(self.derivable(given))

    def rules_within(self, present: frozenset[str], absent: frozenset[Term] = frozenset()) -> list[ast.AST]:
        """The catalog's facts and every rule whose positive body needs only predicates in `present`
        and no atom of an `absent` pattern.

        With `present` the predicates that have atoms in the frame's answer set and `absent` patterns that
        match none of them, this is all that can fire: any other rule has a false body (presence.py says
        when a guess at both may be trusted).
        """
        key = (present, absent)
        found = self._within.get(key)
        if found is None:
            have = present | self.fact_predicates
            rules = [r for r in self.compiled if r.needs <= have and not r.requires & absent
                     and not any(group <= absent for group in self.alternatives.get(r.index, ()))]
            traced = sorted({r.signature for r in rules} & self.traces.keys())
            found = self._within[key] = self.facts + [r.statement for r in rules] + [self.traces[s] for s in traced]
        return found

    def patterns_within(self, present: frozenset[str]) -> frozenset[Term]:
        """The patterns that rules within `present` require an atom of: those `rules_within` may leave out."""
        found = self._patterns.get(present)
        if found is None:
            have = present | self.fact_predicates
            found = self._patterns[present] = frozenset().union(*(r.requires for r in self.compiled if r.needs <= have))
        return found

    def derived_outside(self, present: frozenset[str], within: Optional[frozenset[str]] = None) -> list[tuple[str, int]]:
        """Signatures that `rules_within(within)` (by default `present`) can derive and that are not in `present`."""
        key = (present, within)
        found = self._outside.get(key)
        if found is None:
            have = (present if within is None else within) | self.fact_predicates
            found = self._outside[key] = sorted({r.signature for r in self.compiled
                                                 if r.needs <= have and r.signature[0] not in present})
        return found

    def enabling_outside(self, present: frozenset[str]) -> list[tuple[str, int]]:
        """Of `derived_outside(present)`, the signatures that a rule left out of `rules_within(present)` needs: the
        catalog being stratified, a left-out rule can only fire once an atom of one of these is derived."""
        found = self._enabling.get(present)
        if found is None:
            have = present | self.fact_predicates
            needed = set().union(*(r.needs for r in self.compiled if not r.needs <= have))
            found = self._enabling[present] = [s for s in self.derived_outside(present) if s[0] in needed]
        return found

    def defined_in(self, given: frozenset[str]) -> frozenset[str]:
        """The predicates that the catalog's facts or the slice's rules for these predicates define.

        A frame fact's predicate that is not among them has exactly the frame's facts as its atoms.
        """
        return self._slice(given)[0]

    def derivable(self, given: frozenset[str]) -> frozenset[str]:
        """The predicates that may have atoms when the frame's facts use these: those and `defined_in`'s."""
        return self._slice(given)[1]

    def _slice(self, given: frozenset[str]) -> tuple[frozenset[str], frozenset[str]]:
        found = self._slices.get(given)
        if found is None:
            derivable = set(given | self.fact_predicates)
            defined = set(self.fact_predicates)
            pending = list(self.compiled)
            changed = True
            while changed:
                changed = False
                still = []
                for rule in pending:
                    if rule.needs <= derivable:
                        derivable.add(rule.signature[0])
                        defined.add(rule.signature[0])
                        changed = True
                    else:
                        still.append(rule)
                pending = still
            found = self._slices[given] = (frozenset(defined), frozenset(derivable))
        return found

    def driving_rules(self) -> list[RuleInfo]:
        """Rules that decide something, as opposed to definitions (def.*) and data (ent.*)."""
        return [r for r in self.rules if not r.id.startswith(DEFINITION_PREFIXES)]


def _classically_negated(stm: ast.AST) -> bool:
    """Whether the head or a body literal of a statement is a classically negated atom (`-p(X)`)."""
    literals = [stm.head, *stm.body]
    return any(lit.ast_type == ast.ASTType.Literal and lit.atom.ast_type == ast.ASTType.SymbolicAtom
               and lit.atom.symbol.ast_type == ast.ASTType.UnaryOperation for lit in literals)


def signature_of(head: ast.AST) -> tuple[str, int]:
    atom = head.atom if head.ast_type == ast.ASTType.Literal else head
    term = atom.symbol
    if term.ast_type == ast.ASTType.Function:
        return (term.name, len(term.arguments))
    if term.ast_type == ast.ASTType.SymbolicTerm:
        return (term.symbol.name, 0)
    raise CatalogError(f"unsupported head {head}")


@dataclass(frozen=True)
class _Annotations:
    blocks: dict[int, RuleInfo]  # each `%! rule` block's first line -> its RuleInfo
    templates: list[tuple[str, int, PredTemplate]]  # ("pred" or "term", its line, its template)
    hidden: set[tuple[str, int]]
    reads: list[tuple[str, int, PredTemplate]]  # (rule id, line, how its head reads)
    described: dict[int, list[tuple[int, str]]]  # each block's first line -> (line, "says" or "source") of its own


def _annotations(text: str, path: str) -> _Annotations:
    """Map each `%! rule` block's first line to its RuleInfo; collect templates, rules' own words and hidden predicates."""
    blocks: dict[int, RuleInfo] = {}
    templates: list[tuple[str, int, PredTemplate]] = []
    reads: list[tuple[str, int, PredTemplate]] = []
    hidden: set[tuple[str, int]] = set()
    described: dict[int, list[tuple[int, str]]] = {}
    current: dict[str, str] = {}
    start = 0

    def close() -> None:
        """A rule block ends: it must have said what it says and where it comes from, or its id would be lost."""
        missing = [f"'%! {key}'" for key in ("says", "source") if key not in current]
        if current and missing:
            raise CatalogError(f"{path}:{start}: rule {current['rule']} has no {' and no '.join(missing)}")

    for number, line in enumerate(text.splitlines(), start=1):
        line = line.strip()
        if not line.startswith("%!"):
            continue
        match = _ANNOTATION.match(line)
        key, value = match.groups() if match else (None, None)
        if key not in _ANNOTATION_KEYS:  # a misspelt keyword would leave its block to the rule before it
            raise CatalogError(f"{path}:{number}: not an annotation: {line!r}"
                               f" (a '%!' line is '%! <keyword> <value>', keyword one of {', '.join(_ANNOTATION_KEYS)})")
        if not value:
            raise CatalogError(f"{path}:{number}: '%! {key}' without its {'id' if key == 'rule' else 'value'}")
        if key == "rule" and re.search(r"\s", value):
            raise CatalogError(f"{path}:{number}: rule id {value!r} holds white space")
        if key == "hide":
            name, _, arity = value.partition("/")
            if not arity.isdigit():
                raise CatalogError(f"{path}:{number}: hide needs name/arity, got {value!r}")
            hidden.add((name, int(arity)))
        elif key in ("pred", "term", "reads", "denies"):  # a term's words (hazard(obstacle(3))) are written like a predicate's
            if key == "reads" and not current:
                raise CatalogError(f"{path}:{number}: 'reads' before any '%! rule'")
            pred = _PRED.match(value)
            if not pred:
                raise CatalogError(f"{path}:{number}: bad {key} annotation {value!r}")
            name, params, template = pred.groups()
            args = tuple(p.strip() for p in params.split(",")) if params else ()
            for placeholder in PLACEHOLDER.finditer(template):
                param, fmt = placeholder.group(1), placeholder.group(2)
                if param not in args and not param[:1].islower():  # a constant's name reads as its words
                    raise CatalogError(f"{path}:{number}: {placeholder.group(0)} names no parameter of {name}{args}")
                if fmt is not None and fmt not in TEMPLATE_FORMATS:
                    raise CatalogError(f"{path}:{number}: unknown format {fmt!r} in {placeholder.group(0)}"
                                       f" (known: {', '.join(sorted(TEMPLATE_FORMATS))})")
            if key == "reads":
                reads.append((current["rule"], number, PredTemplate(name, args, template)))
            else:
                templates.append((key, number, PredTemplate(name, args, template)))
        elif key == "rule":
            close()
            current, start = {"rule": value}, number
        else:
            if not current:
                raise CatalogError(f"{path}:{number}: '{key}' before any '%! rule'")
            if key in current:  # a block whose `%! rule` line is missing: it would take this rule's id
                first = next(line for line, said in described[start] if said == key)
                raise CatalogError(f"{path}:{number}: a second '%! {key}' for rule {current['rule']} (line {first}):"
                                   f" the rule block at {path}:{number} has no `%! rule` line")
            current[key] = value
            described.setdefault(start, []).append((number, key))
            if "says" in current and "source" in current:
                blocks[start] = RuleInfo(current["rule"], current["says"], current["source"], path, start)
    close()
    return _Annotations(blocks, templates, hidden, reads, described)


@dataclass
class _Places:
    """Where the files read so far write what the loader checks once all are read: "file:line"."""

    templates: dict[tuple[str, int] | str, str] = field(default_factory=dict)  # by signature; a constant's by name
    facts: list[tuple[tuple[str, int], str, Optional[str]]] = field(default_factory=list)  # (signature, place, rule id)


def _compile_file(path: str, text: str, catalog: Catalog, places: _Places) -> None:
    declared = places.templates
    found = _annotations(text, path)
    blocks = found.blocks
    catalog.hidden |= found.hidden
    for rule_id, _, template in found.reads:
        catalog.rule_templates[(rule_id, template.signature)] = template
    for key, line, template in found.templates:
        constant = key == "term" and not template.params  # a constant's words: its own, apart from any predicate's
        what = template.name if constant else template.signature
        if key == "denies":  # how "there is no evidence of it" reads: one wording too, apart from the atom's
            what = "not " + "/".join(map(str, template.signature))
        if what in declared:  # the later one would replace the shipped wording, unsaid
            named = template.name if constant else "/".join(map(str, template.signature))
            raise CatalogError(f"{path}:{line}: a second '%! {key}' for {named}: it has words at {declared[what]}"
                               " already (one wording each)")
        declared[what] = f"{path}:{line}"
        if key == "denies":
            catalog.denials[template.signature] = template
        elif constant:
            catalog.words[template.name] = template.template
        else:
            catalog.templates[template.signature] = template
    starts = sorted(blocks)
    for info in blocks.values():
        catalog.rules.append(info)

    def owner(line: int) -> RuleInfo | None:
        best = None
        for start in starts:
            if start < line:
                best = blocks[start]
        return best

    parsed: list[ast.AST] = []
    messages: list[str] = []
    try:
        ast.parse_string(text, parsed.append, logger=lambda _code, message: messages.append(message.strip()))
    except RuntimeError:
        detail = "; ".join(m.replace("<string>", path) for m in messages) or "syntax error"
        unended = _unended_line(text, messages)
        if unended is None:
            raise CatalogError(f"{path}: cannot parse: {detail}") from None
        info = owner(unended)
        rule = f" {info.id}:" if info is not None else ""
        raise CatalogError(f"{path}:{unended}:{rule} cannot parse: the statement ends on this line without a full stop"
                           f" (clingo: {detail})") from None
    for stm in parsed:
        if stm.ast_type in (ast.ASTType.Program, ast.ASTType.Comment):
            continue
        if stm.ast_type != ast.ASTType.Rule:
            raise CatalogError(f"{path}:{stm.location.begin.line}: only rules and facts belong in a catalog")
        info = owner(stm.location.begin.line)
        if info is not None:
            _check_described_first(info, found.described[info.line], stm.location.begin.line)
        if _classically_negated(stm):  # the prover and the slicers read an atom's predicate from its name
            raise CatalogError(f"{path}:{stm.location.begin.line}: classical negation ('-p') is not supported: "
                               "name the opposite as a predicate of its own, or use 'not p'")
        normal = stm.head.ast_type == ast.ASTType.Literal and stm.head.atom.ast_type == ast.ASTType.SymbolicAtom
        if not stm.body:
            if not normal:  # a choice, a disjunction or a constraint: no fact the prover could cite
                raise CatalogError(f"{path}:{stm.location.begin.line}: only normal rules and facts are supported")
            catalog.facts.append(stm)
            atoms = _ground_fact(stm, path, info)
            places.facts.extend((signature, f"{path}:{stm.location.begin.line}", info and info.id)
                                for signature in dict.fromkeys((a.name, len(a.arguments)) for a in atoms))
            for atom in atoms:
                catalog.fact_predicates.add(atom.name)
                catalog.fact_atoms.setdefault(atom.name, []).append(atom)
                if info is not None:
                    catalog.fact_rule[atom] = info.id
            continue
        if info is None:
            raise CatalogError(f"{path}:{stm.location.begin.line}: rule has no '%! rule' annotation")
        if not normal:
            raise CatalogError(f"{path}:{stm.location.begin.line}: {info.id}: only normal rules are supported")
        try:
            body = tuple(compile_literal(lit) for lit in stm.body)
        except ValueError as exc:  # an aggregate, a conditional literal: nothing the prover can replay
            raise CatalogError(f"{path}:{stm.location.begin.line}: {info.id}: {exc}") from None
        head, computed = _computed_head_arguments(stm.head.atom.symbol, body)
        body += computed
        if any(lit.negated and not lit.is_atom for lit in body):
            raise CatalogError(f"{path}:{stm.location.begin.line}: {info.id}: negated comparisons are not supported")
        catalog.compiled.append(
            CompiledRule(
                index=len(catalog.compiled),
                info=info,
                statement=_traced(_grounding_form(stm, set(term_vars(head)).union(*(lit.variables for lit in body))),
                                  len(catalog.compiled)),
                head=head,
                body=body,
                signature=signature_of(stm.head),
                needs=frozenset(lit.predicate for lit in body if lit.is_atom and not lit.negated),
                requires=frozenset(pattern for lit in body if lit.is_atom and not lit.negated
                                   for pattern in [pattern_of(lit.atom)] if is_fixed(pattern)),
                assignments=_assignments(body),
            )
        )
    derived = {(rule.info.id, rule.signature) for rule in catalog.compiled}
    for rule_id, line, template in found.reads:
        if (rule_id, template.signature) not in derived:
            name, arity = template.signature
            raise CatalogError(f"{path}:{line}: 'reads' gives words for {name}/{arity}, which rule {rule_id} does not derive")


_SYNTAX_ERROR_AT = re.compile(r"^<string>:(\d+):(\d+)")


def _unended_line(text: str, messages: list[str]) -> Optional[int]:
    """The line a statement that lacks its full stop ends on, where clingo's syntax error says so.

    clingo reports a missing full stop at the next statement's first token, often a block further on. Taken
    as one when the error is at the first token of its line (or the end of the file), and the code before it
    ends as a statement can (a name, a number, a closing bracket; not `,`, `:-` or `;`) with its brackets closed.
    """
    found = _SYNTAX_ERROR_AT.match(messages[0]) if messages else None
    if found is None:
        return None
    lines = text.splitlines()
    line, column = int(found.group(1)), int(found.group(2))
    if line <= len(lines) and lines[line - 1][:column - 1].strip():
        return None
    code = [(number, _without_comment(lines[number - 1]).rstrip()) for number in range(1, min(line, len(lines) + 1))]
    code = [(number, written) for number, written in code if written]
    if not code or not re.search(r'[\w)"]$', code[-1][1]):
        return None
    statement = []
    for _, written in reversed(code):
        if written.endswith("."):
            break
        statement.append(re.sub(r'"(?:\\.|[^"\\])*"', "", written))
    opened = "".join(statement)
    return code[-1][0] if opened.count("(") == opened.count(")") else None


def _without_comment(line: str) -> str:
    """A line of clingo without its `%` comment (a `%` inside a string stays)."""
    quoted = False
    for i, char in enumerate(line):
        if char == '"' and (i == 0 or line[i - 1] != "\\"):
            quoted = not quoted
        elif char == "%" and not quoted:
            return line[:i]
    return line


def _check_described_first(info: RuleInfo, described: list[tuple[int, str]], statement: int) -> None:
    """A block's `says` and `source` come before its statements: one after them starts a block with no `%! rule`
    line, whose statement would otherwise be credited to this rule."""
    for line, key in described:
        if line > statement:
            raise CatalogError(f"{info.file}:{line}: '%! {key}' after rule {info.id}'s statement at line {statement}:"
                               f" the rule block at {info.file}:{line} has no `%! rule` line")


def _computed_head_arguments(head: ast.AST, body: tuple[Literal, ...]) -> tuple[Term, tuple[Literal, ...]]:
    """The head with a fresh variable for each computed argument, and `Fresh = expr` for the body's end.

    `left_lane(L-1)` cannot be matched against `left_lane(2)` to find L; `left_lane(H) :- ..., H = L-1` can, and
    means the same. The prover replays rules in this form: otherwise what they derive reads as a given fact.
    """
    taken = set(term_vars(compile_term(head))).union(*(lit.variables for lit in body))
    computed: list[Literal] = []

    def bind(node: ast.AST) -> Term:
        if node.ast_type == ast.ASTType.Function:
            return ("f", node.name, tuple(bind(arg) for arg in node.arguments))
        term = compile_term(node)
        if term[0] in ("v", "s"):
            return term
        name = next(f"Head{i}" for i in range(len(taken) + 1) if f"Head{i}" not in taken)
        taken.add(name)
        equality = (int(ast.ComparisonOperator.Equal), term)
        computed.append(Literal(False, None, (("v", name), (equality,)), term_vars(term) | {name}, f"{name} = {node}"))
        return ("v", name)

    return bind(head), tuple(computed)


class _NameAnonymous(ast.Transformer):
    """Gives each `_` of a positive body atom a fresh name (`_grounding_form`)."""

    def __init__(self, taken: set[str]):
        self.taken = taken
        self.count = 0

    def visit_Variable(self, variable: ast.AST) -> ast.AST:
        if variable.name != "_":
            return variable
        name = f"Any{self.count}"
        while name in self.taken:
            self.count += 1
            name = f"Any{self.count}"
        self.taken.add(name)
        return variable.update(name=name)


def _grounding_form(stm: ast.AST, taken: set[str]) -> ast.AST:
    """The rule with a fresh variable for each `_` in its positive body atoms: the same answer sets.

    For `p(O,_)` in a positive body clingo adds a projection of p to O; a variable that occurs once needs
    none. Measured on random scenes: grounding 8 to 10 % faster at 50 and 200 objects, the same atoms.
    A `_` under `not` stays: there it is quantified inside the negation. `taken`: the rule's variables.
    """
    naming = _NameAnonymous(taken)
    body = [naming.visit(lit) if lit.ast_type == ast.ASTType.Literal and lit.sign == ast.Sign.NoSign
            and lit.atom.ast_type == ast.ASTType.SymbolicAtom else lit for lit in stm.body]
    return stm.update(body=body)


def _traced(stm: ast.AST, index: int) -> ast.AST:
    """A rule of a TRACED predicate, `p(X) :- B`, as `__by_p(X,index) :- B`; any other rule as it is."""
    symbol = stm.head.atom.symbol
    if symbol.ast_type != ast.ASTType.Function or symbol.name not in TRACED:
        return stm
    record = symbol.update(name=TRACE_PREFIX + symbol.name,
                           arguments=[*symbol.arguments, ast.SymbolicTerm(symbol.location, Number(index))])
    return stm.update(head=stm.head.update(atom=stm.head.atom.update(symbol=record)))


def _parsed_rule(text: str) -> ast.AST:
    parsed: list[ast.AST] = []
    ast.parse_string(text, parsed.append)
    return parsed[-1]


def _assignments(body: tuple[Literal, ...]) -> frozenset[int]:
    bound = set().union(*(lit.variables for lit in body if lit.is_atom and not lit.negated))
    found = set()
    for i, lit in enumerate(body):
        if lit.comparison is not None and len(lit.comparison[1]) == 1 and lit.comparison[1][0][0] == int(ast.ComparisonOperator.Equal):
            left, right = lit.comparison[0], lit.comparison[1][0][1]
            if (left[0] == "v" and left[1] not in bound) or (right[0] == "v" and right[1] not in bound):
                found.add(i)
    return frozenset(found)


def _ground_fact(stm: ast.AST, path: str, info: Optional[RuleInfo]) -> list[Symbol]:
    """The atoms a catalog fact stands for (pools expanded), to credit them to their rule."""
    rule_at = {stm.location.begin.line: info.id} if info is not None else {}
    control = _ground_alone([stm], path, rule_at)  # held while its atoms are read: they live in it
    return [a.symbol for a in control.symbolic_atoms if a.is_fact]


def _ground_alone(statements: Iterable[ast.AST], path: str, rule_at: dict[int, str]) -> Control:
    """The statements grounded with no facts. clingo finds an unsafe variable (`foo(X).`, `p(A) :- not q.`) only
    when it grounds: refused here, named by the file, line and rule id (`rule_at`: a statement's line -> its rule)."""
    messages: list[str] = []
    control = Control(["--warn=none"], logger=lambda _code, message: messages.append(message.strip()))
    try:
        with ast.ProgramBuilder(control) as builder:
            for statement in statements:
                builder.add(statement)
        control.ground([("base", [])])
    except RuntimeError:
        raise CatalogError(_grounding_problem(messages, path, rule_at)) from None
    return control


_CLINGO_AT = re.compile(r"^<string>:(\d+):[\d:-]+: error: (.*?):?$")
_UNSAFE = re.compile(r"note: '(\w+)' is unsafe")


def _grounding_problem(messages: list[str], path: str, rule_at: dict[int, str]) -> str:
    """clingo's first grounding error as the catalog reads: where its statement is written and its rule, not the
    rule as clingo rewrote it (`#range(Y,1,2999);[#inc_base]`)."""
    for message in messages:
        lines = message.splitlines()
        found = _CLINGO_AT.match(lines[0])
        if found is None:
            continue
        line = int(found.group(1))
        rule = f" {rule_at[line]}:" if line in rule_at else ""
        unsafe = [m.group(1) for m in map(_UNSAFE.search, lines[1:]) if m]
        what = found.group(2)
        if unsafe:
            what = (f"unsafe variable{'s' if len(unsafe) > 1 else ''} {', '.join(unsafe)}: no positive body atom"
                    f" binds {'them' if len(unsafe) > 1 else 'it'}")
        return f"{path}:{line}:{rule} clingo cannot ground it: {what}"
    said = " ".join(" ".join(m.split()) for m in messages).replace("<string>", path)
    return f"{path}: clingo cannot ground it: {said or 'no reason given'}"


def _signature(atom: Term) -> tuple[str, int]:
    return (atom[1].name, len(atom[1].arguments)) if atom[0] == "s" else (atom[1], len(atom[2]))


def _terms(term: Term | Symbol) -> Iterable[tuple[str, int]]:
    """The signatures of the compound terms in an atom's arguments, at any depth (`hazard(obstacle(O))`: obstacle/1)."""
    if not isinstance(term, Symbol) and term[0] == "s":
        term = term[1]
    if isinstance(term, Symbol):
        arguments: Sequence = term.arguments if term.type == SymbolType.Function else ()
    else:
        arguments = term[2] if term[0] == "f" else ()
    for argument in arguments:
        if not isinstance(argument, Symbol) and argument[0] == "s":
            argument = argument[1]
        if isinstance(argument, Symbol) and argument.type == SymbolType.Function and argument.arguments:
            yield argument.name, len(argument.arguments)
        elif not isinstance(argument, Symbol) and argument[0] == "f" and argument[2]:
            yield argument[1], len(argument[2])
        yield from _terms(argument)


def _where(rule: CompiledRule) -> str:
    return f"{rule.info.file}:{rule.statement.location.begin.line}: {rule.info.id}"


def _check_words(catalog: Catalog, places: _Places) -> None:
    """Every atom a rule derives reads as English: its predicate has a `%! pred` template (unless hidden), and a
    hazard its words (`%! term obstacle(O)`, or for a constant `%! term flashing_red`). Else a proof shows the raw
    atom, its numbers in centimetres: `truck_too_close(7, 2500)`, "there is a hazard: truck close (7, 2500)"."""
    read = _read(catalog)
    for rule in catalog.compiled:
        name, arity = rule.signature
        if rule.signature not in catalog.templates and rule.signature not in catalog.hidden:
            others = [f"the one at {places.templates[s]} is for {_show(s)}" for s in catalog.templates if s[0] == name]
            hint = f" ({'; '.join(others)})" if others else ""
            if not hint and rule.signature not in read:  # nothing reads it either: a misspelt predicate (forbiden)
                hint = _guess(_show(rule.signature), map(_show, catalog.templates))
            raise CatalogError(f"{_where(rule)}: {name}/{arity} has no '%! pred' template: its atoms would read as raw"
                               f" terms, numbers in centimetres{hint}")
        if name != "hazard" or arity != 1:
            continue
        hazard = rule.head[2][0] if rule.head[0] == "f" else None
        if hazard is not None and hazard[0] == "f" and (hazard[1], len(hazard[2])) not in catalog.templates:
            raise CatalogError(f"{_where(rule)}: the hazard {hazard[1]}/{len(hazard[2])} has no '%! term' template:"
                               " it would read as a raw term, numbers in centimetres")
        constant = hazard[1] if hazard is not None and hazard[0] == "s" else None
        if constant is not None and constant.type == SymbolType.Function and constant.name not in catalog.words:
            words = constant.name.replace("_", " ")
            raise CatalogError(f"{_where(rule)}: the hazard {constant.name} has no '%! term' words: it would read as"
                               f" \"{words}\"")


VERDICT_CONSTANTS = ("permitted", "recommended", "replacement")  # the actions every verdict reads (engine.SolvedFrame)
# The atoms the verdict reads (those, the proposal's reasons and prohibitions, the sanity layer's notes): a rule
# deriving another predicate that no rule reads decides nothing.
VERDICT_READS = frozenset({(name, 1) for name in VERDICT_CONSTANTS} | {("applicable", 1), ("forbidden", 1), ("noted", 1)})


def frame_predicates(providers: Iterable[FactProvider] = ()) -> frozenset[tuple[str, int]]:
    """The predicates a frame's facts may give: the scene's, the parameters' and its fact providers'."""
    return SCENE_PREDICATES.union({("param", 2)}, *(provider.predicates for provider in providers))


def _setting_names(catalog: Catalog, providers: Sequence[FactProvider]) -> dict[str, frozenset[str]]:
    """Per setting predicate, the names that the reasoner's, the fact providers' or the catalog's own facts give."""
    given = {"param": PARAM_NAMES}
    if providers:
        given["window_param"] = frozenset().union(*(provider.params for provider in providers))
    return {name: names | {atom.arguments[0].name for atom in catalog.fact_atoms.get(name, [])
                           if len(atom.arguments) == 2 and atom.arguments[0].type == SymbolType.Function}
            for name, names in given.items()}


def _show(signature: tuple[str, int]) -> str:
    return f"{signature[0]}/{signature[1]}"


def _guess(name: str, known: Iterable[str]) -> str:
    close = difflib.get_close_matches(name, sorted(known), n=1)
    return f" (did you mean {close[0]}?)" if close else ""


def _warnings(catalog: Catalog, places: _Places, providers: Sequence[FactProvider]) -> Iterable[str]:
    """What loads but is likely a mistake, in catalog order (`Catalog.warnings`), given what the frames' fact
    providers give besides the scene."""
    given = ({rule.signature for rule in catalog.compiled} | {signature for signature, _, _ in places.facts}
             | frame_predicates(providers))
    yield from _unknown_reads(catalog, given, _setting_names(catalog, providers))
    yield from _unread(catalog)
    yield from _unworded(catalog, places, given)


def _unknown_reads(catalog: Catalog, given: set[tuple[str, int]],
                   settings: dict[str, frozenset[str]]) -> Iterable[str]:
    """A body atom of a predicate that nothing gives (`given`) and no `%! pred` declares, or a setting no fact names:
    a misspelling (`large_vehicles(C)`, `not truck_exmept(O)`, `param(truck_dist, T)`) by which its rule never
    fires, or is never blocked. A declared predicate may be given by nothing: a pack's setting (school_bus_law)."""
    known = {_show(s) for s in given | set(catalog.templates)}
    for rule in catalog.compiled:
        for lit in rule.body:
            if not lit.is_atom:
                continue
            signature = _signature(lit.atom)
            if signature not in given and signature not in catalog.templates:
                yield (f"{_where(rule)}: nothing gives {_show(signature)}: no catalog fact, rule or frame fact, and no"
                       f" '%! pred' declares it{_guess(_show(signature), known)}")
            name = _setting(lit.atom) if signature[0] in settings and signature[1] == 2 else None
            if name is not None and name not in settings[signature[0]]:
                hint = _guess(name, settings[signature[0]]) or f" (known: {', '.join(sorted(settings[signature[0]]))})"
                yield f"{_where(rule)}: {signature[0]}({name}, _) names no setting{hint}"


def _setting(atom: Term) -> Optional[str]:
    """The name a setting's atom gives as its first argument (`param(truck_dist, T)`), if a constant."""
    first = atom[2][0] if atom[0] == "f" else ("s", atom[1].arguments[0])
    return first[1].name if first[0] == "s" and first[1].type == SymbolType.Function else None


def _read(catalog: Catalog) -> set[tuple[str, int]]:
    """The predicates that a rule's body or the verdict reads."""
    return {_signature(lit.atom) for rule in catalog.compiled for lit in rule.body if lit.is_atom} | VERDICT_READS


def _unread(catalog: Catalog) -> Iterable[str]:
    """A rule deriving a predicate that no rule body and not the verdict reads (`forbiden(accelerate)`)."""
    read = _read(catalog)
    for rule in catalog.compiled:
        if rule.signature not in read:
            yield (f"{_where(rule)}: nothing reads {_show(rule.signature)}: no rule's body, nor the verdict"
                   f"{_guess(_show(rule.signature), map(_show, read))}")


def _unworded(catalog: Catalog, places: _Places, given: set[tuple[str, int]]) -> Iterable[str]:
    """Words missing or for nothing: a compound term in a rule's head with no `%! term` (an exception hook's
    `ab(truck_ahead(O))` reads "an exception applies: truck ahead (7)"); a catalog fact with no `%! pred` (a pack's
    setting, which the catalog it is loaded with words); a template whose signature no atom or term has."""
    atoms = [rule.head for rule in catalog.compiled] + [lit.atom for rule in catalog.compiled for lit in rule.body
                                                        if lit.is_atom]
    terms = {signature for atom in atoms for signature in _terms(atom)}
    terms |= {signature for facts in catalog.fact_atoms.values() for atom in facts for signature in _terms(atom)}
    for rule in catalog.compiled:
        for signature in dict.fromkeys(_terms(rule.head)):
            if signature not in catalog.templates:
                yield f"{_where(rule)}: the term {_show(signature)} in its head has no '%! term' template"
    for signature, place, rule_id in places.facts:
        if signature not in catalog.templates and signature not in catalog.hidden:
            yield f"{place}: {rule_id or 'a fact'}: {_show(signature)} has no '%! pred' template"
    used = given | terms | {_signature(atom) for atom in atoms}
    for signature, place in places.templates.items():
        if isinstance(signature, tuple) and signature not in used:
            yield f"{place}: the template for {_show(signature)} words no predicate or term that the catalog uses"


def _check_ranks(catalog: Catalog) -> None:
    """`rank/2` orders the actions (def.ranks_below): one rank per action, one action per rank.

    A jurisdiction pack ranks the lane changes with facts of its own. An action ranked twice ranks below itself,
    and is never recommended where it is called for; two actions of one rank are both recommended, and the
    verdict picks one by an order of its own.
    """
    by_action: dict[Symbol, Symbol] = {}  # action -> the first fact that ranks it
    by_rank: dict[Symbol, Symbol] = {}  # rank -> the first fact that gives it
    for atom in catalog.fact_atoms.get("rank", []):
        if len(atom.arguments) != 2:
            continue
        action, rank = atom.arguments
        before = by_action.setdefault(action, atom)
        if before == atom:
            before = by_rank.setdefault(rank, atom)
            if before == atom:
                continue
            problem = f"rank {rank} is given twice: to {action} here, to {before.arguments[0]}"
        else:
            problem = f"{action} is ranked twice: {rank} here, {before.arguments[1]}"
        info, earlier = (catalog.by_id.get(catalog.fact_rule.get(a, "")) for a in (atom, before))
        here = f"{info.file}:{info.line}: {info.id}: " if info is not None else ""
        there = f" by {earlier.id} at {earlier.file}:{earlier.line}" if earlier is not None else " by a fact of no rule"
        raise CatalogError(f"{here}{problem}{there} (rank/2 gives each action one rank, each rank to one action)")


def _check_stratified(catalog: Catalog) -> None:
    """No atom may depend on itself through negation (`_exception_graph`).

    Then the program has exactly one answer set, the grounder computes it as
    facts, and every atom's justification is well-founded. A cycle is named by
    the rules that close it, the first in catalog order: the same every run.
    """
    edges = _exception_graph(catalog.compiled)
    component = _components(edges)
    for rule in catalog.compiled:
        head = _node(rule.head)
        for target, negated, by in edges[head]:  # the edges of every rule with this head: the rule's own named
            if by is rule and negated and component[target] == component[head]:
                back = _path(edges, target, head, component)
                raise CatalogError(
                    f"{rule.info.file}:{rule.statement.location.begin.line}: {rule.info.id}: {_node_text(head)} depends"
                    f" on itself through 'not {_node_text(target)}'"
                    + "".join(f"; {_node_text(a)} rests on {_node_text(b)} by {r.info.id} at {r.info.file}:"
                              f"{r.statement.location.begin.line}" for a, b, r in back)
                    + ": the catalog must be stratified")


_Node = tuple[str, Optional[tuple[str, int]]]  # a predicate, and for EXCEPTION_HOOK its argument's functor (None: any)


def _node(atom: Term) -> _Node:
    """An atom's node in `_exception_graph`: its predicate; for `ab/1` its argument's functor too."""
    if atom[0] == "s":
        return (atom[1].name, None)
    if atom[1] == EXCEPTION_HOOK and len(atom[2]) == 1:
        argument = atom[2][0]
        if argument[0] == "f":
            return (EXCEPTION_HOOK, (argument[1], len(argument[2])))
        if argument[0] == "s" and argument[1].type == SymbolType.Function:
            return (EXCEPTION_HOOK, (argument[1].name, len(argument[1].arguments)))
    return (atom[1], None)


def _node_text(node: _Node) -> str:
    name, functor = node
    if functor is None:
        return name
    inner, arity = functor
    return f"{name}({inner}({', '.join('_' * arity)}))" if arity else f"{name}({inner})"


def _exception_graph(rules: Sequence[CompiledRule]) -> dict[_Node, list[tuple[_Node, bool, CompiledRule]]]:
    """head node -> (node, negated, rule) for each body atom of its rules that some rule can derive, in order.

    Nodes are predicates, except that `ab/1` atoms are told apart by their argument's functor: an exception
    about a truck ahead (`ab(truck_ahead(O)) :- in_ego_lane(O), ...`) shares no atom with one about a range
    sensor's reach that `in_ego_lane` rests on through `not ab(beyond_reach(..))`, and per predicate the two
    made a cycle through negation that clingo does not see. An `ab(X)` matches every functor.
    """
    heads: dict[str, dict[_Node, None]] = {}  # predicate -> its head nodes, in catalog order
    for rule in rules:
        heads.setdefault(rule.signature[0], {})[_node(rule.head)] = None
    edges: dict[_Node, list[tuple[_Node, bool, CompiledRule]]] = {n: [] for nodes in heads.values() for n in nodes}
    for rule in rules:
        for lit in rule.body:
            if lit.is_atom:
                name, functor = _node(lit.atom)
                edges[_node(rule.head)].extend((head, lit.negated, rule) for head in heads.get(name, ())
                                               if functor is None or head[1] is None or head[1] == functor)
    return edges


def _path(edges: dict[_Node, list[tuple[_Node, bool, CompiledRule]]], start: _Node, end: _Node,
          component: dict[_Node, int]) -> list[tuple[_Node, _Node, CompiledRule]]:
    """The first shortest way from `start` to `end` within their component: (node, the node it rests on, by rule)."""
    came: dict[_Node, tuple[_Node, CompiledRule]] = {start: (start, None)}
    queue = [start]
    for node in queue:
        if node == end:
            break
        for target, _, rule in edges[node]:
            if target not in came and component[target] == component[start]:
                came[target] = (node, rule)
                queue.append(target)
    steps = []
    node = end
    while node != start:
        before, rule = came[node]
        steps.append((before, node, rule))
        node = before
    return steps[::-1]


def _dependencies(rules: Iterable[CompiledRule]) -> dict[str, set[tuple[str, bool]]]:
    """head -> (body predicate, negated) for every atom in its rules' bodies."""
    edges: dict[str, set[tuple[str, bool]]] = {}
    for rule in rules:
        for lit in rule.body:
            if lit.is_atom:
                edges.setdefault(rule.signature[0], set()).add((lit.predicate, lit.negated))
    return edges


def _components(edges: dict[Hashable, Iterable[tuple]]) -> dict[Hashable, int]:
    """Strongly connected components of a dependency graph (Tarjan's, without recursion): node -> (node, ...)."""
    index: dict[Hashable, int] = {}
    low: dict[Hashable, int] = {}
    component: dict[Hashable, int] = {}
    stack: list[Hashable] = []
    counter = 0

    def visit(root: Hashable) -> None:
        nonlocal counter
        work = [(root, iter(edges.get(root, ())))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        while work:
            node, children = work[-1]
            for child, *_ in children:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    work.append((child, iter(edges.get(child, ()))))
                    break
                if child not in component:
                    low[node] = min(low[node], index[child])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    while True:
                        member = stack.pop()
                        component[member] = index[node]
                        if member == node:
                            break

    for predicate in list(edges):
        if predicate not in index:
            visit(predicate)
    return component


def catalog_dirs() -> list[Path]:
    """The shipped catalogs: driving rules, then sanity rules."""
    return [Path(str(resources.files("discern.rules") / "catalog")),
            Path(str(resources.files("discern.sanity") / "catalog"))]


def _check_safe(catalog: Catalog) -> None:
    """A catalog with a rule clingo cannot ground is refused on loading, not at every frame: each file's rules
    grounded alone (no facts: quick), so that the message names the file."""
    by_file: dict[str, list[CompiledRule]] = {}
    for rule in catalog.compiled:
        by_file.setdefault(rule.info.file, []).append(rule)
    for file, rules in by_file.items():
        _ground_alone([r.statement for r in rules], file, {r.statement.location.begin.line: r.info.id for r in rules})


def _catalog_texts(dirs: Sequence[Path] | None, extra_files: Iterable[Path]) -> list[tuple[Path, str]]:
    files: list[Path] = []
    for directory in dirs if dirs is not None else catalog_dirs():
        directory = Path(directory)
        if not directory.is_dir():
            raise CatalogError(f"rules directory {directory} does not exist")
        files.extend(sorted(directory.glob("*.lp")))
    files.extend(Path(f) for f in extra_files)
    texts = []
    for path in files:
        try:
            texts.append((path, path.read_text(encoding="utf-8")))
        except UnicodeDecodeError as exc:
            raise CatalogError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
        except OSError as exc:  # a broken symlink or a directory named x.lp
            raise CatalogError(f"{path}: cannot read: {exc.strerror or exc}") from None
    return texts


def _digest(texts: list[tuple[Path, str]]) -> str:
    digest = hashlib.blake2b(digest_size=8)
    for path, text in texts:
        digest.update(f"{path.name}\0{text}\0".encode())
    return digest.hexdigest()


def catalog_digest(dirs: Sequence[Path] | None = None, extra_files: Iterable[Path] = ()) -> str:
    """What load_catalog(dirs, extra_files).digest would be, without compiling it: a log records which catalog
    decided it, so that a replay by another one says so."""
    return _digest(_catalog_texts(dirs, extra_files))


def load_catalog(dirs: Sequence[Path] | None = None, extra_files: Iterable[Path] = (),
                 providers: Iterable[FactProvider] = ()) -> Catalog:
    """`providers`: those of the Reasoner it is for, whose facts the warnings take as given (the sanity window's)."""
    catalog, places = _compiled(dirs, extra_files)
    _check(catalog, places, list(providers))
    return catalog


def _compiled(dirs: Sequence[Path] | None, extra_files: Iterable[Path]) -> tuple[Catalog, _Places]:
    catalog = Catalog(rules=[], templates={}, compiled=[], facts=[])
    texts = _catalog_texts(dirs, extra_files)
    places = _Places()
    for path, text in texts:
        _compile_file(str(path), text, catalog, places)
    catalog.digest = _digest(texts)
    return catalog, places


def _check(catalog: Catalog, places: _Places, providers: Sequence[FactProvider]) -> None:
    """What only the whole catalog shows: refused in one line naming the file, line and rule; or a warning."""
    seen: dict[str, RuleInfo] = {}
    for info in catalog.rules:
        if info.id in seen:
            first = seen[info.id]
            raise CatalogError(f"rule id {info.id} is used twice ({first.file}:{first.line}, {info.file}:{info.line})")
        seen[info.id] = info
    _check_ranks(catalog)
    _check_stratified(catalog)
    _check_safe(catalog)
    _check_words(catalog, places)
    catalog.warnings = list(dict.fromkeys(_warnings(catalog, places, providers)))
    catalog.alternatives  # found now (a few ms), not while the first frame's decision waits on it


DECIDING = ("action", "permitted", "recommended")  # what a verdict is read from: a driving catalog must define them


def load_driving_rules(directories: Sequence[Path], extra_files: Iterable[Path] = (),
                       providers: Iterable[FactProvider] = ()) -> Catalog:
    """A catalog with these driving-rules directories in place of rules/catalog; the sanity rules stay.

    Each directory must hold *.lp files that define driving rules: without any, no action is ever forbidden,
    a verdict that means nothing. A directory named twice is loaded once. `providers` as for `load_catalog`.
    """
    once: dict[Path, Path] = {}
    for directory in map(Path, directories):
        if not directory.exists():
            raise CatalogError(f"rules directory {directory} does not exist")
        if not directory.is_dir():
            raise CatalogError(f"rules directory {directory} is not a directory")
        if not any(directory.glob("*.lp")):
            raise CatalogError(f"rules directory {directory} has no *.lp files: no driving rules to load")
        once.setdefault(directory.resolve(), directory)
    given = list(once.values())
    shipped = [d for d in catalog_dirs()[1:] if d.resolve() not in once]
    catalog, places = _compiled(given + shipped, extra_files)
    for directory in given:
        if not any(Path(rule.file).parent == directory for rule in catalog.driving_rules()):
            raise CatalogError(
                f"rules directory {directory} defines no driving rules (no `%! rule` other than def.* and ent.*)"
            )
    defined = {rule.signature[0] for rule in catalog.compiled} | catalog.fact_predicates
    missing = [name for name in DECIDING if name not in defined]
    if missing:  # every action would be "forbidden by no rule", none recommended
        raise CatalogError(
            f"rules directories {', '.join(map(str, given))} define no {', '.join(n + '/1' for n in missing)}: "
            "the decision rules (as in rules/catalog/90_decision.lp) are missing"
        )
    _check(catalog, places, list(providers))
    return catalog


def static_fact_refused(name: str) -> ValueError:
    """A frame giving a fact of a predicate every frame has alike: its rules were grounded, or specialised, without it."""
    return ValueError(f"frame fact {name} is defined by the catalog and cannot be given per frame")


def static_predicates(catalog: Catalog, shared: Iterable[str] = ()) -> frozenset[str]:
    """Predicates whose atoms are the same in every frame: defined by the catalog from such predicates alone.

    `shared` names predicates given alike to every frame (the reasoner's parameters).
    """
    # A TRACED predicate's rules give records, not its atoms: grounded with every frame, they are never static.
    static = (set(catalog.fact_predicates) | {rule.signature[0] for rule in catalog.compiled} | set(shared)) - TRACED
    changed = True
    while changed:
        changed = False
        for rule in catalog.compiled:
            head = rule.signature[0]
            if head in static and any(lit.predicate not in static for lit in rule.body if lit.is_atom):
                static.discard(head)
                changed = True
    return frozenset(static)


def static_model(statements: Iterable[ast.AST], constant: str = "") -> list[Symbol]:
    """The atoms of what no frame changes, grounded once: the catalog's facts, the rules of `static_predicates`, and
    `constant`, fact text every frame shares. A stratified part grounds to facts alone."""
    control = Control(["--warn=none"])
    with ast.ProgramBuilder(control) as builder:
        for statement in statements:
            builder.add(statement)
    control.add("base", [], constant)
    control.ground([("base", [])])
    atoms = list(control.symbolic_atoms)
    if not all(atom.is_fact for atom in atoms):
        raise CatalogError("the part of the catalog that no frame changes does not ground to facts alone")
    return sorted(atom.symbol for atom in atoms)
