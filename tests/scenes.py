"""A terse way to write scenes in tests: keyword arguments in, validated Scene out."""

from __future__ import annotations

from typing import Optional

from discern.rules.scene import Scene


def obj(cls: str, x: float, y: float, lane: Optional[int] = None, kind: str = "current", oid: Optional[int] = None,
        vy: Optional[float] = None, **extra) -> dict:
    data = {"class": cls, "position": {"x": x, "y": y}, **extra}
    if oid is not None:
        data["id"] = oid
    if lane is not None:
        data["lane"] = {"kind": kind, "id": lane}
    if vy is not None:
        data["velocity"] = {"x": 0.0, "y": vy}
    return data


def scene(speed: float = 10.0, lane: int = 1, lanes: int = 1, limit: Optional[float] = 15.0,
          intent: str = "continue_in_lane", objects: tuple = (), light: Optional[str] = None,
          sign: Optional[str] = None, intersection: Optional[dict] = None, sensors: Optional[dict] = None,
          other_lanes: tuple = (), zone: str = "city", frame: int = 1, path: Optional[str] = None,
          crossings: tuple = (), lane_ends: Optional[dict] = None, exits: tuple = (),
          movements: Optional[dict] = None, **extra) -> Scene:
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
        "timestamp": frame * 0.1,
        "ego": {"speed": speed, "lane": lane, "intent": intent, "zone": zone, "predicted_path": path},
        "speed_limit": limit,
        "lanes": lane_list,
        "objects": objs,
        "traffic_lights": [{"colour": light}] if light else [],
        "signs": [{"kind": sign}] if sign else [],
        "intersection": intersection,
        "sensors": [{"side": s, "distance": d} for s, d in (sensors or {}).items()],
        "path_crossings": [{"ego_path": a, "object_path": b} for a, b in crossings],
        **extra,
    }
    return Scene.model_validate(data)
