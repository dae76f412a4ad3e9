"""The temporal window: facts that need more than the current frame.

The monitor passes the vehicle's recent scenes (oldest first) as `history`;
this provider keeps those within `WindowConfig.seconds` of the current frame
and turns them into facts the sanity rules reason over (sanity/catalog):
how long a limit has been read, lights going on and off, objects the camera
lost, and where tracked objects are heading. It also adds the few
current-frame facts clingo is poor at computing (sizes, outlines, courses).

Everything here is arithmetic on a few dozen objects; the decisions are made
in the rules, where they are justified.
"""

from __future__ import annotations

import math
import statistics
import weakref
from dataclasses import dataclass
from functools import lru_cache
from typing import Iterable, NamedTuple, Optional, Sequence

from clingo import Symbol, SymbolType

from discern.rules.facts import Params, cm, lamp
from discern.rules.scene import (MAX_ID, DetectedObject, IntersectionStage, IntersectionType, LaneKind, LightColour,
                                 ObjectClass, Scene, SensorSide, SignKind, Size, Source)

CONFIRMING = {Source.radar, Source.lidar, Source.ultrasonic, Source.fused, Source.annotation}
PICTURE = {Source.camera, Source.fused}  # sources that classify signs from a picture (def.read_from_a_picture)
EGO_LENGTH, EGO_WIDTH = 4.6, 2.0
CROSSING = frozenset({LaneKind.cross_left, LaneKind.cross_right})
# Typical width per class when the detector gives no size; the lengths are the catalog's (ent.typical_length), and
# for the classes it gives none, these.
WIDTH = {ObjectClass.car: 1.8, ObjectClass.truck: 2.5, ObjectClass.bus: 2.5, ObjectClass.emergency_vehicle: 2.2,
         ObjectClass.motorcycle: 0.8, ObjectClass.bike: 0.8, ObjectClass.bicycle: 0.6, ObjectClass.pedestrian: 0.6,
         ObjectClass.animal: 0.6}
LENGTH = {ObjectClass.pedestrian: 0.6, ObjectClass.animal: 1.5}
DEFAULT_SIZE = 1.0  # m, length and width of a thing of a class neither gives
FLASH_MIN_PHASE_S = 0.25  # s: the shortest on or off phase of a flashing signal (about 0.3 s at 60 a minute)
FLASH_MAX_PHASE_S = 1.0  # s: the longest (0.8 s lit at 50 a minute), with a frame of slack
LINE_EVIDENCE = "a_stop_line_and_no_traffic_lights"
STAGES = list(IntersectionStage)  # in the order the ego goes through them
APPROACH_SLACK = 2.0  # m the distance to the stop line may grow, as perception wavers, on the same approach
# How far an object may be from where its course put it and still be the object its id named (`_same_object`): a
# detector's ranging errs by a metre or two, and by some 10 % of the range for a camera's depth; a hard brake or
# swerve adds 8 m/s^2; an object of unknown speed may move at any speed a road user does.
REUSE_GATE_M = 2.0
REUSE_GATE_SHARE = 0.15
REUSE_ACCEL = 8.0  # m/s^2
REUSE_ANY_SPEED = 30.0  # m/s


@dataclass(frozen=True)
class WindowConfig:
    """How much history the sanity layer uses, and how much it asks of it."""

    seconds: float = 2.0  # frames older than this are out of the window
    max_frames: int = 40  # frames without timestamps, whose age cannot be told: at most this many, and no more than fill `seconds`
    confirm_frames: int = 2  # frames in a row a reading needs before it is believed
    confirm_s: float = 0.2  # and for how long: at 50 Hz two frames are 40 ms, a flicker
    track_frames: int = 2  # frames a lost object must have been tracked to be kept
    track_s: float = 0.3  # and for how long: at 5 Hz two frames are 0.4 s, at 50 Hz three are a 60 ms ghost
    untimed_frame_s: float = 0.1  # how long a frame without timestamps is taken to last (10 Hz, as KITTI's)
    horizon_s: float = 3.0  # how far ahead tracked courses are followed
    sensor_margin: float = 2.0  # m a range reading may exceed a lost object's distance and still be it
    # A flashing signal runs at about 1 Hz (MUTCD 4D.19: 50-60 flashes a minute, lit for 1/2 to 2/3 of each):
    # each phase lasts some 0.3-0.8 s. A dark gap shorter than this is a dropped frame or LED flicker, not a
    # flash; a phase longer than the most is a steady light.
    flash_min_phase_s: float = FLASH_MIN_PHASE_S
    flash_max_phase_s: float = FLASH_MAX_PHASE_S

    def __post_init__(self) -> None:
        if not self.seconds > 0 or self.max_frames < 1 or self.confirm_frames < 1 or self.track_frames < 1:
            raise ValueError(
                "window needs seconds > 0, max_frames >= 1, confirm_frames >= 1 and track_frames >= 1, "
                f"got {self}"
            )
        if self.confirm_s < 0 or self.track_s < 0 or not self.untimed_frame_s > 0:
            raise ValueError(
                "window needs confirm_s >= 0, track_s >= 0 and untimed_frame_s > 0, "
                f"got {self.confirm_s}, {self.track_s} and {self.untimed_frame_s}"
            )
        if not self.horizon_s > 0:
            raise ValueError(f"window horizon_s must be > 0, got {self.horizon_s}")
        if not 0 < self.flash_min_phase_s <= self.flash_max_phase_s:
            raise ValueError(
                "window needs 0 < flash_min_phase_s <= flash_max_phase_s, "
                f"got {self.flash_min_phase_s} and {self.flash_max_phase_s}"
            )


@dataclass(frozen=True)
class _Summary:
    """What the window facts read of one frame, worked out once: a frame sits in many later windows."""

    readings: frozenset[int]
    primary: Optional[int]
    misread: tuple[tuple[int, str], ...]  # limits read from a picture where a stop sign belonged, with the evidence
    perceived: Optional[int]  # the perceived limit (the scene's speed_limit)
    stop_evidence: tuple[str, ...]  # what showed a stop sign belonged at the approach, where none was read as one
    on_vehicles: frozenset[int]  # limits read off signs inside a motor vehicle's outline (a sticker, an advert)
    beside_exits: frozenset[int]  # limits read only off signs beside a lane that leaves the road (an exit's own)
    # lit lamps by the rules' name for them (rules.facts.lamp): a ball's colour, or an arrow's, `red_left_arrow`
    lights: frozenset[str]
    flashing: frozenset[str]
    steady: frozenset[str]  # lamps some light of which is not flagged flashing
    # where a light is listed unlit (colour "none"): None for a ball, else the arrow's direction. A lamp not listed
    # at all is out of view, not dark: a truck passing in front of a steady yellow makes no dark phase
    unlit: frozenset[Optional[str]]
    stop_sign: bool
    school_sign: bool
    dark: bool  # traffic lights in view, none of them lit
    speed: int  # the ego's, cm/s
    at_line: bool  # the ego at an intersection's stop line (stage "at")
    objects: dict[int, DetectedObject]  # by id
    ids: frozenset[int]
    confirmed: tuple[tuple[int, frozenset[Source]], ...]  # objects a range sensor saw, with those sensors
    lit: tuple[int, ...]  # objects showing emergency lights

    @classmethod
    def of(cls, scene: Scene, bodies: "Bodies") -> "_Summary":
        confirming = [(o.id, frozenset(CONFIRMING.intersection(o.sources))) for o in scene.objects]
        return cls(
            readings=frozenset(_readings(scene)),
            primary=_primary(scene),
            misread=_misread(scene),
            perceived=cm(scene.speed_limit) if scene.speed_limit is not None else None,
            stop_evidence=_stop_evidence(scene),
            on_vehicles=frozenset(value for value, _, cls in _signs_within(scene, bodies) if cls in bodies.motor),
            beside_exits=frozenset(value for value, _ in _signs_beside_exits(scene, bodies.half_lane)),
            # a lamp of colour "none" (unlit, glare, unreadable) shows no colour: it is no light seen, and does not
            # make a red seen before any less the last colour seen (the core gives it no fact either)
            lights=frozenset(lamp(l) for l in scene.traffic_lights if l.colour is not LightColour.none),
            flashing=frozenset(lamp(l) for l in scene.traffic_lights if l.flashing and l.colour is not LightColour.none),
            steady=frozenset(lamp(l) for l in scene.traffic_lights if not l.flashing and l.colour is not LightColour.none),
            unlit=frozenset(l.direction and l.direction.value for l in scene.traffic_lights
                            if l.colour is LightColour.none),
            stop_sign=any(s.kind is SignKind.stop for s in scene.signs),
            school_sign=any(s.kind is SignKind.school_zone for s in scene.signs),
            dark=_dark(scene),
            speed=cm(scene.ego.speed),
            at_line=scene.intersection is not None and scene.intersection.stage is IntersectionStage.at,
            objects={o.id: o for o in scene.objects},
            ids=frozenset(o.id for o in scene.objects),
            confirmed=tuple((oid, sources) for oid, sources in confirming if sources),
            lit=tuple(o.id for o in scene.objects if o.emergency_lights),
        )


