"""The catalog's frame rules specialised to what no frame changes, before clingo grounds them.

A static predicate (catalog.static_predicates: the parameters, the class hierarchy, a
jurisdiction's settings) has the same atoms in every frame, yet clingo joins a rule's
`param(decel,A)` against them in every frame's grounding, about 4 us a literal. Here
each such literal is settled once, as a partial evaluator does: a positive literal
that one static atom matches is dropped and its variables take that atom's values; a
negated one whose atom is known to hold or not is dropped, or kills the rule; a
comparison left with constants only is evaluated. A rule whose body cannot hold
(the other jurisdiction's `passing_side(right)`, `A > F` with both known) is left out.
The static atoms are still grounded with every frame, so the answer set is the same:
only the work of finding them again is saved. The prover replays the rules as written.
"""

from __future__ import annotations

from typing import Iterable, Optional

import clingo
from clingo import Symbol, SymbolType, ast

_TRUE_OF = {  # how clingo compares two values (its term order)
    ast.ComparisonOperator.Equal: lambda a, b: a == b,
    ast.ComparisonOperator.NotEqual: lambda a, b: a != b,
    ast.ComparisonOperator.LessThan: lambda a, b: a < b,
    ast.ComparisonOperator.LessEqual: lambda a, b: a <= b,
    ast.ComparisonOperator.GreaterThan: lambda a, b: a > b,
    ast.ComparisonOperator.GreaterEqual: lambda a, b: a >= b,
}

# Where clingo.parse_term and the grounder part: `0**-1` is 0 to the one and undefined to the other, `N\0` ends the
# process (SIGFPE) in the one and is undefined to the other.
_UNLIKE_GROUNDER = ("**", "\\")

DEAD = None  # what `Specializer.statement` returns for a rule that can never fire


class Specializer:
    def __init__(self, static_atoms: Iterable[Symbol], static: frozenset[str]):
        """`static_atoms`: the model of the `static` predicates (`catalog.static_model`)."""
        self.static = static
        self._atoms: dict[tuple[str, int], list[Symbol]] = {}
        for symbol in static_atoms:
            self._atoms.setdefault((symbol.name, len(symbol.arguments)), []).append(symbol)
        self._done: dict[int, tuple[ast.AST, Optional[ast.AST]]] = {}

    def program(self, statements: Iterable[ast.AST]) -> list[ast.AST]:
        """The statements specialised, the dead rules left out."""
        found = []
        for statement in statements:
            special = self.statement(statement)
            if special is not DEAD:
                found.append(special)
        return found

    def statement(self, statement: ast.AST) -> Optional[ast.AST]:
        found = self._done.get(id(statement))
        if found is None:
            special = self._specialise(statement) if statement.ast_type == ast.ASTType.Rule else statement
            found = self._done[id(statement)] = (statement, special)  # held, so that its id is not reused
        return found[1]

    def _specialise(self, rule: ast.AST) -> Optional[ast.AST]:
        keep: frozenset[str] = frozenset()
        while True:
            special, binding = self._specialised(rule, keep)
            if special is DEAD or special is rule:
                return special
            # clingo enumerates every value between two constant bounds of a variable (`Y >= 0, Y < 1500`: 60 us,
            # `Y < 100000`: 4 ms) instead of checking the few atoms that bind it; where that would come of it, the
            # values those comparisons read stay the static atoms'.
            ranged = _bounded_twice(special.body) - _bounded_twice(rule.body)
            if not ranged:
                return special
            culprits = _compared(rule.body, ranged, binding) - keep or _compared(rule.body, None, binding) - keep
            if not culprits:
                return rule
            keep = keep | culprits

    def _specialised(self, rule: ast.AST, keep: frozenset[str]) -> tuple[Optional[ast.AST], dict[str, Symbol]]:
        body = list(rule.body)
        binding: dict[str, Symbol] = {}
        changed = True
        while changed:  # a value bound by one literal may settle another
            changed = False
            kept = []
            for literal in body:
                literal = _substitute(literal, binding)
                verdict = self._settle(literal, binding, keep)
                if verdict is False:
                    return DEAD, binding
                if verdict is True:
                    changed = True
                    continue
                kept.append(literal)
            body = kept
        if len(body) == len(rule.body) and not binding:
            return rule, binding
        return rule.update(head=_substitute(rule.head, binding), body=body), binding

    def _settle(self, literal: ast.AST, binding: dict[str, Symbol], keep: frozenset[str]) -> Optional[bool]:
        """True: the literal holds (bindings added); False: it cannot hold; None: only the frame can tell.

        A positive literal binding a variable in `keep` stays as written."""
        if literal.ast_type != ast.ASTType.Literal:
            return None
        atom = literal.atom
        if atom.ast_type == ast.ASTType.Comparison:
            return _compare(atom) if literal.sign == ast.Sign.NoSign else None
        if atom.ast_type != ast.ASTType.SymbolicAtom or atom.symbol.ast_type != ast.ASTType.Function:
            return None
        term = atom.symbol
        if term.name not in self.static or not _plain(term):
            return None
        candidates = self._atoms.get((term.name, len(term.arguments)), [])
        matches = []
        for symbol in candidates:
            found = _unify(term.arguments, symbol.arguments, {})
            if found is not None:
                matches.append(found)
                if len(matches) > 1:
                    break
        if literal.sign == ast.Sign.Negation:
            if not matches:
                return True  # no static atom is like it: `not` holds whatever the variables are
            if matches == [{}]:
                return False  # the very atom holds
            return None
        if literal.sign != ast.Sign.NoSign:
            return None
        if not matches:
            return False
        if len(matches) == 1 and not keep & matches[0].keys():
            binding.update(matches[0])
            return True
        return None


