"""The scene and proposal model: the one schema every part of Discern speaks.

Adapters build it, the rules and the sanity layer read it, the zenoh protocol
and the MCAP log carry it as JSON. Units are SI (metres, m/s, seconds);
positions are relative to the ego: x to the right, y ahead, bumper to nearest face.
"""

from __future__ import annotations

import re
import reprlib
from enum import Enum
from typing import Annotated, Literal, Optional

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationError, ValidationInfo, field_validator, model_validator

SCHEMA_VERSION = 1


def _a_json_integer(value: object) -> object:
    """The version is the JSON number 1 (1.0 too, as JSON Schema's `const` has it): a Literal alone also takes true,
    which the published schema refuses, so that a log would hold a message its own channel schema rejects."""
    if type(value) not in (int, float) or value != 1:
        raise ValueError(f"Input should be 1 (got {_shown(value)})")
    return 1


def _whole(value: object) -> object:
    """JSON Schema's "integer" is any number without a fraction: 3.0 is a lane id the published schema accepts, so the
    model takes it too, where strict validation alone would refuse it. A fraction still gets the integer error."""
    return int(value) if type(value) is float and value.is_integer() else value


Version = Annotated[Literal[1], BeforeValidator(_a_json_integer)]
WholeNumber = Annotated[int, BeforeValidator(_whole)]


class Named(str, Enum):
    """A value by its name: `f"{verdict.action}"` is `brake`, as the JSON says, not `Action.brake`."""

    def __str__(self) -> str:
        return self.value


class Action(Named):
    brake = "brake"
    accelerate = "accelerate"
    cruise = "cruise"
    change_lane_left = "change_lane_left"
    change_lane_right = "change_lane_right"
    turn_left = "turn_left"
    turn_right = "turn_right"
    pull_over = "pull_over"


class Zone(Named):
    city = "city"
    residential = "residential"
    school = "school"
    campus = "campus"
    rural = "rural"
    road = "road"
    highway = "highway"


class Intent(Named):
    continue_in_lane = "continue_in_lane"
    merge_into_left_lane = "merge_into_left_lane"
    merge_into_right_lane = "merge_into_right_lane"
    enter_left_lane = "enter_left_lane"
    enter_right_lane = "enter_right_lane"
    stay_in_leftmost_lane = "stay_in_leftmost_lane"
    stay_in_rightmost_lane = "stay_in_rightmost_lane"
    pull_over = "pull_over"


class LaneKind(Named):
    current = "current"
    oncoming = "oncoming"
    cross_left = "cross_left"
    cross_right = "cross_right"
    sidewalk_left = "sidewalk_left"
    sidewalk_right = "sidewalk_right"
    shoulder = "shoulder"


# What each object class is: the scene schema's description of `class` says it, and the catalog's entity hierarchy
# (rules/catalog/00_entities.lp) reasons with it. A test holds the two lists together.
OBJECT_CLASSES = {
    "car": "a passenger car or van (a motor vehicle)",
    "truck": "a lorry or truck (a heavy motor vehicle, which brakes less hard than a car)",
    "bus": "a bus or coach (a heavy motor vehicle); one stopped with flashing red lights is a school bus",
    "bike": "a motorbike: AV-CSR's name for a motorised two-wheeler, a motor vehicle like `motorcycle` (a pedal "
            "cycle is `bicycle`)",
    "motorcycle": "a motorcycle, moped or scooter (a motorised two-wheeler, a motor vehicle)",
    "bicycle": "a pedal cycle and its rider, e-bikes included (a two-wheeler and a vulnerable road user)",
    "emergency_vehicle": "an ambulance, fire engine or police vehicle (a motor vehicle; its lights are "
                         "`emergency_lights`)",
    "pedestrian": "a person on foot (a vulnerable road user)",
    "animal": "an animal on or near the road (a vulnerable road user)",
    "traffic_light": "a traffic signal head detected as an object (its colour is given in `traffic_lights`)",
    "plastic_bag": "a plastic bag or similar light litter, which can be driven over",
    "roadblock": "a road block closing the road or lane",
    "barrier": "a barrier, fence or bollard on the road",
    "traffic_cone": "a traffic cone",
    "debris": "debris on the road (fallen load, parts, rocks), which cannot be driven over",
    "unknown": "an object perception cannot classify (taken to be able to move)",
}


