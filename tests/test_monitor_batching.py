"""A decision worker decides the proposals queued for it in batches: each verdict as if decided alone."""

from __future__ import annotations

import gc
import itertools
import time
from collections import deque
from dataclasses import replace

import pytest
import zenoh

from discern.monitor import decision_worker
from discern.monitor.config import ZenohSettings
from discern.monitor.decision_worker import BatchTime, Job, Judge, WorkerSettings
from discern.monitor.example_planner import highway_scene
from discern.rules.engine import Reasoner, Request
from discern.rules.scene import Proposal
from discern.rules.verdict import Verdict
from discern.sanity import default_providers, window_reasoner
from tests.monitor_process import serve, wait_until
from tests.audit_logs import flashing

pytestmark = pytest.mark.wall_clock  # run alone: see the marker in pyproject.toml

BUDGET_MS = 3000
DELAY_MS = 150  # test-only hook: each batch sleeps this long first
VEHICLES, FRAMES = 6, 4  # 24 proposals: one by one they would need 3.6 s, over the budget
ACTIONS = ("cruise", "accelerate", "change_lane_left", "brake")


@pytest.fixture(scope="module")
def monitor():
    proc, ep = serve("--id", "batch", "--budget-ms", str(BUDGET_MS), "--test-only-decision-delay-ms", str(DELAY_MS))
    session = zenoh.open(ZenohSettings(listen=[], connect=[ep]).to_zenoh())
    yield session
    session.close()
    assert proc.stop() == 0, proc.output


def payload(vehicle: str, scene, action: str) -> bytes:
    return Proposal(vehicle=vehicle, action=action, scene=scene).model_dump_json(by_alias=True).encode()


def burst(session, proposals: list[tuple[str, bytes]]) -> list[Verdict]:
    """Send every proposal at once (one session: each vehicle's frames arrive in order), then collect the verdicts."""
    pending = [session.get(f"discern/{vehicle}/check", payload=data, timeout=10) for vehicle, data in proposals]
    verdicts = []
    for replies in pending:
        [reply] = [r.ok for r in replies if r.ok is not None]
        verdicts.append(Verdict.model_validate_json(reply.payload.to_bytes()))
    return verdicts


def alone(reasoner: Reasoner, vehicle: str, scene, action: str, history: tuple) -> dict:
    verdict = reasoner.decide(scene, action, history=history, vehicle=vehicle)
    return comparable(Verdict.model_validate_json(verdict.model_dump_json()))


def comparable(verdict: Verdict) -> dict:
    return verdict.model_dump(exclude={"latency_ms"})


def test_a_burst_from_several_vehicles_is_decided_by_the_rules_each_as_if_alone(monitor):
    frames = {
        f"burst_{v}": [(highway_scene(100 * f + 280, 8, seed=v), ACTIONS[(v + f) % len(ACTIONS)]) for f in range(FRAMES)]
        for v in range(VEHICLES)
    }
    order = [(vehicle, f) for f in range(FRAMES) for vehicle in frames]  # interleaved, as a fleet sends
    verdicts = burst(monitor, [(v, payload(v, *frames[v][f])) for v, f in order])
    assert not [v for v in verdicts if v.failsafe], [v.error for v in verdicts if v.failsafe]
    reasoner = window_reasoner()
    for (vehicle, f), verdict in zip(order, verdicts):
        history = tuple(scene for scene, _ in frames[vehicle][:f])
        assert comparable(verdict) == alone(reasoner, vehicle, *frames[vehicle][f], history)
        assert 0 < verdict.latency_ms < BUDGET_MS
    assert {v.decision.value for v in verdicts} >= {"approve", "override"}


