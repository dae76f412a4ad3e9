"""Bad input gets a fail-safe verdict naming the problem, is counted, and the monitor keeps serving."""

from __future__ import annotations

import json
import math
import threading

import pytest
import zenoh

from discern.monitor.client import Monitor
from discern.monitor.config import ZenohSettings
from discern.monitor.example_planner import highway_scene
from discern.monitor.log import read_log
from discern.monitor.protocol import (CAUTION_ORDER, RULE_BAD_INPUT, InputError, decode_proposal, failsafe_verdict,
                                      most_cautious, peek_frame)
from discern.monitor.server import EXCERPT_BYTES
from discern.rules.scene import Action, Proposal
from discern.rules.verdict import Decision, Verdict
from tests.monitor_process import serve, status, wait_until

pytestmark = pytest.mark.wall_clock  # run alone: see the marker in pyproject.toml

MAX_PAYLOAD = 8192


@pytest.fixture(scope="module")
def log_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("bad-log")


@pytest.fixture(scope="module")
def monitor(log_dir):
    proc, ep = serve(
        "--id", "bad", "--budget-ms", "5000", "--max-payload-bytes", str(MAX_PAYLOAD),
        "--log-dir", str(log_dir), "--log-flush-s", "0.05",
    )
    yield ep, proc
    assert proc.stop() == 0, proc.output


@pytest.fixture(scope="module")
def session(monitor):
    s = zenoh.open(ZenohSettings(listen=[], connect=[monitor[0]]).to_zenoh())
    yield s
    s.close()


def ask(session, key: str, payload: bytes) -> Verdict:
    replies = [r.ok for r in session.get(key, payload=payload, timeout=10) if r.ok is not None]
    assert len(replies) == 1, f"expected one verdict on {key}, got {len(replies)}"
    return Verdict.model_validate_json(replies[0].payload.to_bytes())


def proposal(vehicle: str, frame: int = 1, action: str = "cruise", **override) -> dict:
    data = json.loads(Proposal(vehicle=vehicle, action=action, scene=highway_scene(frame, 3)).model_dump_json(by_alias=True))
    data.update(override)
    return data


def with_scene(vehicle: str, path: tuple, value) -> bytes:
    data = proposal(vehicle)
    node = data["scene"]
    for part in path[:-1]:
        node = node[part]
    node[path[-1]] = value
    return json.dumps(data).encode()