class ObjectClass(Named):
    __doc__ = "What kind of road user or thing an object is. " + "; ".join(
        f"`{name}`: {words}" for name, words in OBJECT_CLASSES.items()) + "."

    car = "car"
    truck = "truck"
    bus = "bus"
    bike = "bike"
    motorcycle = "motorcycle"
    bicycle = "bicycle"
    emergency_vehicle = "emergency_vehicle"
    pedestrian = "pedestrian"
    animal = "animal"
    traffic_light = "traffic_light"
    plastic_bag = "plastic_bag"
    roadblock = "roadblock"
    barrier = "barrier"
    traffic_cone = "traffic_cone"
    debris = "debris"
    unknown = "unknown"


class Indicator(Named):
    none = "none"
    left = "left"
    right = "right"
    hazard = "hazard"
    brake_light = "brake_light"


class Source(Named):
    """Who reported a fact; the sanity layer ranks them (docs/sanity.md)."""

    camera = "camera"
    radar = "radar"
    lidar = "lidar"
    ultrasonic = "ultrasonic"
    map = "map"
    fused = "fused"
    annotation = "annotation"


class LightColour(Named):
    red = "red"
    yellow = "yellow"
    green = "green"
    none = "none"


class ArrowDirection(Named):
    """The movement an arrow light governs; a light without one is a ball, governing the whole approach."""

    straight = "straight"
    left = "left"
    right = "right"


class SignKind(Named):
    stop = "stop"
    yield_ = "yield"
    speed_limit = "speed_limit"
    no_entry = "no_entry"
    school_zone = "school_zone"
    no_turn_on_red = "no_turn_on_red"


class IntersectionType(Named):
    t_intersect = "t_intersect"
    signaled = "signaled"
    unsignaled = "unsignaled"
    four_way = "four_way"
    roundabout = "roundabout"


class IntersectionStage(Named):
    arriving = "arriving"
    at = "at"
    enter = "enter"


class SensorSide(Named):
    front = "front"
    front_left = "front_left"
    front_right = "front_right"
    left = "left"
    right = "right"
    rear = "rear"
    rear_left = "rear_left"
    rear_right = "rear_right"


# The rules reason over 32-bit integers in centimetres and cm/s and square closing speeds, so every
# quantity is bounded where clingo's arithmetic stays exact: a value past these bounds is refused by name,
# never wrapped into a wrong (and possibly permissive) verdict.
MAX_RANGE_M = 10_000.0  # farther than any sensor sees
MAX_SPEED_MS = 150.0  # faster than any road vehicle; a closing speed of 300 m/s squared in cm/s fits 32 bits
MAX_ID = 2**31 - 1  # clingo's largest integer
MAX_LANE_ID = 1_000  # lanes are counted from the left, and the rules look one lane beyond
MAX_TIMESTAMP_S = 1e12  # 31,700 years either side of the clock's zero; in ms still a whole number a float holds exactly
MAX_FRAME_ID = 2**63 - 1  # a signed 64-bit counter, as planners and MCAP keep them
# More entries than any sensor suite reports in one frame. It also bounds what refusing a hostile payload costs:
# a list of 340,000 empty objects took the monitor 13 s to describe, error by error.
MAX_ITEMS = 1_000

