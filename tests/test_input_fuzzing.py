"""Generated input, not hand-picked cases: whatever arrives is decided or refused by name, never a crash.

Scenes come from the published JSON Schema itself (hypothesis-jsonschema), so every corner the schema
admits is tried: extreme but allowed numbers, any unicode in ids, empty and long lists. The runs are
derandomized so that CI sees the same examples every time.
"""

import json
import math
from pathlib import Path

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from hypothesis_jsonschema import from_schema
from pydantic import ValidationError

from discern.adapters.avcsr import AvcsrError, read_file
from discern.monitor.protocol import InputError, decode_proposal
from discern.rules.render import render_html, render_json
from discern.rules.scene import Action, Scene, describe_errors
from tests.test_avcsr_adapter import FRAME

SCHEMAS = Path(__file__).resolve().parents[1] / "rules" / "schema"
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
            "objects": [{"id": 1, "class": "pedestrian", "position": {"x": 30, "y": 60}, "predicted_path": 'kreuz"ung'}],
            "path_crossings": [{"ego_path": "straße 2", "object_path": crossing}],
        })

    assert "brake.path_crossing" in reasoner.decide(scene('kreuz"ung'), Action.cruise).rules
    assert reasoner.decide(scene("kreuzung"), Action.cruise).decision.value == "approve"


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