@dataclass(frozen=True)
class Bodies:
    """How the catalog moves and sizes an object the detector says little of, read from the catalog itself, so that
    the window's predicted courses and the rules agree: an object of unknown speed ahead keeps pace with the ego if
    it is a motor vehicle (def.motor_vehicle) outside a crossing lane, and else stands; behind, one that cannot move
    by itself (def.stands_by_nature) stands and the rest keep pace; lengths are ent.typical_length's. Half the
    lane width (the parameter lane_width) tells a position ahead from one beside."""

    motor: frozenset[ObjectClass]
    stands: frozenset[ObjectClass]
    lengths: dict[ObjectClass, float]
    half_lane: float

    @classmethod
    def of(cls, static_atoms: Iterable[Symbol], lane_width: float) -> "Bodies":
        """From the atoms of what no frame changes (the catalog's static model)."""
        known = {c.value for c in ObjectClass}
        by_name: dict[str, list[Symbol]] = {}
        for atom in static_atoms:
            if atom.arguments and atom.arguments[0].type == SymbolType.Function and atom.arguments[0].name in known:
                by_name.setdefault(atom.name, []).append(atom)
        classes = {name: frozenset(ObjectClass(a.arguments[0].name) for a in by_name.get(name, []))
                   for name in ("motor_vehicle", "stands_by_nature")}
        lengths = {ObjectClass(a.arguments[0].name): a.arguments[1].number / 100 for a in by_name.get("typical_length", [])}
        return cls(classes["motor_vehicle"], classes["stands_by_nature"], {**LENGTH, **lengths}, lane_width / 2)

    @staticmethod
    @lru_cache(maxsize=1)
    def shipped() -> "Bodies":
        """The shipped catalog's, with the default parameters: for a provider no Reasoner has bound."""
        from discern.rules.engine import Reasoner

        reasoner = Reasoner()
        return Bodies.of(reasoner.slicer.static_atoms, reasoner.params.lane_width)

    def footprint(self, obj: DetectedObject) -> tuple[float, float]:
        size = _measured_size(obj)
        if size is not None:
            return size.length, size.width
        return self.lengths.get(obj.cls, DEFAULT_SIZE), WIDTH.get(obj.cls, DEFAULT_SIZE)


def _measured_size(obj: DetectedObject) -> Optional[Size]:
    """The size perception gives, or None where it gives none or a length or width of 0: a detector may give 0 for a
    size it does not know, and taken as measured it would make a camera-only car a toy (san.world.size) and a crossing
    car's body a point (def.crossing_body_ahead)."""
    size = obj.size
    return size if size is not None and size.length > 0 and size.width > 0 else None


# The predicates `WindowProvider.facts` gives, and the names of its window_param/2 (a test checks both on every
# scenario file): what the catalog loader and the proofs take frames to give besides the scene's
# (rules.facts.SCENE_PREDICATES), told by the provider (rules.facts.FactProvider).
WINDOW_PREDICATES = frozenset({
    ("signal_dark", 0), ("window_frames", 1), ("window_param", 2), ("light_seen_on_approach", 0),
    ("slowest_recent_speed", 1), ("slowest_at_line", 1), ("reading_seen", 3), ("reading_span", 2), ("reading_run", 2),
    ("reading_time", 2), ("misread_before", 2), ("sign_on_vehicle_before", 1), ("sign_within", 2),
    ("sign_beside_exit", 2), ("sign_beside_exit_before", 1),
    ("sign_confidence", 2), ("remembered_limit", 1), ("prior_limit", 1), ("prior_run", 2), ("prior_time", 2),
    ("light_flashing_frames", 2), ("light_flashing_time", 2), ("light_lit_time", 2), ("light_flashes", 1),
    ("light_seen_recently", 1),
    ("sign_seen_recently", 1), ("school_sign_run", 1), ("school_sign_time", 1), ("obj_size", 3), ("overlaps", 2),
    ("predicted_conflict", 3), ("obj_source_before", 2), ("remembered", 2), ("remembered_object", 2),
    ("remembered_pos", 3), ("last_seen_ahead", 2), ("track_frames", 2), ("track_time", 2), ("remembered_lane", 3),
    ("remembered_velocity", 3), ("remembered_source", 2), ("sensor_still_reads", 4), ("sensor_reads_past", 4),
    ("reported_before", 2), ("ran_beside", 2), ("remembered_conflict", 3), ("lights_frames", 2), ("lights_time", 2),
    ("crept_at_line", 1), ("id_reused", 2), ("stepped_conflict", 3), ("remembered_stepped_conflict", 3),
})
WINDOW_PARAMS = frozenset({"confirm_frames", "track_frames", "confirm_ms", "track_ms", "window_ms", "flash_max_ms"})