Metres = Annotated[float, Field(ge=-MAX_RANGE_M, le=MAX_RANGE_M, allow_inf_nan=False)]
NonNegMetres = Annotated[float, Field(ge=0, le=MAX_RANGE_M, allow_inf_nan=False)]
Speed = Annotated[float, Field(ge=0, le=MAX_SPEED_MS, allow_inf_nan=False, description="m/s")]
MetresPerSecond = Annotated[float, Field(ge=-MAX_SPEED_MS, le=MAX_SPEED_MS, allow_inf_nan=False)]
MetresPerSecondSquared = Annotated[float, Field(allow_inf_nan=False)]
# Any printable text: the solver's strings end at a NUL, so control characters could make two ids one.
PathId = Annotated[str, Field(min_length=1, pattern=r"^[^\x00-\x1f\x7f]*$")]  # "" would read as no path at all
MAX_NOTE_LENGTH = 1_000
# Printed as they are (`discern check`, the audit): no control characters, C1's too (a terminal's escapes), and short.
Note = Annotated[str, Field(max_length=MAX_NOTE_LENGTH, pattern=r"^[^\x00-\x1f\x7f-\x9f]*$")]


class Strict(BaseModel):
    """Python code may build a model by field name (`cls=`); JSON always carries the schema's names ("class")."""

    model_config = ConfigDict(extra="forbid", populate_by_name=True, serialize_by_alias=True, use_enum_values=False)


# How JSON from outside (the wire, a file) is read: as the published JSON Schema says, no more. Lax mode would
# take "25" for a speed or true for a frame id; by name, "cls" for "class" (a name only Python code may use).
JSON_AS_SCHEMA = {"strict": True, "by_alias": True, "by_name": False}


class Vec2(Strict):
    x: Metres = 0.0
    y: Metres = 0.0


class Velocity(Strict):
    x: MetresPerSecond = 0.0
    y: MetresPerSecond = 0.0


class Ego(Strict):
    speed: Speed = Field(description="ego speed, m/s")
    lane: WholeNumber = Field(ge=1, le=MAX_LANE_ID, description="id of the ego's lane among the current lanes (1 = leftmost)")
    intent: Intent = Intent.continue_in_lane
    zone: Zone = Field(Zone.city, description="where the ego drives; omitted, a city is assumed (the strictest "
                       "usual limits) and the verdict's notes say so")
    acceleration: Optional[MetresPerSecondSquared] = Field(None, description="m/s^2, if known")
    predicted_path: Optional[PathId] = Field(None, description="id of the ego's predicted path")


# Each movement once, at least one: as a JSON Schema array it is `uniqueItems`, which pydantic does not check itself
# (Lane._movements_once_each does).
LaneMovements = Annotated[list[ArrowDirection], Field(min_length=1, max_length=len(ArrowDirection),
                                                       json_schema_extra={"uniqueItems": True})]


class Lane(Strict):
    kind: LaneKind
    id: WholeNumber = Field(ge=1, le=MAX_LANE_ID, description="1 = leftmost lane of its kind")
    ends_in: Optional[NonNegMetres] = Field(None, description="metres ahead where this lane ends")
    leaves_road: bool = Field(False, description="where it ends, this lane leaves the road (an exit or turn lane) "
                              "rather than dropping into the next lane")
    speed_limit: Optional[Speed] = Field(None, description="map speed limit of this lane, m/s")
    movements: Optional[LaneMovements] = Field(
        None, description="the movements this lane may make at the junction ahead (straight, left, right), as its lane-use "
        "arrows, signs or markings show them; a current lane's only. Omitted, they are not known: the ego's movement "
        "is then the proposed action's alone. A cruise, brake or accelerate from a lane that allows turns and no "
        "straight on is judged going each way the lane allows as well as straight on, so the lights for all of them "
        "govern it (a planner that turns proposes the turn); a turn the lane does not allow is forbidden coming up to "
        "the junction")

    @field_validator("movements")
    @classmethod
    def _movements_once_each(cls, movements: Optional[LaneMovements]) -> Optional[LaneMovements]:
        for movement in movements or ():
            if movements.count(movement) > 1:
                raise ValueError(f"movements lists {movement.value} twice")
        return movements

    @model_validator(mode="after")
    def _movements_of_a_current_lane(self) -> "Lane":
        """Lane-use arrows say which way the ego's road goes at the junction: an oncoming or crossing lane's would be
        read by no rule, and silently dropping what a producer sent would hide its mistake."""
        if self.movements is not None and self.kind is not LaneKind.current:
            raise ValueError(f"movements given for a lane of kind {self.kind.value}: only a current lane's lane-use "
                             "arrows are read (the movements the ego's road may make at the junction ahead)")
        return self


