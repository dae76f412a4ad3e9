"""What an audit counts: the disagreements of a log, and the figures around them.

A disagreement is a verdict that did not simply approve the planner: a veto
(shadow mode), an override, or a fail-safe (the monitor could not judge in
time or at all). `Tally` accumulates one file's frames in a worker process
and tallies merge in the parent, so every figure here must be mergeable.

Odometry: a log has no odometer, so distance is integrated from the scenes.
For each vehicle, consecutive frames with 0 < dt <= MAX_GAP_S add
(v0 + v1) / 2 * dt metres (trapezoid rule on ego.speed) and dt seconds of
driving. dt is the difference of the scene timestamps when either frame has
one (> 0: a simulation's clock starts at t = 0), else of the proposals'
arrival times at the monitor. A larger gap or a clock going back (a new
episode, also one that starts again at t = 0) starts a new stretch instead of
being bridged. A frame the monitor refused (out of order, a duplicate) is no
step of the drive: it does not move the odometer, as it did not enter the
monitor's window. Steps are summed in whole millimetres and microseconds, so
that the totals are the same however the frames are split between workers.
"""

from __future__ import annotations

import fnmatch
from array import array
from collections import Counter
from dataclasses import dataclass, field
from enum import Enum
from typing import Iterable, Optional, Sequence

from discern.monitor.log import FileRecovery, RecoveryReport
from discern.monitor.protocol import RULE_BAD_INPUT
from discern.monitor.status import percentile
from discern.rules.scene import Intent, ObjectClass, Scene
from discern.rules.verdict import Decision, Verdict

from .frames import Frame, FrameTask, PairingCounts, plan_tasks, read_frames
from .parallel import run_jobs
from .runs import RunGap, gaps
from .timefmt import iso

MAX_GAP_S = 5.0
# the catalog's vulnerable road users (vulnerable/1; a test holds the two together): a `bike` is a motorbike
# (rules/scene.py OBJECT_CLASSES), a two-wheeler but no vulnerable road user there
VULNERABLE = {ObjectClass.pedestrian, ObjectClass.bicycle, ObjectClass.animal}
STATIC = {ObjectClass.roadblock, ObjectClass.barrier, ObjectClass.traffic_cone, ObjectClass.debris}
MERGING = {Intent.merge_into_left_lane, Intent.merge_into_right_lane}


class Kind(str, Enum):
    veto = "veto"
    override = "override"
    failsafe = "failsafe"


def disagreement_kind(verdict: Verdict) -> Optional[Kind]:
    """veto / override / failsafe, or None for an approval; a fail-safe is one whatever its decision."""
    if verdict.failsafe:
        return Kind.failsafe
    if verdict.decision is Decision.veto:
        return Kind.veto
    if verdict.decision is Decision.override:
        return Kind.override
    return None


def scenario_kind(scene: Optional[Scene]) -> str:
    """'<zone>/<situation>', the situation being the first that applies, most demanding first.

    The log carries no scenario label, so the kind is read off the scene the
    planner sent; docs/audit.md lists the situations.
    """
    if scene is None:
        return "unknown"
    zone = scene.ego.zone.value
    classes = {o.cls for o in scene.objects}
    if scene.intersection is not None:
        situation = f"intersection_{scene.intersection.type.value}"
    elif ObjectClass.emergency_vehicle in classes or any(o.emergency_lights for o in scene.objects):
        situation = "emergency_vehicle"
    elif classes & VULNERABLE:
        situation = "vulnerable_road_user"
    elif classes & STATIC:
        situation = "static_obstacle"
    elif scene.ego.intent in MERGING or any(l.ends_in is not None for l in scene.lanes):
        situation = "merge"
    elif any(l.colour.value != "none" for l in scene.traffic_lights):
        situation = "traffic_light"
    elif any(
        o.lane is not None and o.lane.kind.value == "current" and o.lane.id == scene.ego.lane and o.position.y > 0
        for o in scene.objects
    ):
        situation = "following"
    else:
        situation = "open_road"
    return f"{zone}/{situation}"


