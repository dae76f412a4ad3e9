"""Ground truth read off a highway-env road, expressed in the ego's frame.

Everything downstream (perception faults, the planner's observation, Discern's scene, the RSS peer,
the false-veto judge) starts from these tracks, so every consumer agrees on geometry.
The ego frame is the ego lane's frame at the ego: `ahead` along the lane, `right` across it
(highway-env's lateral axis points to the driver's right). On the straight roads of highway-env this is
the ego heading up to the few degrees of a lane change.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from highway_env.vehicle.objects import Obstacle

SENSOR_RANGE_AHEAD = 150.0  # m: radar/camera reach ahead
SENSOR_RANGE_BEHIND = 80.0  # m: reach behind


@dataclass(frozen=True)
class Track:
    """One other road user relative to the ego (bumper geometry from its centre and size)."""

    id: int
    ahead: float  # m, centre to centre along the ego lane
    right: float  # m, centre to centre across it
    v_ahead: float  # ground velocity along the ego lane, m/s
    v_right: float
    lane: int | None  # Discern lane id (1 = leftmost of the ego's road), None off the mapped lanes
    length: float
    width: float
    static: bool = False  # a road obstacle rather than a vehicle


@dataclass(frozen=True)
class LaneInfo:
    id: int  # Discern id, 1 = leftmost
    speed_limit: float | None
    ends_in: float | None  # m ahead where the lane ends while a neighbour goes on


@dataclass(frozen=True)
class EgoTruth:
    speed: float  # forward speed, m/s
    v_right: float
    lane: int  # Discern id of the lane the ego is in
    lateral: float  # m right of the ego lane's centre
    length: float
    width: float
    lane_width: float
    on_merge_lane: bool
    road_position: float  # m along the road (highway-env's roads run along x)


@dataclass(frozen=True)
class Truth:
    time: float
    ego: EgoTruth
    lanes: list[LaneInfo]
    tracks: list[Track] = field(default_factory=list)

    def lane_limit(self, lane_id: int) -> float | None:
        return next((l.speed_limit for l in self.lanes if l.id == lane_id), None)


class VehicleIds:
    """Small ids for the road users of one episode, the simulator's own identity: numbered in the order of the road's
    lists (vehicles, then objects; Discern ids start at 1, 0 is the ego), not in the order they come into sensor range.
    The order they come into range depends on the ego's trajectory, so the planner alone and a shielded variant of one
    episode would give one physical car different ids, and the fault draws keyed by id (perception.py) would miss
    different cars."""

    def __init__(self) -> None:
        self._ids: dict[int, tuple[object, int]] = {}  # id(obj) -> (obj, number); obj held so its id() is not reused

    def number(self, road, ego) -> None:
        """Numbers every road user not numbered yet, in the road's order: at reset all of them, in range or not."""
        for obj in [*road.vehicles, *road.objects]:
            if obj is not ego and id(obj) not in self._ids:
                self._ids[id(obj)] = (obj, len(self._ids) + 1)

    def __call__(self, obj: object) -> int:
        return self._ids[id(obj)][1]


MERGE_EDGES = {("j", "k"), ("k", "b")}


def _lane_ends_in(network, index, longitudinal: float) -> float | None:
    """Distance to the end of a lane that stops while a neighbour continues (a merge lane)."""
    _from, _to, _id = index
    lane = network.get_lane(index)
    following = network.graph.get(_to, {})
    if not following:
        return None  # the whole road ends here: nothing to merge into
    widest = max(len(lanes) for lanes in following.values())
    if _id < widest:
        return None
    return float(max(lane.length - longitudinal, 0.0))


def read_truth(env, ids: VehicleIds) -> Truth:
    """Snapshot of the unwrapped env's road around its controlled vehicle."""
    env = env.unwrapped
    ego = env.vehicle
    network = env.road.network
    lane_index = ego.lane_index
    lane = network.get_lane(lane_index)
    s_ego, l_ego = lane.local_coordinates(ego.position)
    heading = lane.heading_at(s_ego)
    forward = np.array([np.cos(heading), np.sin(heading)])
    rightward = np.array([-np.sin(heading), np.cos(heading)])
    width = float(lane.width_at(s_ego))
    ego_lane_id = lane_index[2] + 1 if (lane_index[0], lane_index[1]) not in MERGE_EDGES else 1
    side = network.all_side_lanes(lane_index)
    lanes = [
        LaneInfo(
            id=i[2] + 1,
            speed_limit=_limit(network.get_lane(i)),
            ends_in=_lane_ends_in(network, i, network.get_lane(i).local_coordinates(ego.position)[0]),
        )
        for i in side
    ]
    if (lane_index[0], lane_index[1]) in MERGE_EDGES:
        # The slip road: it ends at the end of the parallel merge lane (b, c, last).
        rest = lane.length - s_ego
        if lane_index[:2] == ("j", "k"):
            rest += network.get_lane(("k", "b", 0)).length
        merge = network.graph.get("b", {}).get("c", [])
        rest += merge[-1].length if merge else 0.0
        lanes = [LaneInfo(id=1, speed_limit=_limit(lane), ends_in=float(rest))]
    on_merge_lane = (lane_index[0], lane_index[1]) in MERGE_EDGES or any(
        l.ends_in is not None and l.id == ego_lane_id for l in lanes
    )
    lane_ids = {l.id for l in lanes}

    ids.number(env.road, ego)
    tracks = []
    others = [v for v in env.road.vehicles if v is not ego] + list(env.road.objects)
    for other in others:
        s_o, l_o = lane.local_coordinates(other.position)
        ahead = float(s_o - s_ego)
        right = float(l_o - l_ego)
        if not (-SENSOR_RANGE_BEHIND <= ahead <= SENSOR_RANGE_AHEAD) or abs(right) > 4 * width:
            continue
        velocity = np.asarray(getattr(other, "velocity", np.zeros(2)), dtype=float)
        offset = int(round(l_o / width))
        other_lane = ego_lane_id + offset
        tracks.append(
            Track(
                id=ids(other),
                ahead=ahead,
                right=right,
                v_ahead=float(np.dot(velocity, forward)),
                v_right=float(np.dot(velocity, rightward)),
                lane=other_lane if other_lane in lane_ids else None,
                length=float(other.LENGTH),
                width=float(other.WIDTH),
                static=isinstance(other, Obstacle),
            )
        )
    tracks.sort(key=lambda t: np.hypot(t.ahead, t.right))
    ego_velocity = np.asarray(ego.velocity, dtype=float)
    return Truth(
        time=float(env.time),
        ego=EgoTruth(
            speed=max(float(np.dot(ego_velocity, forward)), 0.0),
            v_right=float(np.dot(ego_velocity, rightward)),
            lane=ego_lane_id,
            lateral=float(l_ego),
            length=float(ego.LENGTH),
            width=float(ego.WIDTH),
            lane_width=width,
            on_merge_lane=on_merge_lane,
            road_position=float(ego.position[0]),
        ),
        lanes=lanes,
        tracks=tracks,
    )


def _limit(lane) -> float | None:
    limit = getattr(lane, "speed_limit", None)
    return float(limit) if limit is not None and np.isfinite(limit) else None