class LaneRef(Strict):
    kind: LaneKind
    id: WholeNumber = Field(ge=1, le=MAX_LANE_ID)


class Size(Strict):
    length: NonNegMetres
    width: NonNegMetres
    height: Optional[NonNegMetres] = None


class DetectedObject(Strict):
    id: WholeNumber = Field(ge=1, le=MAX_ID, description="object id; 0 is the ego")
    cls: ObjectClass = Field(alias="class")
    position: Vec2 = Field(description=(
        "metres relative to the ego: x right, centre to centre; y ahead, from the ego's nearest bumper to the "
        "object's nearest face (negative behind, 0 alongside), as a range sensor measures it: the rules compare y "
        "with gaps of free road"))
    lane: Optional[LaneRef] = None
    velocity: Optional[Velocity] = Field(
        None, description="ground velocity in the ego's axes, m/s (y: along the ego's heading)"
    )
    indicator: Indicator = Indicator.none
    emergency_lights: bool = Field(False, description="flashing red/blue lights seen in this frame")
    predicted_path: Optional[PathId] = None
    sources: list[Source] = Field(default_factory=lambda: [Source.camera], max_length=len(Source))
    elevation: Optional[Metres] = Field(None, description="height of the object's base above the road, m")
    size: Optional[Size] = None
    track_age: Optional[Annotated[int, Field(ge=0, le=MAX_ID), BeforeValidator(_whole)]] = Field(
        None, description="frames this track has existed")


class TrafficLight(Strict):
    colour: LightColour
    flashing: bool = False
    source: Source = Source.camera
    direction: Optional[ArrowDirection] = Field(
        None, description="the movement an arrow governs (straight, left or right); omitted, the light is a ball "
        "(a round light), which governs every movement no lit arrow governs")


class TrafficSign(Strict):
    kind: SignKind
    value: Optional[Speed] = Field(None, description="speed limit read off the sign, m/s")
    source: Source = Source.camera
    position: Optional[Vec2] = None
    confidence: Optional[float] = Field(None, ge=0, le=1)


class Intersection(Strict):
    type: IntersectionType
    stage: IntersectionStage = IntersectionStage.arriving
    road: Optional[Literal["major", "minor"]] = Field(None, description="road class of the ego's approach")
    arrival_rank: Optional[Annotated[int, Field(ge=1, le=MAX_ID), BeforeValidator(_whole)]] = Field(
        None, description="ego's arrival order at an all-way stop")
    distance: Optional[NonNegMetres] = Field(None, description="metres to the stop line")
    stop_line: bool = False
    stop_controlled: bool = Field(False, description="map data: the ego's approach is stop-controlled")


class RangeSensor(Named):
    """What measures a range: a map or a camera reports no distance reading."""

    radar = "radar"
    lidar = "lidar"
    ultrasonic = "ultrasonic"


class RangeReading(Strict):
    side: SensorSide
    distance: NonNegMetres
    kind: RangeSensor = RangeSensor.radar


class PathCrossing(Strict):
    ego_path: PathId
    object_path: PathId


