"""Generated input, not hand-picked cases: whatever arrives is decided or refused by name, never a crash.

Scenes come from the published JSON Schema itself (hypothesis-jsonschema), so every corner the schema
admits is tried: extreme but allowed numbers, any unicode in ids, empty and long lists. The runs are
derandomized so that CI sees the same examples every time.
"""

import json
import math
import re
from pathlib import Path

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from hypothesis_jsonschema import from_schema
from pydantic import ValidationError

from discern.adapters.avcsr import AvcsrError, read_file
from discern.monitor.protocol import InputError, decode_proposal
from discern.rules.render import render_html, render_json
from discern.rules.scene import Action, Proposal, Scene, describe_errors
from tests.test_avcsr_adapter import FRAME

SCHEMAS = Path(__file__).resolve().parents[1] / "rules" / "schema"
PROPOSAL = Proposal.model_validate({
    "vehicle": "car_1", "action": "cruise",
    "scene": {"frame_id": 1, "ego": {"speed": 25.0, "lane": 1}, "lanes": [{"kind": "current", "id": 1}],
              "objects": [{"id": 1, "class": "car", "position": {"x": 0.0, "y": 40.0}}]},
})
SCENE_SCHEMA = json.loads((SCHEMAS / "scene.schema.json").read_text())
PROPOSAL_SCHEMA = json.loads((SCHEMAS / "proposal.schema.json").read_text())

FUZZ = settings(max_examples=120, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))


@FUZZ
@given(document=from_schema(SCENE_SCHEMA), proposed=st.sampled_from(list(Action)), explain=st.booleans())
def test_every_scene_the_schema_admits_is_decided_or_refused_by_field(reasoner, document, proposed, explain):
    try:
        scene = Scene.model_validate(document)
    except ValidationError as exc:
        # Only the cross-field checks (lanes, duplicate ids) refuse what the schema admits; they name the field.
        lines = describe_errors(exc).splitlines()
        assert lines and all(": " in line for line in lines)
        return
    verdict = reasoner.decide(scene, proposed, explain=explain)
    assert (verdict.decision.value == "approve") == (proposed in verdict.permitted)
    if verdict.decision.value == "approve":
        assert verdict.action is proposed
    else:
        assert verdict.action in verdict.permitted or verdict.action is Action.brake
        assert verdict.rules and all(rule in reasoner.catalog.by_id for rule in verdict.rules)
    assert verdict.justification.summary and math.isfinite(verdict.latency_ms)
    assert json.loads(render_json(verdict))["decision"] == verdict.decision.value
    assert "<html" in render_html(verdict)


