"""A real `discern serve` process judging proposals from planners in this process, over zenoh on loopback."""

from __future__ import annotations

import json
import logging
import math
import subprocess
import sys
import threading
import time

import pytest

from discern.monitor import keys
from discern.monitor.client import Monitor
from discern.monitor.example_planner import highway_scene
from discern.rules.verdict import Decision
from discern.monitor.config import free_port
from discern.sanity import window_reasoner
from tests.monitor_process import REPO, endpoint, serve, status, wait_until

pytestmark = pytest.mark.wall_clock  # run alone: see the marker in pyproject.toml


@pytest.fixture(scope="module")
def monitor():
    proc, ep = serve("--id", "rt", "--budget-ms", "5000")  # correctness here; the deadline has its own tests
    yield ep
    assert proc.stop() == 0, proc.output


@pytest.fixture
def client(monitor):
    clients = []

    def make(vehicle="ego", **kwargs):
        c = Monitor(vehicle, connect=[monitor], timeout=5.0, **kwargs)
        clients.append(c)
        return c

    yield make
    for c in clients:
        c.close()


def test_query_returns_the_cores_verdict(client):
    scene = highway_scene(300, 8)  # the car ahead is close: cruise is forbidden
    verdict = client("car_q").check(scene, "cruise")
    expected = window_reasoner().decide(scene, "cruise")
    assert (verdict.decision, verdict.action, verdict.rules) == (expected.decision, expected.action, expected.rules)
    assert verdict.decision is Decision.override and not verdict.failsafe and verdict.error is None
    assert verdict.vehicle == "car_q" and verdict.frame_id == 300 and verdict.proposed.value == "cruise"
    assert verdict.justification.summary.startswith("override cruise") and verdict.justification.tree
    assert 0 < verdict.latency_ms < 5000


def test_pubsub_verdict_arrives_on_the_verdict_key(client):
    seen = []
    monitor = client("car_p", style="pubsub", on_verdict=seen.append)
    verdict = monitor.check(highway_scene(0, 8), "cruise")
    assert verdict.decision is Decision.approve and verdict.frame_id == 0 and not verdict.failsafe
    assert wait_until(lambda: seen) and seen[0].vehicle == "car_p"


def test_explain_asks_for_the_proof_tree_of_an_approval(client):
    monitor = client("car_e")
    plain = monitor.check(highway_scene(1, 8), "cruise")
    explained = monitor.check(highway_scene(2, 8), "cruise", explain=True)
    assert plain.decision is explained.decision is Decision.approve
    assert not plain.justification.tree and explained.justification.tree and explained.justification.text


