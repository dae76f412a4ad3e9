"""Rule bodies as plain Python tuples, evaluated against a model.

clingo's AST objects are slow to walk from Python (every attribute is a C
call); the justifier replays rule bodies many times, so rules are compiled
once into tuples: ("v", name) variable, ("s", Symbol) constant,
("f", name, args) function, ("b", op, left, right), ("u", op, arg).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Optional

from clingo import Function, Number, Symbol, SymbolType, Tuple_
from clingo import ast

Env = dict[str | int, Symbol]  # variables by name; the prover adds the atoms a rule body matched, by id of the literal
Term = tuple

_BIN = ast.BinaryOperator
_UN = ast.UnaryOperator
_CMP = ast.ComparisonOperator
CMP_TEXT = {
    int(_CMP.Equal): "=",
    int(_CMP.NotEqual): "≠",
    int(_CMP.LessThan): "<",
    int(_CMP.LessEqual): "≤",
    int(_CMP.GreaterThan): ">",
    int(_CMP.GreaterEqual): "≥",
}


class Unbound(Exception):
    """A term still has a free variable."""


class Undefined(Unbound):
    """Arithmetic clingo leaves undefined (a division by zero, zero to a negative power, a non-number): the literal
    holding it does not hold, as in clingo's grounding, where its rule instance goes."""


def compile_term(node: ast.AST) -> Term:
    kind = node.ast_type
    if kind == ast.ASTType.Variable:
        return ("v", node.name)
    if kind == ast.ASTType.SymbolicTerm:
        return ("s", node.symbol)
    if kind == ast.ASTType.Function:
        return ("f", node.name, tuple(compile_term(a) for a in node.arguments))
    if kind == ast.ASTType.BinaryOperation:
        return ("b", int(node.operator_type), compile_term(node.left), compile_term(node.right))
    if kind == ast.ASTType.UnaryOperation:
        return ("u", int(node.operator_type), compile_term(node.argument))
    raise ValueError(f"unsupported term in a catalog rule: {node}")


def term_vars(term: Term) -> frozenset[str]:
    tag = term[0]
    if tag == "v":
        return frozenset() if term[1] == "_" else frozenset([term[1]])
    if tag == "s":
        return frozenset()
    if tag == "f":
        return frozenset().union(*(term_vars(a) for a in term[2])) if term[2] else frozenset()
    if tag == "b":
        return term_vars(term[2]) | term_vars(term[3])
    return term_vars(term[2])


@dataclass(frozen=True)
class Literal:
    """A body literal: an atom (possibly negated) or a comparison chain."""

    negated: bool
    atom: Optional[Term]  # ("f", ...) or ("s", ...) for atoms
    comparison: Optional[tuple[Term, tuple[tuple[int, Term], ...]]]
    variables: frozenset[str]
    source: str

    @property
    def is_atom(self) -> bool:
        return self.atom is not None

    @property
    def predicate(self) -> Optional[str]:
        if self.atom is None:
            return None
        return self.atom[1] if self.atom[0] == "f" else self.atom[1].name


def compile_literal(lit: ast.AST) -> Literal:
    atom = lit.atom
    negated = lit.sign != ast.Sign.NoSign
    if atom.ast_type == ast.ASTType.SymbolicAtom:
        term = compile_term(atom.symbol)
        return Literal(negated, term, None, term_vars(term), str(lit))
    if atom.ast_type == ast.ASTType.Comparison:
        left = compile_term(atom.term)
        guards = tuple((int(g.comparison), compile_term(g.term)) for g in atom.guards)
        variables = term_vars(left).union(*(term_vars(t) for _, t in guards))
        return Literal(negated, None, (left, guards), variables, str(lit))
    raise ValueError(f"unsupported literal in a catalog rule: {lit}")


def _int_div(a: int, b: int) -> int:
    q = abs(a) // abs(b)
    return q if (a >= 0) == (b >= 0) else -q


def evaluate(term: Term, env: Env) -> Symbol:
    tag = term[0]
    if tag == "s":
        return term[1]
    if tag == "v":
        try:
            return env[term[1]]
        except KeyError:
            raise Unbound(term[1]) from None
    if tag == "f":
        args = [evaluate(a, env) for a in term[2]]
        return Tuple_(args) if term[1] == "" else Function(term[1], args)
    try:
        if tag == "u":
            value = evaluate(term[2], env).number
            if term[1] == _UN.Minus:
                value = -value
            elif term[1] == _UN.Absolute:
                value = abs(value)
            else:
                return Number(~value)
            return Number(value if _LOW <= value <= _HIGH else _wrap(value))
        a, b = evaluate(term[2], env).number, evaluate(term[3], env).number
    except RuntimeError:  # .number of a non-number: clingo's arithmetic on it is undefined
        raise Undefined("arithmetic on a non-number") from None
    op = term[1]
    if op == _BIN.Plus:
        value = a + b
    elif op == _BIN.Minus:
        value = a - b
    elif op == _BIN.Multiplication:
        value = a * b
    elif op == _BIN.Division or op == _BIN.Modulo:
        if b == 0:
            raise Undefined("a division by zero")
        value = _int_div(a, b) if op == _BIN.Division else a - b * _int_div(a, b)
    elif op == _BIN.Power:
        if b < 0:
            if a == 0:
                raise Undefined("zero to a negative power")
            return Number(0)
        value = pow(a, b, 1 << 32)
    else:
        raise Unbound(f"unsupported operator {op}")
    return Number(value if _LOW <= value <= _HIGH else _wrap(value))