class Scene(Strict):
    """One frame of the world as the planner saw it."""

    frame_id: WholeNumber = Field(ge=0, le=MAX_FRAME_ID)
    timestamp: float = Field(0.0, ge=-MAX_TIMESTAMP_S, le=MAX_TIMESTAMP_S, allow_inf_nan=False, description="seconds")
    ego: Ego
    speed_limit: Optional[Speed] = Field(None, description="limit in force as perceived, m/s")
    map_speed_limit: Optional[Speed] = Field(None, description="limit from map data, m/s")
    divided_road: bool = Field(
        False, description="a median or barrier divides the ego's road into separate roadways (map data)"
    )
    lanes: list[Lane] = Field(default_factory=list, max_length=MAX_ITEMS)
    objects: list[DetectedObject] = Field(default_factory=list, max_length=MAX_ITEMS)
    traffic_lights: list[TrafficLight] = Field(default_factory=list, max_length=MAX_ITEMS)
    signs: list[TrafficSign] = Field(default_factory=list, max_length=MAX_ITEMS)
    intersection: Optional[Intersection] = None
    sensors: list[RangeReading] = Field(default_factory=list, max_length=MAX_ITEMS)
    path_crossings: list[PathCrossing] = Field(default_factory=list, max_length=MAX_ITEMS)
    notes: list[Note] = Field(default_factory=list, max_length=MAX_ITEMS, description="warnings from the adapter or validation")

    @field_validator("objects")
    @classmethod
    def _unique_object_ids(cls, objects: list[DetectedObject]) -> list[DetectedObject]:
        seen: set[int] = set()
        for obj in objects:
            if obj.id in seen:
                raise ValueError(f"object id {obj.id} appears twice")
            seen.add(obj.id)
        return objects

    @field_validator("lanes")
    @classmethod
    def _ego_lane_listed(cls, lanes: list[Lane], info: ValidationInfo) -> list[Lane]:
        # A field check, not the scene's: it is reported beside the other fields' problems (a duplicate object
        # id), where a check of the whole scene runs only once every field is valid.
        ego = info.data.get("ego")
        current = sorted(l.id for l in lanes if l.kind is LaneKind.current)
        if ego is not None and current and ego.lane not in current:
            raise ValueError(f"ego.lane {ego.lane} does not exist: current lanes are {current}")
        return lanes

    @model_validator(mode="after")
    def _lanes_consistent(self) -> "Scene":
        if "zone" not in self.ego.model_fields_set:  # the limits' plausibility rests on it: say it was not given
            self.notes.append("ego.zone not given: a city zone is assumed, whose usual limits may doubt the readings "
                              "of a faster road")
        if not any(l.kind is LaneKind.current for l in self.lanes):
            # The ego stands in a lane even when the frame lists none.
            self.lanes.append(Lane(kind=LaneKind.current, id=self.ego.lane))
            self.notes.append(f"no current lanes given: assuming only the ego's lane {self.ego.lane}")
        known = {(l.kind, l.id) for l in self.lanes}
        for obj in self.objects:
            if obj.lane is not None and (obj.lane.kind, obj.lane.id) not in known:
                # A detection beyond the mapped lanes is still an obstacle: keep it.
                # A same-direction label naming no listed lane places it nowhere: the rules place it by its
                # measured position (def.lane_from_offset); another kind's label still says which way it goes.
                placed = (", and placed by its measured position, as one reported without a lane is"
                          if obj.lane.kind is LaneKind.current else "")
                self.notes.append(
                    f"object {obj.id} is in lane {obj.lane.kind.value}/{obj.lane.id}, "
                    f"which the scene does not list; kept{placed}"
                )
        object_paths = {o.predicted_path for o in self.objects if o.predicted_path is not None}
        for crossing in self.path_crossings:  # one that cannot apply is said so, not dropped unseen
            if crossing.ego_path != self.ego.predicted_path:
                self.notes.append(f"path crossing {crossing.ego_path!r}/{crossing.object_path!r}: "
                                  f"{crossing.ego_path!r} is not the ego's predicted path; it cannot apply")
            if crossing.object_path not in object_paths:
                self.notes.append(f"path crossing {crossing.ego_path!r}/{crossing.object_path!r}: "
                                  f"{crossing.object_path!r} is no object's predicted path; it cannot apply")
        return self