def test_a_bad_proposal_in_a_burst_gets_its_error_and_the_rest_of_its_batch_is_decided(monitor):
    one, two, three = (highway_scene(f, 8, seed=9) for f in (1, 2, 3))
    other = highway_scene(5, 8, seed=10)
    proposals = [
        ("mixed_pacer", payload("mixed_pacer", highway_scene(0, 4), "cruise")),  # the others queue behind it
        ("mixed_a", payload("mixed_a", one, "cruise")),
        ("mixed_a", payload("mixed_a", two, "accelerate")),
        ("mixed_a", payload("mixed_a", two, "cruise")),  # a duplicate frame
        ("mixed_bad", b'{"action": "cruise", "scene": {'),
        ("mixed_b", payload("mixed_b", other, "change_lane_left")),
        ("mixed_a", payload("mixed_a", three, "cruise")),
    ]
    pacer, a1, a2, duplicate, malformed, b, a3 = burst(monitor, proposals)
    assert duplicate.failsafe and "duplicate frame 2" in duplicate.error and duplicate.rules == ["monitor.bad_input"]
    assert malformed.failsafe and "malformed JSON" in malformed.error and malformed.vehicle == "mixed_bad"
    reasoner = window_reasoner()
    assert comparable(a1) == alone(reasoner, "mixed_a", one, "cruise", ())
    assert comparable(a2) == alone(reasoner, "mixed_a", two, "accelerate", (one,))
    assert comparable(a3) == alone(reasoner, "mixed_a", three, "cruise", (one, two))  # the duplicate left no trace
    assert comparable(b) == alone(reasoner, "mixed_b", other, "change_lane_left", ())
    assert not any(v.failsafe for v in (pacer, a1, a2, a3, b))


# -- one worker's judge, in this process -------------------------------------------


def jobs(count: int, budget_s: float, scene_of=lambda i: highway_scene(i, 4)) -> deque:
    now = time.monotonic()
    return deque(
        Job(i, f"v{i}", Proposal(vehicle=f"v{i}", action="cruise", scene=scene_of(i)).model_dump_json().encode(), now,
            now + budget_s)
        for i in range(count)
    )


def test_a_batch_that_fails_is_decided_one_by_one_so_only_the_poisoned_frame_fails():
    calls = itertools.count()

    class Poisoned(Reasoner):  # the batch's grounding fails, then the second frame's alone
        def solve_facts(self, texts, proposed):
            if len(texts) > 1 and next(calls) in (0, 2):
                raise RuntimeError("poisoned")
            return super().solve_facts(texts, proposed)

        def _solve_text(self, text, proposed):
            if next(calls) in (0, 2):
                raise RuntimeError("poisoned")
            return super()._solve_text(text, proposed)

    judge = Judge(WorkerSettings(window_s=2.0, shadow=False))
    judge.reasoner = Poisoned(providers=default_providers())
    judge.time.learn(1, 0.001)  # timed once: it may batch
    backlog = jobs(3, 10.0)
    first, poisoned, third = judge.next_batch(backlog)
    assert not backlog
    assert first.verdict is not None and third.verdict is not None and first.decision == third.decision == "approve"
    assert poisoned.verdict is None and poisoned.internal and poisoned.no_verdict == "internal error: RuntimeError: poisoned"
    assert poisoned.frame_id == 1 and poisoned.action == "cruise"


def test_jobs_answered_before_the_worker_took_them_enter_the_window_and_get_no_second_answer():
    """The watchdog answered them at their deadline; their scenes are still the vehicle's history."""
    judge = Judge(WorkerSettings(window_s=2.0, shadow=False))
    now = time.monotonic()

    def job(rid: int, data: bytes, answered: bool = False) -> Job:
        return Job(rid, "late", data, now, now + 10.0, answered=answered)

    backlog = deque([
        job(0, payload("late", flashing(0, lights=False), "cruise")),
        job(1, payload("late", flashing(1), "cruise"), answered=True),
        job(2, b'{"action": "cruise", "scene": {', answered=True),
        job(3, payload("late", flashing(1), "brake"), answered=True),  # a duplicate frame: stays out, unrefused
        job(4, payload("late", flashing(2), "cruise")),
    ])
    outcomes = {}
    while backlog:
        outcomes.update((o.rid, o) for o in judge.next_batch(backlog))
    receipts = [outcomes[rid] for rid in (1, 2, 3)]
    assert all(o.receipt and o.verdict is None and o.no_verdict is None for o in receipts)
    assert [o.decoded for o in receipts] == [True, False, True] and receipts[1].error.startswith("malformed JSON")
    assert [o.error_kind for o in receipts] == [None, "json", None]  # bad input, counted by the monitor as refused
    decided = Verdict.model_validate_json(outcomes[4].verdict)  # lights in frames 1 and 2: an emergency on duty
    assert decided.action.value == "pull_over" and "san.emergency.flashing" in decided.rules


