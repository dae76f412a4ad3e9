"""The per-vehicle frame window handed to the reasoner as `history`, and the frame order it enforces."""

from __future__ import annotations

import pytest

from discern.monitor.example_planner import highway_scene
from discern.monitor.protocol import InputError
from discern.rules.scene import Action
from discern.monitor.vehicle_state import EXPIRY_MARGIN_S, MAX_FRAMES, PermittedMemory, VehicleState
from discern.sanity import WindowProvider

WINDOW = WindowProvider()


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
    # a late or replayed frame keeps its time; an id going back at a later time starts the count again (below)
    for bad, at, word in ((7, 1.1, "duplicate"), (7, 1.0, "duplicate"), (3, 0.9, "out-of-order")):
        with pytest.raises(InputError, match=word) as refused:
            state.admit(frame(bad, at), now=0.1)
        assert refused.value.kind == "order"
    assert [s.frame_id for s in state.admit(frame(8, 1.2), now=0.2)] == [7]


def test_a_restart_refused_for_want_of_scene_timestamps_is_told_to_set_them():
    """A planner restarted without timestamps got 2 s of "out-of-order frame 0" brakes and no hint why."""
    state = VehicleState(window_s=2.0)
    for i in range(40):
        state.admit(frame(i, 0.0), now=0.05 * i)
    with pytest.raises(InputError) as refused:
        state.admit(frame(0, 0.0), now=2.0)
    assert str(refused.value) == (
        "frame_id: out-of-order frame 0, the last frame received for this vehicle was 39 (without a scene timestamp a"
        " restarted planner cannot be told from a replay, and is refused until it has been silent for 2 s: set"
        ' Scene.timestamp, see docs/protocol.md "Per-vehicle state")')
    timed = VehicleState(window_s=2.0)
    timed.admit(frame(7, 1.0), now=0.0)
    with pytest.raises(InputError) as late:  # a late frame of a planner that sets timestamps: nothing to set
        timed.admit(frame(3, 0.9), now=0.1)
    assert str(late.value) == "frame_id: out-of-order frame 3, the last frame received for this vehicle was 7"


def test_a_vehicle_silent_longer_than_the_window_starts_afresh():
    state = VehicleState(window_s=2.0)
    state.admit(frame(500, 30.0), now=0.0)
    assert state.admit(frame(0, 0.0), now=2.5) == ()  # a restarted planner counts from 0 again


def window(state: VehicleState, scene, now: float) -> list[int]:
    """The frame ids of the scene's window as its decision worker reads it: the sanity window over the history."""
    return [s.frame_id for s in WINDOW.window(scene, state.admit(scene, now))]


def test_a_clock_going_back_starts_the_window_afresh():
    state = VehicleState(window_s=2.0)
    state.admit(frame(1, 5.0), now=0.0)
    assert window(state, frame(2, 0.5), now=0.1) == []  # new episode, same planner
    assert window(state, frame(3, 0.6), now=0.2) == [2]


def test_a_late_frame_and_one_stamped_ahead_of_its_time_cost_no_history():
    state = VehicleState(window_s=2.0)
    for i, t in enumerate([0.0, 0.1, 0.2, 0.3], start=1):
        state.admit(frame(i, t), now=t)
    assert window(state, frame(5, 0.25), now=0.4) == [1, 2, 3]  # came late
    assert window(state, frame(6, 3.4), now=0.5) == []  # the clock glitched forward
    assert window(state, frame(7, 0.5), now=0.6) == [1, 2, 3, 4]  # frame 5 was late: the run goes on after 4
    assert window(state, frame(8, 0.6), now=0.7) == [1, 2, 3, 4, 7]


def test_a_new_episode_going_back_in_frame_id_and_time_is_admitted_with_a_fresh_window():
    state = VehicleState(window_s=2.0)
    for run in range(2):  # a planner restarted at once: the same frames again
        histories = [state.admit(frame(i, 1.0 + 0.05 * i), now=run + 0.05 * i) for i in range(3)]
        assert [[s.frame_id for s in h] for h in histories] == [[], [0], [0, 1]]


def test_a_new_episode_starting_again_at_scene_time_zero_is_admitted_with_a_fresh_window():
    state = VehicleState(window_s=2.0)
    for run in range(2):  # episodes at 20 Hz from t = 0.0, the second right after the first
        histories = [state.admit(frame(i, 0.05 * i), now=2.0 * run + 0.05 * i) for i in range(40)]
        assert [len(h) for h in histories[:3]] == [0, 1, 2]  # frame 0 at 0.0 starts it, not 40 refusals


def test_a_clock_going_back_to_zero_while_the_frame_id_rises_starts_the_window_afresh():
    state = VehicleState(window_s=2.0)
    for i in range(5):
        state.admit(frame(i, 1.0 + 0.05 * i), now=0.05 * i)
    assert window(state, frame(5, 0.0), now=0.25) == []  # a planner that keeps counting across episodes
    assert window(state, frame(6, 0.05), now=0.3) == [5]


def test_without_scene_timestamps_a_frame_going_back_is_refused_not_a_new_episode():
    state = VehicleState(window_s=2.0)
    for i in range(5):
        state.admit(frame(i, 0.0), now=0.05 * i)
    with pytest.raises(InputError, match="out-of-order frame 0"):
        state.admit(frame(0, 0.0), now=0.3)