@dataclass(frozen=True)
class Filters:
    """Which frames an audit looks at (vehicle, time) and which disagreements it lists (rule, kind).

    Patterns are shell-style (`fleet_a_*`, `lc.*`); empty means all.
    """

    vehicles: tuple[str, ...] = ()
    since_ns: Optional[int] = None
    until_ns: Optional[int] = None
    rules: tuple[str, ...] = ()
    kinds: tuple[Kind, ...] = ()

    def frame_selected(self, frame: Frame) -> bool:
        return self.selects(frame.vehicle, frame.log_time_ns)

    def selects(self, vehicle: Optional[str], log_time_ns: int) -> bool:
        """Whether the vehicle and time filters take a record of this vehicle (None: monitor-wide) and time."""
        if self.vehicles and (vehicle is None or not any(fnmatch.fnmatchcase(vehicle, p) for p in self.vehicles)):
            return False
        if self.since_ns is not None and log_time_ns < self.since_ns:
            return False
        return self.until_ns is None or log_time_ns <= self.until_ns

    def disagreement_selected(self, kind: Kind, rules: Iterable[str]) -> bool:
        if self.kinds and kind not in self.kinds:
            return False
        return not self.rules or any(fnmatch.fnmatchcase(r, p) for r in rules for p in self.rules)

    def describe(self) -> list[str]:
        out = []
        if self.vehicles:
            out.append("vehicle " + " or ".join(self.vehicles))
        if self.since_ns is not None:
            out.append(f"from {iso(self.since_ns)}")
        if self.until_ns is not None:
            out.append(f"until {iso(self.until_ns)}")
        if self.rules:
            out.append("rule " + " or ".join(self.rules))
        if self.kinds:
            out.append("verdict " + " or ".join(k.value for k in self.kinds))
        return out


@dataclass
class Disagreement:
    time_ns: int
    vehicle: str
    file: str
    frame_id: Optional[int]
    scene_time: Optional[float]
    kind: Kind
    proposed: Optional[str]
    executed: str
    recommended: Optional[str]
    rules: list[str]  # every rule the verdict cites
    vetoed_by: Optional[list[str]]  # those that forbade the proposal; None where the log predates vetoed_by
    summary: str
    scenario: str
    latency_ms: Optional[float]
    error: Optional[str]
    verdict_json: str  # the full verdict as logged, justification tree included (kept as text: compact)

    @property
    def pair(self) -> str:
        return f"{self.proposed or '?'} -> {self.executed}"


@dataclass
class Odometer:
    distance_mm: dict[str, int] = field(default_factory=dict)
    driving_us: dict[str, int] = field(default_factory=dict)
    _last: dict[str, tuple[float, float, float]] = field(default_factory=dict)  # scene time, arrival, speed

    def warm(self, vehicle: str, scene_time: float, arrival: float, speed: float) -> None:
        """Start from a frame already counted elsewhere (the previous file's)."""
        self._last[vehicle] = (scene_time, arrival, speed)

    def add(self, vehicle: str, scene_time: float, arrival: float, speed: float) -> None:
        last = self._last.get(vehicle)
        self._last[vehicle] = (scene_time, arrival, speed)
        if last is None:
            return
        dt = scene_time - last[0] if scene_time > 0 or last[0] > 0 else arrival - last[1]
        if 0 < dt <= MAX_GAP_S:
            self.distance_mm[vehicle] = self.distance_mm.get(vehicle, 0) + round((last[2] + speed) / 2 * dt * 1000)
            self.driving_us[vehicle] = self.driving_us.get(vehicle, 0) + round(dt * 1_000_000)

    def merge(self, other: "Odometer") -> None:
        for mine, theirs in ((self.distance_mm, other.distance_mm), (self.driving_us, other.driving_us)):
            for vehicle, value in theirs.items():
                mine[vehicle] = mine.get(vehicle, 0) + value

    def vehicle_km(self, vehicle: str) -> float:
        return self.distance_mm.get(vehicle, 0) / 1_000_000

    @property
    def km(self) -> float:
        return sum(self.distance_mm.values()) / 1_000_000

    @property
    def hours(self) -> float:
        return sum(self.driving_us.values()) / 3_600_000_000


