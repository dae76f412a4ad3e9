"""Fact text as the reasoner generates it, read without clingo.

Plain fact text is a run of `name.` or `name(a,b,...).` whose arguments are
integers and constants written as clingo prints them: all the generated facts
are. It can be split on '.', each fact's arguments counted by its commas, and
each fact is its atom's text; any other text (strings, comments, whitespace,
nested terms, arithmetic, intervals, pools, classical negation, rules) is
left to clingo's parser.
"""

from __future__ import annotations

import functools
import re

_FACT_NAME = re.compile(r"(?:^|\.)([a-z_][A-Za-z0-9_]*)")  # the predicate names of fact text without strings
QUOTED = r'"(?:[^"\\]++|\\.)*+"'  # a clingo string: its dots end no fact (possessive: never retried from inside)
_QUOTED_OR_NAME = re.compile(rf'{QUOTED}|(?:^|(?<=\.))([a-z_][A-Za-z0-9_]*)')
_QUOTED_OR_STOP = re.compile(rf'({QUOTED})|\.')
# Possessive quantifiers: the text is matched once, without backtracking (half the time).
_IDENTIFIER = r"_*+[a-z][A-Za-z0-9_]*+"  # clingo's, without primes: `_X` and `_` are variables
_ARGUMENT = rf"(?:-?+[1-9][0-9]*+|0|{_IDENTIFIER})"
_PLAIN = re.compile(rf"(?:{_IDENTIFIER}(?:\({_ARGUMENT}(?:,{_ARGUMENT})*+\))?+\.)++")


def fact_names(text: str) -> frozenset[str]:
    """The predicate names of fact text; a '.' inside a quoted id (`ego_path("a.param")`) starts no fact."""
    if '"' not in text:
        return frozenset(_FACT_NAME.findall(text))
    return frozenset(name for name in _QUOTED_OR_NAME.findall(text) if name)


def one_fact_a_line(text: str) -> str:
    """Fact text for people: one fact a line."""
    return _QUOTED_OR_STOP.sub(lambda m: m.group(1) or ".\n", text).rstrip("\n")


@functools.lru_cache(maxsize=4)
def is_plain(text: str) -> bool:
    """Cached: the slicer and the answer set both ask it of the same frame's text (70 us at 50 objects)."""
    return _PLAIN.fullmatch(text) is not None


def facts_of(text: str, name: str, arity: int) -> list[str]:
    """Plain fact text's atoms of name/arity as clingo prints them, in one scan of the text."""
    return [fact for fact in _facts_named(name).findall(text) if _arity(fact) == arity]


def facts_with_first(text: str, name: str, arity: int, first: str) -> list[str]:
    """Plain fact text's atoms of name/arity whose first argument is written `first`.

    A proof asks for a few objects' facts in a frame of hundreds: a substring
    search for each beats splitting every fact of the frame.
    """
    if arity == 0:
        return []
    needle = f"{name}({first}," if arity > 1 else f"{name}({first})."
    found = []
    start = text.find(needle)
    while start != -1:
        if start == 0 or text[start - 1] == ".":  # a fact's start, not the tail of a longer name
            fact = text[start:text.index(".", start)]
            if _arity(fact) == arity:
                found.append(fact)
        start = text.find(needle, start + 1)
    return found


@functools.lru_cache(maxsize=None)
def _facts_named(name: str) -> re.Pattern:
    return re.compile(rf"(?:^|(?<=\.)){re.escape(name)}(?:\([^.]*\))?(?=\.)")


def _arity(fact: str) -> int:
    return fact.count(",") + 1 if fact.endswith(")") else 0