def test_a_vehicle_expires_once_silent_past_its_window_and_the_margin():
    state = VehicleState(window_s=2.0)
    state.admit(frame(1, 1.0), now=100.0)
    assert not state.expired(100.0 + 2.0 + EXPIRY_MARGIN_S)
    assert state.expired(100.0 + 2.0 + EXPIRY_MARGIN_S + 0.01)


def test_a_forgotten_vehicle_has_no_permitted_actions_left():
    memory = PermittedMemory()
    memory.remember("v", (Action.cruise,), now=1.0)
    memory.forget("v")
    assert memory.recent("v", 1.0) == () and memory._last == {}


def test_an_old_frame_of_the_episode_is_refused_though_it_goes_back_in_frame_id_and_time():
    state = VehicleState(window_s=2.0)
    for i in range(10, 16):
        state.admit(frame(i, 2.0 + 0.05 * i), now=0.05 * i)
    for old in (14, 11):  # later than the episode's first frame (10): a replay, not a restart
        with pytest.raises(InputError, match=f"out-of-order frame {old}"):
            state.admit(frame(old, 2.0 + 0.05 * old), now=0.8)
    assert [s.frame_id for s in state.admit(frame(16, 2.8), now=0.81)] == list(range(10, 16))


def test_a_frame_back_in_id_or_time_alone_or_before_the_episode_moved_on_is_no_new_episode():
    state = VehicleState(window_s=2.0)
    state.admit(frame(5, 3.0), now=0.0)
    state.admit(frame(6, 3.05), now=0.05)
    with pytest.raises(InputError, match="out-of-order frame 0"):
        state.admit(frame(0, 3.05), now=0.1)  # the id went back, the clock did not move on
    with pytest.raises(InputError, match="duplicate frame 6"):
        state.admit(frame(6, 1.0), now=0.15)  # the clock went back, the id did not
    single = VehicleState(window_s=2.0)
    single.admit(frame(5, 1.0), now=0.0)
    with pytest.raises(InputError, match="duplicate frame 5"):  # indistinguishable from a replay: refused
        single.admit(frame(5, 1.0), now=0.1)
    with pytest.raises(InputError, match="out-of-order frame 3"):  # late: the episode had not moved past frame 5
        single.admit(frame(3, 0.9), now=0.15)


def test_the_window_is_bounded_whatever_the_rate():
    state = VehicleState(window_s=1e6)
    for i in range(MAX_FRAMES + 50):
        history = state.admit(frame(i, 1.0 + i * 1e-4), now=float(i) * 1e-4)
    assert len(history) == MAX_FRAMES


def times(state: VehicleState, scene, now: float) -> list[float]:
    """The scene times of the scene's window as its decision worker reads it."""
    return [s.timestamp for s in WINDOW.window(scene, state.admit(scene, now))]


def test_a_frame_counter_that_wraps_while_scene_time_runs_on_keeps_the_window():
    """A 16-bit counter going from 65535 to 0 got fail-safes ("out-of-order frame 0") for a whole window."""
    state = VehicleState(window_s=2.0)
    stamps = [100.0 + 0.05 * i for i in range(40)]
    windows = [times(state, frame((65520 + i) % 65536, t), now=0.05 * i) for i, t in enumerate(stamps)]
    assert windows[16] == stamps[:16]  # frame 0: the frames 65520 to 65535 before it
    assert windows[39] == stamps[:39]  # frame 23: the whole drive, 1.95 s of it
    history = state.admit(frame(24, 102.0), now=2.0)
    assert [s.frame_id for s in history[-3:]] == [21, 22, 23]  # the frames since the wrap keep their own ids
    with pytest.raises(InputError, match="duplicate frame 24"):
        state.admit(frame(24, 102.05), now=2.05)


def test_a_planner_restarted_on_the_drives_clock_counts_from_zero_with_the_window_kept():
    state = VehicleState(window_s=2.0)
    for i in range(500, 510):
        state.admit(frame(i, 0.05 * i), now=0.05 * i)
    assert times(state, frame(0, 25.6), now=25.6) == [0.05 * i for i in range(500, 510)]  # 25.0 to 25.45


def test_a_frame_back_in_id_and_time_after_a_wrap_is_still_refused_and_one_far_ahead_too():
    state = VehicleState(window_s=2.0)
    for i in range(8):
        state.admit(frame((65532 + i) % 65536, 10.0 + 0.05 * i), now=0.05 * i)  # 65532 .. 65535, 0 .. 3
    with pytest.raises(InputError, match="out-of-order frame 1"):
        state.admit(frame(1, 10.25), now=0.4)  # a replay of frame 1: back in id and time
    with pytest.raises(InputError, match="out-of-order frame 0"):
        state.admit(frame(0, 12.5), now=0.45)  # back in id, and more than a window ahead: a glitch, not a count
    assert times(state, frame(4, 10.4), now=0.5) == [10.0 + 0.05 * i for i in range(8)]


def test_a_frame_from_before_the_wrap_that_comes_after_it_is_late_and_costs_no_history():
    state = VehicleState(window_s=2.0)
    for i in range(8):
        state.admit(frame((65532 + i) % 65536, 10.0 + 0.05 * i), now=0.05 * i)  # 65532 .. 65535, 0 .. 3
    assert times(state, frame(65534, 10.1), now=0.4) == [10.0, 10.05]  # its id rises: judged with its own past
    assert times(state, frame(4, 10.4), now=0.45) == [10.0 + 0.05 * i for i in range(8)]  # and passed over