@dataclass
class Tally:
    frames: int = 0
    decisions: Counter = field(default_factory=Counter)  # approve / veto / override / failsafe
    vehicle_frames: Counter = field(default_factory=Counter)
    scenario_frames: Counter = field(default_factory=Counter)
    disagreements: list[Disagreement] = field(default_factory=list)
    latencies_ms: array = field(default_factory=lambda: array("d"))
    odometer: Odometer = field(default_factory=Odometer)
    first_ns: Optional[int] = None
    last_ns: Optional[int] = None
    counts: PairingCounts = field(default_factory=PairingCounts)
    recovery: list[FileRecovery] = field(default_factory=list)
    gaps: list[RunGap] = field(default_factory=list)  # the runs the files leave incomplete, once all are merged

    def add(self, frame: Frame, filters: Filters) -> None:
        if not filters.frame_selected(frame):
            return
        verdict = frame.verdict
        scene = frame.proposal.scene if frame.proposal is not None else None
        driven = scene is not None and RULE_BAD_INPUT not in verdict.rules  # a refused frame is no step
        if frame.lead_in:  # the earlier files' last frames start this task's odometry
            if driven:
                self.odometer.warm(frame.vehicle, scene.timestamp, frame.arrived_ns / 1e9, scene.ego.speed)
            return
        kind = disagreement_kind(verdict)
        scenario = scenario_kind(scene)
        self.frames += 1
        self.decisions[kind.value if kind else "approve"] += 1
        self.vehicle_frames[frame.vehicle] += 1
        self.scenario_frames[scenario] += 1
        t = frame.log_time_ns
        self.first_ns = t if self.first_ns is None else min(self.first_ns, t)
        self.last_ns = t if self.last_ns is None else max(self.last_ns, t)
        if verdict.latency_ms is not None:
            self.latencies_ms.append(verdict.latency_ms)
        if driven:
            self.odometer.add(frame.vehicle, scene.timestamp, frame.arrived_ns / 1e9, scene.ego.speed)
        if kind is not None and filters.disagreement_selected(kind, verdict.rules):
            self.disagreements.append(
                Disagreement(
                    time_ns=t,
                    vehicle=frame.vehicle,
                    file=frame.file,
                    frame_id=verdict.frame_id,
                    # a fail-safe at the deadline answers before the scene is read: its proposal has the time
                    scene_time=(
                        verdict.timestamp if verdict.timestamp is not None or scene is None else scene.timestamp
                    ),
                    kind=kind,
                    # a fail-safe sent before its payload was read names what a glance found: refused, it proposed nothing
                    proposed=verdict.proposed.value if verdict.proposed and (scene or not verdict.failsafe) else None,
                    executed=verdict.action.value,
                    recommended=verdict.recommended.value if verdict.recommended else None,
                    rules=list(verdict.rules),
                    vetoed_by=list(verdict.vetoed_by) if "vetoed_by" in verdict.model_fields_set else None,
                    summary=verdict.justification.summary,
                    scenario=scenario,
                    latency_ms=verdict.latency_ms,
                    error=verdict.error,
                    verdict_json=verdict.model_dump_json(),
                )
            )

    def merge(self, other: "Tally") -> None:
        self.frames += other.frames
        self.decisions.update(other.decisions)
        self.vehicle_frames.update(other.vehicle_frames)
        self.scenario_frames.update(other.scenario_frames)
        self.disagreements.extend(other.disagreements)
        self.latencies_ms.extend(other.latencies_ms)
        self.odometer.merge(other.odometer)
        for t in (other.first_ns, other.last_ns):
            if t is not None:
                self.first_ns = t if self.first_ns is None else min(self.first_ns, t)
                self.last_ns = t if self.last_ns is None else max(self.last_ns, t)
        self.counts.merge(other.counts)
        self.recovery.extend(other.recovery)

    def finish(self) -> "Tally":
        self.disagreements.sort(key=lambda d: (d.time_ns, d.vehicle))
        return self

    @property
    def unanswered(self) -> int:
        return max(0, self.counts.unanswered - self.counts.carried)


