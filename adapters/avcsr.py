"""Read AUTO-DISCERN / AV-CSR frame files (Prolog facts) into Scenes, unchanged.

The files are plain Prolog facts, one block per frame; the frame a fact
belongs to is its timestamp argument T (as in the original s(CASP) program).
path_intersects, which has no T, holds in every frame; the template's
sensor/2, which has none either, belongs to the FRAME block it sits under.
A fact AV-CSR does not write, a wrong arity or a fact that contradicts
another is refused with its file and line; anything else odd in the data is
kept and reported as a note on the scene, never silently fixed.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Union

from pydantic import ValidationError

from discern.rules.scene import JSON_AS_SCHEMA, Action, IntersectionStage, Scene, Zone, describe_error

Term = Union[int, float, str, "Compound", list]


@dataclass(frozen=True)
class Compound:
    name: str
    args: tuple

    def __repr__(self) -> str:  # in every message, as the file writes it: pos(0, 3, 4)
        return _show(self)


class AvcsrError(ValueError):
    """A frame file that cannot be read; the message names file, line and problem."""


# Prolog's own spellings are read as Prolog reads them: 'car' is the atom car, /* ... */ a comment, 1.0e1 a float.
_TOKEN = re.compile(
    r"\s*(?:(?P<comment>%[^\n]*|/\*(?s:.*?)\*/)|(?P<num>-?\d+(?:\.\d+)?(?:[eE][+-]?\d+)?(?![\w.]\d))"
    r"|(?P<atom>[a-z][A-Za-z0-9_]*)|(?P<quoted>'(?:[^'\\\n]|''|\\.)*')"
    r"|(?P<var>[A-Z_][A-Za-z0-9_]*)|(?P<punct>[(),\[\]|])|(?P<end>\.(?=\s|$|%))|(?P<bad>\S))"
)
_UNSUPPORTED = {'"': "a double-quoted string", "/": "an operator or an unclosed /* comment",
                "'": "an unclosed quoted atom", "{": "a curly term", ":": "an operator (:-, a module qualifier)"}


def _tokens(text: str, path: str):
    line = 1
    for m in _TOKEN.finditer(text):
        line += text.count("\n", m.start(), m.start() + len(m.group(0)) - len(m.group(0).lstrip()))
        kind = m.lastgroup
        value = m.group(kind)
        if kind == "comment":
            line += value.count("\n")
            continue
        if kind == "bad":
            what = _UNSUPPORTED.get(value)
            raise AvcsrError(f"{path}:{line}: unexpected character {value!r}" + (f" ({what}: not part of a fact)" if what else ""))
        if kind == "quoted":
            kind, value = "atom", value[1:-1].replace("''", "'")
        yield kind, value, line
        line += value.count("\n")


MAX_TERM_DEPTH = 16
MAX_DIGITS = 30  # a whole number longer is no speed, id or frame; Python refuses past 4300 digits anyway


def _number(tok: str, where: str) -> Union[int, float]:
    if "." in tok or "e" in tok.lower():
        return float(tok)  # too large a float is inf, which the scene model names
    if len(tok) > MAX_DIGITS:
        raise AvcsrError(f"{where}: the number {tok[:12]}... has {len(tok)} digits, more than {MAX_DIGITS}")
    return int(tok)


class _Parser:
    def __init__(self, text: str, path: str):
        self.tokens = list(_tokens(text, path))
        self.pos = 0
        self.path = path

    def peek(self):
        return self.tokens[self.pos] if self.pos < len(self.tokens) else (None, None, self.tokens[-1][2] if self.tokens else 1)

    def at(self, mark: str) -> bool:
        """Whether the next token is this punctuation mark: a quoted atom that spells one ('[') is an atom."""
        kind, tok, _ = self.peek()
        return kind in ("punct", "end") and tok == mark

    def take(self, value: str | None = None):
        kind, tok, line = self.peek()
        if kind is None or (value is not None and not self.at(value)):
            found = "the end of the file" if kind is None else repr(tok)
            raise AvcsrError(f"{self.path}:{line}: expected {value or 'a term'}, found {found}")
        self.pos += 1
        return kind, tok, line

    def clauses(self) -> list[tuple[Compound, int]]:
        out = []
        while self.peek()[0] is not None:
            term = self.term()
            _, _, line = self.take(".")
            if not isinstance(term, Compound):
                raise AvcsrError(f"{self.path}:{line}: a fact must be a compound term, got {term!r}")
            out.append((term, line))
        return out

    def term(self, depth: int = 0) -> Term:
        kind, tok, line = self.take()
        if depth > MAX_TERM_DEPTH:  # AV-CSR's facts nest two deep; a deep one must not exhaust the stack
            raise AvcsrError(f"{self.path}:{line}: a term nested more than {MAX_TERM_DEPTH} deep")
        if kind == "num":
            return _number(tok, f"{self.path}:{line}")
        if kind == "var":
            raise AvcsrError(f"{self.path}:{line}: variable {tok} in a fact (facts must be ground)")
        if kind == "punct" and tok == "[":
            items: list = []
            if not self.at("]"):
                items.append(self.term(depth + 1))
                while self.at(","):
                    self.take(",")
                    items.append(self.term(depth + 1))
            self.take("]")
            return items
        if kind != "atom":
            raise AvcsrError(f"{self.path}:{line}: unexpected {tok!r}")
        if self.at("("):
            self.take("(")
            args = [self.term(depth + 1)]
            while self.at(","):
                self.take(",")
                args.append(self.term(depth + 1))
            self.take(")")
            return Compound(tok, tuple(args))
        return tok


@dataclass
class AvcsrFrame:
    scenario: str
    environment: str
    frame: int
    scene: Scene
    expected: Action | None
    notes: list[str] = field(default_factory=list)


_HEADER = re.compile(r"%%%\s*FRAME\s+(\d+)")

# The facts AV-CSR writes (its template.pl and README, and main_scasp.pl's sensor/3) by name and arity, with their
# arguments; T is the frame. path_intersects/2 holds in every frame, sensor/2 in the FRAME block it sits under.
_FORMS: dict[tuple[str, int], tuple[str, ...]] = {
    ("self_speed", 2): ("Speed", "T"),
    ("self_lane", 2): ("Lane", "T"),
    ("speed_limit", 2): ("Speed", "T"),
    ("obj_meta", 6): ("T", "Id", "Class", "pos(X, Y)", "lane(Kind, Lane)", "Indicator"),
    ("lanes", 3): ("Kind", "[Ids]", "T"),
    ("intersection", 3): ("Type", "Meta", "T"),
    ("intersection", 4): ("Type", "Meta", "Stage", "T"),
    ("at_intersection", 2): ("Id", "T"),
    ("in_intersection", 2): ("Id", "T"),
    ("traffic_light", 2): ("Colour", "T"),
    ("traffic_sign", 2): ("Sign", "T"),
    ("intent", 2): ("Intent", "T"),
    ("self_pred_path", 2): ("Path", "T"),
    ("obj_pred_path", 3): ("Id", "Path", "T"),
    ("path_intersects", 2): ("SelfPath", "ObjectPath"),
    ("sensor", 2): ("Side", "Dist"),
    ("sensor", 3): ("Side", "Dist", "T"),
    ("left_sensor", 2): ("Dist", "T"),
    ("expected_action", 2): ("Action", "T"),
}

# The template's at_intersection/in_intersection(0, T): the ego (object 0) waits at, or has entered, the intersection.
_STAGES = {"at_intersection": IntersectionStage.at, "in_intersection": IntersectionStage.enter}
_STAGE_KEY = "ego's stage at the intersection"


def _show(term: Term) -> str:
    """A term as the file writes it, for messages."""
    if isinstance(term, Compound):
        return f"{term.name}({', '.join(map(_show, term.args))})"
    if isinstance(term, list):
        return f"[{', '.join(map(_show, term))}]"
    return str(term)


def _timestamp_index(fact: Compound, path: Path, line: int) -> int | None:
    """Where a fact keeps its frame T (None: it has none); an unknown name or arity is refused before any
    argument is read, so that a stray fact cannot invent a frame."""
    args = _FORMS.get((fact.name, len(fact.args)))
    if args is None:
        forms = [f"{name}({', '.join(a)})" for (name, _), a in _FORMS.items() if name == fact.name]
        if forms:
            raise AvcsrError(
                f"{path}:{line}: {_show(fact)} has {len(fact.args)} arguments; AV-CSR writes {' or '.join(forms)}"
            )
        known = ", ".join(f"{name}/{arity}" for name, arity in sorted(_FORMS))
        raise AvcsrError(f"{path}:{line}: unknown fact {fact.name}/{len(fact.args)}; the AV-CSR facts are {known}")
    return args.index("T") if "T" in args else None


def _environment(text: str) -> tuple[str, Zone, list[str]]:
    """The environment that the file's first comment line names, and its zone; any other is read as city, with a
    note, since the zone sets which speed limits are plausible."""
    word = None
    for line in map(str.strip, text.splitlines()):
        if not line or re.fullmatch(r"%[\W_]*", line):  # a blank line, or a comment without words
            continue
        match = re.match(r"%+[\W_]*([A-Za-z]+)", line)
        if match and not _HEADER.match(line):
            word = match.group(1)
        break
    zones = [zone.value for zone in Zone]
    if word and word.lower() in zones:
        return word.capitalize(), Zone(word.lower()), []
    known = ", ".join(zones)
    said = (
        f"the first comment line names environment {word!r}, not one of {known}"
        if word
        else f"no comment line before the facts names the environment (one of {known})"
    )
    note = f"{said}: the zone is assumed to be city"
    return (word or "unknown").capitalize(), Zone.city, [note]


def read_file(path: Union[str, Path]) -> list[AvcsrFrame]:
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise AvcsrError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    except OSError as exc:  # a broken symlink or a directory named x.pl, found in a directory given
        raise AvcsrError(f"{path}: cannot read: {exc.strerror or exc}") from None
    environment, zone, file_notes = _environment(text)
    headers = [(m.start(), _number(m.group(1), f"{path}:{text.count(chr(10), 0, m.start()) + 1}"))
               for m in _HEADER.finditer(text)]
    line_starts = [0] + [i + 1 for i, c in enumerate(text) if c == "\n"]

    def block_of(line: int) -> int | None:
        offset = line_starts[line - 1]
        current = None
        for start, frame in headers:
            if start <= offset:
                current = frame
        return current

    by_frame: dict[int, list[tuple[Compound, int]]] = {}
    global_facts: list[tuple[Compound, int]] = []
    notes: dict[int, list[str]] = {}
    for fact, line in _Parser(text, str(path)).clauses():
        index = _timestamp_index(fact, path, line)
        block = block_of(line)
        if index is not None:
            t = fact.args[index]
        elif fact.name == "sensor":  # the template's sensor/2 has no T: it belongs to the block it sits in
            if block is None:
                raise AvcsrError(
                    f"{path}:{line}: {_show(fact)} has no frame T and sits under no %%% FRAME n %%% header"
                )
            t = block
        else:  # path_intersects holds in every frame
            global_facts.append((fact, line))
            continue
        if not isinstance(t, int):
            raise AvcsrError(f"{path}:{line}: {fact.name} has timestamp {t!r}, expected an integer")
        by_frame.setdefault(t, []).append((fact, line))
        if block is not None and block != t:
            note = f"{path.name}:{line}: {_show(fact)} is stamped T={t} but sits under FRAME {block}; read as T={t}"
            notes.setdefault(t, []).append(note)
            notes.setdefault(block, []).append(note)
    if not by_frame:
        raise AvcsrError(f"{path}: no frames: no fact names a frame T")
    _check_crossings(global_facts, by_frame, path)
    frames = []
    for t in sorted(by_frame):
        scene, expected, extra = _scene(by_frame[t] + global_facts, t, zone, path)
        frame_notes = file_notes + notes.get(t, []) + extra + scene.notes
        frames.append(AvcsrFrame(path.stem, environment, t, scene, expected, frame_notes))
    return frames


def _check_crossings(crossings: list[tuple[Compound, int]], by_frame: dict, path: Path) -> None:
    """Refuse a path_intersects that no frame can use, rather than drop it; AV-CSR's rules match
    path_intersects(SelfPath, ObjectPath) only, so the order matters."""
    paths = [
        ({_show(f.args[0]) for f, _ in facts if f.name == "self_pred_path"},
         {_show(f.args[1]) for f, _ in facts if f.name == "obj_pred_path"})
        for facts in by_frame.values()
    ]
    for fact, line in crossings:
        first, second = map(_show, fact.args)
        if any(first in ego and second in objects for ego, objects in paths):
            continue
        if any(second in ego and first in objects for ego, objects in paths):
            raise AvcsrError(
                f"{path}:{line}: {_show(fact)} names the object's path first; AV-CSR's rules match "
                f"path_intersects(SelfPath, ObjectPath) only, so it would never apply: "
                f"write path_intersects({second}, {first})"
            )
        raise AvcsrError(
            f"{path}:{line}: {_show(fact)} applies in no frame: none has both self_pred_path({first}, T) "
            f"and obj_pred_path(_, {second}, T)"
        )


def _key(f: Compound) -> str:
    """What a fact states that a frame holds once, in words: a second fact with the same key must be the same fact."""
    a = f.args
    if f.name in ("traffic_sign", "path_intersects"):  # a frame may hold several
        return _show(f)
    if f.name in _STAGES:
        return _STAGE_KEY
    if f.name in ("obj_meta", "obj_pred_path"):
        return f"{f.name} for object {_show(a[1] if f.name == 'obj_meta' else a[0])}"
    if f.name == "lanes":
        return f"lanes of kind {_show(a[0])}"
    if f.name in ("sensor", "left_sensor"):
        return f"{'left' if f.name == 'left_sensor' else _show(a[0])} sensor reading"
    return f.name


# The scene's fields each fact fills, so that a value the scene model refuses is named by its fact and line.
_EGO_FIELDS = {"self_speed": ("ego", "speed"), "self_lane": ("ego", "lane"), "intent": ("ego", "intent"),
               "self_pred_path": ("ego", "predicted_path"), "speed_limit": ("speed_limit",),
               "intersection": ("intersection",)}
_LISTS = ("objects", "lanes", "traffic_lights", "signs", "sensors")
# AV-CSR's own indicator words (its entities.pl) that the scene model has no word for, read as none with a note.
_SIDELESS_INDICATORS = {
    "turn_signals": "a turn signal without its side, which the scene's left and right need",
    "tail_lights": "tail lights, which signal nothing",
}


def _sideless(indicator: Term) -> bool:
    return isinstance(indicator, str) and indicator in _SIDELESS_INDICATORS


def _scene(facts: list[tuple[Compound, int]], t: int, zone: Zone, path: Path) -> tuple[Scene, Action | None, list[str]]:
    data: dict = {"frame_id": t, "lanes": [], "objects": [], "traffic_lights": [], "signs": [], "sensors": []}
    ego: dict = {"zone": zone}
    expected = None
    held: dict[str, tuple[Compound, int]] = {}
    object_paths: list[tuple[Compound, int]] = []
    crossings: list[tuple[Term, Term]] = []
    origins: dict[tuple, tuple[Compound, int]] = {}  # a field of the scene -> the fact that filled it
    notes: list[str] = []
    for f, line in facts:
        key = _key(f)
        if key in held:
            first, first_line = held[key]
            if f == first:  # the same fact twice says nothing new
                continue
            raise AvcsrError(
                f"{path}:{line}: {_show(f)} contradicts {_show(first)} at line {first_line}: frame {t} holds one {key}"
            )
        held[key] = f, line
        if f.name == "obj_pred_path":
            object_paths.append((f, line))
            continue
        lengths = {name: len(data[name]) for name in _LISTS}
        try:
            expected = _read_fact(f, data, ego, crossings) or expected
        except (ValueError, TypeError, AttributeError, IndexError) as exc:
            raise AvcsrError(f"{path}:{line}: {f.name}/{len(f.args)} cannot be read: {exc}") from None
        for name, before in lengths.items():
            origins.update({(name, i): (f, line) for i in range(before, len(data[name]))})
        if f.name in _EGO_FIELDS:
            origins[_EGO_FIELDS[f.name]] = f, line
        if f.name == "self_lane":
            origins[("lanes",)] = f, line  # the one check of the lanes as a whole: the ego's lane is among them
        if f.name == "obj_meta" and _sideless(f.args[5]):
            notes.append(f"{path.name}:{line}: {_show(f)}: indicator {f.args[5]} is "
                         f"{_SIDELESS_INDICATORS[f.args[5]]}: read as none")
    notes += _intersection_stage(data, held, t, path)
    for f, line in object_paths:
        owners = [i for i, obj in enumerate(data["objects"]) if obj["id"] == f.args[0]]
        if not owners:
            raise AvcsrError(f"{path}:{line}: {_show(f)}: frame {t} has no obj_meta for object {_show(f.args[0])}")
        data["objects"][owners[0]]["predicted_path"] = f.args[1]
        origins[("objects", owners[0], "predicted_path")] = f, line
    data["path_crossings"] = [
        {"ego_path": p, "object_path": q}
        for p, q in crossings
        if p == ego.get("predicted_path") and any(q == obj.get("predicted_path") for obj in data["objects"])
    ]
    data["ego"] = ego
    try:
        # through JSON, strictly, as a scene from a planner is read: a quoted atom ('12') is no number
        return Scene.model_validate_json(json.dumps(data, default=_show), **JSON_AS_SCHEMA), expected, notes
    except ValidationError as exc:
        raise AvcsrError("\n".join(_problem(err, origins, path, t) for err in exc.errors(include_url=False))) from None


SHOWN_FACT_CHARS = 120


def _problem(err: dict, origins: dict[tuple, tuple[Compound, int]], path: Path, t: int) -> str:
    """A value the scene model refuses, named by the fact and line it came from: `file:6: obj_meta(...): class: ...`."""
    loc = tuple(err["loc"])
    if err["type"] == "too_long":  # the fact that added the first item past the limit, not the list's other checks
        loc += (err["ctx"]["max_length"],)
    for cut in range(len(loc), 0, -1):
        if loc[:cut] in origins:
            fact, line = origins[loc[:cut]]
            field = ".".join(map(str, loc[cut:]))
            shown = _show(fact)
            if len(shown) > SHOWN_FACT_CHARS:  # a list of thousands of lanes: its start names the fact
                shown = shown[:SHOWN_FACT_CHARS] + " ..."
            return f"{path}:{line}: {shown}: {field + ': ' if field else ''}{describe_error(err)}"
    where = ".".join(map(str, loc))
    return f"{path}: frame {t}: {where + ': ' if where else ''}{describe_error(err)}"


def _intersection_stage(data: dict, held: dict, t: int, path: Path) -> list[str]:
    """The ego's stage: intersection/4 states it, as may the template's at_intersection/in_intersection(0, T) beside
    intersection/3; they must agree. With neither, the ego is read as arriving, and a note says so."""
    inter = data.get("intersection")
    stated = held.get(_STAGE_KEY)
    if stated is None:
        if inter is None or "stage" in inter:
            return []
        inter["stage"] = IntersectionStage.arriving
        stageless = _show(held["intersection"][0])
        return [f"{stageless} gives no stage, nor does at_intersection/in_intersection(0, {t}): read as arriving"]
    f, line = stated
    if inter is None:
        raise AvcsrError(
            f"{path}:{line}: {_show(f)}: frame {t} has no intersection(Type, Meta, T) to say which intersection"
        )
    if "stage" in inter and inter["stage"] != _STAGES[f.name].value:
        inter_fact, inter_line = held["intersection"]
        raise AvcsrError(
            f"{path}:{line}: {_show(f)} contradicts {_show(inter_fact)} at line {inter_line}: "
            f"frame {t} holds one {_STAGE_KEY}"
        )
    inter["stage"] = _STAGES[f.name]
    return []


def _read_fact(f: Compound, data: dict, ego: dict, crossings: list) -> Action | None:
    """One fact into the scene's data, or the expected action; a fact of the wrong shape raises, and _scene names it."""
    a = f.args
    if f.name == "self_speed":
        ego["speed"] = a[0]
    elif f.name == "self_lane":
        ego["lane"] = a[0]
    elif f.name == "speed_limit":
        data["speed_limit"] = a[0]
    elif f.name == "intent":
        ego["intent"] = a[0]
    elif f.name == "obj_meta":
        _, oid, cls, pos, lane, indicator = a
        indicator = "none" if _sideless(indicator) else indicator
        x, y = _pair(pos, "pos")
        kind, lane_id = _pair(lane, "lane")
        data["objects"].append(
            {
                "id": oid,
                "class": cls,
                "position": {"x": x, "y": y},
                "lane": {"kind": kind, "id": lane_id},
                "indicator": indicator,
                "sources": ["annotation"],
            }
        )
    elif f.name == "lanes":
        kind, ids = a[0], a[1]
        if not isinstance(ids, list):
            raise ValueError(f"expected a list of lane ids such as [1, 2], found {_show(ids)}")
        for lane_id in dict.fromkeys(ids):
            data["lanes"].append({"kind": kind, "id": lane_id})
    elif f.name == "traffic_light":
        if a[0] != "none":  # AV-CSR's traffic_light(none, T): no light in view, not a dark one (template.pl)
            data["traffic_lights"].append({"colour": a[0], "source": "annotation"})
    elif f.name == "traffic_sign":
        data["signs"].append({"kind": a[0], "source": "annotation"})
    elif f.name == "intersection":
        inter = {"type": a[0]}
        if a[1] in ("major", "minor"):
            inter["road"] = a[1]
        elif isinstance(a[1], int):
            inter["arrival_rank"] = a[1]
        elif a[1] != "none":
            raise ValueError(f"meta {_show(a[1])} is not none, major, minor or the ego's arrival rank")
        if len(a) == 4:
            inter["stage"] = a[2]
        data["intersection"] = inter
    elif f.name in _STAGES:
        if a[0] != 0:
            raise ValueError(f"object {_show(a[0])}: only 0, the ego, can be read (a scene holds no object's stage)")
    elif f.name == "self_pred_path":
        ego["predicted_path"] = a[0]
    elif f.name == "path_intersects":
        crossings.append((a[0], a[1]))
    elif f.name == "sensor":
        data["sensors"].append({"side": a[0], "distance": a[1], "kind": "ultrasonic"})
    elif f.name == "left_sensor":
        data["sensors"].append({"side": "left", "distance": a[0], "kind": "ultrasonic"})
    elif f.name == "expected_action":
        if not isinstance(a[0], str) or a[0] not in Action.__members__:
            raise ValueError(f"{a[0]!r} is not one of {', '.join(action.value for action in Action)}")
        return Action(a[0])
    return None


def _pair(term, name: str) -> tuple:
    if not isinstance(term, Compound) or term.name != name or len(term.args) != 2:
        raise ValueError(f"expected {name}(_, _), found {term!r}")
    return term.args


def read_dir(directory: Union[str, Path]) -> list[AvcsrFrame]:
    files = sorted(Path(directory).glob("*.pl"))
    if not files:
        raise AvcsrError(f"{directory}: no AV-CSR .pl frame files")
    return [frame for f in files for frame in read_file(f)]
