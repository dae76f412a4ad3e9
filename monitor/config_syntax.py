"""Where a zenoh JSON5 config file breaks the syntax, and how, for the one-line refusal of `discern serve`.

Zenoh's JSON5 parser names the start of the value it could not finish, not the fault: a comma missing at the
end of line 1 of `{ listen: { endpoints: ["tcp/..."] <newline> scouting: {} }` is reported at the `[` of line 1,
"expected boolean or null". This reads the file as JSON5 is written (strings, comments, brackets, colons, commas
and the bare words between them) and says where the first fault is and what it is, naming a missing comma.
Values are checked only as far as their syntax: what they mean is zenoh's to say, with its exact position.
"""

from __future__ import annotations

import re
from typing import Optional

_CLOSE = {"{": "}", "[": "]"}
_PUNCTUATION = "{}[]:,"
# the bare words that are JSON5 values: numbers (a leading sign, hexadecimal, Infinity and NaN included) and literals
_VALUE_WORD = re.compile(r"[+-]?(?:Infinity|NaN|0[xX][0-9a-fA-F]+|(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)|true|false|null")
_LINE_ENDS = "\n\r\u2028\u2029"


def json5_fault(text: str) -> Optional[str]:
    """The first syntax fault of a JSON5 text, as "line L column C: what", or None if none is found."""
    try:
        _check(text)
    except _Fault as fault:
        return f"{_position(text, fault.at)}: {fault.what}"
    return None


class _Fault(Exception):
    def __init__(self, at: int, what: str):
        super().__init__(what)
        self.at, self.what = at, what


def _check(text: str) -> None:
    """Raise _Fault at the first token out of its place in the grammar."""
    stack: list[tuple[str, int]] = []  # the open brackets and braces, with where they open
    expect = "value"  # value | value_or_close | key_or_close | colon | comma_or_close | end
    key = ""
    value_end = 0  # where the last complete value ends
    for kind, start, end in _tokens(text):
        word = text[start:end]
        found = "the end of the file" if kind == "eof" else repr(word if len(word) <= 40 else word[:40] + "...")
        if expect in ("value", "value_or_close"):
            if kind in _CLOSE:
                stack.append((kind, start))
                expect = "key_or_close" if kind == "{" else "value_or_close"
                continue
            if kind == "]" and expect == "value_or_close":
                stack.pop()
            elif kind == "word" and not _VALUE_WORD.fullmatch(word):
                raise _Fault(start, f"{found} is no JSON5 value: quote a string (a number, true, false and null "
                                    "are not quoted)")
            elif kind not in ("string", "word"):
                raise _Fault(start, f"expected a value, found {found}")
        elif expect == "key_or_close":
            if kind in ("string", "word"):
                if kind == "word" and not word.replace("$", "_").isidentifier():
                    raise _Fault(start, f"{found} is no key: quote it")
                key, expect = word if kind == "string" else f"'{word}'", "colon"
                continue
            if kind != "}":
                raise _Fault(start, f"expected a key or '}}', found {found}")
            stack.pop()
        elif expect == "colon":
            if kind != ":":
                raise _Fault(start, f"expected ':' after the key {key}, found {found}")
            expect = "value"
            continue
        elif expect == "comma_or_close":
            opener, opened = stack[-1]
            close = _CLOSE[opener]
            if kind == ",":
                expect = "key_or_close" if opener == "{" else "value_or_close"
                continue
            if kind in ("string", "word", "{", "["):
                raise _Fault(start, f"expected ',' or '{close}', found {found}: likely a comma missing after the "
                                    f"value that ends at {_position(text, value_end - 1)}")
            if kind != close:
                raise _Fault(start, f"expected ',' or '{close}' (the '{opener}' at {_position(text, opened)} is "
                                    f"open), found {found}")
            stack.pop()
        elif kind == "eof":  # expect == "end": the text is one value
            return
        else:
            raise _Fault(start, f"expected the end of the file after the value that ends at "
                                f"{_position(text, value_end - 1)}, found {found}")
        value_end = end  # a value is complete: a string, a word, or a closed bracket or brace
        expect = "comma_or_close" if stack else "end"


def _tokens(text: str):
    """(kind, start, end) of each token: a punctuation character, "string", "word", and last "eof"."""
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c.isspace() or c == "\ufeff":
            i += 1
        elif text.startswith("//", i):
            while i < n and text[i] not in _LINE_ENDS:
                i += 1
        elif text.startswith("/*", i):
            close = text.find("*/", i + 2)
            if close < 0:
                raise _Fault(i, "a comment starts here that is never closed with '*/'")
            i = close + 2
        elif c in _PUNCTUATION:
            yield c, i, i + 1
            i += 1
        elif c in "\"'":
            j = i + 1
            while j < n and text[j] != c and text[j] not in "\n\r":
                # an escape, a line continuation (backslash, line end) included
                j += (3 if text.startswith("\r\n", j + 1) else 2) if text[j] == "\\" else 1
            if j >= n or text[j] != c:
                raise _Fault(i, "a string starts here that is not closed on its line")
            yield "string", i, j + 1
            i = j + 1
        else:
            j = i
            while j < n and not (text[j].isspace() or text[j] in _PUNCTUATION or text[j] in "\"'"
                                 or text.startswith("//", j) or text.startswith("/*", j)):
                j += 1
            yield "word", i, j
            i = j
    yield "eof", n, n


def _position(text: str, at: int) -> str:
    """"line L column C" of a character, counted from 1 as zenoh counts them."""
    line, line_start = text.count("\n", 0, at) + 1, text.rfind("\n", 0, at) + 1
    return f"line {line} column {at - line_start + 1}"
