"""The one terse way to write scenes, for the tests and the worked examples: keywords in, validated Scene out."""

from __future__ import annotations

from typing import Optional

from discern.rules.scene import Scene

MPH = 0.44704  # m/s in a mile per hour: the packs' signs read mph


def obj(cls: str, x: float, y: float, lane: Optional[int] = None, kind: str = "current", oid: Optional[int] = None,
        vy: Optional[float] = None, vx: float = 0.0, sources: Optional[tuple] = None, **extra) -> dict:
    """An object `x` m to the right and `y` m ahead; moving only where `vy` is given; seen by the camera alone
    (the scene model's default) unless `sources` says otherwise; without `oid`, `scene` numbers it."""
    data = {"class": cls, "position": {"x": x, "y": y}, **extra}
    if oid is not None:
        data["id"] = oid
    if sources is not None:
        data["sources"] = list(sources)
    if lane is not None:
        data["lane"] = {"kind": kind, "id": lane}
    if vy is not None:
        data["velocity"] = {"x": vx, "y": vy}
    return data


def sensor(side: str, distance: float, kind: str = "radar") -> dict:
    """A range sensor's reading: the nearest thing on `side` is `distance` m away."""
    return {"side": side, "distance": distance, "kind": kind}


def limit_sign(mph: float) -> dict:
    """A speed-limit sign the camera reads, in m/s as the scene model has it."""
    return {"kind": "speed_limit", "value": round(mph * MPH, 3), "source": "camera"}


def scene(speed: float = 10.0, lane: int = 1, lanes: int = 1, limit: Optional[float] = 15.0,
          intent: str = "continue_in_lane", objects: tuple = (), light: Optional[str] = None,
          sign: Optional[str] = None, intersection: Optional[dict] = None, sensors: tuple = (),
          other_lanes: tuple = (), zone: str = "city", frame: int = 1, path: Optional[str] = None,
          crossings: tuple = (), lane_ends: Optional[dict] = None, exits: tuple = (), lights: tuple = (),
          signs: tuple = (), movements: Optional[dict] = None, **extra) -> Scene:
    """A validated Scene; frames are 0.1 s apart. `light` and `sign` are short for one light of that colour and one
    sign of that kind, `lights` and `signs` list them in full; `movements` gives lanes their lane-use movements, by
    lane id; `extra` sets (or replaces) any other field."""
    lane_list = [{"kind": "current", "id": i} for i in range(1, lanes + 1)]
    for l in lane_list:
        if lane_ends and l["id"] in lane_ends:
            l["ends_in"] = lane_ends[l["id"]]
            l["leaves_road"] = l["id"] in exits
        if movements and l["id"] in movements:
            l["movements"] = list(movements[l["id"]])
    lane_list += [{"kind": k, "id": 1} for k in other_lanes]
    objs = []
    for i, o in enumerate(objects, start=1):
        o = dict(o)
        o.setdefault("id", i)
        objs.append(o)
    data = {
        "frame_id": frame,
        "timestamp": round(0.1 * frame, 3),
        "ego": {"speed": speed, "lane": lane, "intent": intent, "zone": zone, "predicted_path": path},
        "speed_limit": limit,
        "lanes": lane_list,
        "objects": objs,
        "traffic_lights": ([{"colour": light}] if light else []) + list(lights),
        "signs": ([{"kind": sign}] if sign else []) + list(signs),
        "intersection": intersection,
        "sensors": list(sensors),
        "path_crossings": [{"ego_path": a, "object_path": b} for a, b in crossings],
        **extra,
    }
    return Scene.model_validate(data)