class WindowProvider:
    """FactProvider for the sanity rules (see discern.rules.facts.FactProvider)."""

    predicates = WINDOW_PREDICATES
    params = WINDOW_PARAMS

    def __init__(self, config: WindowConfig = WindowConfig()):
        self.config = config
        self.bodies: Optional[Bodies] = None  # the catalog's, set by its Reasoner (bind); else the shipped one's
        # the speed (m/s) one accelerate adds before the next decision: speeding up is judged on the course it gives
        self.accel_step: float = Params().accel_step
        # by id() of a live scene: a frame is read again by every later window it sits in
        self._summaries: dict[int, _Summary] = {}
        self._jumped: dict[tuple[int, int, int], frozenset[int]] = {}  # _jumps, by the two frames and their interval

    def bind(self, static_atoms: Sequence[Symbol], params) -> None:
        """Called by the Reasoner it feeds: its catalog's and parameters' idea of objects (Bodies)."""
        self.bodies = Bodies.of(static_atoms, params.lane_width)
        self.accel_step = params.accel_step

    def facts(self, scene: Scene, history: Sequence[Scene]) -> str:
        if self.bodies is None:
            self.bodies = Bodies.shipped()
        bodies = self.bodies
        out: list[str] = []
        out.extend(_world_facts(scene, bodies))
        out.extend(_predicted_conflicts(scene, self.config.horizon_s, bodies, self.accel_step))
        window = self.window(scene, history)
        if not window and _dark(scene):  # no earlier frame to weigh it against
            out.append("signal_dark.")
        if window:
            c = self.config
            out.append(
                f"window_frames({len(window) + 1}).window_param(confirm_frames,{c.confirm_frames})."
                f"window_param(track_frames,{c.track_frames})."
            )
            out.append(f"window_param(confirm_ms,{round(c.confirm_s * 1000)}).window_param(track_ms,{round(c.track_s * 1000)}).")
            out.append(f"window_param(window_ms,{round(c.seconds * 1000)})."
                       f"window_param(flash_max_ms,{round(c.flash_max_phase_s * 1000)}).")
            now, past = self._summary(scene), [self._summary(s) for s in window]
            times = [s.timestamp for s in window] + [scene.timestamp]
            clock = _Clock.of(times, c.untimed_frame_s)
            # a traffic light seen on the way to the intersection ahead shows it signalised after it leaves the view
            approach = _approaches([*window, scene])
            lit = {a for a, f in zip(approach, [*past, now]) if a is not None and f.lights}
            if approach[-1] is not None and any(a == approach[-1] and f.lights for a, f in zip(approach, past)):
                out.append("light_seen_on_approach.")
            out.extend(_limit_facts(now, past, c.confirm_frames, clock, [a in lit for a in approach[:-1]]))
            out.extend(_light_facts(now, past, times, c, clock))
            out.extend(_dark_signal(now, past, c, clock))
            out.extend(_sign_facts(now, past, clock))
            jumped = [self._jumps(a, b, sa, sb, clock.ms[k + 1] - clock.ms[k])
                      for k, (a, b, sa, sb) in enumerate(zip(window, [*window[1:], scene], past, [*past[1:], now]))]
            out.extend(_memory_facts(scene, now, window, past, jumped, c, clock, bodies, self.accel_step))
            out.append(f"slowest_recent_speed({min(p.speed for p in past)}).")  # stopped or not: the rules say
            at_line = [p.speed for p in past if p.at_line]  # a stop in a queue short of the line is no stop at it
            if at_line:
                out.append(f"slowest_at_line({min(at_line)}).")
            speeds = [p.speed for p in past] + [now.speed]
            if now.at_line and len(at_line) == len(past) and all(a <= b for a, b in zip(speeds, speeds[1:])):
                # pulling off from the line: its stop may have left the window (def.stopped_at_line)
                out.append(f"crept_at_line({clock.lasted(0, len(past))}).")
        return "".join(out)

    def _summary(self, scene: Scene) -> _Summary:
        """The scene's summary, kept exactly as long as the scene lives.

        Holding the scenes themselves (a fixed number of recent ones) kept thousands of frames alive past
        every window: memory, and full garbage collections of hundreds of milliseconds in a busy worker.
        The entry goes when the scene does, before its id() can be reused.
        """
        summary = self._summaries.get(id(scene))
        if summary is None:
            summary = self._summaries[id(scene)] = _Summary.of(scene, self.bodies)
            weakref.finalize(scene, self._summaries.pop, id(scene), None).atexit = False  # nothing to do at exit
        return summary

    def _jumps(self, before: Scene, after: Scene, was: _Summary, now: _Summary, ms: int) -> frozenset[int]:
        """The ids two frames in a row both show that name different objects (`_same_object`), worked out once per
        pair: a pair of frames sits in many later windows, and judging every object of every pair in each window
        cost a 50-object frame's window 5 ms. Kept as long as both frames live, as summaries are."""
        key = (id(before), id(after), ms)
        jumped = self._jumped.get(key)
        if jumped is None:
            legs, bodies = _legs([before, after]), self.bodies
            jumped = self._jumped[key] = frozenset(
                oid for oid in was.ids & now.ids
                if not _same_object(was.objects[oid], now.objects[oid], legs, ms / 1000, bodies))
            for scene in (before, after):
                weakref.finalize(scene, self._jumped.pop, key, None).atexit = False
        return jumped

    def window(self, scene: Scene, history: Sequence[Scene]) -> list[Scene]:
        """The recent frames, oldest first: those of the current run newer than `seconds` before this one.

        A frame older than, or numbered before, the one delivered before it is out of place, or starts a new run:
        - followed by a frame that is not, it came late and is dropped, so that the frames are in time order (a late
          frame put in the wrong place makes a steady light look dark and lit again);
        - not older than the frame before that one, it is the one before that was out of place (stamped ahead of
          its time, or delivered early): that one is dropped, so that one odd timestamp does not cost the frames
          before it (a pedestrian hidden a moment is remembered through it);
        - the frame being decided: its window is the frames before it, in id and time (it may have come late);
        - otherwise the run restarts: what came before is another run, whose frames are not this one's past,
          however close their timestamps.
        Frames with timestamps are kept for the whole `seconds`, however many: at 50 Hz a cap of 40 frames cut a
        2 s window to 0.8 s, too short to see a light flash. Only frames without timestamps are counted against
        `max_frames`.
        """
        run: list[Scene] = []
        frames = (*history, scene)
        for i, frame in enumerate(frames):
            if run and _goes_back(frame, run[-1]):
                later = frames[i + 1] if i + 1 < len(frames) else None
                if later is not None and not _goes_back(later, run[-1]):
                    continue  # late: the run goes on after it
                if len(run) > 1 and not _goes_back(frame, run[-2]):
                    run.pop()  # the frame before was out of place
                elif later is None:
                    run = [past for past in run if past.timestamp < frame.timestamp and past.frame_id < frame.frame_id]
                else:
                    run = []  # a restart
            run.append(frame)
        run.pop()  # the scene itself
        kept: list[Scene] = []
        # frames whose age cannot be told, without timestamps or stamped no earlier than the frame after them (a
        # clock that has stopped), last untimed_frame_s each: as many as fill `seconds`, and no more than max_frames.
        # A stopped clock kept every frame since it stopped, and a red light seen 25 s before held the ego
        untimed = min(self.config.max_frames, max(1, round(self.config.seconds / self.config.untimed_frame_s)))
        unaged, after = 0, scene
        for past in reversed(run):
            unaged += past.timestamp >= after.timestamp
            if scene.timestamp - past.timestamp > self.config.seconds or unaged > untimed:
                break
            kept.append(past)
            after = past
        kept.reverse()
        return kept


def _goes_back(frame: Scene, before: Scene) -> bool:
    """Whether `frame` is older than, or numbered before, the frame `before` it."""
    return frame.timestamp < before.timestamp or frame.frame_id < before.frame_id


# --- speed-limit readings ---------------------------------------------------


def _readings(scene: Scene) -> set[int]:
    values = {cm(s.value) for s in scene.signs if s.kind is SignKind.speed_limit and s.value is not None}
    if scene.speed_limit is not None:
        values.add(cm(scene.speed_limit))
    return values


def _misread(scene: Scene) -> tuple[tuple[int, str], ...]:
    """Limits read from a picture where a stop sign belonged (`_stop_evidence`): where the rules took the sign for a
    stop sign. The perceived limit is weighed against the limit read before it (`_perceived_misreads`)."""
    values = sorted({cm(s.value) for s in scene.signs
                     if s.kind is SignKind.speed_limit and s.value is not None and s.source in PICTURE})
    return tuple((v, e) for v in values for e in _stop_evidence(scene))


def _stop_evidence(scene: Scene) -> tuple[str, ...]:
    """What showed the approach stop-controlled while the ego came up to, or stood at, the intersection and no stop
    sign was read: the map or a stop line without traffic lights (san.stop.evidence_map, san.stop.evidence_line).
    Cross traffic and a vehicle ahead stopping are the rules' own evidence, worked out in the frame; they are not
    remembered. Lights seen in other frames of the approach are the window's to weigh (`_limit_facts`)."""
    x = scene.intersection
    if x is None or x.stage not in (IntersectionStage.arriving, IntersectionStage.at):
        return ()
    if any(s.kind is SignKind.stop for s in scene.signs):
        return ()  # the stop sign is read as one: the limit sign beside it is another sign (san.stop.misread_sign)
    lit = any(l.colour is not LightColour.none for l in scene.traffic_lights)
    evidence = ["the_map_marks_it_stop_controlled"] if x.stop_controlled else []
    if x.stop_line and not lit and x.type is not IntersectionType.signaled:
        evidence.append(LINE_EVIDENCE)
    return tuple(evidence)


