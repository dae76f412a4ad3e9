"""Perception between ground truth and the facts, with injectable faults.

The camera and the radar see the tracks of `truth`; faults are injected per frame:
- noisy distances (Gaussian, growing with range),
- missed camera detections: the camera loses a vehicle for `miss_frames` frames while the radar keeps
  it (the object reaches Discern with sources=[radar] only; with `miss_drop_track` it vanishes from the
  object list and only the range sensor's reading betrays it),
- phantom camera objects that no radar confirms,
- misread speed-limit signs (see signs.py).
The planner drives on the camera's tracks; Discern gets the fused object list and the range readings.
Every random draw is keyed by (seed, episode, frame, vehicle), the vehicle by the simulator's own identity
(truth.VehicleIds: its place on the road's list), so the variants of one episode meet the same faults on the same
cars wherever those cars are in range in both.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from discern.rules.scene import SensorSide, Source

from .signs import SignLayer, SignReading
from .truth import Track, Truth

FAULT_KINDS = ("noise", "missed", "dropped", "phantoms", "signs")
ALL_FAULTS = ("noise", "missed", "phantoms", "signs")  # 'all': "dropped" is "missed" gone from Discern's list too
# What --faults gives a named fault when no flag sets its rate (and the value a misread sign reads).
DEFAULT_RATES = {"noise": 1.0, "miss_rate": 0.05, "phantom_rate": 0.1, "sign_rate": 0.5, "sign_value": 80.0}
RANGE_FRONT = 150.0  # m: long-range radar
RANGE_REAR = 80.0
RANGE_SIDE = 40.0  # m: corner radars


@dataclass(frozen=True)
class Faults:
    """Fault rates; all zero is a perfect perception."""

    noise: float = 0.0  # m: distance noise std is noise * (0.2 + range / 50 m): 1.2x noise at 50 m
    miss_rate: float = 0.0  # per vehicle and frame: chance the camera starts losing it
    miss_frames: int = 3
    miss_drop_track: bool = False  # missed vehicles vanish from the object list (range readings only)
    phantom_rate: float = 0.0  # per frame: chance a phantom camera object appears
    phantom_frames: int = 2
    sign_rate: float = 0.0  # per sign: chance it is misread
    sign_value: float = 80.0  # m/s read off a perturbed sign
    seed: int = 0
    # the kinds in the order --faults named them, for the label: `signs,missed` reads as the user wrote it
    order: tuple[str, ...] = ()

    @classmethod
    def preset(cls, kinds: str | list[str], seed: int = 0, **rates) -> "Faults":
        """Faults from names ('none', 'all' or a comma list of noise, missed, dropped, phantoms, signs)."""
        parts = [k.strip() for k in (kinds.split(",") if isinstance(kinds, str) else kinds)]
        names = [k for k in parts if k]
        if not names:
            raise ValueError(f"fault set {kinds!r} names no fault kind: give 'none' for a run without faults")
        if len(names) < len(parts):  # "signs," then "missed": the shell split "signs, missed" in two sets
            raise ValueError(f"fault set {kinds!r} has an empty kind: write a set without spaces or stray commas "
                             "(signs,missed), since a space starts the next set")
        if len(names) > 1 and {"none", "all"} & set(names):
            raise ValueError(f"fault set {','.join(names)!r}: 'none' and 'all' stand alone, not with other kinds")
        if names == ["all"]:
            names = list(ALL_FAULTS)
        if names == ["none"]:
            names = []
        unknown = sorted(set(names) - set(FAULT_KINDS))
        if unknown:
            raise ValueError(f"unknown fault kind(s) {', '.join(unknown)}: choose from none, all, {', '.join(FAULT_KINDS)}")
        if {"missed", "dropped"} <= set(names):
            raise ValueError(f"fault set {','.join(names)!r}: 'dropped' is 'missed' with the object gone from the list "
                             "Discern gets too: name one of them")
        defaults = dict(DEFAULT_RATES)
        defaults.update({k: v for k, v in rates.items() if v is not None})
        return cls(
            noise=defaults["noise"] if "noise" in names else 0.0,
            miss_rate=defaults["miss_rate"] if {"missed", "dropped"} & set(names) else 0.0,
            miss_drop_track="dropped" in names,
            phantom_rate=defaults["phantom_rate"] if "phantoms" in names else 0.0,
            sign_rate=defaults["sign_rate"] if "signs" in names else 0.0,
            sign_value=defaults["sign_value"],
            seed=seed,
            order=tuple(names),
        )

    def kinds(self) -> dict[str, tuple[str, float]]:
        """The injected fault kinds, each with the name of its rate and the rate."""
        return {
            name: (key, rate)
            for name, on, key, rate in (
                ("noise", self.noise > 0, "noise", self.noise),
                ("missed", self.miss_rate > 0 and not self.miss_drop_track, "miss_rate", self.miss_rate),
                ("dropped", self.miss_rate > 0 and self.miss_drop_track, "miss_rate", self.miss_rate),
                ("phantoms", self.phantom_rate > 0, "phantom_rate", self.phantom_rate),
                ("signs", self.sign_rate > 0, "sign_rate", self.sign_rate),
            )
            if on
        }

    def label(self) -> str:
        """The injected kinds in the order named, each with its rate where that is not DEFAULT_RATES' ('missed@0.9',
        'signs@0.5:60' for signs misread as 60 m/s): rows run at other rates must not read as the default's."""
        labels = []
        kinds = self.kinds()
        for name in sorted(kinds, key=lambda k: self.order.index(k) if k in self.order else len(self.order)):
            key, rate = kinds[name]
            value = name == "signs" and self.sign_value != DEFAULT_RATES["sign_value"]
            labels.append(name + (f"@{rate:g}" if value or rate != DEFAULT_RATES[key] else "")
                          + (f":{self.sign_value:g}" if value else ""))
        return ",".join(labels) or "none"