def test_a_proposal_shed_for_lack_of_time_still_enters_its_vehicles_window():
    judge = Judge(WorkerSettings(window_s=2.0, shadow=False))
    now = time.monotonic()

    def job(rid: int, frame: int, lights: bool = True, arrived: float = now, left: float = 10.0) -> Job:
        return Job(rid, "shed", payload("shed", flashing(frame, lights), "cruise"), arrived, now + left)

    [first] = judge.next_batch(deque([job(0, 0, lights=False)]))
    assert first.decision == "approve"
    judge.time.fixed_s, judge.time.per_proposal_s = 0.0, 0.05  # 50 ms a decision: 75 ms with the margin
    [shed] = judge.next_batch(deque([job(1, 1, arrived=now - 0.09, left=0.01)]))  # 10 ms of its 100 left
    assert shed.verdict is None and "left after queueing" in shed.no_verdict
    [decided] = judge.next_batch(deque([job(2, 2)]))
    verdict = Verdict.model_validate_json(decided.verdict)  # lights in frames 1 and 2: an emergency on duty
    assert verdict.action.value == "pull_over" and "san.emergency.flashing" in verdict.rules
    assert shed.decoded and shed.frame_id == 1 and shed.action == "cruise"  # logged as the proposal it is


def test_a_batch_holds_only_what_can_be_decided_before_the_oldest_deadline():
    judge = Judge(WorkerSettings(window_s=2.0, shadow=False))
    judge.time.learn(1, 0.01)
    judge.time.fixed_s, judge.time.per_proposal_s = 0.0, 0.01  # 10 ms a proposal
    backlog = jobs(10, 0.055)  # 1.5 x 30 ms fits in 55 ms, 1.5 x 40 ms does not
    decided = list(judge.next_batch(backlog))
    assert [o.rid for o in decided] == [0, 1, 2] and all(o.verdict is not None for o in decided)
    assert [job.rid for job in backlog] == list(range(3, 10))  # left for the next batch


def test_under_overload_the_batch_starts_where_it_decides_the_most_proposals_in_time():
    judge = Judge(WorkerSettings(window_s=2.0, shadow=False))
    judge.time.learn(1, 0.01)
    judge.time.fixed_s, judge.time.per_proposal_s = 0.0, 0.01  # 10 ms a proposal, 15 ms with the margin
    backlog = jobs(8, 0.020)  # the two oldest have 20 ms left: from them, one fits
    for k in range(2, 8):  # the six younger ones have 95 ms: all six fit in one batch
        backlog[k] = replace(backlog[k], deadline=backlog[k].deadline + 0.075)
    outcomes = list(judge.next_batch(backlog))
    shed, decided = outcomes[:2], outcomes[2:]
    assert [o.rid for o in shed] == [0, 1] and all(o.verdict is None and o.decoded for o in shed)
    assert all("shed under overload: 6 younger proposals" in o.no_verdict for o in shed)
    assert [o.rid for o in decided] == list(range(2, 8)) and all(o.verdict is not None for o in decided)
    assert not backlog


def test_without_overload_the_batch_starts_with_the_oldest_proposal():
    judge = Judge(WorkerSettings(window_s=2.0, shadow=False))
    judge.time.learn(1, 0.01)
    judge.time.fixed_s, judge.time.per_proposal_s = 0.0, 0.01
    backlog = jobs(4, 0.020)  # the oldest has time for itself only, the rest for more: it still goes first
    for k in range(1, 4):
        backlog[k] = replace(backlog[k], deadline=backlog[k].deadline + 0.075)
    assert [o.rid for o in judge.next_batch(backlog)] == [0]  # alone: a batch from rid 1 would take 3, no more