def _perceived_misreads(past: list[_Summary], confirm: int) -> list[tuple[tuple[int, str], ...]]:
    """Per past frame, the perceived limit where the rules took it for a misread stop sign (def.read_here): read
    where a stop sign belonged, and higher than the limit believed before its run, as a new sign read there is.
    Without a limit believed before it the rules weigh it against the zone's usual limit, which the window does not
    know, so it is not remembered: a limit carried on through a long wait at the line is no sign read there."""
    runs = _runs(p.primary for p in past)
    found: list[tuple[tuple[int, str], ...]] = [() for _ in past]
    for k, run in enumerate(runs):
        held = _believed(runs[:k], confirm)
        if run.value is None or held is None or run.value <= runs[held].value:
            continue
        for j in range(run.first, run.last + 1):
            if past[j].perceived == run.value:
                found[j] = tuple((run.value, e) for e in past[j].stop_evidence)
    return found


def _primary(scene: Scene) -> Optional[int]:
    """The one limit a frame reads: the perceived limit, else the lowest sign read."""
    if scene.speed_limit is not None:
        return cm(scene.speed_limit)
    signs = [cm(s.value) for s in scene.signs if s.kind is SignKind.speed_limit and s.value is not None]
    return min(signs) if signs else None


class _Run(NamedTuple):
    value: Optional[int]  # None: frames that read nothing
    frames: int
    first: int  # the indices of its first and last frames
    last: int


def _runs(values: Iterable[Optional[int]]) -> list[_Run]:
    """Runs of equal readings in consecutive frames, oldest first. Frames that read nothing are runs of None, which
    part the readings either side: two one-frame misreads a second apart are no reading in two frames in a row."""
    runs: list[_Run] = []
    for i, value in enumerate(values):
        if runs and runs[-1].value == value:
            runs[-1] = runs[-1]._replace(frames=runs[-1].frames + 1, last=i)
        else:
            runs.append(_Run(value, 1, i, i))
    return runs


def _believed(runs: list[_Run], confirm: int) -> Optional[int]:
    """The index of the run whose limit held at the end of `runs`: the last run read in enough frames in a row, or
    the latest lower one read since it in enough frames, in a row or not, in at least half the frames from its first
    reading on (a sign seen between occlusions, or in turn with the old limit; san.limit.debounce_drop): two
    glimpses half a second apart are no sign. A reading since it in too few frames does not change the limit, up or
    down (san.limit.debounce); the settled limit read again after a gap is the settled run still."""
    settled = [i for i, run in enumerate(runs) if run.value is not None and run.frames >= confirm]
    if not settled:
        return None
    last = settled[-1]
    for i in range(len(runs) - 1, last, -1):
        run = runs[i]
        if run.value is not None and run.value < runs[last].value:
            count, span = _read_since(runs, i, last)
            if count >= confirm and 2 * count >= span:
                return i
    return last


def _read_since(runs: list[_Run], i: int, settled: int) -> tuple[int, int]:
    """Frames reading run i's limit, counted back from it to the settled run, across runs that read nothing or a
    higher limit, until a run that read a lower one; and how many frames there are from the first of them to run i's
    last."""
    value, count, first = runs[i].value, 0, runs[i].first
    for run in reversed(runs[settled + 1:i + 1]):
        if run.value == value:
            count, first = count + run.frames, run.first
        elif run.value is not None and run.value < value:
            break
    return count, runs[i].last - first + 1


def _seen_facts(value: int, readings: list[frozenset[int]], last: int, since: int, clock: "_Clock") -> str:
    """In how many frames a limit was read, counted back from index `last` to `since` (after the settled limit
    before it) across frames that read nothing or only higher limits (the one it would lower), until one that read
    a lower limit; for how long from the first; and over how many frames from the first to the last."""
    count, first = 0, last
    for i in range(last, since - 1, -1):
        if value in readings[i]:
            count, first = count + 1, i
        elif any(v < value for v in readings[i]):
            break
    return f"reading_seen({value},{count},{clock.lasted(first, last)}).reading_span({value},{last - first + 1})."


@dataclass(frozen=True)
class _Clock:
    """The window's frame times, in whole ms, and how long one frame lasts."""

    ms: tuple[int, ...]
    frame_ms: int

    @classmethod
    def of(cls, times: Sequence[float], untimed_frame_s: float) -> "_Clock":
        """A frame lasts the window's median frame interval (the lower middle one): the frame rate's, which a dropout
        does not stretch as it does the mean. Frames without timestamps (all 0), out of order, or three and more all of
        one instant (a clock that has stopped) come `untimed_frame_s` apart; two frames of one instant are one frame
        seen again, which lasts as long as one."""
        ms = [round(t * 1000) for t in times]
        if not any(ms) or ms[-1] < ms[0] or len(ms) > 2 and ms[-1] == ms[0]:
            ms = [round(i * untimed_frame_s * 1000) for i in range(len(times))]
        steps = [b - a for a, b in zip(ms, ms[1:]) if b > a]
        return cls(tuple(ms), statistics.median_low(steps) if steps else round(untimed_frame_s * 1000))

    def lasted(self, first: int, last: int) -> int:
        """How long something seen from the frame at index `first` to the one at `last` lasted: from the first to the
        last and through the last, so that so many evenly spaced frames last so many frame intervals. Its own
        timestamps, not a count of frames: a 40 ms flicker after a second without frames lasts 60 ms, not a second."""
        return self.ms[last] - self.ms[first] + self.frame_ms


def _run_facts(value: int, run: _Run, clock: _Clock) -> str:
    """A reading's run: in how many frames in a row, and for how long."""
    return f"reading_run({value},{run.frames}).reading_time({value},{clock.lasted(run.first, run.last)})."


def _limit_facts(now: _Summary, past: list[_Summary], confirm: int, clock: _Clock, signalled: list[bool]) -> list[str]:
    """Limits read over the window. `signalled`: whether each past frame was on an approach where a traffic light was
    seen, whose stop line is no evidence of a stop sign."""
    misreads = [p.misread + perceived for p, perceived in zip(past, _perceived_misreads(past, confirm))]
    out = sorted({f"misread_before({v},{e})." for misread, lit in zip(misreads, signalled) for v, e in misread
                  if not (lit and e == LINE_EVIDENCE)})
    out.extend(sorted({f"sign_on_vehicle_before({v})." for p in past for v in p.on_vehicles}))
    out.extend(sorted({f"sign_beside_exit_before({v})." for p in past for v in p.beside_exits}))
    here = len(past)  # the current frame's index
    readings = [p.readings for p in past] + [now.readings]
    for value in sorted(now.readings):
        first = here
        while first > 0 and value in past[first - 1].readings:
            first -= 1
        out.append(_run_facts(value, _Run(value, here - first + 1, first, here), clock))
    primary = now.primary
    runs = _runs(p.primary for p in past)
    settled = [run for run in runs if run.value is not None and run.frames >= confirm]
    since = settled[-1].last + 1 if settled else 0  # where readings start to count against the settled limit
    out.extend(_seen_facts(value, readings, here, since, clock) for value in sorted(now.readings))
    if primary is None:  # no limit read now: the one read last is still a reading, with what held before it
        last = _believed(runs, confirm)
        if last is None:
            return out
        run = runs[last]
        out.append(f"remembered_limit({run.value}).{_run_facts(run.value, run, clock)}"
                   + _seen_facts(run.value, readings, run.last, since, clock))
        runs = runs[:last]
    elif runs and runs[-1].value == primary:  # the current reading's own run
        runs.pop()
    # a misread stop sign, or a sign on a vehicle, says nothing of the limit before the current reading
    # (san.stop.misread_limit, san.world.sign_on_a_vehicle): taken for the limit read before, it would outweigh the
    # real sign read after it
    before = _believed([run._replace(value=None) if _no_limit_in(past[run.first], misreads[run.first], run.value,
                                                                 signalled[run.first])
                        else run for run in runs], confirm)
    if before is not None:
        run = runs[before]
        # with its run, so that the rules can tell a settled limit from a one-frame lower reading
        out.append(f"prior_limit({run.value}).prior_run({run.value},{run.frames})."
                   f"prior_time({run.value},{clock.lasted(run.first, run.last)}).")
    return out


