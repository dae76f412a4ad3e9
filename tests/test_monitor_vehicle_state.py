"""The per-vehicle frame window handed to the reasoner as `history`, and the frame order it enforces."""

from __future__ import annotations

import pytest

from discern.monitor.example_planner import highway_scene
from discern.monitor.protocol import InputError
from discern.monitor.vehicle_state import MAX_FRAMES, VehicleState


def frame(frame_id: int, timestamp: float):
    return highway_scene(frame_id, 2).model_copy(update={"timestamp": timestamp})


def test_history_is_the_previous_frames_within_the_window_oldest_first():
    state = VehicleState(window_s=2.0)
    assert state.admit(frame(0, 10.0), now=100.0) == ()
    for i in range(1, 40):
        history = state.admit(frame(i, 10.0 + 0.1 * i), now=100.0 + 0.1 * i)
    assert [s.frame_id for s in history] == list(range(19, 39))  # scene time 11.9 .. 13.8 within 2 s of 13.9
    assert all(a.timestamp < b.timestamp for a, b in zip(history, history[1:]))


def test_without_scene_timestamps_the_window_follows_arrival_time():
    state = VehicleState(window_s=1.0)
    for i in range(10):
        history = state.admit(frame(i, 0.0), now=50.0 + 0.25 * i)
    assert [s.frame_id for s in history] == [5, 6, 7, 8]


def test_replayed_and_old_frames_are_refused_without_touching_the_window():
    state = VehicleState(window_s=2.0)
    state.admit(frame(7, 1.0), now=0.0)
    for bad, word in ((7, "duplicate"), (3, "out-of-order")):
        with pytest.raises(InputError, match=word) as refused:
            state.admit(frame(bad, 1.1), now=0.1)
        assert refused.value.kind == "order"
    assert [s.frame_id for s in state.admit(frame(8, 1.2), now=0.2)] == [7]


def test_a_vehicle_silent_longer_than_the_window_starts_afresh():
    state = VehicleState(window_s=2.0)
    state.admit(frame(500, 30.0), now=0.0)
    assert state.admit(frame(0, 0.0), now=2.5) == ()  # a restarted planner counts from 0 again


def test_a_clock_going_back_clears_the_window():
    state = VehicleState(window_s=2.0)
    state.admit(frame(1, 5.0), now=0.0)
    assert state.admit(frame(2, 0.5), now=0.1) == ()  # new episode, same planner


def test_the_window_is_bounded_whatever_the_rate():
    state = VehicleState(window_s=1e6)
    for i in range(MAX_FRAMES + 50):
        history = state.admit(frame(i, 1.0 + i * 1e-4), now=float(i) * 1e-4)
    assert len(history) == MAX_FRAMES
