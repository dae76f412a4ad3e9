"""Read AUTO-DISCERN / AV-CSR frame files (Prolog facts) into Scenes, unchanged.

The files are plain Prolog facts, one block per frame; the frame a fact
belongs to is its timestamp argument T (as in the original s(CASP) program),
and facts without T hold in every frame. Anything odd in the data is kept
and reported as a note on the scene, never silently fixed.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Union

from pydantic import ValidationError

from discern.rules.scene import Action, Scene, describe_errors

Term = Union[int, float, str, "Compound", list]


@dataclass(frozen=True)
class Compound:
    name: str
    args: tuple


class AvcsrError(ValueError):
    """A frame file that cannot be read; the message names file, line and problem."""


_TOKEN = re.compile(
    r"\s*(?:(?P<comment>%[^\n]*)|(?P<num>-?\d+(?:\.\d+)?(?![\w.]\d))|(?P<atom>[a-z][A-Za-z0-9_]*)"
    r"|(?P<var>[A-Z_][A-Za-z0-9_]*)|(?P<punct>[(),\[\]|])|(?P<end>\.(?=\s|$|%))|(?P<bad>\S))"
)

ZONES = {"city": "city", "road": "road", "residential": "residential", "campus": "campus", "highway": "highway"}


def _tokens(text: str, path: str):
    line = 1
    for m in _TOKEN.finditer(text):
        line += text.count("\n", m.start(), m.start() + len(m.group(0)) - len(m.group(0).lstrip()))
        kind = m.lastgroup
        value = m.group(kind)
        if kind == "comment":
            continue
        if kind == "bad":
            raise AvcsrError(f"{path}:{line}: unexpected character {value!r}")
        yield kind, value, line
        line += value.count("\n")


class _Parser:
    def __init__(self, text: str, path: str):
        self.tokens = list(_tokens(text, path))
        self.pos = 0
        self.path = path

    def peek(self):
        return self.tokens[self.pos] if self.pos < len(self.tokens) else (None, None, self.tokens[-1][2] if self.tokens else 1)

    def take(self, value: str | None = None):
        kind, tok, line = self.peek()
        if kind is None or (value is not None and tok != value):
            raise AvcsrError(f"{self.path}:{line}: expected {value or 'a term'}, found {tok!r}")
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

    def term(self) -> Term:
        kind, tok, line = self.take()
        if kind == "num":
            return float(tok) if "." in tok else int(tok)
        if kind == "var":
            raise AvcsrError(f"{self.path}:{line}: variable {tok} in a fact (facts must be ground)")
        if tok == "[":
            items: list = []
            if self.peek()[1] != "]":
                items.append(self.term())
                while self.peek()[1] == ",":
                    self.take(",")
                    items.append(self.term())
            self.take("]")
            return items
        if kind != "atom":
            raise AvcsrError(f"{self.path}:{line}: unexpected {tok!r}")
        if self.peek()[1] == "(":
            self.take("(")
            args = [self.term()]
            while self.peek()[1] == ",":
                self.take(",")
                args.append(self.term())
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


def _timestamp_index(fact: Compound) -> int | None:
    """Where a fact keeps its timestamp, per the AV-CSR template."""
    first = {"obj_meta"}
    if fact.name in first:
        return 0
    if fact.name in ("path_intersects",) or (fact.name == "sensor" and len(fact.args) == 2):
        return None
    return len(fact.args) - 1


def read_file(path: Union[str, Path]) -> list[AvcsrFrame]:
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise AvcsrError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    first = text.lstrip().splitlines()[0] if text.strip() else ""
    env_word = first.lstrip("% ").split(" ")[0].split("-")[0].strip().lower()
    environment = env_word.capitalize() if env_word else "Unknown"
    headers = [(m.start(), int(m.group(1))) for m in _HEADER.finditer(text)]
    line_starts = [0] + [i + 1 for i, c in enumerate(text) if c == "\n"]

    def block_of(line: int) -> int | None:
        offset = line_starts[line - 1]
        current = None
        for start, frame in headers:
            if start <= offset:
                current = frame
        return current

    by_frame: dict[int, list[Compound]] = {}
    global_facts: list[Compound] = []
    notes: dict[int, list[str]] = {}
    for fact, line in _Parser(text, str(path)).clauses():
        index = _timestamp_index(fact)
        if index is None:
            global_facts.append(fact)
            continue
        t = fact.args[index]
        if not isinstance(t, int):
            raise AvcsrError(f"{path}:{line}: {fact.name} has timestamp {t!r}, expected an integer")
        by_frame.setdefault(t, []).append(fact)
        block = block_of(line)
        if block is not None and block != t:
            notes.setdefault(t, []).append(
                f"{path.name}:{line}: {fact.name} is stamped T={t} but sits under FRAME {block}; read as T={t}"
            )
    frames = []
    for t in sorted(by_frame):
        facts = by_frame[t] + global_facts
        scene, expected, extra = _scene(facts, t, environment, str(path))
        frames.append(AvcsrFrame(path.stem, environment, t, scene, expected, notes.get(t, []) + extra + scene.notes))
    return frames


def _scene(facts: list[Compound], t: int, environment: str, path: str) -> tuple[Scene, Action | None, list[str]]:
    data: dict = {"frame_id": t, "lanes": [], "objects": [], "traffic_lights": [], "signs": [], "sensors": []}
    ego: dict = {"zone": ZONES.get(environment.lower(), "city")}
    expected = None
    ego_paths: set[str] = set()
    obj_paths: dict[int, str] = {}
    crossings: list[tuple[str, str]] = []
    notes: list[str] = []
    seen_lanes: set[tuple[str, int]] = set()
    for f in facts:
        try:
            expected = _read_fact(f, data, ego, ego_paths, obj_paths, crossings, notes, seen_lanes) or expected
        except (ValueError, TypeError, AttributeError, IndexError) as exc:
            raise AvcsrError(f"{path}: frame {t}: {f.name}/{len(f.args)} cannot be read: {exc}") from None
    for obj in data["objects"]:
        if obj["id"] in obj_paths:
            obj["predicted_path"] = obj_paths[obj["id"]]
    data["path_crossings"] = [
        {"ego_path": p, "object_path": q} for p, q in crossings if p in ego_paths and q in obj_paths.values()
    ]
    data["ego"] = ego
    try:
        return Scene.model_validate(data), expected, notes
    except ValidationError as exc:
        raise AvcsrError(f"{path}: frame {t}:\n{describe_errors(exc)}") from None


def _read_fact(f: Compound, data: dict, ego: dict, ego_paths: set, obj_paths: dict, crossings: list,
               notes: list, seen_lanes: set) -> Action | None:
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
        for lane_id in ids:
            if (kind, lane_id) not in seen_lanes:
                seen_lanes.add((kind, lane_id))
                data["lanes"].append({"kind": kind, "id": lane_id})
    elif f.name == "traffic_light":
        data["traffic_lights"].append({"colour": a[0], "source": "annotation"})
    elif f.name == "traffic_sign":
        data["signs"].append({"kind": a[0], "source": "annotation"})
    elif f.name == "intersection":
        kind, meta, stage = a[0], a[1], a[2] if len(a) == 4 else "arriving"
        inter = {"type": kind, "stage": stage}
        if meta in ("major", "minor"):
            inter["road"] = meta
        elif isinstance(meta, int):
            inter["arrival_rank"] = meta
        data["intersection"] = inter
    elif f.name == "self_pred_path":
        ego_paths.add(a[0])
        ego["predicted_path"] = a[0]
    elif f.name == "obj_pred_path":
        obj_paths[a[0]] = a[1]
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
    elif f.name in ("at_intersection", "in_intersection"):
        notes.append(f"{f.name} is not used by the AV-CSR rules; ignored")
    else:
        notes.append(f"unknown fact {f.name}/{len(a)}; ignored")
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