@dataclass
class Aggregates:
    """The figures of the report, computed once from a finished tally.

    Per rule, a disagreement counts for the rules that forbade its proposal (`vetoed_by`), not for every rule
    it cites: a sanity note or a rule a proof used forbade nothing, and counted with the rest it led the table
    for vetoes others made. Those are counted apart, as also cited. A verdict logged before `vetoed_by` was
    (2026-11-27) says not which of its rules forbade: it counts for every rule it cites, as `unattributed`.
    """

    per_rule: list[tuple[str, int, int]]  # rule, disagreements it forbade, those citing it without forbidding
    unattributed: int  # disagreements logged without vetoed_by, counted for every rule they cite
    per_pair: list[tuple[str, int]]
    per_scenario: list[tuple[str, int, int]]  # kind, disagreements, frames
    # vehicle, disagreements, frames, km, refused inputs; also a key that names no vehicle (@invalid), refused only
    per_vehicle: list[tuple[str, int, int, float, int]]
    per_kind: dict[str, int]
    over_time: list[tuple[int, int, dict[str, int]]]  # bucket start ns, bucket width ns, count per kind
    km: float
    hours: float
    per_hour: Optional[float]
    per_km: Optional[float]
    latency: dict[str, Optional[float]]

    @classmethod
    def of(cls, tally: Tally, buckets: int = 48) -> "Aggregates":
        rows = tally.disagreements
        forbade: Counter = Counter()
        cited: Counter = Counter()
        for d in rows:
            vetoed_by = set(d.rules if d.vetoed_by is None else d.vetoed_by)
            forbade.update(vetoed_by)
            cited.update(set(d.rules) - vetoed_by)
        per_scenario = Counter(d.scenario for d in rows)
        per_vehicle = Counter(d.vehicle for d in rows)
        refused = tally.counts.refused_by_vehicle
        odo = tally.odometer
        n = len(rows)
        return cls(
            per_rule=sorted(((r, forbade[r], cited[r]) for r in forbade | cited), key=lambda r: (-r[1], -r[2], r[0])),
            unattributed=sum(d.vetoed_by is None for d in rows),
            per_pair=Counter(d.pair for d in rows).most_common(),
            per_scenario=sorted(
                ((k, per_scenario[k], f) for k, f in tally.scenario_frames.items()), key=lambda r: (-r[1], -r[2], r[0])
            ),
            per_vehicle=sorted(
                (
                    (v, per_vehicle[v], tally.vehicle_frames[v], odo.vehicle_km(v), refused[v])
                    for v in tally.vehicle_frames.keys() | refused.keys()
                ),
                key=lambda r: (-r[1], r[0]),
            ),
            per_kind={k.value: sum(1 for d in rows if d.kind is k) for k in Kind},
            over_time=_over_time(rows, tally.first_ns, tally.last_ns, buckets),
            km=odo.km,
            hours=odo.hours,
            per_hour=n / odo.hours if odo.hours > 0 else None,
            per_km=n / odo.km if odo.km > 0 else None,
            latency=latency_summary(tally.latencies_ms),
        )


def latency_summary(values: Sequence[float]) -> dict[str, Optional[float]]:
    if not values:
        return {"samples": 0, "p50_ms": None, "p90_ms": None, "p99_ms": None, "max_ms": None}
    ordered = sorted(values)
    return {
        "samples": len(ordered),
        "p50_ms": percentile(ordered, 50),
        "p90_ms": percentile(ordered, 90),
        "p99_ms": percentile(ordered, 99),
        "max_ms": ordered[-1],
    }


NICE_WIDTHS_S = (1, 2, 5, 10, 15, 30, 60, 120, 300, 600, 900, 1800, 3600, 7200, 21600, 43200, 86400)


def bucket_width_ns(span_ns: int, buckets: int) -> int:
    """The smallest round width (1 s ... 1 day, then whole days) that covers the span in `buckets` bars."""
    need = span_ns / max(1, buckets) / 1e9
    for width in NICE_WIDTHS_S:
        if width >= need:
            return width * 1_000_000_000
    return int(-(-need // 86400)) * 86400 * 1_000_000_000


def _over_time(rows: list[Disagreement], first: Optional[int], last: Optional[int], buckets: int):
    if first is None or last is None:
        return []
    width = bucket_width_ns(last - first, buckets)
    start = first - first % width
    out = []
    for i in range((last - start) // width + 1):
        out.append((start + i * width, width, {k.value: 0 for k in Kind}))
    for d in rows:
        out[(d.time_ns - start) // width][2][d.kind.value] += 1
    return out


def tally_task(job: tuple[FrameTask, Filters]) -> Tally:
    """One task's tally (runs in a worker process)."""
    task, filters = job
    report = RecoveryReport()
    frames, pairing = read_frames(task, report, counted=filters.selects)
    tally = Tally()
    for frame in frames:
        tally.add(frame, filters)
    tally.counts = pairing.counts
    tally.recovery = report.files
    return tally


def audit_logs(paths: list[str], filters: Optional[Filters] = None, workers: int = 1) -> Tally:
    """The merged tally of every file, read in runs of consecutive files, one job each."""
    filters = filters if filters is not None else Filters()
    total = Tally()
    jobs = [(task, filters) for task in plan_tasks(paths, parts=max(1, workers))]
    for tally in run_jobs(tally_task, jobs, workers):
        total.merge(tally)
    total.gaps = gaps(paths, total.counts.last_status)
    return total.finish()
