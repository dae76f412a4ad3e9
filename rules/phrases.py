"""Atoms and comparisons as English, from the catalog's predicate templates (like s(CASP)'s #pred)."""

from __future__ import annotations

import functools
import re
from typing import Optional

from clingo import Function, Number, Symbol, SymbolType
from clingo.ast import BinaryOperator, ComparisonOperator as _CMP, UnaryOperator

from .answer_set import AnswerSet
from .catalog import PLACEHOLDER, Catalog, CompiledRule, PredTemplate
from .terms import CMP_TEXT, Env, Literal, Term, Unbound, Undefined, evaluate, term_vars


# `[words|other words]` in a template: alternatives. In a template with a closing speed, the first, or the last
# where the speed is negative ("car 1 pulls away from the ego at 2.0 m/s"); in any other, the first whose values
# are all known, else the last ("the speed of car 1 is known", not "car 1 moves at some speed and some speed").
_CHOICE = re.compile(r"\[([^\[\]]*)\]")
_ALTERNATIVE = re.compile(r"\|(?![^(]*\))")  # a `|` between alternatives, not one inside a placeholder


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
# Settings (param/2 and the sanity window's window_param/2) by name: the words, unit and scale of each. A name
# not here is a distance in cm, its words its name ("crossing_dist": "the crossing distance is 15 m").
_SETTINGS = {
    "reaction_ms": ("reaction time", "s", 1000), "headway_ms": ("headway kept in faster-moving traffic", "s", 1000),
    "slow_headway_ms": ("headway kept in slower traffic", "s", 1000),
    "slow_traffic_speed": ("speed up to which the headway of slower traffic is kept", "m/s", 100),
    "fast_traffic_speed": ("speed from which traffic is faster-moving", "m/s", 100),
    "turn_gap_ms": ("time a turn takes to clear", "s", 1000), "decel": ("firm braking deceleration", "m/s²", 100),
    "heavy_decel": ("full braking deceleration of a truck or bus", "m/s²", 100),
    "bend_accel": ("sideways acceleration the tightest bends are built for at speed", "m/s²", 100),
    "accel_step": ("speed one step of accelerating adds", "m/s", 100),
    "overtake_dist": ("distance within which a slower vehicle ahead is overtaken", "m", 100),
    "move_over_dist": ("distance within which an emergency vehicle or a stopped school bus is given room", "m", 100),
    "speed_margin": ("margin allowed over the limit", "m/s", 100), "turn_speed": ("fastest turning speed", "m/s", 100),
    "caution_speed": ("slowest cautious speed", "m/s", 100),
    "caution_drop": ("drop below the limit that caution calls for", "m/s", 100),
    "cyclist_speed": ("fastest a cyclist of unknown speed is taken to ride", "m/s", 100),
    "stopped_speed": ("speed under which a vehicle counts as stopped", "m/s", 100), "min_gap": ("minimum gap", "m", 100),
    "drift_speed": ("sideways speed at which a vehicle moves into the next lane", "m/s", 100),
    "range_match": ("distance within which a range reading is an object's", "m", 100),
    "confirm_frames": ("number of frames that confirm a reading", "", 1),
    "confirm_ms": ("time that confirms a reading", "s", 1000),
    "track_frames": ("number of frames that establish a track", "", 1),
    "track_ms": ("time that establishes a track", "s", 1000),
    "window_ms": ("time the window of recent frames spans", "s", 1000),
}
_DISTANCE_UNIT = ("m", 100)  # a setting _SETTINGS does not name: a distance in cm
_SETTING_FORMATS = {"s": "ms", "m": "m", "m/s": "mps", "m/s²": "decel"}  # a setting's unit (_SETTINGS) as a template format
_UNKNOWN = {"percent": "some confidence", "obj": "some object", "m": "some distance", "mps": "some speed", "speed": "some speed", "decel": "some deceleration", "limit": "some speed", "ms": "some time",
            "ahead": "somewhere", "right": "somewhere", "along": "some speed", "across": "some speed",
            "closing": "some speed", "lane": "a lane", "detail": "", "paren": ""}
