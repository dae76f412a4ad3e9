"""Fact text as the reasoner generates it, read without clingo.

Plain fact text is a run of `name.` or `name(a,b,...).` whose arguments are
integers and constants written as clingo prints them: all the generated facts
are. It can be split on '.', each fact's arguments counted by its commas, and
each fact is its atom's text; any other text (strings, comments, whitespace,
nested terms, arithmetic, intervals, pools, classical negation, rules) is
left to clingo's parser.
"""

from __future__ import annotations

import re

FACT_NAME = re.compile(r"(?:^|\.)([a-z_][A-Za-z0-9_]*)")  # the predicate names of fact text
# Possessive quantifiers: the text is matched once, without backtracking (half the time).
_IDENTIFIER = r"_*+[a-z][A-Za-z0-9_]*+"  # clingo's, without primes: `_X` and `_` are variables
_ARGUMENT = rf"(?:-?+[1-9][0-9]*+|0|{_IDENTIFIER})"
_PLAIN = re.compile(rf"(?:{_IDENTIFIER}(?:\({_ARGUMENT}(?:,{_ARGUMENT})*+\))?+\.)++")


def is_plain(text: str) -> bool:
    return _PLAIN.fullmatch(text) is not None


def facts_by_signature(text: str) -> dict[tuple[str, int], set[str]]:
    """Plain fact text's atoms as clingo prints them, by (name, arity)."""
    found: dict[tuple[str, int], set[str]] = {}
    for fact in text[:-1].split("."):
        name, paren, rest = fact.partition("(")
        signature = (name, rest.count(",") + 1) if paren else (name, 0)
        atoms = found.get(signature)
        if atoms is None:
            atoms = found[signature] = set()
        atoms.add(fact)
    return found