def _no_limit_in(frame: _Summary, misread: tuple[tuple[int, str], ...], value: Optional[int], signalled: bool) -> bool:
    """Whether the rules took the sign that read `value` in this frame (its `misread` values, the perceived limit's
    among them) for a stop sign, or it was on a vehicle or beside an exit lane (an exit's limit, not the road's)."""
    return (value in frame.on_vehicles or value in frame.beside_exits
            or any(v == value and not (signalled and e == LINE_EVIDENCE) for v, e in misread))


# --- lights and signs ---------------------------------------------------------


def _light_facts(now: _Summary, past: list[_Summary], times: list[float], config: WindowConfig,
                 clock: _Clock) -> list[str]:
    if not now.lights and not any(p.lights for p in past):  # most frames: nothing lit in the whole window
        return []
    frames = past + [now]
    out = []
    # each lamp on its own: a ball and each arrow flash, and are remembered, apart (a flashing yellow arrow beside a
    # steady yellow ball is no flashing ball)
    for name in sorted({name for f in frames for name in f.lights if _colour(name) is not LightColour.green}):
        # perception's flag: in how many of the latest frames that show the lamp, back to a steady report of it,
        # and over how long: at 50 Hz, or with one camera frame delivered twice, two flags are a glint, not a flash
        states = [None if name not in f.lights else name not in f.steady for f in frames]
        flagged, first, last = _recent_run(states, times, config)
        if flagged:
            out.append(f"light_flashing_frames({name},{flagged}).light_flashing_time({name},{clock.lasted(first, last)}).")
            # a light lit longer than a flash is lit is steady, whatever its flags (an LED flickering on camera)
            first, last = _lit_phase([name in f.lights for f in frames], times, config)
            out.append(f"light_lit_time({name},{clock.lasted(first, last)}).")
        # lit (True), listed unlit (False), or out of view (None), which keeps what was seen last: only a light
        # seen dark has a dark phase. A yellow lit now needs a whole lit phase seen as well as a dark one: a steady
        # yellow hidden for a moment and back is on, off, on too, and taking it for flashing would let the ego run it
        seen = [True if name in f.lights else False if _place(name) in f.unlit else None for f in frames]
        if _flashes(seen, times, config, whole_lit=_colour(name) is LightColour.yellow):
            out.append(f"light_flashes({name}).")
    last = next((p for p in reversed(past) if p.lights), None)
    if not now.lights and last is not None:
        # the lamps when last seen, as the rules judged them then: a red ball beside a green arrow still held the
        # movements the arrow does not govern (a green ball alone is remembered as nothing); a yellow perception
        # flagged flashing calls for caution, not for a stop, and only a steady one is remembered. Every arrow is
        # remembered, green too: it, not the ball, governed its movement
        for name in sorted(last.lights):
            colour = _colour(name)
            if colour is LightColour.red or colour is LightColour.yellow and name in last.steady or name != colour.value:
                out.append(f"light_seen_recently({name}).")
    return out


def _colour(name: str) -> LightColour:
    """The colour of a lamp named as rules.facts.lamp names it."""
    return LightColour(name.partition("_")[0])


def _place(name: str) -> Optional[str]:
    """Where a lamp named as rules.facts.lamp names it sits: None for a ball, else its arrow's direction."""
    return name.split("_")[1] if name.endswith("_arrow") else None


def _dark(scene: Scene) -> bool:
    return bool(scene.traffic_lights) and all(l.colour is LightColour.none for l in scene.traffic_lights)


def _dark_signal(now: _Summary, past: list[_Summary], config: WindowConfig, clock: _Clock) -> list[str]:
    """Traffic lights in view with none of them lit (out, or unreadable): still a signal, one that shows nothing,
    where the core gives a lamp of colour "none" no fact at all; still dark in a frame that has them out of view a
    moment. Lights seen lit in the window must have been dark as long as a reading needs (confirm_frames, confirm_s):
    one unlit frame of a green is a glitch, and braking for it with a truck behind is phantom braking."""
    if now.lights:
        return []
    frames = past + [now]
    first = len(frames) - 1
    while first > 0 and not frames[first - 1].lights:  # dark, or out of view a moment: not lit since
        first -= 1
    dark = [i for i in range(first, len(frames)) if frames[i].dark]
    if not dark:
        return []
    if not any(f.lights for f in frames[:first]):  # never seen lit: dark as long as it has been seen
        return ["signal_dark."]
    lasted = clock.lasted(dark[0], len(frames) - 1)
    return ["signal_dark."] if len(dark) >= config.confirm_frames and lasted >= config.confirm_s * 1000 else []


def _recent_run(states: Sequence[Optional[bool]], times: Sequence[float], config: WindowConfig) -> tuple[int, int, int]:
    """In how many frames, counted back from now, something was seen flashing (True) at a flash's pace; and the
    indices of the first and the last of them (0 and 0 when there are none).

    A frame is True (flagged flashing, or lit for a beacon), False (shown and reported steady: the count stops
    there) or None (not shown: dark between flashes, or hidden). The latest True frame must be no longer ago than
    a flash's longest phase, and no two True frames further apart: two glints a second and more apart, or a flag
    long ago, are no flashing light. Frames without timestamps have no pace to hold against.
    """
    longest = round(config.flash_max_phase_s * 1000)
    count, since, first, last = 0, round(times[-1] * 1000), 0, 0
    for index in reversed(range(len(states))):
        state, t = states[index], round(times[index] * 1000)
        if state is None:
            continue
        if not state or since - t > longest:
            break
        if not count:
            last = index
        count, since, first = count + 1, t, index
    return count, first, last


def _lit_phase(lit: list[bool], times: list[float], config: WindowConfig) -> tuple[int, int]:
    """The indices of the first and the last frame of the latest lit phase of a light lit (True) in some frames at
    `times`. Two lit frames no further apart than a flash's shortest phase have no dark phase between them (what is
    missed between them is a lost frame or flicker); further apart, one may have passed unseen, and the phase ends."""
    shortest = round(config.flash_min_phase_s * 1000)
    ms = [round(t * 1000) for t in times]
    last = max(i for i, on in enumerate(lit) if on)
    first = last
    for i in reversed(range(first)):
        if lit[i]:
            if ms[first] - ms[i] > shortest:
                break
            first = i
    return first, last