_SIGN_UNITS = {"mph": 44.704}  # cm/s per unit a pack's speed_unit/1 may name
_WRAPPED = {"lane": "lane {}", "detail": ": {}", "paren": " ({})"}  # a value with the words around it, unknown: none


class Phrasebook:
    """Renders atoms and comparisons as English with the catalog's templates."""

    def __init__(self, catalog: Catalog, answer: AnswerSet):
        self.catalog = catalog
        self._answer = answer
        self._classes: dict[int, str] = {}  # object id -> its class in words ("" when it has none)
        self._sign_unit: Optional[str] = None  # read from the answer set when a limit is first shown

    def value(self, sym: Optional[Symbol], fmt: Optional[str], param: str, digits: int = 1, unit_digits: int = 1) -> str:
        """`digits`: decimals of metres, m/s and seconds; more where a comparison's sides would read alike;
        `unit_digits`: of a speed in the unit of the pack's signs (mph), likewise."""
        if sym is None:
            return _UNKNOWN.get(fmt or "", f"some {param}")
        if fmt in _WRAPPED:
            return _WRAPPED[fmt].format(self.value(sym, None, param))
        kind = sym.type
        if fmt == "id":
            return sym.string if kind == SymbolType.String else str(sym)
        if kind != SymbolType.Number:
            args = sym.arguments if kind == SymbolType.Function else ()
            if args and (sym.name, len(args)) in self.catalog.templates:  # a term with words of its own
                return self.sentence(sym.name, list(args))
            if kind == SymbolType.Function and not args and sym.name in self.catalog.words:
                words = self.catalog.words[sym.name]
                return self._filled(PredTemplate(sym.name, (), words), []) if "@(" in words else words
            return _words(sym)
        n = sym.number
        if n and round(n / 100, digits) == 0:  # 4 cm/s is "0.04 m/s", not "0.0 m/s"
            digits = 2
        if fmt in _SIGNED:
            if n == 0:
                return _SIGNED[fmt][0]
            words = _SIGNED[fmt][1] if n > 0 else _SIGNED[fmt][2]
            return words.format(f"{abs(n) / 100:.{digits}f}")
        if fmt == "m":
            return f"{n / 100:.{digits}f} m"
        if fmt == "mps":
            return f"{n / 100:.{digits}f} m/s"
        if fmt == "decel":
            return f"{n / 100:.{digits}f} m/s²"
        if fmt == "closing":  # its sign is in the words around it: a template's `[closes in|pulls away]`
            return f"{abs(n) / 100:.{digits}f} m/s"
        if fmt in ("limit", "speed"):
            return f"{n / 100:.{digits}f} m/s" + self._in_sign_unit(n, unit_digits)
        if fmt == "ms":
            if 0 < abs(n) < 100:  # a 40 ms reading is "0.04 s", not "0.0 s"
                return f"{n / 1000:g} s"
            return f"{n / 1000:.{digits}f} s"
        if fmt == "ordinal":
            return _ordinal(n)
        if fmt == "percent":
            return f"{n} %"
        if fmt == "frames":
            return "1 frame" if n == 1 else f"{n} frames"
        if fmt == "obj":
            cls = self._classes.get(n)
            if cls is None:
                found = self._answer.with_first("object", 2, sym)
                cls = _words(found[0].arguments[1]) if found else ""
                cls = self._classes[n] = "unknown object" if cls == "unknown" else cls  # not "unknown 7"
            if n < 0:  # the window's name for an object whose id the tracker gave another (sanity/window.py, _names)
                return f"the {cls or 'object'} once tracked as {-n}"
            return f"{cls} {n}" if cls else f"object {n}"
        return str(n)

    def _in_sign_unit(self, cms: int, digits: int = 1) -> str:
        """A limit as its sign shows it, in the unit the jurisdiction pack names: a reader checks '85 mph', not 38.0 m/s.
        The ego's speed too, so that it reads against the limit in one unit."""
        unit = self.sign_unit()
        if not unit:
            return ""
        shown = round(cms / _SIGN_UNITS[unit], digits)
        return f" ({shown:g} {unit})"

    def sign_unit(self) -> str:
        """The unit the pack's signs give speeds in (speed_unit/1), if Discern knows it; "" if none."""
        if self._sign_unit is None:
            units = [unit.arguments[0].name for unit in self._answer.of("speed_unit", 1)]
            self._sign_unit = units[0] if units and units[0] in _SIGN_UNITS else ""
        return self._sign_unit

    def sentence(self, name: str, args: list[Optional[Symbol]]) -> str:
        if name in ("param", "window_param") and len(args) == 2 and args[0] is not None and args[1] is not None:
            setting = args[0].name
            label, unit, scale = _setting(setting)
            n = args[1].number
            shown = f"the {label} is {n / scale:.{_setting_digits(n, scale)}f} {unit}".rstrip()
            return shown + self._in_sign_unit(n) if unit == "m/s" else shown  # a margin of '2.24 m/s (5 mph)'
        template = self.catalog.templates.get((name, len(args)))
        if template is None:
            inner = ", ".join("_" if a is None else str(a) for a in args)
            return f"{name}({inner})" if args else name
        return self._filled(template, args)

    def denial(self, name: str, args: list[Optional[Symbol]]) -> str:
        """That there is no evidence of an atom: "there is no evidence that" and its words, or the predicate's own
        denial (`%! denies`), where its words end in a detail that would read as a claim after the colon."""
        template = self.catalog.denials.get((name, len(args)))
        if template is not None:
            return self._filled(template, args)
        return "there is no evidence that " + self.sentence(name, args)

    def _filled(self, template: PredTemplate, args: list[Optional[Symbol]]) -> str:
        values = dict(zip(template.params, args))
        chosen = template.template
        if "[" in chosen:
            closing = [values.get(p.group(1)) for p in PLACEHOLDER.finditer(chosen) if p.group(2) == "closing"]
            receding = any(_negative(value) for value in closing) if closing else None
            chosen = _CHOICE.sub(lambda found: _alternative(found.group(1), values, receding), chosen)
        parts = _template_parts(chosen)
        words = [parts[0]]
        for i in range(1, len(parts), 4):  # (placeholder's parameter, its format, its unknown words, the text after)
            param, unknown = parts[i], parts[i + 2]
            value = values.get(param) if param in values or not param[:1].islower() else Function(param)
            words.append(unknown if value is None and unknown is not None else self.value(value, parts[i + 1], param))
            words.append(parts[i + 3])
        text = _LOOSE_SPACE.sub("", "".join(words))
        return _ARTICLE.sub(_article, text) if "a @(" in chosen else text

    def atom(self, sym: Symbol, rule: Optional[str] = None) -> str:
        """`rule`: the id of the rule that derived it, whose own words for it (`%! reads`) come first."""
        _, name, args = self._answer.shape(sym)
        if rule is not None:
            own = self.catalog.rule_templates.get((rule, (name, len(args))))
            if own is not None:
                return self._filled(own, list(args))
        return self.sentence(name, list(args))

    def formats_of(self, rule: CompiledRule) -> dict[str, str]:
        """Units of a rule's variables, read off the templates of the atoms they appear in."""
        formats = self.catalog.variable_formats.get(rule.index)
        if formats is not None:
            return formats
        formats = {}
        for term in [rule.head] + [lit.atom for lit in rule.body if lit.is_atom]:
            if term[0] != "f":
                continue
            if term[1] in ("param", "window_param") and len(term[2]) == 2 and term[2][0][0] == "s":
                setting, value = term[2][0][1].name, term[2][1]  # a setting's unit: turn_gap_ms is a time
                unit = _setting(setting)[1]
                fmt = _SETTING_FORMATS.get(unit)
                if value[0] == "v" and fmt is not None:
                    formats.setdefault(value[1], fmt)
                continue
            template = self.catalog.templates.get((term[1], len(term[2])))
            if template is None:
                continue
            by_param = {m.group(1): m.group(2) for m in PLACEHOLDER.finditer(template.template)}
            for param, arg in zip(template.params, term[2]):
                fmt = by_param.get(param)
                if arg[0] == "v" and fmt in _COMPARED:
                    formats.setdefault(arg[1], _COMPARED[fmt])
        self.catalog.variable_formats[rule.index] = formats
        return formats

    def comparison(self, rule: CompiledRule, lit: Literal, env: Env) -> str:
        formats = self.formats_of(rule)
        left, guards = lit.comparison
        terms = [left] + [t for _, t in guards]
        ops = [op for op, _ in guards]
        # A side that is one variable says the unit; a computed one may mix units (|X| * 1000 / VX is a time made of
        # a distance and a speed), so its variables' units count only where no side is one variable.
        fmt = next((formats[t[1]] for t in terms if t[0] == "v" and t[1] in formats), None) or next(
            (formats[v] for t in terms for v in sorted(term_vars(t)) if v in formats), None)
        values: list[Optional[Symbol]] = []
        for term in terms:
            try:
                values.append(evaluate(term, env))
            except Undefined as exc:  # "needs that X = (S/0) can be evaluated (a division by zero), which is false"
                return f"{lit.source} can be evaluated ({exc})"
            except Unbound:
                values.append(None)
        numbers = [v.number for v in values if v is not None and v.type == SymbolType.Number]
        sideways = any(self._sideways_variable(t, formats) is not None for t in terms)
        if sideways and len(numbers) == len(values) and not (
                fmt == "across" and any(not term_vars(t) and v.number == 0 for t, v in zip(terms, values))):
            # '-VX >= S' as '0.0 m/s to the left ≥ 0.5 m/s': a sideways speed says its side, not a sign
            digits = _digits_to_tell_apart(numbers, "mps")
            shown = [self._sideways(term, value, formats, digits) for term, value in zip(terms, values)]
            return " ".join([shown[0]] + [w for op, side in zip(ops, shown[1:]) for w in (CMP_TEXT.get(op, "?"), side)])
        if fmt in ("speed", "mps") and any(formats.get(v) == "limit" for t in terms for v in term_vars(t)):
            fmt = "limit"  # the ego's speed against a limit: both in m/s and in the unit of the signs
        elif fmt == "speed":
            fmt = "mps"
        if fmt in _MOTION:
            if len(terms) == 2 and len(numbers) == 2 and any(not term_vars(t) and v.number == 0 for t, v in zip(terms, values)):
                return self._motion_against_zero(terms, values, ops[0], fmt)
            if fmt == "closing" and len(terms) == 2 and len(numbers) == 2 and ops[0] in _CLOSING_BOUND:
                constant = [not term_vars(t) for t in terms]
                if constant.count(True) == 1:
                    return self._closing_against(terms, values, ops[0], constant[0])
            fmt = "mps"  # between two speeds a side or a gap reads worse than plain numbers
        if fmt in _AXES and len(numbers) == len(values):
            if len(terms) == 2 and any(not term_vars(t) and v.number == 0 for t, v in zip(terms, values)):
                return self._against_zero(terms, values, ops[0], fmt, self._owner(rule, terms, env, fmt))
            # A variable that is no position on this axis (a distance parameter) has no side: "15.0 m ahead"
            # would be false of it, so such a comparison reads as signed numbers, "-1.0 m < 15.0 m".
            off_axis = any(t[0] == "v" and formats.get(t[1]) != fmt for t in terms)
            if off_axis or not any(n < 0 for n in numbers):
                fmt = "m"  # distances ahead, all of them: "5.0 m < 8.0 m" reads plainly
            else:
                # Signed positions: each with its side, and the comparison as words, since "-5.2 m ≤ -3.5 m"
                # contradicts "5.2 m to the left" said just above it. A value computed from the position
                # (a gap, |X|) is a distance and keeps plain metres.
                axis = {v for v, f in formats.items() if f == fmt}
                digits = _digits_to_tell_apart(numbers, fmt)
                shown = ["the ego" if v.number == 0 else
                         self.value(v, "m" if t[0] not in ("v", "s") and term_vars(t) & axis else fmt, "", digits)
                         for t, v in zip(terms, values)]
                return " ".join([shown[0]] + [w for op, value in zip(ops, shown[1:]) for w in (_AXES[fmt][op], value)])
        digits = _digits_to_tell_apart(numbers, fmt)
        unit = self.sign_unit() if fmt == "limit" else ""
        unit_digits = _digits_to_tell_apart(numbers, fmt, _SIGN_UNITS[unit]) if unit else 1
        settings = _setting_scales(rule)
        if fmt == "limit":  # a setting added to a limit shows its decimals, and the sides theirs: '13.41 + 2.24'
            digits = max([digits] + [_setting_digits(env[v].number, settings[v]) for t in terms if t[0] == "b"
                                     for v in term_vars(t) if v in settings and v in env])
        shown = [lit.source if value is None else self._side(term, value, fmt, max(digits, _setting_digits(
                     value.number, settings[term[1]]) if term[0] == "v" and term[1] in settings else digits), formats,
                     env, unit_digits, settings)
                 for term, value in zip(terms, values)]
        return " ".join([shown[0]] + [w for op, side in zip(ops, shown[1:]) for w in (CMP_TEXT.get(op, "?"), side)])

    def _side(self, term: Term, value: Symbol, fmt: Optional[str], digits: int, formats: dict[str, str], env: Env,
              unit_digits: int = 1, settings: Optional[dict[str, int]] = None) -> str:
        """One side of a comparison. A limit plus an allowance (`R + S`, a reading's rounding slack; `S + M`, the
        margin over the limit) shows the limit as its sign gives it and the allowance apart: '13.4 m/s (30 mph) +
        0.05 m/s', not one sum '13.5 m/s (30.1 mph)' that no sign shows. Where the other side is so close that
        its speed in mph needs more decimals to tell them apart, the sum follows, in those decimals: '15.66 m/s
        (35.03 mph) > 13.41 m/s (30 mph) + 2.24 m/s (5 mph) = 15.65 m/s (35.01 mph)', since 30 mph is 13.41 m/s
        only to the centimetre."""
        if fmt == "limit" and term[0] == "b" and term[1] in _PLUS_MINUS and term[2][0] == term[3][0] == "v":
            limit, allowance = term[2][1], term[3][1]
            setting = settings is not None and allowance in settings and formats.get(allowance) == "mps"
            if (formats.get(limit) == "limit" and (allowance not in formats or setting) and limit in env
                    and allowance in env):
                added = env[allowance].number
                shown = (f"{added / 100:.{_setting_digits(added, settings[allowance])}f} m/s{self._in_sign_unit(added)}"
                         if setting else f"{added / 100:g} m/s")
                side = f"{self.value(env[limit], 'limit', '', digits)} {_PLUS_MINUS[term[1]]} {shown}"
                if unit_digits > 1:
                    side += f" = {self.value(value, 'limit', '', digits, unit_digits)}"
                return side
        if fmt == "limit" and term[0] == "v" and formats.get(term[1]) == "limit":
            return self.value(value, fmt, "", digits)  # a limit as its sign gives it
        if fmt == "m" and value.type == SymbolType.Number and value.number > 0:
            # A distance that is a position says along which axis: "4.0 m ahead < 15.0 m" and "4.0 m to the
            # side < 15.0 m", not the same "4.0 m < 15.0 m" twice under one conclusion.
            axis = formats.get(term[2][1]) if term[0] == "u" and term[2][0] == "v" else None
            if term[0] == "v" and formats.get(term[1]) in _AXES:
                return self.value(value, formats[term[1]], "", digits)
            if term[0] == "u" and term[1] == int(UnaryOperator.Absolute) and axis in _AXES:
                return f"{self.value(value, 'm', '', digits)} {_ABSOLUTE[axis]}"
        return self.value(value, fmt, "", digits, unit_digits)

    def _motion_against_zero(self, terms: list[Term], values: list[Symbol], op: int, fmt: str) -> str:
        """'VX < 0' as '15.0 m/s to the left is a move to the left', and 'C > 0' of a closing speed as 'the gap
        shrinks by 5.0 m/s', or as 'the gap shrinks (it grows by 1.5 m/s)' where it fails: no bare minus sign
        under a line that says the side or the gap in words."""
        op, value = _nonzero_side(terms, values, op)
        if fmt != "closing":
            return f"{self.value(value, fmt, '')} {_MOTION[fmt][op]}"
        n = value.number
        said = _MOTION[fmt][op]
        if n == 0:
            return said if op == _EQ else f"{said} (it stays the same)"
        verb = "shrinks" if n > 0 else "grows"
        by = self.value(value, "closing", "")  # its size: the words say which way
        if said == f"the gap {verb}":  # the words already say which way: "the gap shrinks by 5.0 m/s"
            return f"{said} by {by}"
        return f"{said} (it {verb} by {by})"

    @staticmethod
    def _sideways_variable(term: Term, formats: dict[str, str]) -> Optional[bool]:
        """Whether a comparison's side is a sideways velocity (False: VX) or its negation (True: -VX); None if neither."""
        negated = term[0] == "u" and term[1] == int(UnaryOperator.Minus) and term[2][0] == "v"
        variable = term[2] if negated else term
        return negated if variable[0] == "v" and formats.get(variable[1]) == "across" else None

    def _sideways(self, term: Term, value: Symbol, formats: dict[str, str], digits: int) -> str:
        """A sideways velocity (VX) or its negation (-VX) as a speed to its side; anything else as a plain speed."""
        negated = self._sideways_variable(term, formats)
        if negated is None:
            return self.value(value, "mps", "", digits)
        # VX is rightward when positive, -VX when negative; a zero reads on the side the comparison is about
        rightward = value.number < 0 if negated else value.number >= 0
        side = "to the right" if rightward else "to the left"
        return f"{self.value(Number(abs(value.number)), 'mps', '', digits)} {side}"

    def _closing_against(self, terms: list[Term], values: list[Symbol], op: int, constant_first: bool) -> str:
        """'C < -200' of a closing speed as 'the gap grows by more than 2.0 m/s (it shrinks by 8.0 m/s)', not
        '8.0 m/s < -2.0 m/s' under a line that says the ego closes in at 8.0 m/s."""
        if constant_first:
            op, closing, bound = _FLIPPED[op], values[1], values[0].number
        else:
            closing, bound = values[0], values[1].number
        verb = "shrinks" if bound > 0 else "grows"
        before, after = _CLOSING_BOUND[op][bound > 0]
        size = self.value(Number(abs(bound)), "closing", "")
        n = closing.number
        actual = "it stays the same" if n == 0 else f"it {'shrinks' if n > 0 else 'grows'} by {self.value(closing, 'closing', '')}"
        return f"the gap {verb} by {before} {size}{after} ({actual})"

    def _against_zero(self, terms: list[Term], values: list[Symbol], op: int, fmt: str, owner: Optional[str]) -> str:
        """'Y < 0' as 'car 1, 4.0 m behind, is behind the ego', not '-4.0 m < 0.0 m' under 'car 1 is 4.0 m behind';
        `owner`: whose position it is, without which '6.0 m ahead is behind the ego' says nothing of anything."""
        op, value = _nonzero_side(terms, values, op)
        if owner is not None:
            return f"{owner}, {self.value(value, fmt, '')}, {_AXES[fmt][op]} the ego"
        shown = f"{value.number / 100:.1f} m" if value.number == 0 else self.value(value, fmt, "")
        return f"{shown} {_AXES[fmt][op]} the ego"

    def _owner(self, rule: CompiledRule, terms: list[Term], env: Env, fmt: str) -> Optional[str]:
        """The object whose position a comparison's variable is: the object of the body atom (obj_pos) that
        gives that variable as a position on this axis."""
        variables = {t[1] for t in terms if t[0] == "v"}
        for lit in rule.body:
            if not lit.is_atom or lit.negated or lit.atom[0] != "f":
                continue
            template = self.catalog.templates.get((lit.atom[1], len(lit.atom[2])))
            if template is None:
                continue
            by_param = {m.group(1): m.group(2) for m in PLACEHOLDER.finditer(template.template)}
            args = dict(zip(template.params, lit.atom[2]))
            if not any(by_param.get(p) == fmt and a[0] == "v" and a[1] in variables for p, a in args.items()):
                continue
            for param, arg in args.items():
                if by_param.get(param) == "obj":
                    try:
                        return self.value(evaluate(arg, env), "obj", "")
                    except Unbound:
                        return None
        return None