BAD = {
    "malformed_json": (b'{"action": "cruise", "scene": {', "malformed JSON", "json"),
    "not_json": (b"\xff\xfe\x00garbage", "malformed JSON", "json"),
    "empty": (b"", "empty payload", "json"),
    "unknown_class": (
        lambda v: with_scene(v, ("objects", 0, "class"), "ufo"),
        "scene.objects.0.class: unknown value 'ufo'",
        "schema",
    ),
    "nan": (
        lambda v: with_scene(v, ("ego", "speed"), "NaN").replace(b'"NaN"', b"NaN"),
        "scene.ego.speed: Input should be a finite number",
        "schema",
    ),
    "out_of_range": (
        lambda v: with_scene(v, ("objects", 0, "velocity", "y"), 1e8),
        "scene.objects.0.velocity.y: Input should be less than or equal to 150",
        "schema",
    ),
    "infinity": (
        lambda v: with_scene(v, ("objects", 1, "position", "y"), 1).replace(b'"y": 1}', b'"y": 1e999}'),
        "scene.objects.1.position.y: Input should be a finite number",
        "schema",
    ),
    "missing_action": (
        lambda v: json.dumps({k: x for k, x in proposal(v).items() if k != "action"}).encode(),
        "action: is required but missing",
        "schema",
    ),
    "unknown_action": (lambda v: json.dumps(proposal(v, action="cruise") | {"action": "fly"}).encode(), "action: unknown value 'fly'", "schema"),
    "wrong_version": (lambda v: json.dumps(proposal(v) | {"version": 2}).encode(), "version", "schema"),
    "oversized": (lambda v: json.dumps(proposal(v) | {"pad": "x" * MAX_PAYLOAD}).encode(), f"exceeds the limit of {MAX_PAYLOAD} bytes", "size"),
    "other_vehicle": (lambda v: json.dumps(proposal("somebody_else")).encode(), "payload names 'somebody_else'", "vehicle"),
    # decoded strictly, by JSON type as the published schema reads it: nothing is converted
    "speed_as_text": (
        lambda v: with_scene(v, ("ego", "speed"), "25"), "scene.ego.speed: Input should be a valid number (got '25')",
        "schema",
    ),
    "lane_as_text": (
        lambda v: with_scene(v, ("ego", "lane"), "2"), "scene.ego.lane: Input should be a valid integer (got '2')",
        "schema",
    ),
    "frame_id_as_boolean": (
        lambda v: with_scene(v, ("frame_id",), True), "scene.frame_id: Input should be a valid integer (got true)",
        "schema",
    ),
    "explain_as_text": (
        lambda v: json.dumps(proposal(v) | {"explain": "yes"}).encode(), "explain: Input should be a valid boolean",
        "schema",
    ),
    "control_character_in_a_note": (
        lambda v: with_scene(v, ("notes",), ["\x1b[2J\x1b]0;owned\x07"]), "scene.notes.0: String should match pattern",
        "schema",
    ),
    "long_note": (
        lambda v: with_scene(v, ("notes",), ["x" * 1001]), "scene.notes.0: String should have at most 1000 characters",
        "schema",
    ),
    "explain_as_number": (
        lambda v: json.dumps(proposal(v) | {"explain": 1}).encode(), "explain: Input should be a valid boolean (got 1)",
        "schema",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_input_gets_a_failsafe_brake_naming_the_problem(session, case):
    payload, expected, _ = BAD[case]
    vehicle = f"bad_{case}"
    verdict = ask(session, f"discern/{vehicle}/check", payload(vehicle) if callable(payload) else payload)
    assert verdict.decision is Decision.override and verdict.action is Action.brake and verdict.failsafe
    assert expected in verdict.error, verdict.error
    assert verdict.vehicle == vehicle and verdict.rules == ["monitor.bad_input"]
    assert verdict.justification.summary.startswith("fail-safe brake")


def test_a_refusal_of_a_huge_unknown_key_names_it_cut_short(session, monitor):
    key = "k" * 6000  # the payload stays under this monitor's limit; the cut is the same for 300 KB
    verdict = ask(session, "discern/long_key/check", with_scene("long_key", (key,), 1))
    assert verdict.rules == ["monitor.bad_input"] and verdict.frame_id == 1
    assert verdict.error.startswith(f"schema violation: scene.{'k' * 64}... (cut from 6000 characters): ")
    assert "Extra inputs are not permitted" in verdict.error and len(verdict.error) < 200
    assert len(verdict.justification.summary) < 250 and len(verdict.justification.text) < 250
    _, proc = monitor
    assert wait_until(lambda: any("long_key" in line for line in proc.lines))
    assert max(len(line) for line in proc.lines) < 1000  # the warning on stderr too


def test_duplicate_and_out_of_order_frames_are_refused(session):
    key = "discern/replayer/check"
    assert not ask(session, key, json.dumps(proposal("replayer", frame=5)).encode()).failsafe
    duplicate = ask(session, key, json.dumps(proposal("replayer", frame=5)).encode())
    older = ask(session, key, json.dumps(proposal("replayer", frame=3)).encode())
    assert duplicate.failsafe and "duplicate frame 5" in duplicate.error
    assert older.failsafe and "out-of-order frame 3" in older.error and older.frame_id == 3
    assert not ask(session, key, json.dumps(proposal("replayer", frame=6)).encode()).failsafe


def test_an_invalid_vehicle_in_the_key_is_answered_on_that_key_and_logged_apart_from_every_vehicle(session, log_dir):
    verdict = ask(session, "discern/not.a.vehicle/check", json.dumps(proposal("x")).encode())
    assert verdict.failsafe and "not a valid vehicle id" in verdict.error
    # `_invalid` is a valid vehicle id: its own records must not mix with those of keys naming no vehicle
    assert not ask(session, "discern/_invalid/check", json.dumps(proposal("_invalid")).encode()).failsafe

    def logged():
        return {(r.vehicle, r.kind) for r in read_log(log_dir) if r.vehicle in ("@invalid", "_invalid")}

    wait_until(lambda: {("@invalid", "rejected"), ("_invalid", "proposal")} <= logged())
    assert ("_invalid", "rejected") not in logged()


def test_an_oversized_payload_is_logged_with_an_excerpt_of_its_first_bytes(session, log_dir):
    padded = {"pad": "é" * MAX_PAYLOAD} | proposal("big_one")  # two bytes a character: the excerpt ends mid-character
    payload = json.dumps(padded, ensure_ascii=False).encode()
    verdict = ask(session, "discern/big_one/check", payload)
    assert verdict.failsafe and "exceeds the limit" in verdict.error

    def rejected():  # the log is read while the monitor writes it
        return [r.rejected for r in read_log(log_dir) if r.vehicle == "big_one" and r.kind == "rejected"]

    [record] = wait_until(rejected)
    assert record.size == len(payload) and "exceeds the limit" in record.error
    assert record.excerpt == payload[:EXCERPT_BYTES].decode("utf-8", "replace")


WILDCARD_KEYS = ("discern/*/check", "discern/**/check", "discern/car_$*/check", "discern/wild/*")


def test_a_wildcard_key_or_an_invalid_vehicle_id_is_refused_as_an_error_and_never_counted_as_a_vehicle(session, monitor):
    ep, _ = monitor
    [before] = status(ep, "bad")
    for key in WILDCARD_KEYS:
        verdict = ask(session, key, json.dumps(proposal("wild")).encode())
        assert verdict.failsafe and verdict.rules == ["monitor.bad_input"], key
        assert f"key {key!r} has a wildcard" in verdict.error, verdict.error
    invalid = ask(session, "discern/not.a.vehicle/check", json.dumps(proposal("wild")).encode())
    assert invalid.failsafe and "not a valid vehicle id" in invalid.error
    puts = ("discern/*/proposal", "discern/**")
    for key in puts:  # nobody to answer: counted only
        session.put(key, json.dumps(proposal("wild")).encode())
    refused = len(WILDCARD_KEYS) + len(puts) + 1
    wanted = before["errors_by_kind"].get("vehicle", 0) + refused
    [after] = wait_until(lambda: [r for r in status(ep, "bad") if r["errors_by_kind"].get("vehicle", 0) >= wanted])
    assert after["errors_by_kind"]["vehicle"] == wanted and after["errors"] == before["errors"] + refused
    assert after["vehicles"] == before["vehicles"]


def test_bad_published_proposal_gets_its_verdict_on_the_vehicle_key(session):
    got = []
    arrived = threading.Event()
    sub = session.declare_subscriber(
        "discern/pub_bad/verdict", lambda s: (got.append(s.payload.to_bytes()), arrived.set())
    )
    try:
        wait_until(lambda: False, timeout=0.3)  # let the subscription reach the monitor
        session.put("discern/pub_bad/proposal", b"{not json")
        assert arrived.wait(10)
    finally:
        sub.undeclare()
    verdict = Verdict.model_validate_json(got[0])
    assert verdict.failsafe and verdict.vehicle == "pub_bad" and "malformed JSON" in verdict.error


def test_refusals_are_counted_and_good_proposals_still_judged(session, monitor):
    ep, proc = monitor
    for case in ("malformed_json", "unknown_class", "other_vehicle"):  # make sure some refusals happened whatever ran before
        payload = BAD[case][0]
        ask(session, f"discern/count_{case}/check", payload(f"count_{case}") if callable(payload) else payload)
    session.put("discern/**/proposal", b"{}")  # names no vehicle: counted, never broadcast an answer to
    good = ask(session, "discern/still_fine/check", json.dumps(proposal("still_fine")).encode())
    assert good.decision is Decision.approve and not good.failsafe
    report = wait_until(lambda: [r for r in status(ep, "bad") if r["errors_by_kind"].get("vehicle", 0) >= 2])
    [report] = report
    assert report["errors"] >= 3 and report["errors_by_kind"]["json"] >= 1 and report["errors_by_kind"]["schema"] >= 1
    assert report["failsafes"] >= 2 and report["approvals"] >= 1
    # a refusal's fail-safe override is a fail-safe, not also an override: the counts add up, as the audit's do
    assert report["proposals"] == sum(report[k] for k in ("approvals", "vetoes", "overrides", "failsafes"))
    assert proc.proc.poll() is None


@pytest.mark.parametrize("style", ["query", "pubsub"])
def test_the_client_sends_a_bad_scene_on_so_the_monitor_refuses_counts_and_logs_it(monitor, log_dir, style):
    ep, _ = monitor
    vehicle = f"client_bad_{style}"
    good = json.loads(highway_scene(1, 3).model_dump_json(by_alias=True))
    cases = [
        (good | {"ego": good["ego"] | {"speed": math.nan}}, "cruise", "scene.ego.speed: Input should be a finite number"),
        (good | {"ego": good["ego"] | {"lane": 9}}, "cruise", "ego.lane 9 does not exist"),
        (good, "fly", "action: unknown value 'fly'"),
    ]
    [before] = status(ep, "bad")
    with Monitor(vehicle, connect=[ep], timeout=5, style=style) as client:
        assert client.wait_for_monitor(timeout=5)
        wait_until(lambda: False, timeout=0.3)  # let the verdict subscription reach the monitor
        verdicts = [client.check(scene, action) for scene, action, _ in cases]
    for verdict, (_, _, expected) in zip(verdicts, cases):
        assert verdict.failsafe and verdict.rules == ["monitor.bad_input"] and verdict.action is Action.brake
        assert expected in verdict.error, verdict.error
        assert verdict.latency_ms is not None  # timed by the monitor: its answer, not one made up by the client
    wanted = before["errors_by_kind"].get("schema", 0) + len(cases)
    assert wait_until(lambda: status(ep, "bad")[0]["errors_by_kind"].get("schema", 0) >= wanted)

    def rejected():  # the log is read while the monitor writes it
        records = [r.rejected for r in read_log(log_dir) if r.vehicle == vehicle and r.kind == "rejected"]
        return records if len(records) == len(cases) else None

    assert [expected in r.error for r, (_, _, expected) in zip(wait_until(rejected), cases)] == [True] * len(cases)


def test_the_client_sends_wrongly_typed_fields_as_they_are_so_the_monitor_refuses_them_by_name(monitor):
    ep, _ = monitor
    good = json.loads(highway_scene(1, 3).model_dump_json(by_alias=True))
    cases = [  # (scene, explain, expected error): strings for numbers are not converted on the way
        (good | {"ego": good["ego"] | {"speed": "25"}}, False, "scene.ego.speed: Input should be a valid number (got '25')"),
        (good | {"ego": good["ego"] | {"lane": "2"}}, False, "scene.ego.lane: Input should be a valid integer (got '2')"),
        (good | {"frame_id": "7"}, False, "scene.frame_id: Input should be a valid integer (got '7')"),
        (good, "yes", "explain: Input should be a valid boolean (got 'yes')"),
    ]
    with Monitor("client_typed", connect=[ep], timeout=5) as client:
        assert client.wait_for_monitor(timeout=5)
        verdicts = [client.check(scene, "cruise", explain=explain) for scene, explain, _ in cases]
    for verdict, (_, _, expected) in zip(verdicts, cases):
        assert verdict.failsafe and verdict.rules == ["monitor.bad_input"], verdict
        assert verdict.error == f"schema violation: {expected}"
        assert verdict.latency_ms is not None  # the monitor's refusal, not the client's


def test_a_typed_scene_given_a_nan_after_it_was_built_is_refused_naming_the_field_and_the_nan(monitor):
    """pydantic does not check a field set after the model was built: the NaN went out as null, refused as a missing
    number ("got null"), where the same scene as a dict was refused as a NaN."""
    ep, _ = monitor
    scene = highway_scene(1, 3)
    scene.ego.speed = math.nan  # a perception filter diverged
    with Monitor("client_typed_nan", connect=[ep], timeout=5) as client:
        assert client.wait_for_monitor(timeout=5)
        verdict = client.check(scene, "cruise")
    assert verdict.failsafe and verdict.rules == ["monitor.bad_input"], verdict
    assert verdict.error == "schema violation: scene.ego.speed: Input should be a finite number (got nan)"
    assert verdict.latency_ms is not None  # the monitor's refusal, not the client's


def test_failsafe_picks_the_most_cautious_permitted_action():
    assert most_cautious([Action.accelerate, Action.change_lane_left, Action.cruise]) is Action.cruise
    assert most_cautious([Action.accelerate]) is Action.accelerate
    assert most_cautious([]) is Action.brake
    assert CAUTION_ORDER[0] is Action.brake and len(set(CAUTION_ORDER)) == len(Action)


def test_a_shadow_failsafe_for_a_proposal_of_the_failsafe_action_itself_reads_as_no_veto_of_it():
    """A refused duplicate that proposed brake read "fail-safe veto of brake (...; would brake)"."""
    reason = "frame_id: duplicate frame 87, the last frame received for this vehicle was 87"
    same = failsafe_verdict("car", reason, RULE_BAD_INPUT, proposed=Action.brake, shadow=True)
    assert same.justification.summary == f"fail-safe brake, as proposed (shadow mode): {reason}"
    assert same.action is Action.brake and same.recommended is Action.brake and same.failsafe
    other = failsafe_verdict("car", reason, RULE_BAD_INPUT, proposed=Action.cruise, shadow=True)
    assert other.justification.summary.startswith("fail-safe veto of cruise (shadow mode, not enforced; would brake)")


def test_a_proposal_with_a_byte_order_mark_is_judged_as_discern_check_reads_the_file_and_logged_without_it(
        session, log_dir):
    """RFC 8259 lets a reader ignore the mark; `discern check` does, and a file that checks is a message it takes."""
    verdict = ask(session, "discern/bom/check", b"\xef\xbb\xbf" + json.dumps(proposal("bom", frame=3)).encode())
    assert not verdict.failsafe and verdict.frame_id == 3
    logged = wait_until(lambda: [r for r in read_log(log_dir) if r.vehicle == "bom" and r.kind == "proposal"])
    assert logged[0].proposal.scene.frame_id == 3


@pytest.mark.parametrize("style", ["query", "pubsub"])
def test_a_refusal_is_labelled_with_the_scenes_frame_id_not_one_nested_elsewhere_and_a_whole_float_counts(
        session, monitor, style):
    stray = ask(session, "discern/stray_frame/check",
                json.dumps({"zz": {"frame_id": 99}, **proposal("stray_frame", frame=5)}).encode())
    assert stray.rules == ["monitor.bad_input"] and stray.frame_id == 5 and "zz" in stray.error
    good = json.loads(highway_scene(1, 3).model_dump_json(by_alias=True))
    with Monitor(f"stray_{style}", connect=[monitor[0]], timeout=5, style=style) as client:
        assert client.wait_for_monitor(timeout=5)
        wait_until(lambda: False, timeout=0.3)  # let the verdict subscription reach the monitor
        nested = client.check({"zz": {"frame_id": 99}} | good | {"frame_id": 6}, "cruise")
        whole = client.check(good | {"frame_id": 8.0, "zz": 1}, "cruise")
    assert nested.frame_id == 6 and nested.latency_ms is not None and "zz" in nested.error  # the monitor's refusal
    assert whole.frame_id == 8 and whole.latency_ms is not None and "zz" in whole.error


@pytest.mark.timeout(60)  # a hang guard, not a speed target: the scan that tried each quote again took hours here
@pytest.mark.parametrize("hostile", [b'{\\"version\\":1,' * 60_000, b'"' + b"\\" * 1_000_001, b'x"' * 500_000],
                         ids=["json_escaped_twice", "backslashes", "quotes"])
def test_labelling_a_payload_of_unclosed_or_escaped_quotes_reads_each_byte_once_and_finds_no_frame(hostile):
    """The label is looked for by the decision worker and the watchdog alike: one vehicle's bad bytes must not hold
    up every other vehicle's verdict (a 17 KB JSON-escaped proposal silenced a fleet for seconds)."""
    assert peek_frame(hostile) == (None, None)
    assert peek_frame(hostile + json.dumps(proposal("late", frame=5)).encode()) == (None, None)  # in the open string
    assert peek_frame(json.dumps(proposal("ok", frame=5)).encode() + hostile)[0] == 5


@pytest.mark.timeout(60)  # a hang guard, not a speed target: the field's path was found by a scan that took minutes
def test_a_lone_surrogate_after_many_escaped_quotes_is_refused_naming_its_field():
    """The path to a bad value is read with the label's tokens: a scan of its own retried each escaped quote (32 KB
    took 9 s on a decision worker, or on the server's own thread for a payload it reads itself)."""
    quotes = b'\\"' * 128_000
    payload = b'{"scene":{"notes":["fine","' + quotes + b'\\ud800x"]},"action":"cruise"}'
    with pytest.raises(InputError) as refused:
        decode_proposal(payload, "v")
    assert str(refused.value).startswith("malformed JSON: scene.notes.1: lone surrogate \\ud800 in a string")


def test_a_huge_integer_or_a_lone_surrogate_is_refused_naming_its_field_and_the_problem(session, monitor):
    huge = json.dumps(proposal("huge")).replace('"frame_id": 1', '"frame_id": 1' + "0" * 5000).encode()
    refused = ask(session, "discern/huge/check", huge)
    assert refused.error.startswith("malformed JSON: scene.frame_id: number out of range at line 1 column ")
    good = json.loads(highway_scene(1, 3).model_dump_json(by_alias=True))
    with Monitor("huge_client", connect=[monitor[0]], timeout=5) as client:
        assert client.wait_for_monitor(timeout=5)
        unsent = client.check(good | {"frame_id": 10**5000}, "brake")
        lone = client.check(good | {"notes": ["fine", "\ud800"]}, "brake")
    assert unsent.error.startswith("schema violation: scene.frame_id: Input should be less than or equal to "
                                   "9223372036854775807 (got an integer of about 5001 digits); not sent: ")
    assert lone.error.startswith("malformed JSON: scene.notes.1: lone surrogate \\ud800 in a string, no character at")
    assert lone.latency_ms is not None  # sent as it is, and refused by the monitor
