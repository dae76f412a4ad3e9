"""Over the decision budget the monitor answers anyway: a fail-safe verdict, never silence."""

from __future__ import annotations

import json
import multiprocessing
import os
import signal
import sys
import time
import threading

import pytest
import zenoh

from discern.monitor.client import Monitor
from discern.monitor.decision_pool import _Slot
from discern.monitor.decision_worker import STOP, WorkerSettings
from discern.monitor.config import ZenohSettings, free_port
from discern.monitor.example_planner import highway_scene
from discern.monitor.log import read_log
from discern.monitor.protocol import RULE_DEADLINE, failsafe_verdict
from discern.monitor.vehicle_state import PERMITTED_MEMORY_S, PermittedMemory
from discern.rules.scene import Action, Proposal
from discern.rules.verdict import Decision, Verdict
from tests.audit_logs import audit, flashing
from tests.monitor_process import DiscernProcess, endpoint, serve, status, wait_until

pytestmark = pytest.mark.wall_clock  # run alone: see the marker in pyproject.toml

BUDGET_MS = 50
DELAY_MS = 400  # test-only hook: every decision sleeps this long first
MALFORMED = b'{"action": "cruise", "scene": {"frame_id": 7, '


@pytest.fixture(scope="module")
def slow_log(tmp_path_factory):
    return tmp_path_factory.mktemp("slow-log")


@pytest.fixture(scope="module")
def slow_monitor(slow_log):
    proc, ep = serve(
        "--id", "slow", "--budget-ms", str(BUDGET_MS), "--test-only-decision-delay-ms", str(DELAY_MS),
        "--log-dir", str(slow_log), "--log-flush-s", "0.05",
    )
    yield ep
    assert proc.stop() == 0, proc.output


def ask(session: zenoh.Session, vehicle: str, payload: bytes):
    """Send a proposal without waiting; `answer(...)` of the result is its verdict."""
    return session.get(f"discern/{vehicle}/check", payload=payload, timeout=10)


def answer(replies) -> Verdict:
    [reply] = [r.ok for r in replies if r.ok is not None]
    return Verdict.model_validate_json(reply.payload.to_bytes())


def proposal(vehicle: str, frame_scene, action: str = "cruise") -> bytes:
    return Proposal(vehicle=vehicle, action=action, scene=frame_scene).model_dump_json(by_alias=True).encode()


def test_a_decision_over_budget_gets_a_failsafe_verdict_at_the_deadline(slow_monitor):
    with Monitor("slowpoke", connect=[slow_monitor], timeout=5) as monitor:
        verdict = monitor.check(highway_scene(0, 4), "accelerate")
    assert verdict.failsafe and verdict.rules == [RULE_DEADLINE]
    assert verdict.decision is Decision.override and verdict.action is Action.brake
    assert f"no decision within the {BUDGET_MS} ms budget" in verdict.error
    assert verdict.frame_id == 0 and verdict.proposed is Action.accelerate
    assert verdict.latency_ms < DELAY_MS  # at the deadline, or sooner once the monitor knows it is slow