_LOW, _HIGH = -(1 << 31), (1 << 31) - 1


def _wrap(value: int) -> int:
    """clingo's integers are 32-bit and wrap around: the prover must compute what the grounder did."""
    return (value + (1 << 31)) % (1 << 32) - (1 << 31)


Shape = tuple  # (is_function, name, args) of a symbol


def shape_of(sym: Symbol) -> Shape:
    if sym.type == SymbolType.Function:
        return (True, sym.name, tuple(sym.arguments))
    return (False, None, ())


def match(term: Term, sym: Symbol, env: Env, shape: Callable[[Symbol], Shape] = shape_of) -> Optional[Env]:
    """Unify a partly bound term with a ground symbol; the extended env, or None.

    `shape` lets callers cache symbol structure: every clingo attribute read is a C call.
    """
    tag = term[0]
    if tag == "v":
        name = term[1]
        if name == "_":
            return env
        bound = env.get(name)
        if bound is not None:
            return env if bound == sym else None
        extended = dict(env)
        extended[name] = sym
        return extended
    if tag == "f" and term[2]:
        is_function, name, args = shape(sym)
        if not is_function or name != term[1] or len(args) != len(term[2]):
            return None
        for sub, value in zip(term[2], args):
            env = match(sub, value, env, shape)
            if env is None:
                return None
        return env
    try:
        return env if evaluate(term, env) == sym else None
    except Unbound:
        return None


ANY = ("v", "_")


def pattern_of(atom: Term) -> Term:
    """What every atom an atom term can match shares: its constants and functors, the rest anonymous."""
    tag = atom[0]
    if tag == "s":
        return atom
    if tag != "f" or not atom[1]:  # variables, arithmetic, tuples
        return ANY
    return ("f", atom[1], tuple(pattern_of(a) for a in atom[2]))


def is_fixed(pattern: Term) -> bool:
    """Whether a pattern says more about its atoms than their predicate: some argument is not anonymous."""
    if pattern[0] == "s":
        return bool(pattern[1].type == SymbolType.Function and pattern[1].arguments)
    return pattern[0] == "f" and any(a != ANY for a in pattern[2])


def pattern_signature(pattern: Term) -> tuple[str, int]:
    """The predicate and arity of an atom's pattern."""
    return (pattern[1].name, len(pattern[1].arguments)) if pattern[0] == "s" else (pattern[1], len(pattern[2]))


def pattern_text(pattern: Term) -> str:
    """A pattern in clingo syntax, `_` for its anonymous parts."""
    if pattern[0] == "s":
        return str(pattern[1])
    if pattern[0] == "v":
        return "_"
    return f"{pattern[1]}({','.join(pattern_text(a) for a in pattern[2])})" if pattern[2] else pattern[1]


def compare(op: int, a: Symbol, b: Symbol) -> bool:
    if op == _CMP.Equal:
        return a == b
    if op == _CMP.NotEqual:
        return a != b
    if op == _CMP.LessThan:
        return a < b
    if op == _CMP.LessEqual:
        return a <= b
    if op == _CMP.GreaterThan:
        return a > b
    return a >= b


def is_assignment(lit: Literal, env: Env) -> bool:
    """`X = expr` with X free and expr bound: clingo reads it as an assignment."""
    if lit.comparison is None:
        return False
    left, guards = lit.comparison
    if len(guards) != 1 or guards[0][0] != _CMP.Equal:
        return False
    right = guards[0][1]
    return (left[0] == "v" and left[1] not in env and not (term_vars(right) - env.keys())) or (
        right[0] == "v" and right[1] not in env and not (term_vars(left) - env.keys())
    )


def check_comparison(lit: Literal, env: Env) -> Optional[Env] | bool:
    """The (extended) env when the comparison holds, False when it fails, None when undecidable."""
    left, guards = lit.comparison
    if is_assignment(lit, env):
        right = guards[0][1]
        var, expr = (left, right) if left[0] == "v" and left[1] not in env else (right, left)
        extended = dict(env)
        try:
            extended[var[1]] = evaluate(expr, env)
        except Undefined:
            return False
        return extended
    try:
        lhs = evaluate(left, env)
        for op, term in guards:
            rhs = evaluate(term, env)
            if not compare(op, lhs, rhs):
                return False
            lhs = rhs
    except Undefined:
        return False
    except Unbound:
        return None
    return env
