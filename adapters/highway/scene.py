"""Perceived highway-env frame -> Discern Scene (the one schema; see discern.rules.scene).

Object positions are reported as a range sensor measures them: `y` runs from the ego's nearest
bumper to the object's nearest face (ego front to the rear of a car ahead, ego rear to the front of a
car behind, 0 while they overlap alongside), `x` is the centre-to-centre offset across the lane.
The catalog compares `y` with gaps, and a gap is free road between bumpers: centre-to-centre
distances would hand it 5 m (one car length) that is not there.
"""

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
    RangeSensor,
    Scene,
    Size,
    Vec2,
    Velocity,
    Zone,
)

from .perception import Perceived
from .truth import Track


def _r(value: float) -> float:
    return round(float(value), 3)


def _ahead(track: Track, ego_length: float) -> float:
    """Signed bumper-to-bumper distance along the lane."""
    gap = max(abs(track.ahead) - (track.length + ego_length) / 2.0, 0.0)
    return gap if track.ahead >= 0 else -gap


def build_scene(
    perceived: Perceived, previous_speed: float | None = None, period: float = 1.0, frame_id: int | None = None
) -> Scene:
    """`frame_id` overrides the perception's per-episode frame number (a monitor wants ids that only rise)."""
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
                position=Vec2(x=_r(t.right), y=_r(_ahead(t, ego.length))),
                lane=LaneRef(kind=LaneKind.current, id=t.lane) if t.lane is not None else None,
                velocity=Velocity(x=_r(t.v_right), y=_r(t.v_ahead)),
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
        frame_id=perceived.frame if frame_id is None else frame_id,
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
        sensors=[RangeReading(side=side, distance=dist, kind=RangeSensor.radar) for side, dist in perceived.ranges.items()],
    )
