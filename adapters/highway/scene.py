"""Perceived highway-env frame -> Discern Scene (the one schema; see discern.rules.scene)."""

from __future__ import annotations

from discern.rules.scene import (
    DetectedObject,
    Ego,
    Intent,
    Lane,
    LaneKind,
    LaneRef,
    ObjectClass,
    RangeReading,
    Scene,
    Size,
    Source,
    Vec2,
    Zone,
)

from .perception import Perceived


def _r(value: float) -> float:
    return round(float(value), 3)


def build_scene(perceived: Perceived, previous_speed: float | None = None, period: float = 1.0) -> Scene:
    truth = perceived.truth
    ego = truth.ego
    lane_limit = truth.lane_limit(ego.lane)
    objects = []
    for d in perceived.detections:
        t = d.track
        objects.append(
            DetectedObject(
                id=t.id,
                cls=ObjectClass.roadblock if t.static else ObjectClass.car,
                position=Vec2(x=_r(t.right), y=_r(t.ahead)),
                lane=LaneRef(kind=LaneKind.current, id=t.lane) if t.lane is not None else None,
                velocity=Vec2(x=_r(t.v_right), y=_r(t.v_ahead)),
                sources=list(d.sources),
                size=Size(length=t.length, width=t.width),
            )
        )
    lanes = [
        Lane(
            kind=LaneKind.current,
            id=l.id,
            ends_in=_r(l.ends_in) if l.ends_in is not None else None,
            speed_limit=l.speed_limit,
        )
        for l in truth.lanes
    ]
    acceleration = None if previous_speed is None else _r((ego.speed - previous_speed) / period)
    return Scene(
        frame_id=perceived.frame,
        timestamp=_r(truth.time),
        ego=Ego(
            speed=_r(ego.speed),
            lane=ego.lane,
            intent=Intent.merge_into_left_lane if ego.on_merge_lane else Intent.continue_in_lane,
            zone=Zone.highway,
            acceleration=acceleration,
        ),
        speed_limit=perceived.sign.limit if perceived.sign.limit is not None else lane_limit,
        map_speed_limit=lane_limit,
        lanes=lanes,
        objects=objects,
        signs=[perceived.sign.visible] if perceived.sign.visible is not None else [],
        sensors=[RangeReading(side=side, distance=dist, kind=Source.radar) for side, dist in perceived.ranges.items()],
    )