def test_many_vehicles_are_served_concurrently_each_in_frame_order(client):
    results: dict[str, list] = {}

    def drive(vehicle):
        monitor = client(vehicle)
        results[vehicle] = [monitor.check(highway_scene(f, 8, seed=hash(vehicle) % 7), "cruise") for f in range(8)]

    threads = [threading.Thread(target=drive, args=(f"fleet_{i}",)) for i in range(6)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(60)
    assert sorted(results) == [f"fleet_{i}" for i in range(6)]
    for vehicle, verdicts in results.items():
        assert [v.frame_id for v in verdicts] == list(range(8))
        assert all(v.vehicle == vehicle and not v.failsafe for v in verdicts)


def test_a_planner_restarting_its_episodes_at_scene_time_zero_is_judged_afresh_each_time(client):
    """Frame 0 at 0.0 after frame 5 at 0.25: a new episode, not six frames refused as out of order."""
    monitor = client("restarts_at_zero")
    for episode in range(3):
        verdicts = [
            monitor.check(highway_scene(f, 4).model_copy(update={"timestamp": round(0.05 * f, 2)}), "cruise")
            for f in range(6)
        ]
        assert not [v.error for v in verdicts if v.failsafe], episode
        assert [v.frame_id for v in verdicts] == list(range(6))


@pytest.mark.parametrize("style", ["query", "pubsub"])
def test_check_after_close_returns_a_failsafe_instead_of_raising(client, style):
    monitor = client(f"closed_{style}", style=style)
    monitor.close()
    verdict = monitor.check(highway_scene(9, 4), "cruise")
    assert verdict.failsafe and verdict.rules == ["monitor.no_answer"] and verdict.action.value == "brake"
    assert verdict.error == "not sent: this Monitor is closed" and verdict.frame_id == 9


@pytest.mark.parametrize("style", ["query", "pubsub"])
def test_publish_after_close_raises_a_value_error_saying_it_is_closed(client, style):
    """It raised zenoh's own "session closed", which its docstring did not name."""
    monitor = client(f"closed_pub_{style}", style=style)
    monitor.close()
    with pytest.raises(ValueError, match="^not sent: this Monitor is closed$"):
        monitor.publish(highway_scene(9, 4), "cruise")


def test_status_reports_counts_and_latency(client, monitor):
    client("car_s").check(highway_scene(0, 8), "cruise")
    [report] = status(monitor, "rt")
    assert report["monitor_id"] == "rt" and report["proposals"] >= 1 and report["approvals"] >= 1
    assert report["latency_ms"]["p50_ms"] > 0 and report["latency_ms"]["p99_ms"] >= report["latency_ms"]["p50_ms"]
    assert report["vehicles"] >= 1


def test_status_takes_a_shell_style_wildcard_id(monitor):
    assert [report["monitor_id"] for report in status(monitor, "r*")] == ["rt"]


def test_on_verdict_sees_every_verdict_of_the_vehicle_once_in_query_style(client):
    seen = []
    monitor = client("car_v", on_verdict=seen.append)
    replies = [monitor.check(highway_scene(f, 8), "cruise") for f in range(3)]
    assert wait_until(lambda: len(seen) >= 3) and seen == replies  # each reply, in order
    monitor.publish(highway_scene(3, 8), "cruise")
    assert wait_until(lambda: len(seen) >= 4)
    assert [v.frame_id for v in seen] == [0, 1, 2, 3]


@pytest.mark.parametrize("style", ["query", "pubsub"])
def test_an_on_verdict_that_raises_is_logged_and_check_still_returns_the_verdict(client, style, caplog):
    """A bug in the planner's callback once raised out of `check` in query style, and the override was lost."""
    def broken(verdict):
        raise RuntimeError("bug in the planner's logging")

    monitor = client(f"broken_{style}", style=style, on_verdict=broken)
    with caplog.at_level(logging.ERROR, logger="discern.monitor.client"):
        verdict = monitor.check(highway_scene(300, 8), "cruise")
        assert wait_until(lambda: caplog.records)  # over publish/subscribe, logged on zenoh's thread
    assert verdict.decision is Decision.override and not verdict.failsafe and verdict.frame_id == 300
    [record] = caplog.records
    assert record.getMessage() == f"on_verdict raised on the verdict of vehicle 'broken_{style}' frame 300"
    assert record.exc_info[0] is RuntimeError


@pytest.mark.parametrize("style", ["query", "pubsub"])
def test_a_slow_on_verdict_keeps_no_check_from_returning_its_verdict(client, style):
    """Called in a queried check, the callback made the check wait for it, past its timeout; called on zenoh's
    subscriber thread, it held up the verdicts behind it, and a check over publish/subscribe missed its own."""
    release = threading.Event()
    seen = []

    def slow(verdict):
        release.wait(30)  # bounded, so that a check that does wait for it ends
        seen.append(verdict.frame_id)

    monitor = client(f"slow_callback_{style}", style=style, on_verdict=slow)
    verdicts = [monitor.check(highway_scene(f, 8), "cruise") for f in range(2)]
    seen_by_then = list(seen)
    release.set()
    assert [(v.frame_id, v.failsafe) for v in verdicts] == [(0, False), (1, False)], [v.error for v in verdicts]
    assert seen_by_then == []
    assert wait_until(lambda: len(seen) == 2) and seen == [0, 1]


def test_close_returns_once_on_verdict_has_seen_the_verdicts_that_came_before(client):
    seen = []

    def until_closed(verdict):
        wait_until(lambda: monitor.session.is_closed(), timeout=30)
        time.sleep(0.5)  # still busy well after the session closed: a close() that did not wait has returned
        seen.append(verdict.frame_id)

    monitor = client("callback_at_close", on_verdict=until_closed)
    monitor.check(highway_scene(0, 8), "cruise")
    monitor.close()
    assert seen == [0]


def test_an_on_verdict_that_closes_its_monitor_closes_it(client, caplog):
    """close() waits for the callbacks before it; from a callback it cannot wait for its own end."""
    monitor = client("closes_itself", on_verdict=lambda verdict: monitor.close())
    with caplog.at_level(logging.ERROR, logger="discern.monitor.client"):
        assert not monitor.check(highway_scene(0, 8), "cruise").failsafe
        assert wait_until(lambda: monitor.session.is_closed())
    assert monitor.check(highway_scene(1, 8), "cruise").error == "not sent: this Monitor is closed"
    assert not caplog.records


def test_planner_example_drives_against_the_monitor(monitor):
    run = subprocess.run(
        [sys.executable, "-m", "discern.monitor.commands", "planner-example", "--connect", monitor,
         "--vehicle", "example", "--frames", "4", "--rate", "50"],
        cwd=REPO, capture_output=True, text=True, timeout=60,
    )
    assert run.returncode == 0, run.stdout + run.stderr
    lines = [l for l in run.stdout.splitlines() if l.startswith("frame")]
    assert len(lines) == 4 and "approve" in lines[0]


def test_the_documented_minimal_proposal_gets_the_documented_verdict(monitor):
    """docs/protocol.md shows a proposal and its verdict: a real monitor must answer exactly that."""
    import re

    import zenoh

    from discern.monitor.config import ZenohSettings

    doc = (REPO / "docs" / "protocol.md").read_text()
    proposal = re.search(r"A minimal proposal:\n\n```json\n(.*?)```", doc, re.S).group(1)
    abridged = re.search(r"Its verdict \(abridged.*?```json\n(.*?)```", doc, re.S).group(1)
    documented = json.loads(abridged.replace("[...]", "[]"))
    session = zenoh.open(ZenohSettings(listen=[], connect=[monitor]).to_zenoh())
    try:
        [reply] = [r.ok for r in session.get("discern/car_7/check", payload=proposal.encode(), timeout=10) if r.ok]
    finally:
        session.close()
    answered = json.loads(reply.payload.to_bytes())
    for verdict in (documented, answered):  # what the example abridges, and what varies run to run
        verdict["justification"].pop("text")
        verdict["justification"].pop("tree")
        verdict.pop("latency_ms")
    assert answered == documented


def test_a_restarted_planner_is_judged_from_its_first_frame_again(monitor):
    """Its frame ids and scene time go back: a new episode, not replayed frames."""
    for run in range(2):
        result = subprocess.run(
            [sys.executable, "-m", "discern.monitor.commands", "planner-example", "--connect", monitor,
             "--vehicle", "restarted", "--frames", "3", "--rate", "20"],
            cwd=REPO, capture_output=True, text=True, timeout=60,
        )
        assert result.returncode == 0, f"run {run}:\n{result.stdout}{result.stderr}"  # 1: a fail-safe came back


def test_without_a_monitor_the_client_returns_a_failsafe_in_time():
    with Monitor("lonely", connect=[endpoint(free_port())], timeout=0.2) as monitor:
        started = time.monotonic()
        verdict = monitor.check(highway_scene(0, 4), "accelerate")
        elapsed = time.monotonic() - started
    assert verdict.failsafe and verdict.action.value == "brake" and verdict.rules == ["monitor.no_answer"]
    assert verdict.error == ("no monitor answered on discern/lonely/check: none that serves vehicle 'lonely' is reachable; "
                             "this session is linked to no peer or router: nothing listens at its endpoints, or, where "
                             "TLS or access control is configured, its certificate is refused")
    assert elapsed < 2.0


@pytest.mark.parametrize("timeout, got", [
    (math.inf, "inf"), (math.nan, "nan"), (-1, "-1"), (0, "0"), (1e12, "1000000000000.0"), (True, "True (bool)"),
    ("0.1", "'0.1' (str)"),  # "got 0.1" did not say why 0.1 was refused
])
def test_a_timeout_no_wait_can_take_is_refused_when_the_client_is_made(timeout, got):
    with pytest.raises(ValueError) as refused:
        Monitor("impatient", connect=[endpoint(free_port())], timeout=timeout)
    assert str(refused.value) == f"timeout must be a finite number above 0 s and at most 120 s, got {got}"


def test_a_bad_timeout_given_to_check_gets_a_failsafe_naming_it():
    with Monitor("impatient", connect=[endpoint(free_port())]) as monitor:
        verdict = monitor.check(highway_scene(3, 4), "accelerate", timeout=-0.001)
    assert verdict.failsafe and verdict.action.value == "brake" and verdict.rules == ["monitor.no_answer"]
    assert verdict.error == "not sent: timeout must be a finite number above 0 s and at most 120 s, got -0.001"
    assert verdict.frame_id == 3 and verdict.proposed.value == "accelerate"


def test_a_timeout_given_to_check_as_a_string_is_named_with_its_type():
    with Monitor("impatient", connect=[endpoint(free_port())]) as monitor:
        verdict = monitor.check(highway_scene(3, 4), "accelerate", timeout="0.1")
    assert verdict.error == "not sent: timeout must be a finite number above 0 s and at most 120 s, got '0.1' (str)"


@pytest.mark.timeout(60)  # a hang guard, not a speed target: NaN and inf waited for good
@pytest.mark.parametrize("timeout, got", [
    (math.nan, "nan"), (math.inf, "inf"), (0, "0"), ("2", "'2' (str)"), (None, "None (NoneType)"),
])
def test_wait_for_monitor_refuses_a_timeout_check_would_refuse(timeout, got):
    with Monitor("impatient", connect=[endpoint(free_port())]) as monitor:
        with pytest.raises(ValueError) as refused:
            monitor.wait_for_monitor(timeout=timeout)
    assert str(refused.value) == f"timeout must be a finite number above 0 s and at most 120 s, got {got}"


def test_a_single_endpoint_given_as_a_string_is_taken_as_one(monitor):
    """Iterated, the string's letters were taken for endpoints: "bad zenoh endpoint 't'"."""
    with Monitor("one_endpoint", connect=monitor, timeout=5.0) as client:
        assert client.wait_for_monitor(timeout=5.0)
        assert not client.check(highway_scene(0, 4), "cruise").failsafe


def test_an_endpoint_zenoh_cannot_take_is_refused_naming_it_without_rust_source_paths():
    with pytest.raises(ValueError) as refused:
        Monitor("unknown_protocol", connect=["udpx/1.2.3.4:5"])
    assert str(refused.value) == "cannot connect to udpx/1.2.3.4:5: Unicast not supported for udpx protocol"


@pytest.mark.parametrize("connect, problem", [
    ("tcp/127.0.0.1:notaport", "invalid port 'notaport'"),
    ("tcp/127.0.0.1:99999", "invalid port '99999'"),
    ("tcp/127.0.0.1", "no port"),
    ("tcp/[::1]", "no port"),
    ("tcp/:7447", "no host"),
])
def test_an_ip_endpoint_without_a_host_and_port_is_refused_naming_it(connect, problem):
    """zenoh took it, and tried to connect to it in vain, saying nothing: a planner whose every check failed."""
    with pytest.raises(ValueError) as refused:
        Monitor("mistyped", connect=connect)
    assert str(refused.value) == f"cannot connect to {connect}: {problem}: give <host>:<port>, a port from 1 to 65535"


def test_a_scene_that_cannot_be_sent_at_all_gets_a_local_failsafe_naming_the_problem():
    scene = json.loads(highway_scene(0, 2).model_dump_json(by_alias=True)) | {"notes": [object()]}
    with Monitor("sloppy", connect=[endpoint(free_port())]) as monitor:
        verdict = monitor.check(scene, "cruise")
    assert verdict.failsafe and verdict.action.value == "brake" and verdict.rules == ["monitor.bad_input"]
    assert verdict.error.startswith("schema violation: scene.notes.0: ")
    assert verdict.error.endswith("not sent: it cannot be written as JSON: Object of type object is not JSON serializable")


def test_a_scene_nested_past_the_json_encoders_depth_gets_a_local_failsafe_not_a_recursion_error():
    scene = json.loads(highway_scene(0, 2).model_dump_json(by_alias=True))
    node = scene["ego"]
    for _ in range(100_000):  # a planner's runaway structure
        node["next"] = node = {}
    with Monitor("tangled", connect=[endpoint(free_port())]) as monitor:
        verdict = monitor.check(scene, "cruise")
        with pytest.raises(ValueError, match="it cannot be written as JSON: maximum recursion depth exceeded"):
            monitor.publish(scene, "cruise")
    assert verdict.failsafe and verdict.action.value == "brake" and verdict.rules == ["monitor.bad_input"]
    assert "scene.ego.next: Extra inputs are not permitted" in verdict.error
    assert verdict.error.endswith("not sent: it cannot be written as JSON: maximum recursion depth exceeded while "
                                  "encoding a JSON object")


@pytest.mark.parametrize("reply, reason", [
    (b'{"version": 7}', "unreadable verdict from the monitor: version: Input should be 1"),
    ({"vehicle": "someone_else", "frame_id": 0},
     "the monitor's reply is about vehicle 'someone_else' frame 0, not this proposal (vehicle 'misrouted' frame 0)"),
    ({"vehicle": "misrouted", "frame_id": 999},
     "the monitor's reply is about vehicle 'misrouted' frame 999, not this proposal (vehicle 'misrouted' frame 0)"),
    ({"vehicle": "misrouted", "frame_id": None},  # an approval naming no frame is no answer to a known frame
     "the monitor's reply is about vehicle 'misrouted' frame None, not this proposal (vehicle 'misrouted' frame 0)"),
])
def test_a_reply_that_is_no_verdict_on_this_proposal_is_not_acted_on_and_says_why(reply, reason):
    """An approval of another vehicle's or frame's proposal once came back as this one's; a garbled one lost its reason."""
    import zenoh

    from discern.monitor.config import ZenohSettings
    from discern.monitor.protocol import encode
    from discern.rules.verdict import Verdict

    if isinstance(reply, dict):
        reply = encode(Verdict(decision="approve", proposed="cruise", action="cruise", justification={"summary": "approve"}, **reply))
    ep = endpoint(free_port())
    impostor = zenoh.open(ZenohSettings(listen=[ep]).to_zenoh())
    try:
        impostor.declare_queryable("discern/misrouted/check", lambda q: q.reply(q.key_expr, reply))
        with Monitor("misrouted", connect=[ep], timeout=2.0) as client:
            verdict = client.check(highway_scene(0, 2), "cruise")
    finally:
        impostor.close()
    assert verdict.failsafe and verdict.action.value == "brake" and verdict.rules == ["monitor.no_answer"]
    assert verdict.frame_id == 0 and verdict.error.startswith(reason)


@pytest.mark.parametrize("style", ["query", "pubsub"])
def test_an_invalid_proposal_answered_with_a_deadline_failsafe_is_refused_naming_its_problem(style):
    """A busy monitor answers at its deadline before reading the payload: the planner was told of the deadline,
    not of the string it had sent for a speed, which the client had found itself."""
    import zenoh

    from discern.monitor.config import ZenohSettings
    from discern.monitor.protocol import RULE_DEADLINE, encode, failsafe_verdict

    deadline = encode(failsafe_verdict("busy", "no decision within the 50 ms budget", RULE_DEADLINE, frame_id=0))
    scene = json.loads(highway_scene(0, 2).model_dump_json(by_alias=True))
    scene["ego"]["speed"] = "25"
    ep = endpoint(free_port())
    busy = zenoh.open(ZenohSettings(listen=[ep]).to_zenoh())
    try:
        busy.declare_queryable("discern/busy/check", lambda q: q.reply(q.key_expr, deadline))
        busy.declare_subscriber("discern/busy/proposal", lambda sample: busy.put("discern/busy/verdict", deadline))
        with Monitor("busy", connect=[ep], timeout=2.0, style=style) as client:
            assert client.wait_for_monitor()
            verdict = client.check(scene, "cruise")
    finally:
        busy.close()
    assert verdict.failsafe and verdict.action.value == "brake" and verdict.rules == ["monitor.bad_input"]
    assert verdict.frame_id == 0 and verdict.error == (
        "schema violation: scene.ego.speed: Input should be a valid number (got '25'); "
        "and the monitor answered with a monitor.deadline fail-safe: no decision within the 50 ms budget")


def answer_probe(query) -> None:
    """What a monitor answers to Monitor.wait_for_monitor's probe: that it serves the vehicle."""
    with query:
        query.reply(str(query.key_expr), b'{"monitor_id": "impostor", "vehicles_filter": "*"}')


def test_over_publish_subscribe_an_unreadable_verdict_is_the_reason_a_wait_gets_no_verdict():
    import zenoh

    from discern.monitor.config import ZenohSettings

    ep = endpoint(free_port())
    impostor = zenoh.open(ZenohSettings(listen=[ep]).to_zenoh())
    try:
        impostor.declare_subscriber("discern/garbled/proposal",
                                    lambda sample: impostor.put("discern/garbled/verdict", b'{"version": 7}'))
        impostor.declare_queryable("discern/garbled/check", answer_probe)  # it passes the start-up check
        with Monitor("garbled", connect=[ep], timeout=0.5, style="pubsub") as client:
            assert client.wait_for_monitor()
            verdict = client.check(highway_scene(0, 2), "cruise")
    finally:
        impostor.close()
    assert verdict.failsafe and verdict.rules == ["monitor.no_answer"] and verdict.frame_id == 0
    assert verdict.error.startswith("unreadable verdict from the monitor: version: Input should be 1")


def test_a_monitor_that_answers_after_the_clients_timeout_reads_as_no_verdict_in_time():
    """Zenoh ends the expired query with an error reply of its own; that is no answer, not the monitor's error."""
    import zenoh

    from discern.monitor.config import ZenohSettings

    ep = endpoint(free_port())
    tardy = zenoh.open(ZenohSettings(listen=[ep]).to_zenoh())
    held = []  # the queries it never gets round to answering
    try:
        tardy.declare_queryable("discern/tardy/check", lambda q: answer_probe(q) if keys.PROBE in q.parameters
                                else held.append(q))  # it passes the start-up check, then never answers in time
        with Monitor("tardy", connect=[ep], timeout=0.2) as client:
            assert client.wait_for_monitor()
            verdict = client.check(highway_scene(0, 2), "cruise")
    finally:
        held.clear()
        tardy.close()
    assert verdict.failsafe and verdict.rules == ["monitor.no_answer"]
    assert verdict.error == "no verdict from a monitor on discern/tardy/check within 200 ms"


def test_shadow_mode_vetoes_without_replacing_the_action():
    proc, ep = serve("--id", "shadow", "--shadow", "--budget-ms", "5000")
    try:
        with Monitor("shadowed", connect=[ep], timeout=5.0) as monitor:
            verdict = monitor.check(highway_scene(300, 8), "cruise")
    finally:
        assert proc.stop() == 0, proc.output
    assert verdict.decision is Decision.veto and verdict.shadow and verdict.action.value == "cruise"
    assert verdict.rules and not verdict.failsafe


@pytest.mark.parametrize("rule", ["san.memory.stop_sign", "san.memory.object_permanence", "san.limit.remembered"])
def test_the_vehicles_recent_frames_reach_the_sanity_layer(client, rule):
    """The monitor's per-vehicle window is the `history` the sanity rules need: same verdict as in-process."""
    from tests.worked_examples import EXAMPLES

    [example] = [e for e in EXAMPLES if e.rule == rule]
    *earlier, last = example.frames
    monitor = client(f"window_{rule.replace('.', '_')}")
    for frame in earlier:
        assert not monitor.check(frame, example.proposed).failsafe
    verdict = monitor.check(last, example.proposed)
    reasoner = window_reasoner()
    with_history = reasoner.decide(last, example.proposed, history=tuple(earlier))
    assert (verdict.decision, verdict.action, verdict.rules) == (with_history.decision, with_history.action, with_history.rules)
    assert rule in verdict.rules
    assert reasoner.decide(last, example.proposed).decision is not verdict.decision  # the history decided it


def test_a_frame_counter_that_wraps_gets_verdicts_not_order_refusals(client):
    """The review's planner: a 16-bit counter from 65520 on, its scene time running on at 20 Hz. Frame 0 was
    refused ("out-of-order frame 0, the last frame received for this vehicle was 65535"), and so was every frame
    for the next 2 s: fail-safe brakes."""
    monitor = client("wrapper")
    verdicts = [monitor.check(highway_scene(i, 8, dt=0.05).model_copy(
        update={"frame_id": (65520 + i) % 65536, "timestamp": 100.0 + 0.05 * i}), "cruise") for i in range(40)]
    assert [v.frame_id for v in verdicts] == [(65520 + i) % 65536 for i in range(40)]
    assert [v.error for v in verdicts if v.failsafe] == []


@pytest.mark.parametrize("rule", ["san.memory.stop_sign", "san.memory.object_permanence", "san.limit.remembered"])
def test_the_window_reaches_the_sanity_layer_across_a_frame_counter_that_wraps(client, rule):
    """The frames before the wrap are the history of the frames after it, as if the counter had run on."""
    from tests.worked_examples import EXAMPLES

    [example] = [e for e in EXAMPLES if e.rule == rule]
    *earlier, last = example.frames
    monitor = client(f"wrap_{rule.replace('.', '_')}")
    for k, frame in enumerate(earlier):  # counted up to 65535, the last frame as 0
        assert not monitor.check(frame.model_copy(update={"frame_id": 65536 - len(earlier) + k}), example.proposed).failsafe
    verdict = monitor.check(last.model_copy(update={"frame_id": 0}), example.proposed)
    with_history = window_reasoner().decide(last, example.proposed, history=tuple(earlier))
    assert (verdict.decision, verdict.action, verdict.rules) == (with_history.decision, with_history.action, with_history.rules)
    assert rule in verdict.rules and verdict.frame_id == 0
