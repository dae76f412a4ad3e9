"""Random valid highway scenes for the benchmarks: one generator, so their figures compare."""

from __future__ import annotations

import random

from discern.rules.scene import Scene

CLASSES = ["car", "truck", "bus", "pedestrian", "bicycle", "roadblock", "unknown", "plastic_bag"]
LANES = 4
WARM_UP_SCENES = 30  # other scenes decided before the timed ones: a worker that has run a while has seen their kinds


def random_scene(rng: random.Random, n: int, frame: int, perception: bool = False) -> Scene:
    """`n` objects around a highway ego; `perception` adds what the sanity layer reads.

    That means sensor sources per object, a posted and a mapped limit, and a front range reading.
    """
    classes = CLASSES[:-1] if perception else CLASSES
    objects = []
    for i in range(1, n + 1):
        kind = rng.choice(["current"] * 4 + ["oncoming", "sidewalk_right"])
        obj = {
            "id": i, "class": rng.choice(classes),
            "position": {"x": rng.uniform(-12, 12), "y": rng.uniform(-60, 120)},
            "lane": {"kind": kind, "id": rng.randint(1, LANES) if kind == "current" else 1},
        }
        if perception:
            obj["velocity"] = {"x": rng.uniform(-1, 1), "y": rng.uniform(0, 30)} if rng.random() < 0.7 else None
            obj["sources"] = rng.choice([["camera", "radar"], ["camera", "radar"], ["camera"], ["radar"]])
        else:
            obj["velocity"] = {"x": 0.0, "y": rng.uniform(0, 30)} if rng.random() < 0.7 else None
        objects.append(obj)
    scene = {
        "frame_id": frame, "timestamp": frame * 0.05,
        "ego": {"speed": rng.uniform(0, 30), "lane": rng.randint(1, LANES), "zone": "highway"},
        "speed_limit": 30.0,
        "lanes": [{"kind": "current", "id": i} for i in range(1, LANES + 1)]
        + [{"kind": "oncoming", "id": 1}, {"kind": "sidewalk_right", "id": 1}],
        "objects": objects,
        "sensors": [{"side": "left", "distance": rng.uniform(0.2, 5)}],
    }
    if perception:
        scene.update(frame_id=frame + 100, timestamp=10.0 + frame, map_speed_limit=30.0,
                     signs=[{"kind": "speed_limit", "value": 30.0, "source": "camera"}])
        scene["sensors"].append({"side": "front", "distance": rng.uniform(5, 100)})
    return Scene.model_validate(scene)
