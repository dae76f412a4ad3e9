"""Atoms and comparisons as English, from the catalog's predicate templates (like s(CASP)'s #pred)."""

from __future__ import annotations

import functools
import re
from typing import Optional

from clingo import Symbol, SymbolType

from .answer_set import AnswerSet
from .catalog import PLACEHOLDER, Catalog, CompiledRule
from .terms import CMP_TEXT, Env, Literal, Term, Unbound, evaluate, term_vars


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