def _flashes(seen: list[Optional[bool]], times: list[float], config: WindowConfig, whole_lit: bool = False) -> bool:
    """Whether a light seen on (True) and off (False) over frames at `times` goes through a whole flash cycle. A
    frame that does not show it (None) keeps what was seen before; frames before it is first seen do not count.

    It must go on, off and on again (one whole dark phase seen between two lit ones), and every
    phase must last as long as a flash does: a steady light that drops out of one frame or
    flickers goes off for a tenth of a second, and one lit for seconds is steady. A phase lasts
    from its first frame to the first frame of the next; the phases at the window's edges are
    cut, so only their length so far is held against the most a phase may last.
    Without timestamps nothing lasts, and nothing is seen flashing. With `whole_lit`, a light lit now must
    also have been seen through a whole lit phase (on, off, on, off, on, or off, on, off, on).
    """
    known = next((i for i, state in enumerate(seen) if state is not None), len(seen))
    on: list[bool] = []
    for state in seen[known:]:
        on.append(on[-1] if state is None else state)
    times = times[known:]
    starts = [i for i in range(len(on)) if i == 0 or on[i] != on[i - 1]]
    if len(starts) < 3 or not any(on[i] for i in starts[:-2]):  # no on, off, on
        return False
    ms = [round(t * 1000) for t in times]  # whole milliseconds: 0.5 - 0.25 is 0.25 exactly
    shortest, longest = round(config.flash_min_phase_s * 1000), round(config.flash_max_phase_s * 1000)
    ends = [ms[i] for i in starts[1:]] + [ms[-1]]
    lengths = [end - ms[i] for i, end in zip(starts, ends)]
    whole = lengths[1:-1]  # seen from start to end
    if whole_lit and on[-1] and not any(on[i] for i in starts[1:-1]):
        return False
    return all(shortest <= n <= longest for n in whole) and lengths[0] <= longest and lengths[-1] <= longest


def _sign_facts(now: _Summary, past: list[_Summary], clock: _Clock) -> list[str]:
    """A stop sign or a school-zone sign seen before and out of view now (the signs whose memory the rules use); and
    the school-zone sign's latest run of frames, whose length the rules weigh as a limit reading's."""
    out = []
    if not now.stop_sign and any(p.stop_sign for p in past):
        out.append("sign_seen_recently(stop).")
    if not now.school_sign and any(p.school_sign for p in past):
        out.append("sign_seen_recently(school_zone).")
    seen = [f.school_sign for f in past] + [now.school_sign]
    if any(seen):
        last = max(i for i, shown in enumerate(seen) if shown)
        first = last
        while first > 0 and seen[first - 1]:
            first -= 1
        out.append(f"school_sign_run({last - first + 1}).school_sign_time({clock.lasted(first, last)}).")
    return out


def _approaches(scenes: Sequence[Scene]) -> list[Optional[int]]:
    """Which approach to an intersection each frame is on, numbered oldest first (None: no intersection ahead).

    An approach goes on while each frame shows an intersection of the same type as the frame before, at a stage no
    earlier and, where both tell it, no farther from its stop line (give or take `APPROACH_SLACK`): anything else is
    the next intersection, whose lights are its own.
    """
    out: list[Optional[int]] = []
    count, before = 0, None
    for scene in scenes:
        x = scene.intersection
        if x is None:
            out.append(None)
        else:
            same = (before is not None and x.type is before.type
                    and STAGES.index(x.stage) >= STAGES.index(before.stage)
                    and (x.distance is None or before.distance is None or x.distance <= before.distance + APPROACH_SLACK))
            if not same:
                count += 1
            out.append(count)
        before = x
    return out


# --- objects -------------------------------------------------------------------


def _extent(obj: DetectedObject, bodies: Bodies) -> tuple[float, float]:
    """How far the object reaches along y (ahead) and along x (to the right). Its length lies along its course:
    across the ego's road for one moving more across it than along it, or standing in a crossing lane."""
    length, width = bodies.footprint(obj)
    v = obj.velocity
    if v is not None and (v.x or v.y):
        across = abs(v.x) > abs(v.y)
    else:
        across = obj.lane is not None and obj.lane.kind in (LaneKind.cross_left, LaneKind.cross_right)
    return (width, length) if across else (length, width)


def _relative_velocity(obj: DetectedObject, ego_speed: float, bodies: Bodies) -> tuple[float, float]:
    """Velocity relative to the ego; an unknown speed as the catalog assumes it (Bodies)."""
    if obj.velocity is not None:
        return obj.velocity.x, obj.velocity.y - ego_speed
    if obj.position.y < 0:
        return (0.0, -ego_speed) if obj.cls in bodies.stands else (0.0, 0.0)
    if obj.cls in bodies.motor and (obj.lane is None or obj.lane.kind not in CROSSING):
        return 0.0, 0.0
    return 0.0, -ego_speed


def _to_centre(y: float, length: float) -> float:
    """A position y (the gap from the ego's bumper to the object's nearest face; 0 alongside) as the distance
    between the two centres, along which positions move at the object's speed."""
    reach = (EGO_LENGTH + length) / 2
    return y + reach if y > 0 else y - reach if y < 0 else 0.0


def _to_gap(centre: float, length: float) -> float:
    """The inverse of `_to_centre`: 0 while the two overlap along the road."""
    reach = (EGO_LENGTH + length) / 2
    return centre - reach if centre > reach else centre + reach if centre < -reach else 0.0


def _world_facts(scene: Scene, bodies: Bodies) -> list[str]:
    """Sizes; limit signs that sit inside the outline of an object, and how sure perception was of each reading;
    camera-only vehicles that sit inside the outline of a confirmed object."""
    sizes = [(o.id, _measured_size(o)) for o in scene.objects]
    out = [f"obj_size({oid},{cm(size.length)},{cm(size.width)})." for oid, size in sizes if size is not None]
    out.extend(f"sign_within({value},{oid})." for value, oid, _ in _signs_within(scene, bodies))
    out.extend(f"sign_beside_exit({value},{lane})." for value, lane in _signs_beside_exits(scene, bodies.half_lane))
    out.extend(f"sign_confidence({value},{percent})." for value, percent in _confidences(scene).items())
    camera_only = [o for o in scene.objects if o.sources == [Source.camera]]
    if not camera_only:
        return out
    outlines = [(o.id, o.position.x, o.position.y, *_extent(o, bodies))
                for o in scene.objects if CONFIRMING.intersection(o.sources)]
    if not outlines:
        return out
    for obj in camera_only:
        x, y = obj.position.x, obj.position.y
        out.extend(f"overlaps({obj.id},{oid})." for oid, ox, oy, length, width in outlines
                   if abs(x - ox) <= width / 2 and _within_length(y, oy, length))
    return out


def _confidences(scene: Scene) -> dict[int, int]:
    """How sure perception is of each limit value read, in percent: its surest sign's. A value also read by a sign
    that gives no confidence, or given as the perceived limit, is left out: nothing says it is a guess."""
    found: dict[int, int] = {}
    unknown = {cm(scene.speed_limit)} if scene.speed_limit is not None else set()
    for sign in scene.signs:
        if sign.kind is not SignKind.speed_limit or sign.value is None:
            continue
        if sign.confidence is None:
            unknown.add(cm(sign.value))
        else:
            found[cm(sign.value)] = max(found.get(cm(sign.value), 0), round(sign.confidence * 100))
    return {value: percent for value, percent in found.items() if value not in unknown}


def _signs_beside_exits(scene: Scene, half_lane: float) -> list[tuple[int, int]]:
    """(value, lane id) of each limit read only off signs that stand past the outer edge of a lane that leaves the
    road (the ego's road's outermost lane on that side, not the ego's own): where an exit posts its own limit
    (san.limit.exit_lane_sign). A value also read off a sign elsewhere is the road's too."""
    current = sorted(l.id for l in scene.lanes if l.kind is LaneKind.current)
    ego = scene.ego.lane
    edges = {}  # exit lane id: (side, its outer edge's offset from the ego's line on that side)
    for lane in scene.lanes:
        if lane.kind is LaneKind.current and lane.leaves_road and lane.ends_in is not None and lane.id != ego:
            if lane.id == current[-1] and lane.id > ego:
                edges[lane.id] = (1, (2 * (lane.id - ego) + 1) * half_lane)
            elif lane.id == current[0] and lane.id < ego:
                edges[lane.id] = (-1, (2 * (ego - lane.id) + 1) * half_lane)
    if not edges:
        return []
    beside: dict[int, int] = {}
    elsewhere: set[int] = set()
    for sign in scene.signs:
        if sign.kind is not SignKind.speed_limit or sign.value is None:
            continue
        x = sign.position.x if sign.position is not None else None
        lane = next((lid for lid, (side, edge) in edges.items() if x is not None and side * x > edge), None)
        if lane is None:
            elsewhere.add(cm(sign.value))
        else:
            beside.setdefault(cm(sign.value), lane)
    return [(value, lane) for value, lane in sorted(beside.items()) if value not in elsewhere]