MAX_ID_LENGTH = 128
ID_RULE = f"[A-Za-z0-9_-]{{1,{MAX_ID_LENGTH}}}"  # a vehicle or monitor id: one zenoh key chunk
_ID = re.compile(ID_RULE)


def valid_id(text: str) -> bool:
    """Whether `text` is a vehicle or monitor id as the protocol's keys and the Proposal's schema take it."""
    return _ID.fullmatch(text) is not None


class Proposal(Strict):
    """What the planner asks the monitor to judge: one message, one frame."""

    version: Version = SCHEMA_VERSION
    vehicle: str = Field("ego", min_length=1, max_length=MAX_ID_LENGTH, pattern=f"^{ID_RULE}$")
    action: Action
    scene: Scene
    explain: bool = Field(False, description="ask for the full justification tree")


# A field name is short: a longer one is an unknown key, which could be any size (a refusal repeats its line
# in the verdict's error, summary and text, and in the log). Cut, it still names the problem; so does a line
# cut to MAX_PROBLEM, longer than any the schema's own names make.
MAX_PATH_PART = 64
MAX_PROBLEM = 300
MAX_VALUE_SHOWN = 60


class _JsonRepr(reprlib.Repr):
    """Values as the sender wrote them in JSON: null, true and false, not Python's None, True and False."""

    def repr_NoneType(self, value: None, level: int) -> str:
        return "null"

    def repr_bool(self, value: bool, level: int) -> str:
        return "true" if value else "false"


# An offending value in a few dozen characters, without writing out the whole of it first (a list of thousands
# of objects). Set attribute by attribute: Repr takes no arguments before Python 3.12.
_BRIEF = _JsonRepr()
_BRIEF.maxlevel, _BRIEF.maxlist, _BRIEF.maxdict = 2, 3, 3
_BRIEF.maxstring = _BRIEF.maxother = _BRIEF.maxlong = MAX_VALUE_SHOWN


def _shown(value: object) -> str:
    if type(value) is int and value.bit_length() > 4096:  # Python will not write it out (over 4,300 digits)
        return f"an integer of about {int(value.bit_length() * 0.30103) + 1} digits"
    return _BRIEF.repr(value)[:MAX_VALUE_SHOWN]


def _cut(text: str, limit: int) -> str:
    return text if len(text) <= limit else f"{text[:limit]}... (cut from {len(text)} characters)"


def describe_error(err: dict) -> str:
    """One problem of a ValidationError (an item of `errors()`) in words, with the offending value, without its field."""
    message = err["msg"].removeprefix("Value error, ")
    if err["type"] == "enum":
        expected = err.get("ctx", {}).get("expected", "")
        return f"unknown value {_shown(err['input'])} (expected one of {expected})"
    if err["type"] == "missing":
        return "is required but missing"
    if err["type"] != "value_error" and "input" in err and err["type"] not in ("model_type", "dict_type"):
        return f"{message} (got {_shown(err['input'])})"
    return message


def describe_errors(exc: ValidationError, root: str = "", limit: Optional[int] = None) -> str:
    """One line per problem, naming the field path, the problem and the offending value; each line bounded.

    `limit`: describe only the first problems and count the rest. A hostile payload can carry a hundred
    thousand problems; the monitor names a few and moves on.
    """
    errors = exc.errors(include_url=False)
    lines = []
    for err in errors[:limit]:
        # a whole-scene check names its fields itself
        path = ".".join(_cut(str(p), MAX_PATH_PART) for p in (root, *err["loc"]) if p != "")
        message = describe_error(err)
        lines.append(_cut(f"{path}: {message}" if path else message, MAX_PROBLEM))
    if len(errors) > len(lines):
        lines.append(f"... and {len(errors) - len(lines)} more")
    return "\n".join(lines)
