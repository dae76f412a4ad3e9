"""The monitor's answers in the MCAP log: in the order they were claimed, handed to the writer once sent."""

from __future__ import annotations

import time

import pytest

from discern.monitor.config import LogSettings
from discern.monitor.example_planner import highway_scene
from discern.monitor.log import McapLogWriter, RecoveryReport, read_log
from discern.monitor.protocol import encode
from discern.monitor.server import Answer, Request, _AnswerLog
from discern.rules.engine import Reasoner
from discern.rules.scene import Proposal
from discern.sanity import window_reasoner

pytestmark = pytest.mark.wall_clock  # run alone: see the marker in pyproject.toml


def _answered(reasoner: Reasoner, frame: int) -> tuple[Request, Answer]:
    proposal = Proposal(vehicle="car_1", action="cruise", scene=highway_scene(frame, 4))
    verdict = reasoner.decide(proposal.scene, proposal.action, vehicle="car_1")
    payload = encode(proposal)
    now = time.monotonic()
    request = Request(frame, "discern/car_1/check", "car_1", payload, b"", len(payload), now, time.time_ns(), now + 0.05)
    return request, Answer(encode(verdict), verdict.decision.value, False, verdict.latency_ms)


def _logged(directory) -> list[tuple[str, int]]:
    records = list(read_log(directory, RecoveryReport()))
    return [(r.kind, (r.proposal.scene if r.kind == "proposal" else r.verdict).frame_id) for r in records]


def test_answers_reach_the_log_in_the_order_they_were_claimed_whichever_sender_releases_first(tmp_path):
    reasoner = window_reasoner()
    writer = McapLogWriter(LogSettings(directory=tmp_path), "unit")
    answers = _AnswerLog(writer)
    first, second = _answered(reasoner, 0), _answered(reasoner, 1)
    assert answers.claim(*first) and answers.claim(*second)
    assert not answers.claim(*first)  # claimed once only
    answers.release()  # the second sender is done first: both go, the first claimed first
    answers.release()
    writer.close()
    assert _logged(tmp_path) == [("proposal", 0), ("verdict", 0), ("proposal", 1), ("verdict", 1)]


def test_a_claimed_answer_waits_for_its_verdict_to_be_sent_before_the_writer_gets_it(tmp_path):
    writer = McapLogWriter(LogSettings(directory=tmp_path), "unit")
    answers = _AnswerLog(writer)
    assert answers.claim(*_answered(window_reasoner(), 0))
    writer.close()  # closed between the claim and its release: nothing was handed over yet
    assert _logged(tmp_path) == []


def test_stopping_hands_the_claimed_answers_to_the_writer(tmp_path):
    writer = McapLogWriter(LogSettings(directory=tmp_path), "unit")
    answers = _AnswerLog(writer)
    assert answers.claim(*_answered(window_reasoner(), 3))
    answers.flush("not read: the monitor stopped")
    writer.close()
    assert _logged(tmp_path) == [("proposal", 3), ("verdict", 3)]