def test_a_worker_decides_one_at_a_time_until_it_has_timed_a_decision():
    judge = Judge(WorkerSettings(window_s=2.0, shadow=False))
    backlog = jobs(5, 10.0)
    assert [o.rid for o in judge.next_batch(backlog)] == [0]
    assert judge.time.known and len(list(judge.next_batch(backlog))) == 4


def test_the_batch_time_estimate_learns_a_fixed_part_and_a_part_per_proposal():
    estimate = BatchTime()
    took = lambda n: 0.005 + 0.0013 * n  # noqa: E731  (8-object highway frames, about)
    for i in range(300):
        n = 1 + i * 7 % 32
        estimate.learn(n, took(n))
    for n in (1, 8, 32):
        assert estimate.predict(n) == pytest.approx(took(n), rel=0.2)
    assert estimate.predict(32) < 0.3 * 32 * estimate.predict(1)  # a batch costs far less than its frames alone


def test_the_largest_batch_that_fits_a_time_is_read_off_the_estimate():
    estimate = BatchTime()
    estimate.fixed_s, estimate.per_proposal_s = 0.003, 0.002
    assert estimate.most_within(0.0195) == 8 and estimate.most_within(0.0189) == 7
    assert estimate.most_within(0.002) == 0  # not even the fixed part fits


def test_decisions_leave_no_reference_cycles_for_the_full_collections_to_find():
    reasoner = window_reasoner()
    frames = [highway_scene(f, 8, seed=4) for f in range(1, 6)]
    gc.collect()
    gc.set_debug(gc.DEBUG_SAVEALL)  # what a collection finds unreachable is kept in gc.garbage, not freed
    try:
        for k, scene in enumerate(frames):
            for action in ACTIONS:
                reasoner.decide(scene, action, history=tuple(frames[:k]), explain=k % 2 == 0)
            reasoner.prepare()
        reasoner.decide_many([Request(scene, "cruise") for scene in frames])
        gc.collect()
        cycles = list(gc.garbage)
    finally:
        gc.set_debug(0)
        gc.garbage.clear()
    assert cycles == []


def test_an_idle_worker_readies_controls_for_recent_frames_until_a_proposal_comes():
    reasoner = window_reasoner()
    for seed, objects in ((1, 0), (2, 8)):  # two slices: with and without objects
        reasoner.decide(highway_scene(seed, objects, seed=seed), "cruise")
    made = []
    prepare = reasoner.prepare
    reasoner.prepare = lambda limit=None: made.append(prepare(limit)) or made[-1]
    idle = decision_worker.IdleWork(reasoner)
    idle.run(busy=lambda: True)
    assert sum(made) == 0
    idle.run(busy=iter([False, True]).__next__)  # one Control made, then a proposal is waiting
    assert sum(made) == 1
    idle.run()
    assert sum(made) == 2


def test_a_worker_whose_idle_work_fails_stops_it_and_still_decides(caplog):
    reasoner = window_reasoner()
    scene = highway_scene(1, 8, seed=3)
    reasoner.decide(scene, "cruise")
    calls = []

    def broken(limit=None):
        calls.append(limit)
        raise RuntimeError("no memory for a Control")

    reasoner.prepare = broken
    idle = decision_worker.IdleWork(reasoner)
    idle.run()
    idle.run()
    assert len(calls) == 1 and "idle time failed" in caplog.text
    assert reasoner.decide(scene, "cruise").decision.value == "approve"


def test_an_idle_worker_runs_a_full_collection_at_most_once_an_interval(monkeypatch):
    full = []

    def count(phase, info):
        if phase == "start" and info["generation"] == 2:
            full.append(info)

    clock = [1000.0]
    monkeypatch.setattr(decision_worker.time, "monotonic", lambda: clock[0])
    idle = decision_worker.IdleWork(window_reasoner())
    gc.callbacks.append(count)
    try:
        idle.run()  # just started: too soon
        clock[0] += decision_worker.FULL_COLLECTION_S
        idle.run()
        idle.run()  # just collected: too soon again
    finally:
        gc.callbacks.remove(count)
    assert len(full) == 1