def _plain(term: ast.AST) -> bool:
    """Whether a term is variables, constants and functions alone. Arithmetic is clingo's to judge: where it is
    undefined (`V/0`), clingo drops the rule's instance, even where no static atom is like the literal's others."""
    kind = term.ast_type
    if kind == ast.ASTType.Function:
        return not term.external and all(_plain(argument) for argument in term.arguments)
    return kind in (ast.ASTType.Variable, ast.ASTType.SymbolicTerm)


def _unify(terms: Iterable[ast.AST], symbols: Iterable[Symbol], found: dict[str, Symbol]) -> Optional[dict[str, Symbol]]:
    """The variables' values that make the (`_plain`) terms equal to the symbols; None where they cannot be equal."""
    for term, symbol in zip(terms, symbols):
        kind = term.ast_type
        if kind == ast.ASTType.Variable:
            if term.name == "_":
                continue
            if found.get(term.name, symbol) != symbol:
                return None
            found = {**found, term.name: symbol}
        elif kind == ast.ASTType.SymbolicTerm:
            if term.symbol != symbol:
                return None
        else:
            if (symbol.type != SymbolType.Function or not symbol.positive or symbol.name != term.name
                    or len(symbol.arguments) != len(term.arguments)):  # `f(X)` is not `-f(1)`: that is `-f(X)`'s
                return None
            found = _unify(term.arguments, symbol.arguments, found)
            if found is None:
                return None
    return found


def _bounded_twice(body: Iterable[ast.AST]) -> set[str]:
    """The variables that two or more comparisons compare with constants alone, each link of a chain (`0 <= Y < W`)
    counting as one comparison. A variable assigned constants (`H = (350/2)`) counts as a constant, and variables an
    equality relates (`D = Y+1`) share their bounds: clingo folds those in too."""
    comparisons = [(_variables(left) | _variables(right), guard.comparison == ast.ComparisonOperator.Equal)
                   for literal in body
                   if literal.ast_type == ast.ASTType.Literal and literal.atom.ast_type == ast.ASTType.Comparison
                   for terms in [[literal.atom.term] + [guard.term for guard in literal.atom.guards]]
                   for left, guard, right in zip(terms, literal.atom.guards, terms[1:])]
    constant: set[str] = set()
    changed = True
    while changed:
        changed = False
        for names, equality in comparisons:
            free = names - constant
            if equality and len(free) == 1:
                constant |= free
                changed = True
    related: dict[str, frozenset[str]] = {}
    for names, equality in comparisons:
        free = names - constant
        if equality and len(free) == 2:
            joined = frozenset().union(*(related.get(name, {name}) for name in free))
            related.update(dict.fromkeys(joined, joined))
    seen: dict[frozenset[str], int] = {}
    for names, equality in comparisons:
        free = names - constant
        if len(free) == 1 and not equality:
            name = free.pop()
            group = related.get(name, frozenset([name]))
            seen[group] = seen.get(group, 0) + 1
    return {name for group, count in seen.items() if count > 1 for name in group}


def _compared(body: Iterable[ast.AST], ranged: Optional[set[str]], binding: dict[str, Symbol]) -> frozenset[str]:
    """The bound variables read by the comparisons that reach a `ranged` variable through shared variables (by all
    comparisons where `ranged` is None)."""
    comparisons = [_variables(literal.atom) for literal in body
                   if literal.ast_type == ast.ASTType.Literal and literal.atom.ast_type == ast.ASTType.Comparison]
    reached = set(ranged) if ranged is not None else set().union(*comparisons)
    changed = True
    while changed:
        changed = False
        for names in comparisons:
            if names & reached and not names <= reached:
                reached |= names
                changed = True
    return frozenset(reached & binding.keys())


def _compare(comparison: ast.AST) -> Optional[bool]:
    """The truth of a comparison of constants (clingo's arithmetic and term order), None while a variable is in it."""
    values = [_value(comparison.term)] + [_value(guard.term) for guard in comparison.guards]
    if any(value is None for value in values):
        return None
    for left, guard, right in zip(values, comparison.guards, values[1:]):
        if not _TRUE_OF[guard.comparison](left, right):
            return False
    return True


def _value(term: ast.AST) -> Optional[Symbol]:
    if _variables(term):
        return None
    text = str(term)
    if any(operator in text for operator in _UNLIKE_GROUNDER):
        return None
    try:
        return clingo.parse_term(text)
    except (RuntimeError, ValueError):  # an undefined operation (a division by 0): clingo's to judge
        return None


class _VariableFinder(ast.Transformer):
    def __init__(self):
        self.names: set[str] = set()

    def visit_Variable(self, variable: ast.AST) -> ast.AST:
        self.names.add(variable.name)
        return variable


def _variables(node: ast.AST) -> set[str]:
    finder = _VariableFinder()
    finder.visit(node)
    return finder.names


class _Substitution(ast.Transformer):
    def __init__(self, binding: dict[str, Symbol]):
        self.binding = binding

    def visit_Variable(self, variable: ast.AST) -> ast.AST:
        value = self.binding.get(variable.name)
        return variable if value is None else ast.SymbolicTerm(variable.location, value)


def _substitute(node: ast.AST, binding: dict[str, Symbol]) -> ast.AST:
    return _Substitution(binding).visit(node) if binding else node