@dataclass(frozen=True)
class Detection:
    track: Track
    sources: tuple[Source, ...]
    phantom: bool = False

    @property
    def camera(self) -> bool:
        return Source.camera in self.sources


@dataclass(frozen=True)
class Perceived:
    """One frame as the vehicle's sensors report it."""

    frame: int
    truth: Truth
    detections: list[Detection]
    ranges: dict[SensorSide, float]
    sign: SignReading
    missed: list[int] = field(default_factory=list)  # ids the camera lost this frame (for the record)

    def camera_tracks(self) -> list[Track]:
        """What a camera-driven planner sees."""
        return [d.track for d in self.detections if d.camera]


def _draw(*key: int) -> np.random.Generator:
    return np.random.default_rng([abs(int(k)) for k in key])


class Perception:
    def __init__(self, faults: Faults | None = None, signs: SignLayer | None = None):
        self.faults = faults or Faults()
        self.signs = signs or SignLayer(
            misread_rate=self.faults.sign_rate, misread_value=self.faults.sign_value, seed=self.faults.seed
        )
        self.episode = 0
        self.frame = 0

    def reset(self, episode_seed: int, truth: Truth) -> Perceived:
        self.episode = int(episode_seed)
        self.frame = 0
        self.signs.reset(self.episode, truth.lane_limit(truth.ego.lane))
        return self.perceive(truth)

    def step(self, truth: Truth) -> Perceived:
        self.frame += 1
        return self.perceive(truth)

    def _missed(self, track_id: int) -> bool:
        f = self.faults
        if f.miss_rate <= 0.0 or self.frame == 0:
            return False
        return any(
            _draw(f.seed, self.episode, 1, track_id, self.frame - back).random() < f.miss_rate
            for back in range(f.miss_frames)
            if self.frame - back > 0
        )

    def _noisy(self, track: Track) -> Track:
        if self.faults.noise <= 0.0:
            return track
        rng = _draw(self.faults.seed, self.episode, 3, track.id, self.frame)
        scale = self.faults.noise * (0.2 + abs(track.ahead) / 50.0)
        return replace(track, ahead=track.ahead + rng.normal(0.0, scale), right=track.right + rng.normal(0.0, scale / 5))

    def _phantoms(self, truth: Truth) -> list[Detection]:
        f = self.faults
        if f.phantom_rate <= 0.0:
            return []
        lane_ids = [l.id for l in truth.lanes]
        found = []
        for age in range(f.phantom_frames):
            start = self.frame - age
            if start < 1:
                continue
            rng = _draw(f.seed, self.episode, 2, start)
            if rng.random() >= f.phantom_rate:
                continue
            lane = int(rng.choice(lane_ids))
            ahead = float(rng.uniform(12.0, 50.0))
            closing = float(rng.uniform(0.0, 8.0))
            found.append(
                Detection(
                    track=Track(
                        id=10_000 + start,
                        ahead=ahead - closing * age,
                        right=(lane - truth.ego.lane) * truth.ego.lane_width - truth.ego.lateral,
                        v_ahead=max(truth.ego.speed - closing, 0.0),
                        v_right=0.0,
                        lane=lane,
                        length=5.0,
                        width=2.0,
                    ),
                    sources=(Source.camera,),
                    phantom=True,
                )
            )
        return found

    def perceive(self, truth: Truth) -> Perceived:
        detections, missed = [], []
        for track in truth.tracks:
            seen = self._noisy(track)
            if self._missed(track.id):
                missed.append(track.id)
                if not self.faults.miss_drop_track:
                    detections.append(Detection(track=seen, sources=(Source.radar,)))
            else:
                detections.append(Detection(track=seen, sources=(Source.camera, Source.radar)))
        detections.extend(self._phantoms(truth))
        return Perceived(
            frame=self.frame,
            truth=truth,
            detections=detections,
            ranges=self._ranges(truth),
            sign=self._sign(truth),
            missed=missed,
        )

    def _sign(self, truth: Truth) -> SignReading:
        ego = truth.ego
        lanes_right = max((l.id for l in truth.lanes), default=ego.lane) - ego.lane  # lane 1 is the leftmost
        right_edge = (lanes_right + 0.5) * ego.lane_width - ego.lateral
        return self.signs.read(ego.road_position, truth.lane_limit(ego.lane), right_edge, ego.length / 2)

    def _ranges(self, truth: Truth) -> dict[SensorSide, float]:
        """Nearest return per side from the range sensors (real objects only; phantoms have no echo)."""
        ego = truth.ego
        half_lane = ego.lane_width / 2.0
        readings: dict[SensorSide, float] = {}
        for track in truth.tracks:
            long_gap = abs(track.ahead) - (track.length + ego.length) / 2.0
            lat_gap = abs(track.right) - (track.width + ego.width) / 2.0
            if abs(track.right) < half_lane:
                side = SensorSide.front if track.ahead > 0 else SensorSide.rear
                distance, reach = long_gap, RANGE_FRONT if track.ahead > 0 else RANGE_REAR
            elif abs(track.right) < 3.0 * half_lane:
                left = track.right < 0
                if long_gap <= 0:
                    side = SensorSide.left if left else SensorSide.right
                    distance = lat_gap
                elif track.ahead > 0:
                    side = SensorSide.front_left if left else SensorSide.front_right
                    distance = float(np.hypot(long_gap, max(lat_gap, 0.0)))
                else:
                    side = SensorSide.rear_left if left else SensorSide.rear_right
                    distance = float(np.hypot(long_gap, max(lat_gap, 0.0)))
                reach = RANGE_SIDE
            else:
                continue
            distance = max(distance, 0.0)
            if self.faults.noise > 0.0:
                rng = _draw(self.faults.seed, self.episode, 4, track.id, self.frame)
                distance = max(distance + rng.normal(0.0, 0.1 * self.faults.noise), 0.0)
            if distance <= reach and distance < readings.get(side, np.inf):
                readings[side] = round(distance, 2)
        return readings