@FUZZ
@given(payload=st.one_of(
    st.binary(max_size=300),
    from_schema(PROPOSAL_SCHEMA).map(lambda d: json.dumps(d).encode()),
    from_schema(PROPOSAL_SCHEMA).map(lambda d: json.dumps(d).encode()[: len(json.dumps(d)) // 2]),
))
def test_any_bytes_on_a_proposal_key_decode_or_name_their_problem(payload):
    try:
        proposal = decode_proposal(payload, "car_1")
    except InputError as exc:
        assert exc.kind in {"json", "schema", "vehicle"} and str(exc)
        return
    assert proposal.vehicle == "car_1"


@FUZZ
@given(document=from_schema(PROPOSAL_SCHEMA))
def test_every_proposal_the_schema_admits_decodes_strictly_or_fails_only_a_cross_field_check(document):
    """Strict decoding refuses only what the schema refuses: a JSON integer is still a number, an enum its string."""
    try:
        decode_proposal(json.dumps(document).encode(), document.get("vehicle", "car_1"))
    except InputError as exc:
        # the lanes (the ego's, and whose lane-use movements), and the object ids are checked across fields, which a
        # JSON Schema cannot say; and the schema's pattern lets Python's `$` take a vehicle id ending in a newline,
        # which no key holds
        assert exc.kind == "vehicle" or any(
            problem in str(exc) for problem in ("does not exist: current lanes are", "appears twice",
                                                "movements given for a lane of kind")
        ), str(exc)


@pytest.mark.parametrize("path, value, expected", [
    (("scene", "frame_id"), True, "scene.frame_id: Input should be a valid integer (got true)"),
    (("scene", "frame_id"), "7", "scene.frame_id: Input should be a valid integer (got '7')"),
    (("scene", "ego", "speed"), "25", "scene.ego.speed: Input should be a valid number (got '25')"),
    (("scene", "ego", "lane"), "2", "scene.ego.lane: Input should be a valid integer (got '2')"),
    (("scene", "objects", 0, "emergency_lights"), "false", "scene.objects.0.emergency_lights: Input should be a valid"),
    (("explain",), "yes", "explain: Input should be a valid boolean (got 'yes')"),
    (("explain",), 1, "explain: Input should be a valid boolean (got 1)"),
    (("version",), "1", "version: Input should be 1 (got '1')"),
    (("version",), True, "version: Input should be 1 (got true)"),
    (("scene", "ego", "lane"), 1.5, "scene.ego.lane: Input should be a valid integer (got 1.5)"),
])
def test_a_wire_value_of_another_json_type_than_the_schema_says_is_refused_not_converted(path, value, expected):
    document = json.loads(PROPOSAL.model_dump_json(by_alias=True))
    target = document
    for key in path[:-1]:
        target = target[key]
    target[path[-1]] = value
    with pytest.raises(InputError) as refused:
        decode_proposal(json.dumps(document).encode(), "car_1")
    assert refused.value.kind == "schema" and str(refused.value).startswith(f"schema violation: {expected}")


def test_json_integers_are_numbers_and_enum_strings_are_their_values_on_the_wire():
    payload = (b'{"action": "cruise", "scene": {"frame_id": 3, "timestamp": 2, "ego": {"speed": 25, "lane": 1, '
               b'"zone": "highway"}, "lanes": [{"kind": "current", "id": 1}], "objects": [{"id": 1, "class": "car", '
               b'"position": {"x": 0, "y": 40}, "velocity": {"x": 0, "y": 20}, "sources": ["camera", "radar"]}]}}')
    proposal = decode_proposal(payload, "car_1")
    assert proposal.scene.ego.speed == 25.0 and isinstance(proposal.scene.ego.speed, float)
    assert proposal.action is Action.cruise and proposal.scene.objects[0].cls.value == "car"


def test_a_whole_number_written_with_a_fraction_is_the_integer_json_schema_takes_it_for():
    """JSON Schema's "integer" is any number without a fraction: a planner that checks its messages against the
    published schema must not be refused by the monitor for writing 3.0."""
    payload = (b'{"version": 1.0, "action": "cruise", "scene": {"frame_id": 3.0, "ego": {"speed": 25, "lane": 1.0}, '
               b'"lanes": [{"kind": "current", "id": 1.0}], "objects": [{"id": 7.0, "class": "car", "track_age": 2.0, '
               b'"position": {"x": 0, "y": 40}}]}}')
    proposal = decode_proposal(payload, "car_1")
    scene = proposal.scene
    assert (proposal.version, scene.frame_id, scene.ego.lane, scene.lanes[0].id) == (1, 3, 1, 1)
    assert (scene.objects[0].id, scene.objects[0].track_age) == (7, 2) and type(scene.frame_id) is int


def test_a_field_under_its_python_name_is_refused_on_the_wire_as_the_schema_does():
    """The schema names an object's class "class"; "cls" is only Python's name for it."""
    payload = (b'{"action": "cruise", "scene": {"frame_id": 3, "ego": {"speed": 25, "lane": 1}, '
               b'"lanes": [{"kind": "current", "id": 1}], "objects": [{"id": 1, "cls": "car", '
               b'"position": {"x": 0, "y": 40}}]}}')
    with pytest.raises(InputError) as refused:
        decode_proposal(payload, "car_1")
    assert refused.value.kind == "schema" and "scene.objects.0.class" in str(refused.value)


SCENARIO_FILES = sorted((Path(__file__).resolve().parents[1] / "scenarios").rglob("*.json"))


@pytest.mark.parametrize("path", SCENARIO_FILES, ids=lambda p: p.name)
def test_every_scene_of_the_scenario_files_decodes_strictly_as_a_proposal(path):
    """The scenes written by hand, numbers and all, are what a planner may send as they are."""
    frames = json.loads(path.read_text(encoding="utf-8"))["frames"]
    for frame in frames:
        payload = json.dumps({"action": frame["proposed"], "scene": frame["scene"]}).encode()
        assert decode_proposal(payload, "car_1").scene.frame_id == frame["scene"]["frame_id"]


def test_a_huge_unknown_key_is_named_cut_short_in_a_bounded_reason():
    document = json.loads(PROPOSAL.model_dump_json(by_alias=True))
    document["scene"]["k" * 300_000] = 1
    document["scene"]["objects"] = [{"j" * 300_000: 1}]
    with pytest.raises(InputError) as refused:
        decode_proposal(json.dumps(document).encode(), "car_1")
    reason = str(refused.value)
    assert f"scene.{'k' * 64}... (cut from 300000 characters): Extra inputs are not permitted" in reason
    assert f"scene.objects.0.{'j' * 64}... (cut from 300000 characters)" in reason
    assert len(reason) < 1000


def test_a_list_past_its_bound_is_refused_by_its_length_alone():
    """340,000 empty objects once meant a million problems, each described: 13 s of a monitor's worker."""
    document = json.loads(PROPOSAL.model_dump_json(by_alias=True))
    document["scene"]["objects"] = [{}] * 340_000
    with pytest.raises(InputError) as refused:
        decode_proposal(json.dumps(document).encode(), "car_1")
    reason = str(refused.value)
    assert reason.startswith("schema violation: scene.objects: List should have at most 1000 items after "
                             "validation, not 340000 (got [{}, {}, {}, ...])")
    assert len(reason) < 300


def test_a_payload_of_many_problems_names_the_first_few_and_counts_the_rest():
    document = json.loads(PROPOSAL.model_dump_json(by_alias=True))
    document["scene"]["objects"] = [{"id": i, "class": "zeppelin", "position": {"x": "left", "y": 1}}
                                    for i in range(1, 1001)]
    with pytest.raises(InputError) as refused:
        decode_proposal(json.dumps(document).encode(), "car_1")
    named = str(refused.value).removeprefix("schema violation: ").split("; ")
    assert named[0].startswith("scene.objects.0.class: unknown value 'zeppelin' (expected one of 'car'")
    assert named[1] == "scene.objects.0.position.x: Input should be a valid number (got 'left')"
    assert len(named) == 6 and named[-1] == "... and 1995 more"


def test_a_range_reading_comes_from_a_range_sensor():
    document = {"frame_id": 1, "ego": {"speed": 10, "lane": 1}, "sensors": [{"side": "front", "distance": 0.3,
                                                                            "kind": "map"}]}
    with pytest.raises(ValidationError) as refused:
        Scene.model_validate(document)
    assert describe_errors(refused.value) == (
        "sensors.0.kind: unknown value 'map' (expected one of 'radar', 'lidar' or 'ultrasonic')")


def test_a_frame_id_past_64_bits_is_refused_by_name():
    with pytest.raises(ValidationError) as refused:
        Scene.model_validate({"frame_id": 2**63, "ego": {"speed": 10, "lane": 1}})
    assert describe_errors(refused.value).startswith("frame_id: Input should be less than or equal to 9223372036854775807")


def test_an_overlong_vehicle_id_is_named_too_long_and_shown_short():
    with pytest.raises(InputError) as refused:
        decode_proposal(PROPOSAL.model_dump_json(exclude={"vehicle"}).encode(), "v" * 20_000)
    assert str(refused.value) == (f"vehicle {'v' * 40!r}... (20000 characters) in the key is not a valid vehicle id: "
                                  "longer than 128 characters")


def test_a_problem_past_its_length_is_cut_saying_so():
    lanes = [{"kind": "current", "id": i} for i in range(1, 1001)]
    with pytest.raises(ValidationError) as refused:
        Scene.model_validate({"frame_id": 1, "ego": {"speed": 1, "lane": 1000}, "lanes": lanes[:-1]})
    [line] = describe_errors(refused.value).splitlines()
    assert line.startswith("lanes: ego.lane 1000 does not exist: current lanes are [1, 2, 3")
    assert re.search(r"\.\.\. \(cut from 49\d\d characters\)$", line) and len(line) < 350


@FUZZ
@given(edits=st.lists(
    st.tuples(st.integers(0, len(FRAME)), st.integers(0, 3), st.text(max_size=3)), min_size=1, max_size=4,
))
def test_a_mangled_avcsr_file_reads_or_names_its_problem(tmp_path_factory, edits):
    text = FRAME
    for at, drop, insert in edits:
        text = text[:at] + insert + text[at + drop:]
    path = tmp_path_factory.mktemp("avcsr") / "frame.pl"
    path.write_text(text, encoding="utf-8")
    try:
        frames = read_file(path)
    except AvcsrError as exc:
        assert str(path) in str(exc)
        return
    assert all(isinstance(frame.scene, Scene) for frame in frames)


@pytest.mark.parametrize("field, value", [
    (("ego", "speed"), 500.0),
    (("objects", 0, "velocity", "y"), -1e8),
    (("objects", 0, "position", "y"), 1e9),
    (("objects", 0, "id"), 2**40),
])
def test_numbers_past_the_solvers_integers_are_refused_by_name(field, value):
    document = {
        "frame_id": 1,
        "ego": {"speed": 10, "lane": 1},
        "objects": [{"id": 1, "class": "car", "position": {"x": 0, "y": 30}, "velocity": {"x": 0, "y": 5}}],
    }
    target = document
    for key in field[:-1]:
        target = target[key]
    target[field[-1]] = value
    with pytest.raises(ValidationError) as refused:
        Scene.model_validate(document)
    assert describe_errors(refused.value).startswith(".".join(map(str, field)) + ":")


def test_unicode_and_quotes_in_path_ids_reach_the_rules(reasoner):
    def scene(crossing: str) -> Scene:
        return Scene.model_validate({
            "frame_id": 1,
            "ego": {"speed": 10, "lane": 1, "predicted_path": "straße 2"},
            "objects": [{"id": 1, "class": "pedestrian", "position": {"x": 30, "y": 20}, "predicted_path": 'kreuz"ung'}],
            "path_crossings": [{"ego_path": "straße 2", "object_path": crossing}],
        })

    assert "brake.path_crossing" in reasoner.decide(scene('kreuz"ung'), Action.cruise).rules
    assert reasoner.decide(scene("kreuzung"), Action.cruise).decision.value == "approve"


@pytest.mark.parametrize("field", ["ego", "object", "ego_path", "object_path"])
def test_an_empty_path_id_is_refused_by_name_not_read_as_no_path(field):
    """'' read as 'no path' dropped a declared crossing: the monitor approved speeding up towards it."""
    document = {
        "frame_id": 1,
        "ego": {"speed": 10, "lane": 1, "predicted_path": "" if field == "ego" else "p"},
        "objects": [{"id": 3, "class": "car", "position": {"x": 0, "y": 12}, "predicted_path": "" if field == "object" else "q"}],
        "path_crossings": [{"ego_path": "" if field == "ego_path" else "p", "object_path": "" if field == "object_path" else "q"}],
    }
    with pytest.raises(ValidationError) as refused:
        Scene.model_validate(document)
    where = {"ego": "ego.predicted_path", "object": "objects.0.predicted_path",
             "ego_path": "path_crossings.0.ego_path", "object_path": "path_crossings.0.object_path"}[field]
    assert describe_errors(refused.value).startswith(f"{where}: String should have at least 1 character")


def test_a_path_crossing_naming_no_path_in_the_scene_is_noted():
    scene = Scene.model_validate({
        "frame_id": 1, "ego": {"speed": 10, "lane": 1, "predicted_path": "p", "zone": "city"},
        "lanes": [{"kind": "current", "id": 1}],
        "objects": [{"id": 3, "class": "car", "position": {"x": 0, "y": 12}, "predicted_path": "q"}],
        "path_crossings": [{"ego_path": "p", "object_path": "q"}, {"ego_path": "e", "object_path": "zz"}],
    })
    assert scene.notes == ["path crossing 'e'/'zz': 'e' is not the ego's predicted path; it cannot apply",
                           "path crossing 'e'/'zz': 'zz' is no object's predicted path; it cannot apply"]


def test_control_characters_in_path_ids_are_refused_by_name():
    with pytest.raises(ValidationError) as refused:
        Scene.model_validate({"frame_id": 1, "ego": {"speed": 0, "lane": 1, "predicted_path": "a\x00b"}})
    assert describe_errors(refused.value).startswith("ego.predicted_path: String should match pattern")


@given(st.text(min_size=1, max_size=130))
@example("car\n")
@example("c" * 128)
def test_a_vehicle_id_is_valid_alike_in_the_key_the_client_and_the_schema(vehicle):
    """One rule for ids: a key the monitor takes is a vehicle the schema and the client take too ('car\\n' was not)."""
    from discern.monitor.client import Monitor
    from discern.rules.scene import Proposal

    scene = Scene.model_validate({"frame_id": 1, "timestamp": 0.0, "ego": {"speed": 1.0, "lane": 1},
                                  "lanes": [{"kind": "current", "id": 1}]})
    try:
        decode_proposal(Proposal(action="cruise", scene=scene).model_dump_json(exclude={"vehicle"}).encode(), vehicle)
        by_key = True
    except InputError:
        by_key = False
    try:
        Proposal(vehicle=vehicle, action="cruise", scene=scene)
        by_schema = True
    except ValidationError:
        by_schema = False
    with pytest.raises(ValueError) as refused:  # the style, checked after the vehicle, stops it from connecting
        Monitor(vehicle=vehicle, style="nonsense")
    by_client = str(refused.value).startswith("style")
    assert by_key == by_schema == by_client, vehicle
    assert not by_key or vehicle.strip("\n") == vehicle


def test_a_scene_without_its_zone_is_judged_as_in_a_city_and_says_so():
    scene = Scene.model_validate({"frame_id": 1, "ego": {"speed": 10, "lane": 1}})
    assert scene.ego.zone.value == "city"
    assert any(n.startswith("ego.zone not given: a city zone is assumed") for n in scene.notes)
    given = Scene.model_validate({"frame_id": 1, "ego": {"speed": 10, "lane": 1, "zone": "city"}})
    assert not any(n.startswith("ego.zone") for n in given.notes)


@pytest.mark.parametrize("lane, problem", [
    ({"kind": "current", "id": 1, "movements": []}, "lanes.0.movements: List should have at least 1 item"),
    ({"kind": "current", "id": 1, "movements": ["left", "straight", "left"]}, "lanes.0.movements: movements lists left twice"),
    ({"kind": "current", "id": 1, "movements": ["u_turn"]}, "lanes.0.movements.0: unknown value 'u_turn'"),
    ({"kind": "oncoming", "id": 1, "movements": ["left"]},
     "lanes.0: movements given for a lane of kind oncoming: only a current lane's lane-use arrows are read"),
])
def test_lane_use_movements_that_say_nothing_or_belong_to_no_current_lane_are_refused_by_name(lane, problem):
    """An empty or repeated list, or arrows on a lane no rule reads them of, is a producer's mistake: named, not dropped."""
    with pytest.raises(ValidationError) as refused:
        Scene.model_validate({"frame_id": 1, "ego": {"speed": 0, "lane": 1}, "lanes": [lane]})
    assert describe_errors(refused.value).startswith(problem)
    assert SCENE_SCHEMA["$defs"]["Lane"]["properties"]["movements"]["anyOf"][0]["uniqueItems"] is True  # as published