def _signs_within(scene: Scene, bodies: Bodies) -> list[tuple[int, int, ObjectClass]]:
    """(value, object id, object class) of each limit sign whose position lies inside an object's outline: a sticker
    or an advert on a truck is read like a sign (the rules say which objects do not post limits)."""
    signs = [s for s in scene.signs if s.kind is SignKind.speed_limit and s.value is not None and s.position is not None]
    if not signs:
        return []
    return [(cm(s.value), o.id, o.cls) for s in signs for o in scene.objects
            for length, width in [_extent(o, bodies)]
            if abs(s.position.x - o.position.x) <= width / 2 and _within_length(s.position.y, o.position.y, length)]


def _within_length(y: float, oy: float, length: float) -> bool:
    """Whether a nearest face at y lies along an object whose nearest face is at oy, give or take a metre.

    Positions are to nearest faces: an object ahead reaches from oy away from the ego, one behind from oy
    back, and one alongside (0) both ways.
    """
    near, far = (oy, oy + length) if oy > 0 else (oy - length, oy) if oy < 0 else (-length, length)
    return near - 1.0 <= y <= far + 1.0


def _predicted_conflicts(scene: Scene, horizon: float, bodies: Bodies, step: float) -> list[str]:
    """Objects whose course, kept as it is, meets the ego's corridor within the horizon: at the ego's speed
    (predicted_conflict), and at the speed one accelerate would give it (stepped_conflict: a child who clears the
    ego's path just before it arrives at its speed may not at one step faster).

    Objects already in the corridor are the lane rules' business; this looks
    for those that will come into it ahead of the ego (crossing, cutting in).
    """
    out = []
    for obj in scene.objects:
        found = _conflict(obj, obj.position.x, obj.position.y, scene.ego.speed, horizon, bodies)
        if found is not None:
            out.append(f"predicted_conflict({obj.id},{found[0]},{found[1]}).")
        stepped = _conflict(obj, obj.position.x, obj.position.y, scene.ego.speed + step, horizon, bodies)
        if stepped is not None:
            out.append(f"stepped_conflict({obj.id},{stepped[0]},{stepped[1]}).")
    return out


def _conflict(obj: DetectedObject, x: float, y: float, ego_speed: float, horizon: float,
              bodies: Bodies) -> Optional[tuple[int, int]]:
    """When (ms) and how far ahead (cm) the course of `obj`, now at (x, y), enters the ego's corridor; None if
    it does not within the horizon, is in it already, or its velocity is unknown."""
    if obj.velocity is None:
        return None
    length, width = _extent(obj, bodies)  # along y, along x
    reach_x = (EGO_WIDTH + width) / 2 + 0.3
    reach_y = (EGO_LENGTH + length) / 2 + 0.5
    y = _to_centre(y, length)
    if abs(x) < reach_x:
        return None
    vx, vy = _relative_velocity(obj, ego_speed, bodies)
    span_x = _inside(x, vx, reach_x)
    span_y = _inside(y, vy, reach_y)
    if span_x is None or span_y is None:
        return None
    start = max(span_x[0], span_y[0], 0.0)
    end = min(span_x[1], span_y[1], horizon)
    meet = y + vy * start
    if not (0.0 < start < end and meet > 0.0):  # from behind, braking would not help
        return None
    return int(round(start * 1000)), cm(_to_gap(meet, length))


def _inside(position: float, speed: float, reach: float) -> Optional[tuple[float, float]]:
    """The times at which position + speed*t lies within (-reach, reach), or None."""
    if speed == 0.0:
        return (-math.inf, math.inf) if abs(position) < reach else None
    a, b = (-reach - position) / speed, (reach - position) / speed
    return (min(a, b), max(a, b))


def _legs(scenes: Sequence[Scene]) -> list[tuple[float, float]]:
    """The ego's drive between each frame and the next: how long (s), and at what speed, its mean over the leg (the
    speed taken to change evenly between frames)."""
    return [(max(b.timestamp - a.timestamp, 0.0), (a.ego.speed + b.ego.speed) / 2) for a, b in zip(scenes, scenes[1:])]


def _track(obj: DetectedObject, legs: Sequence[tuple[float, float]], bodies: Bodies,
           solid: bool = True) -> Optional[tuple[float, float]]:
    """Where the track of a lost object puts it now, (x, y), from where it was last seen, at the velocity it had,
    while the ego drove the legs since as it did (slowing down, it leaves a pedestrian ahead of it, not under it).
    None if on the way the track overlaps the ego's own footprint: an object cannot be where the ego is (`solid`;
    without it, where the course alone puts it)."""
    length, width = _extent(obj, bodies)  # along y, along x
    x, y = obj.position.x, _to_centre(obj.position.y, length)
    for seconds, ego_speed in legs:
        vx, vy = _relative_velocity(obj, ego_speed, bodies)
        span_x = _inside(x, vx, (EGO_WIDTH + width) / 2)
        span_y = _inside(y, vy, (EGO_LENGTH + length) / 2)
        if solid and span_x is not None and span_y is not None and \
                max(span_x[0], span_y[0], 0.0) < min(span_x[1], span_y[1], seconds):
            return None
        x, y = x + vx * seconds, y + vy * seconds
    return x, _to_gap(y, length)


def _side_of(x: float, y: float, half_lane: float) -> SensorSide:
    """The range sensor that faces a position (y: the gap from the ego's bumper, 0 alongside)."""
    if abs(x) < half_lane:
        return SensorSide.front if y > 0 else SensorSide.rear
    left = x < 0
    if y == 0:
        return SensorSide.left if left else SensorSide.right
    if y > 0:
        return SensorSide.front_left if left else SensorSide.front_right
    return SensorSide.rear_left if left else SensorSide.rear_right


def _ran_beside(oid: int, seen_in: list[int], summaries: list[_Summary]) -> set[Source]:
    """The confirming sources that reported other objects on the same side of the ego (ahead, or beside and behind)
    in frames that showed `oid`: they were running there while it was seen."""
    found: set[Source] = set()
    for index in seen_in:
        summary = summaries[index]
        ahead = summary.objects[oid].position.y > 0
        for other, sources in summary.confirmed:
            if other != oid and (summary.objects[other].position.y > 0) == ahead:
                found |= sources
    return found


def _same_object(before: DetectedObject, after: DetectedObject, legs: Sequence[tuple[float, float]], seconds: float,
                 bodies: Bodies) -> bool:
    """Whether `after`, reported under the id of `before` `seconds` later, can be the object `before` was: within
    reach of where the course `before` was on puts it, give or take what a detector's ranging errs by (REUSE_GATE_M,
    and REUSE_GATE_SHARE of its range), what a hard brake or swerve changes (REUSE_ACCEL) and, where its speed was
    not known (or the frames have no timestamps, so that nothing moves between them), what any speed would. A
    tracker that hands a freed id to a new object makes the id jump to wherever the new object is."""
    x, y = _track(before, legs, bodies, solid=False)
    unmoved = before.velocity is None or not any(leg_s for leg_s, _ in legs)
    slack = (REUSE_GATE_M + REUSE_GATE_SHARE * math.hypot(after.position.x, after.position.y)
             + REUSE_ACCEL * seconds ** 2 / 2 + (REUSE_ANY_SPEED * seconds if unmoved else 0.0))
    return math.hypot(x - after.position.x, y - after.position.y) <= slack