@pytest.mark.parametrize("window_s, remembered", [(2.0, False), (5.0, True)])
def test_the_sanity_rules_see_the_whole_window_the_monitor_keeps(window_s, remembered):
    """`--window-s 5`: a red light seen 3 s ago and hidden now is still remembered, as in a 5 s window it must be."""
    from tests.scenes import scene

    judge = Judge(WorkerSettings(window_s=window_s, shadow=False))
    red = scene(frame=1, speed=8.0, lights=[{"colour": "red"}], limit=13.0).model_copy(update={"timestamp": 1.0})
    hidden = scene(frame=2, speed=8.0, limit=13.0).model_copy(update={"timestamp": 4.0})
    now = time.monotonic()
    backlog = deque(Job(i, "v", Proposal(vehicle="v", action=action, scene=sc).model_dump_json().encode(), now, now + 10)
                    for i, (sc, action) in enumerate([(red, "brake"), (hidden, "cruise")]))
    outcomes = [o for _ in range(2) for o in judge.next_batch(backlog)]
    verdict = Verdict.model_validate_json(outcomes[-1].verdict)
    assert ("san.memory.red_light" in verdict.rules) is remembered


def test_a_shed_payload_that_is_no_proposal_is_refused_by_name_not_answered_as_late():
    """Bad input is bad input however busy the worker: refused as such, counted by kind, brake even in shadow mode."""
    judge = Judge(WorkerSettings(window_s=2.0, shadow=True))
    judge.time.learn(1, 0.05)  # 50 ms a decision: 75 ms with the margin
    now = time.monotonic()
    nan = payload("busy", highway_scene(7, 3), "accelerate").replace(b'"speed":25.0', b'"speed":NaN', 1)
    assert b"NaN" in nan
    backlog = deque([
        Job(0, "busy", b'{"action": "cruise", "scene": {"frame_id": 6, ', now - 0.09, now + 0.01),  # 10 ms left
        Job(1, "busy", nan, now - 0.09, now + 0.01),
    ])
    malformed, schema = judge.next_batch(backlog)
    for outcome, kind, frame in ((malformed, "json", 6), (schema, "schema", 7)):
        assert outcome.verdict is not None and outcome.no_verdict is None and outcome.error_kind == kind
        verdict = Verdict.model_validate_json(outcome.verdict)
        assert verdict.rules == ["monitor.bad_input"] and verdict.action.value == "brake" and verdict.failsafe
        assert verdict.decision.value == "override" and verdict.error == outcome.error
        assert verdict.frame_id == frame  # the frame id the payload shows, proposal or not
    assert "malformed JSON" in malformed.error and "scene.ego.speed: Input should be a finite number" in schema.error


def test_a_shed_frame_out_of_order_is_refused_as_a_decided_one_would_be():
    judge = Judge(WorkerSettings(window_s=2.0, shadow=True))
    now = time.monotonic()
    [first] = judge.next_batch(deque([Job(0, "order", payload("order", highway_scene(5, 3), "cruise"), now, now + 10)]))
    assert first.verdict is not None and first.error_kind is None
    judge.time.fixed_s, judge.time.per_proposal_s = 0.0, 0.05
    late = Job(1, "order", payload("order", highway_scene(5, 3), "accelerate"), now - 0.09, now + 0.01)
    [replayed] = judge.next_batch(deque([late]))
    assert replayed.error_kind == "order" and "duplicate frame 5" in replayed.error
    verdict = Verdict.model_validate_json(replayed.verdict)
    assert verdict.rules == ["monitor.bad_input"] and verdict.frame_id == 5
    assert verdict.decision.value == "veto" and verdict.action.value == "accelerate"  # shadow: its action is kept


def test_a_refusal_names_the_frame_id_of_a_payload_that_is_no_proposal():
    """A planner waiting over publish/subscribe matches a verdict to its frame by its frame_id."""
    judge = Judge(WorkerSettings(window_s=2.0, shadow=False))
    now = time.monotonic()
    wrong = payload("labels", highway_scene(41, 3), "cruise").replace(b'"lane":2', b'"lane":"2"', 1)
    assert b'"lane":"2"' in wrong
    [refused] = judge.next_batch(deque([Job(0, "labels", wrong, now, now + 10)]))
    assert refused.error_kind == "schema" and Verdict.model_validate_json(refused.verdict).frame_id == 41