def test_a_backlog_is_answered_in_time_and_nothing_is_lost(slow_monitor):
    verdicts = {}
    [before] = status(slow_monitor, "slow")  # counts so far: other tests share this monitor
    misses, proposals, failsafes = before["deadline_misses"], before["proposals"], before["failsafes"]

    def ask(i):
        with Monitor(f"queued_{i}", connect=[slow_monitor], timeout=5) as monitor:
            verdicts[i] = monitor.check(highway_scene(1, 4), "cruise")

    threads = [threading.Thread(target=ask, args=(i,)) for i in range(6)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(30)
    assert sorted(verdicts) == list(range(6))
    assert all(v.failsafe and v.rules == [RULE_DEADLINE] for v in verdicts.values())
    assert all(v.latency_ms < DELAY_MS for v in verdicts.values())  # none waited for the slow worker
    assert all(f"no decision within the {BUDGET_MS} ms budget" in v.error for v in verdicts.values())
    assert all(v.frame_id == 1 and v.proposed is Action.cruise for v in verdicts.values())  # matchable to their frame
    report = wait_until(lambda: [r for r in status(slow_monitor, "slow") if r["deadline_misses"] >= misses + 6])
    assert report and report[0]["failsafes"] - failsafes == report[0]["proposals"] - proposals == 6


def test_a_late_failsafe_uses_the_most_cautious_recently_permitted_action():
    memory = PermittedMemory()
    memory.remember("v", (Action.accelerate, Action.cruise, Action.change_lane_left), now=10.0)
    recent = failsafe_verdict("v", "late", RULE_DEADLINE, permitted=memory.recent("v", 10.1))
    stale = failsafe_verdict("v", "late", RULE_DEADLINE, permitted=memory.recent("v", 10.0 + 2 * PERMITTED_MEMORY_S))
    other = failsafe_verdict("w", "late", RULE_DEADLINE, permitted=memory.recent("w", 10.1))
    assert recent.action is Action.cruise and stale.action is Action.brake and other.action is Action.brake


def test_a_worker_that_once_was_slow_still_tries_fresh_proposals():
    """The decision-time estimate must never lock every proposal out (it only learns from decisions)."""
    import time
    from collections import deque

    from discern.monitor.decision_worker import Job, Judge, WorkerSettings
    from discern.rules.scene import Proposal

    judge = Judge(WorkerSettings(window_s=2.0, shadow=False))
    judge.time.learn(1, 10.0)  # after a pathological decision
    payload = Proposal(vehicle="v", action="cruise", scene=highway_scene(0, 4)).model_dump_json().encode()
    now = time.monotonic()
    [fresh] = judge.next_batch(deque([Job(1, "v", payload, now, now + BUDGET_MS / 1000)]))
    assert fresh.verdict is not None and fresh.decision == "approve"
    later = Proposal(vehicle="v", action="cruise", scene=highway_scene(1, 4)).model_dump_json().encode()
    [stale] = judge.next_batch(deque([Job(2, "v", later, now - 0.045, now + 0.005)]))  # 5 ms of 50 left
    assert stale.verdict is None and "left after queueing" in stale.no_verdict


def test_a_malformed_payload_answered_at_the_deadline_is_logged_and_counted_as_refused_not_as_a_proposal(
        slow_monitor, slow_log):
    [before] = status(slow_monitor, "slow")
    session = zenoh.open(ZenohSettings(listen=[], connect=[slow_monitor]).to_zenoh())
    try:
        busy = ask(session, "busy", proposal("busy", highway_scene(0, 4)))  # the worker's next 400 ms
        garbled = answer(ask(session, "garbled", MALFORMED))  # answered by the watchdog, unread
        answer(busy)
    finally:
        session.close()
    assert garbled.failsafe and garbled.rules == [RULE_DEADLINE] and garbled.frame_id == 7

    def logged():  # once its verdict is: the log is read while the monitor writes it
        records = [r for r in read_log(slow_log) if r.vehicle == "garbled"]
        return records if any(r.kind == "verdict" for r in records) else None

    records = wait_until(logged)
    assert [r.kind for r in records] == ["rejected", "verdict"]  # no proposal record: it never was one
    assert records[0].rejected.error.startswith("malformed JSON") and records[0].rejected.excerpt == MALFORMED.decode()
    [after] = status(slow_monitor, "slow")  # as the audit counts it: a refused input, whatever was sent in time
    assert after["errors"] - before["errors"] == 1
    assert after["errors_by_kind"]["json"] - before["errors_by_kind"].get("json", 0) == 1


SHED_BUDGET_MS, SHED_DELAY_MS = 1000, 700  # alone a decision makes its budget; queued behind another it cannot


def test_a_shed_frames_scene_is_in_the_window_of_the_next_decided_frame_and_the_replay_agrees(tmp_path, capsys):
    proc, ep = serve(
        "--id", "shedder", "--budget-ms", str(SHED_BUDGET_MS), "--test-only-decision-delay-ms", str(SHED_DELAY_MS),
        "--log-dir", str(tmp_path),
    )
    session = zenoh.open(ZenohSettings(listen=[], connect=[ep]).to_zenoh())
    try:
        assert not answer(ask(session, "siren", proposal("siren", flashing(0, False)))).failsafe  # timed: it may shed
        first = ask(session, "siren", proposal("siren", flashing(1, False)))
        shed = ask(session, "siren", proposal("siren", flashing(2, True)))  # waits out frame 1's 700 ms
        garbled = ask(session, "garbled", MALFORMED)  # shed too, its payload read: refused as what it is
        shed, garbled = answer(shed), answer(garbled)
        answer(first)
        after = answer(ask(session, "siren", proposal("siren", flashing(3, True))))
    finally:
        session.close()
        assert proc.stop() == 0, proc.output
    assert shed.failsafe and shed.rules == [RULE_DEADLINE] and shed.frame_id == 2
    assert garbled.failsafe and garbled.rules == ["monitor.bad_input"] and garbled.error.startswith("malformed JSON")
    # the lights were seen in frames 2 and 3: an emergency vehicle on duty, only if frame 2 is in the window
    assert not after.failsafe and after.action is Action.pull_over and "san.emergency.flashing" in after.rules

    records = list(read_log(tmp_path))
    assert [r.proposal.scene.frame_id for r in records if r.kind == "proposal" and r.vehicle == "siren"] == [0, 1, 2, 3]
    assert [r.kind for r in records if r.vehicle == "garbled"] == ["rejected", "verdict"]
    out = tmp_path / "replay.json"
    code, _, err = audit(capsys, "--replay", str(tmp_path), "--workers", "1", "--json", str(out))
    replay = json.loads(out.read_text())
    assert code == 0, err
    assert replay["changes"] == [] and replay["frames"] + replay["skipped_failsafe"] == 4


def test_a_shadow_monitors_failsafe_keeps_the_proposed_action_where_it_can_read_one():
    """Shadow mode judges and never enforces: not even a missed deadline or a refused frame brakes the vehicle."""
    proc, ep = serve("--id", "shadow_slow", "--shadow", "--budget-ms", str(BUDGET_MS),
                     "--test-only-decision-delay-ms", str(DELAY_MS))
    session = zenoh.open(ZenohSettings(listen=[], connect=[ep]).to_zenoh())
    try:
        late = answer(ask(session, "shadowed", proposal("shadowed", highway_scene(0, 4), "accelerate")))
        assert wait_until(lambda: status(ep, "shadow_slow")[0]["late_decisions"] == 1)  # the worker is idle again
        replayed = answer(ask(session, "shadowed", proposal("shadowed", highway_scene(0, 4), "accelerate")))
        garbage = answer(ask(session, "shadowed", b"not a proposal"))
    finally:
        session.close()
        assert proc.stop() == 0, proc.output
    for verdict, rule in ((late, RULE_DEADLINE), (replayed, "monitor.bad_input")):
        assert verdict.decision is Decision.veto and verdict.action is Action.accelerate and verdict.shadow
        assert verdict.failsafe and verdict.rules == [rule] and verdict.error and verdict.recommended is Action.brake
        assert "shadow mode, not enforced; would brake" in verdict.justification.summary
    assert replayed.error.startswith("frame_id: duplicate frame 0")
    assert garbage.decision is Decision.override and garbage.action is Action.brake and garbage.proposed is None
    assert garbage.justification.summary.endswith("(shadow mode, but no proposed action could be read to keep)")


def test_only_a_rules_verdict_that_comes_after_its_failsafe_counts_as_a_late_decision():
    """Under overload most outcomes behind an answered proposal are sheds: no decision, late or not."""
    from discern.monitor.config import MonitorConfig
    from discern.monitor.decision_worker import Outcome
    from discern.monitor.server import MonitorServer

    server = MonitorServer(MonitorConfig(monitor_id="late", zenoh=ZenohSettings(listen=[endpoint(free_port())])))
    # none of these requests is open any more: the watchdog answered them at their deadlines
    server._on_outcome(Outcome(rid=1, no_verdict="shed: too little of its budget left", decoded=True))
    server._on_outcome(Outcome(rid=2, verdict=b"{}", failsafe=True, error_kind="order", error="duplicate frame 3"))
    assert server.status().late_decisions == 0
    server._on_outcome(Outcome(rid=3, verdict=b"{}", decision="approve", decoded=True))
    assert server.status().late_decisions == 1


def test_a_verdict_the_session_could_not_send_is_counted_as_unsent_not_only_as_decided():
    """The status said every decided proposal was answered, also where no planner could get its verdict."""
    from discern.monitor.config import MonitorConfig
    from discern.monitor.server import Answer, MonitorServer, Request

    config = MonitorConfig(monitor_id="unsent", zenoh=ZenohSettings(listen=[endpoint(free_port())]))
    server = MonitorServer(config)
    server.session = zenoh.open(config.zenoh.to_zenoh())
    server.session.close()  # as at shutdown: a put on it fails
    now = time.monotonic()
    request = Request(1, "discern/car_1/proposal", "car_1", b"{}", b"", 2, now, time.time_ns(), now + 0.05)
    assert server._answer(request, Answer(b"{}", "approve", False, 1.0))
    status = server.status()
    assert (status.proposals, status.approvals, status.unsent) == (1, 1, 1)


def test_a_frame_waiting_behind_a_long_decision_finds_its_vehicles_window():
    """The window was swept after the batch while the replay waited in the worker's pipe: it then started afresh."""
    proc, ep = serve("--id", "stall", "--window-s", "1.5", "--budget-ms", "8000",
                     "--test-only-decision-delay-ms", "3000")  # a batch longer than the window and its margin
    session = zenoh.open(ZenohSettings(listen=[], connect=[ep]).to_zenoh())
    try:
        first = ask(session, "stalled", proposal("stalled", highway_scene(1, 2)))
        time.sleep(0.2)
        replay = ask(session, "stalled", proposal("stalled", highway_scene(1, 2)))
        first, replay = answer(first), answer(replay)
    finally:
        session.close()
        assert proc.stop() == 0, proc.output
    assert not first.failsafe and first.frame_id == 1
    assert replay.failsafe and replay.error.startswith("frame_id: duplicate frame 1")


def test_a_sigterm_to_the_whole_group_lets_the_workers_decide_what_they_were_sent(tmp_path):
    """systemd signals every process of a service: the workers died with their proposals, logged as unread."""
    ep = endpoint(free_port())
    proc = DiscernProcess("serve", "--listen", ep, "--id", "grouped", "--budget-ms", "5000",
                          "--test-only-decision-delay-ms", "1000", "--log-dir", str(tmp_path), own_group=True)
    proc.wait_ready()
    session = zenoh.open(ZenohSettings(listen=[], connect=[ep]).to_zenoh())
    try:
        pending = ask(session, "termed", proposal("termed", highway_scene(1, 2)))
        time.sleep(0.3)  # the worker has it and is deciding
        code = proc.stop_group()
        verdict = answer(pending)
    finally:
        session.close()
    assert code == 0, proc.output
    assert not verdict.failsafe and verdict.frame_id == 1, verdict.error
    assert [r.kind for r in read_log(tmp_path) if r.vehicle == "termed"] == ["proposal", "verdict"]


def test_a_decision_worker_signalled_to_stop_while_it_starts_lives_to_finish_its_work():
    """A stop signal to the whole group in the moments before a worker ignored it (Python starting) killed it."""
    slot = _Slot.spawn(multiprocessing.get_context("spawn"), WorkerSettings(window_s=2.0, shadow=False))
    try:
        os.kill(slot.process.pid, signal.SIGTERM)  # long before its interpreter has started
        slot.wait_ready()
    finally:
        slot.conn.send(STOP)
        slot.stop()
    assert slot.process.exitcode == 0


def test_a_sigint_in_the_first_moments_of_a_monitor_started_from_a_script_stops_it_once_it_can():
    """A shell script's background job ignores SIGINT until the monitor's handler takes it: one sent while the
    interpreter was still importing was lost, and the monitor served on."""
    import subprocess
    from pathlib import Path

    script = Path(sys.executable).with_name("discern")  # the console script, which relaunches itself on jemalloc
    proc = subprocess.Popen(
        [str(script), "serve", "--listen", endpoint(free_port()), "--id", "early_int", "--no-log"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN),  # as `cmd &` in a script starts it
    )
    try:
        time.sleep(0.3)  # importing: before this fix, the SIGINT was lost
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0 and "discern serve: stopped after 0 proposals" in out, out


def test_a_sigterm_while_the_monitor_starts_stops_it_cleanly():
    proc = DiscernProcess("serve", "--listen", endpoint(free_port()), "--id", "early", own_group=True)
    time.sleep(1.0)  # its decision workers are loading the rules
    code = proc.stop_group()
    assert code == 0 and "Traceback" not in proc.output, proc.output


def test_a_shadow_failsafe_at_the_deadline_for_a_payload_failing_the_schema_brakes_and_is_refused_by_name(tmp_path,
                                                                                                        capsys):
    """A payload that fails the schema has no proposed action to keep, even when its answer went at the deadline."""
    proc, ep = serve("--id", "shadow_nan", "--shadow", "--budget-ms", str(BUDGET_MS),
                     "--test-only-decision-delay-ms", "300", "--log-dir", str(tmp_path))
    nan = proposal("nan", highway_scene(0, 4), "accelerate").replace(b'"speed":', b'"speed":NaN,"x":', 1)
    session = zenoh.open(ZenohSettings(listen=[], connect=[ep]).to_zenoh())
    try:
        busy = ask(session, "busy", proposal("busy", highway_scene(0, 4), "accelerate"))
        refused = answer(ask(session, "nan", nan))
        kept = answer(busy)
        assert wait_until(lambda: status(ep, "shadow_nan")[0]["errors"] == 1)
        time.sleep(0.5)  # the worker's own word on it, once it reads it, counts nothing more
        [counts] = status(ep, "shadow_nan")
    finally:
        session.close()
        assert proc.stop() == 0, proc.output
    assert kept.decision is Decision.veto and kept.action is Action.accelerate and kept.rules == [RULE_DEADLINE]
    assert refused.decision is Decision.override and refused.action is Action.brake and refused.proposed is None
    assert refused.rules == ["monitor.bad_input"] and refused.frame_id == 0
    assert refused.error.startswith("schema violation: scene.ego.speed: Input should be a finite number")
    assert counts["errors"] == 1 and counts["errors_by_kind"] == {"schema": 1}
    code, out, err = audit(capsys, str(tmp_path), "--workers", "1", "--vehicle", "nan")
    assert "? -> brake" in out and "monitor.bad_input" in out and "monitor.deadline" not in out


def test_the_audit_shows_no_proposed_action_for_a_deadline_failsafe_whose_payload_was_refused(
        slow_monitor, slow_log, capsys):
    session = zenoh.open(ZenohSettings(listen=[], connect=[slow_monitor]).to_zenoh())
    try:
        busy = ask(session, "busy", proposal("busy", highway_scene(0, 4)))
        garbled = answer(ask(session, "garbled_audit", b'{"action": "accelerate", "frame_id": 9, "scene": '))
        answer(busy)
    finally:
        session.close()
    assert garbled.rules == [RULE_DEADLINE] and garbled.proposed is Action.accelerate  # a glance, not a reading
    wait_until(lambda: any(r.kind == "verdict" for r in read_log(slow_log) if r.vehicle == "garbled_audit"))
    code, out, err = audit(capsys, str(slow_log), "--workers", "1", "--vehicle", "garbled_audit")
    assert "? -> brake" in out and "accelerate" not in out, out