def _setting(name: str) -> tuple[str, str, int]:
    """A setting's words, unit and scale (`_SETTINGS`)."""
    return _SETTINGS.get(name, (name.replace("_dist", "_distance").replace("_", " "), *_DISTANCE_UNIT))


def _setting_digits(n: int, scale: int) -> int:
    """Decimals that show a setting exactly, at least one: '10.0 m', '8.94 m/s'. The setting's line and the
    comparisons that use it show it alike, not '8.94 m/s' above '12.0 m/s > 8.9 m/s'."""
    digits = 1
    while scale > 10 ** digits and n % (scale // 10 ** digits):
        digits += 1
    return digits if scale > 1 else 0


def _setting_scales(rule: CompiledRule) -> dict[str, int]:
    """The rule's variables that are settings (`param(turn_speed, T)`), with each one's scale."""
    return {term[2][1][1]: _setting(term[2][0][1].name)[2] for term in (lit.atom for lit in rule.body if lit.is_atom)
            if term[0] == "f" and term[1] in ("param", "window_param") and len(term[2]) == 2
            and term[2][0][0] == "s" and term[2][1][0] == "v"}


def _alternative(choice: str, values: dict[str, Optional[Symbol]], receding: Optional[bool]) -> str:
    """The alternative of a template's `[...|...]` that its values can fill (`_CHOICE`). `receding`: in a
    template with a closing speed, whether it is negative; the choice is then by its sign alone."""
    alternatives = _ALTERNATIVE.split(choice)
    if receding is not None:
        return alternatives[-1] if receding else alternatives[0]
    for words in alternatives[:-1]:
        if all(values.get(p.group(1)) is not None for p in PLACEHOLDER.finditer(words)):
            return words
    return alternatives[-1]


def _negative(value: Optional[Symbol]) -> bool:
    return value is not None and value.type == SymbolType.Number and value.number < 0


def _nonzero_side(terms: list[Term], values: list[Symbol], op: int) -> tuple[int, Symbol]:
    """A comparison with a literal 0 on either side, as (operator, value) read with the value first."""
    if not term_vars(terms[0]) and values[0].number == 0:
        return _FLIPPED[op], values[1]
    return op, values[0]


def _digits_to_tell_apart(numbers: list[int], fmt: Optional[str], unit: Optional[float] = None) -> int:
    """One decimal, or two where two different numbers would both read '8.9 m/s' (895 against 894 cm/s). `unit`:
    cm/s in a sign's unit (mph): as many decimals, up to three, as tell the numbers apart in it."""
    if unit is not None:
        for digits in (1, 2, 3):
            if all(a == b or round(a / unit, digits) != round(b / unit, digits) for a, b in zip(numbers, numbers[1:])):
                return digits
        return 3
    scale = 1000 if fmt == "ms" else 100
    for a, b in zip(numbers, numbers[1:]):
        if a != b and round(a / scale, 1) == round(b / scale, 1):
            return 2 if fmt != "ms" else 3
    return 1


_SIGNED = {  # (at zero, positive, negative); the sign of a position or speed said in words
    "ahead": ("level with the ego", "{} m ahead", "{} m behind"),
    "right": ("in line with the ego", "{} m to the right", "{} m to the left"),
    "along": ("0.0 m/s along the ego's heading", "{} m/s along the ego's heading", "{} m/s against the ego's heading"),
    "across": ("0.0 m/s sideways", "{} m/s to the right", "{} m/s to the left"),
}
_COMPARED = {"m": "m", "mps": "mps", "speed": "speed", "decel": "decel", "limit": "limit", "ms": "ms", "frames": "frames", "ordinal": "ordinal",
             "percent": "percent", "ahead": "ahead", "right": "right", "along": "along", "across": "across", "closing": "closing"}
_LESS, _LESS_EQ, _MORE, _MORE_EQ = (int(o) for o in (_CMP.LessThan, _CMP.LessEqual, _CMP.GreaterThan,
                                                      _CMP.GreaterEqual))
_EQ, _NOT_EQ = int(_CMP.Equal), int(_CMP.NotEqual)
_ABSOLUTE = {"ahead": "ahead or behind", "right": "to the side"}  # |Y|, |X|: a distance off the ego either way
_PLUS_MINUS = {int(BinaryOperator.Plus): "+", int(BinaryOperator.Minus): "−"}
_FLIPPED = {_LESS: _MORE, _LESS_EQ: _MORE_EQ, _MORE: _LESS, _MORE_EQ: _LESS_EQ, _EQ: _EQ, _NOT_EQ: _NOT_EQ}
# A closing speed against a bound other than 0, by operator and whether the bound is a shrinking gap (> 0): the words
# before the bound's size. 'C > 200': the gap shrinks by more than 2 m/s; 'C > -200': it grows by less, or shrinks.
_CLOSING_BOUND = {
    _MORE: {True: ("more than", ""), False: ("less than", ", if at all")},
    _MORE_EQ: {True: ("at least", ""), False: ("at most", ", if at all")},
    _LESS: {True: ("less than", ", if at all"), False: ("more than", "")},
    _LESS_EQ: {True: ("at most", ", if at all"), False: ("at least", "")},
}
_MOTION = {  # a signed speed against 0 as words: which way it goes, or what the gap does
    "along": {_LESS: "is a move against the ego's heading", _LESS_EQ: "is no move along the ego's heading",
              _MORE: "is a move along the ego's heading", _MORE_EQ: "is no move against the ego's heading",
              _EQ: "is no move along the ego's heading or against it", _NOT_EQ: "is a move along the ego's heading or against it"},
    "across": {_LESS: "is a move to the left", _LESS_EQ: "is no move to the right", _MORE: "is a move to the right",
               _MORE_EQ: "is no move to the left", _EQ: "is no sideways move", _NOT_EQ: "is a sideways move"},
    "closing": {_LESS: "the gap grows", _LESS_EQ: "the gap does not shrink", _MORE: "the gap shrinks",
                _MORE_EQ: "the gap does not grow", _EQ: "the gap holds", _NOT_EQ: "the gap changes"},
}
_AXES = {  # a comparison of signed positions as words, "is" meaning where the first one lies
    "ahead": {_LESS: "is behind", _LESS_EQ: "is not ahead of", _MORE: "is ahead of", _MORE_EQ: "is not behind",
              _EQ: "is level with", _NOT_EQ: "is not level with"},
    "right": {_LESS: "is left of", _LESS_EQ: "is not right of", _MORE: "is right of", _MORE_EQ: "is not left of",
              _EQ: "is in line with", _NOT_EQ: "is not in line with"},
}