def test_the_windows_of_vehicles_silent_past_their_window_are_dropped(monkeypatch):
    judge = Judge(WorkerSettings(window_s=0.05, shadow=False))
    clock = [time.monotonic()]
    monkeypatch.setattr(decision_worker.time, "monotonic", lambda: clock[0])
    for rid, vehicle in enumerate(("gone", "stays")):
        list(judge.next_batch(deque([Job(rid, vehicle, payload(vehicle, highway_scene(1, 2), "cruise"), clock[0], clock[0] + 1)])))
    assert set(judge.vehicles) == {"gone", "stays"}
    clock[0] += decision_worker.EXPIRY_SWEEP_S + 1.0  # past the window and its margin
    arrived = clock[0]
    list(judge.next_batch(deque([Job(2, "stays", payload("stays", highway_scene(2, 2), "cruise"), arrived, arrived + 1)])))
    judge.forget_silent(deque())
    assert set(judge.vehicles) == {"stays"}
    clock[0] += 0.5  # "stays" silent past its 0.05 s window, but not past the margin: kept for now
    judge.forget_silent(deque())
    assert set(judge.vehicles) == {"stays"}
    clock[0] += decision_worker.EXPIRY_SWEEP_S + 1.0
    judge.forget_silent(deque())
    assert judge.vehicles == {}


def test_a_window_is_kept_while_a_job_sent_before_the_silence_ran_out_still_waits(monkeypatch):
    judge = Judge(WorkerSettings(window_s=0.05, shadow=False))
    clock = [time.monotonic()]
    monkeypatch.setattr(decision_worker.time, "monotonic", lambda: clock[0])
    list(judge.next_batch(deque([Job(0, "queued", payload("queued", highway_scene(1, 2), "cruise"), clock[0], clock[0] + 1)])))
    waiting = deque([Job(1, "queued", payload("queued", highway_scene(2, 2), "cruise"), clock[0] + 0.01, clock[0] + 9)])
    clock[0] += decision_worker.EXPIRY_SWEEP_S + 5.0  # a long backlog: the job waited, its vehicle's window with it
    judge.forget_silent(waiting)
    assert set(judge.vehicles) == {"queued"}


def test_an_idle_worker_drops_the_windows_of_vehicles_that_fall_silent(monkeypatch):
    import multiprocessing
    import threading

    from discern.monitor import vehicle_state

    monkeypatch.setattr(decision_worker, "EXPIRY_SWEEP_S", 0.01)
    monkeypatch.setattr(vehicle_state, "EXPIRY_MARGIN_S", 0.0)
    judge = Judge(WorkerSettings(window_s=0.05, shadow=False))
    now = time.monotonic()
    list(judge.next_batch(deque([Job(0, "idle", payload("idle", highway_scene(1, 2), "cruise"), now, now + 1)])))
    assert set(judge.vehicles) == {"idle"}
    monitor_end, worker_end = multiprocessing.Pipe()
    waiting = threading.Thread(
        target=decision_worker._take_waiting, args=(worker_end, deque(), decision_worker.IdleWork(judge.reasoner), judge)
    )
    waiting.start()
    try:
        assert wait_until(lambda: not judge.vehicles, timeout=10)  # no job came: it swept while it waited
    finally:
        monitor_end.send(decision_worker.STOP)
        waiting.join(10)


def test_a_worker_warms_up_on_frames_of_its_own_without_touching_a_vehicle_window_or_its_batch_timing():
    """Warming up readies the reasoner for a planner's first frames; no vehicle's history or deadline estimate may
    carry the warm-up's frames."""
    judge = Judge(WorkerSettings(window_s=2.0, shadow=False))
    kinds_before = judge.reasoner.slicer.kind_count()
    judge.warm_up()
    assert judge.vehicles == {} and not judge.time.known
    assert judge.reasoner.slicer.kind_count() > kinds_before