def _names(now: _Summary, summaries: list[_Summary], jumped: Sequence[frozenset[int]],
           legs: Sequence[tuple[float, float]], clock: _Clock, bodies: Bodies) -> list[dict[int, int]]:
    """Per past frame, the name the window's facts give each object it shows: its id where it is the object the id
    names last (seen now, or lost), the id negated where it is the object the tracker had under the id before it
    handed the id to another (an object lost while its id lives on elsewhere is still lost); an object under the id
    before those two is left out. Sightings of an id that `_same_object` cannot join are different objects (for
    frames in a row, `jumped[i]`: the ids frame i and the one after it show for different objects)."""
    sightings: dict[int, list[tuple[int, DetectedObject]]] = {}
    for index, summary in enumerate([*summaries, now]):
        for oid in summary.ids:
            sightings.setdefault(oid, []).append((index, summary.objects[oid]))
    names: list[dict[int, int]] = [{} for _ in summaries]
    for oid, seen in sightings.items():
        other = 0  # how many objects the id has named since, counting back from its latest sighting
        for (j, after), (i, before) in zip(reversed(seen), reversed(seen[:-1])):
            if (oid in jumped[i] if j == i + 1 else
                    not _same_object(before, after, legs[i:j], (clock.ms[j] - clock.ms[i]) / 1000, bodies)):
                other += 1
            if other > 1:
                break
            names[i][oid] = -oid if other else oid
        if seen[-1][0] < len(summaries):  # lost: its latest sighting is named by the id itself
            names[seen[-1][0]][oid] = oid
    return names


def _memory_facts(scene: Scene, now: _Summary, window: list[Scene], summaries: list[_Summary],
                  jumped: Sequence[frozenset[int]], config: WindowConfig, clock: _Clock, bodies: Bodies,
                  step: float) -> list[str]:
    """Objects the camera lost, where their track puts them now, and what says they are still there;
    earlier confirming sources of objects seen now; emergency lights over the window."""
    out = []
    present = now.objects
    unconfirmed = now.ids.difference(oid for oid, _ in now.confirmed)
    last: dict[int, tuple[int, DetectedObject]] = {}  # lost objects: the index of the frame last seen in, as seen
    lights: dict[int, list[int]] = {}  # the frames (their indices) in which each object showed emergency lights
    earlier: dict[int, set[Source]] = {}
    echoed: dict[int, set[Source]] = {}  # lost objects: the confirming sources that reported them in the window
    seen_in: dict[int, list[int]] = {}  # lost objects: the frames (their indices) they were seen in
    # a frame sits in some twenty windows: set operations on its summary, not a pass over its objects
    legs = _legs([*window, scene])
    # by name (`_names`): an id the tracker gave another object is not the object it named before
    names = _names(now, summaries, jumped, legs, clock, bodies)
    for index, (summary, named) in enumerate(zip(summaries, names)):
        for oid, name in sorted(named.items()):
            if name not in now.ids:
                last[name] = (index, summary.objects[oid])
                seen_in.setdefault(name, []).append(index)
        for oid, confirming in summary.confirmed:
            name = named.get(oid)
            if name in unconfirmed:
                earlier.setdefault(name, set()).update(confirming)
            elif name is not None and name not in now.ids:
                echoed.setdefault(name, set()).update(confirming)
        for oid in summary.lit:
            if oid in named:
                lights.setdefault(named[oid], []).append(index)
    for oid, found in earlier.items():
        out.extend(f"obj_source_before({oid},{s.value})." for s in sorted(found, key=lambda s: s.value))
    kept: set[int] = set()
    for oid, (seen, obj) in last.items():
        age = max(clock.ms[-1] - clock.ms[seen], 0) / 1000  # frames without timestamps: untimed_frame_s apart
        placed = _track(obj, legs[seen:], bodies)
        if placed is None:
            continue  # the ego would have hit it: it did not keep that course, and where it is is not known
        x, y = placed
        tracked = max(len(seen_in[oid]), obj.track_age or 0)
        side = _side_of(x, y, bodies.half_lane)
        reach = math.hypot(x, y) + config.sensor_margin
        facing = [r for r in scene.sensors if r.side is side]  # every range reading confirms (RangeSensor)
        reads = [r for r in facing if r.distance <= reach]
        if tracked < config.track_frames and not reads:
            continue
        kept.add(oid)
        out.append(f"remembered({oid},{int(round(age * 1000))}).remembered_object({oid},{obj.cls.value}).")
        out.append(f"remembered_pos({oid},{cm(x)},{cm(y)}).track_frames({oid},{tracked}).")
        if oid < 0:
            out.append(f"id_reused({oid},{-oid}).")
        out.append(f"last_seen_ahead({oid},{cm(obj.position.y)}).")  # where it was when lost: a phantom is judged there
        # from its first frame in the window to its last, or as many frames as its tracker has followed it; a
        # tracker's age past clingo's 32-bit integers (weeks) saturates, never wrapping into a brief track
        lasted = max(clock.lasted(seen_in[oid][0], seen), (obj.track_age or 0) * clock.frame_ms)
        out.append(f"track_time({oid},{min(lasted, MAX_ID)}).")
        if obj.lane is not None and obj.lane.kind is not LaneKind.current:
            # the ego's road's lanes: placed by its tracked offset (the rules), as a car cutting in moves across
            out.append(f"remembered_lane({oid},{obj.lane.kind.value},{obj.lane.id}).")
        if obj.velocity is not None:
            out.append(f"remembered_velocity({oid},{cm(obj.velocity.x)},{cm(obj.velocity.y)}).")
        out.extend(f"remembered_source({oid},{source.value})." for source in obj.sources)
        # each reading with its kind and distance: the rules doubt one beyond its sensor's reach (san.range.beyond_reach)
        for r in reads:
            out.append(f"sensor_still_reads({oid},{r.side.value},{r.kind.value},{cm(r.distance)}).")
        if facing and not reads:  # it reads clear road past where the object should be (the rules say whether that clears it)
            out.extend(f"sensor_reads_past({oid},{r.side.value},{r.kind.value},{cm(r.distance)})." for r in facing)
        # the range sensors that reported it: one that echoes is gone when they read past it, and one none did may
        # have been a phantom
        out.extend(f"reported_before({oid},{s.value})." for s in sorted(echoed.get(oid, ()), key=lambda s: s.value))
        out.extend(f"ran_beside({oid},{s.value})." for s in sorted(_ran_beside(abs(oid), seen_in[oid], summaries), key=lambda s: s.value))
        found = _conflict(obj, x, y, scene.ego.speed, config.horizon_s, bodies)
        if found is not None:
            out.append(f"remembered_conflict({oid},{found[0]},{found[1]}).")
        stepped = _conflict(obj, x, y, scene.ego.speed + step, config.horizon_s, bodies)
        if stepped is not None:
            out.append(f"remembered_stepped_conflict({oid},{stepped[0]},{stepped[1]}).")
    for oid, lit in lights.items():
        if oid in present or oid in kept:  # frames lit at a beacon's pace up to now (one unlit or unseen is dark)
            frames_lit = lit + [len(window)] if oid in present and present[oid].emergency_lights else lit
            times = [window[i].timestamp if i < len(window) else scene.timestamp for i in frames_lit]
            count, first, last = _recent_run([True] * len(times) + [None], times + [scene.timestamp], config)
            if count:
                out.append(f"lights_frames({oid},{count}).lights_time({oid},{clock.lasted(frames_lit[first], frames_lit[last])}).")
    return out
