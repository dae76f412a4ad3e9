"""The frame window provider: which frames it keeps and the facts it derives from them."""

from __future__ import annotations

import weakref
from typing import Optional

import pytest
from clingo import Function

from discern.rules.scene import ObjectClass
from discern.sanity import WindowConfig, WindowProvider, default_providers
from discern.sanity.window import Bodies
from tests.scenes import MPH, limit_sign, obj, scene, sensor

PROVIDER = WindowProvider()


def at(t: float, limit: Optional[float] = 13.0, **kw):
    sc = scene(limit=limit, **kw)
    return sc.model_copy(update={"timestamp": t})


def facts(frames, provider=PROVIDER) -> set[str]:
    text = provider.facts(frames[-1], tuple(frames[:-1]))
    return {f + "." for f in text.split(".") if f}


def test_reasoner_picks_up_the_window_provider():
    from discern.sanity import window_reasoner

    assert [type(p) for p in window_reasoner().providers] == [WindowProvider]
    assert isinstance(default_providers()[0], WindowProvider)


def test_window_keeps_frames_within_its_seconds_oldest_first():
    frames = [at(t) for t in (0.0, 1.0, 1.5, 2.5, 3.2)]
    assert [s.timestamp for s in PROVIDER.window(frames[-1], frames[:-1])] == [1.5, 2.5]


def test_window_stops_at_a_frame_from_the_future():
    frames = [at(5.0), at(0.2), at(0.3)]  # the clock restarted after the first frame
    assert [s.timestamp for s in PROVIDER.window(frames[-1], frames[:-1])] == [0.2]


def _framed(frame_id: int, t: float, **kw):
    return at(t, frame=frame_id, **kw)


def test_window_stops_at_a_restart_whose_clock_went_back():
    """Episode A ran 0.5 s; episode B restarted its clock (and frame ids) at 0: at B's 0.7 s, A's frames are 0.2 to
    0.7 s old, and none of them belongs in B's window."""
    old = [_framed(i + 1, round(0.1 * i, 1)) for i in range(6)]
    new = [_framed(i + 1, round(0.1 * i, 1)) for i in range(8)]
    history = old + new
    assert [(s.frame_id, s.timestamp) for s in PROVIDER.window(history[-1], history[:-1])] == \
        [(s.frame_id, s.timestamp) for s in new[:-1]]
    clock_only = old + [_framed(7 + i, round(0.1 * i, 1)) for i in range(8)]  # ids go on, the clock restarts
    assert [s.frame_id for s in PROVIDER.window(clock_only[-1], clock_only[:-1])] == list(range(7, 14))


def test_window_stops_at_a_frame_id_reset_without_timestamps():
    history = [_framed(i + 1, 0.0) for i in range(6)] + [_framed(i + 1, 0.0) for i in range(3)]
    assert [s.frame_id for s in PROVIDER.window(history[-1], history[:-1])] == [1, 2]


def test_window_drops_a_frame_that_arrives_late():
    """A frame older than the one delivered before it, followed by a newer one, came late: it is dropped, so the
    window's frames are in time order."""
    times = [0.0, 0.1, 0.2, 0.4, 0.5, 0.3, 0.6]
    for ids in (range(1, 8), [1, 2, 3, 5, 6, 4, 7]):  # numbered as delivered, or as captured
        history = [_framed(i, t) for i, t in zip(ids, times)]
        assert [s.timestamp for s in PROVIDER.window(history[-1], history[:-1])] == [0.0, 0.1, 0.2, 0.4, 0.5]


def test_one_frame_stamped_ahead_of_its_time_does_not_cost_the_frames_before_it():
    times = [0.0, 0.1, 0.2, 0.3, 3.4, 0.5, 0.6]  # frame 5's clock glitched forward
    history = [_framed(i + 1, t) for i, t in enumerate(times)]
    assert [s.timestamp for s in PROVIDER.window(history[-1], history[:-1])] == [0.0, 0.1, 0.2, 0.3, 0.5]
    assert [s.timestamp for s in PROVIDER.window(history[-2], history[:-2])] == [0.0, 0.1, 0.2, 0.3]


@pytest.mark.parametrize("ids", [range(1, 7), [1, 2, 3, 5, 6, 4]])
def test_a_frame_decided_as_it_comes_late_is_judged_with_the_frames_before_it(ids):
    times = [0.0, 0.1, 0.2, 0.4, 0.5, 0.3]
    history = [_framed(i, t) for i, t in zip(ids, times)]
    assert [s.timestamp for s in PROVIDER.window(history[-1], history[:-1])] == [0.0, 0.1, 0.2]


def test_a_pedestrian_hidden_across_a_clock_glitch_is_remembered():
    walking = [obj("pedestrian", 4.0 - 0.15 * i, 20 - i, oid=2, vy=0.0, vx=-1.5, sources=["camera"])
               for i in range(3)]
    times = [0.0, 0.1, 0.2, 0.3, 3.4, 0.5]
    frames = [_framed(i + 1, t, objects=[walking[i]] if i < 3 else []) for i, t in enumerate(times)]
    assert any(f.startswith("remembered(2,") for f in facts(frames))


def test_a_late_frame_without_the_light_does_not_make_a_steady_yellow_flash():
    yellow = [{"colour": "yellow"}]
    frames = [_framed(i + 1, t, lights=[] if t == 0.3 else yellow) for i, t in enumerate([0.0, 0.1, 0.2, 0.4, 0.5, 0.3, 0.6])]
    assert not any(f.startswith("light_flashes") for f in facts(frames))


def test_window_caps_the_number_of_frames_without_timestamps():
    provider = WindowProvider(WindowConfig(max_frames=3))
    frames = [at(0.0) for _ in range(10)]
    assert len(provider.window(frames[-1], frames[:-1])) == 3


def test_frames_without_timestamps_fill_the_windows_seconds_and_age_by_the_untimed_frame_interval():
    """2 s of untimed frames at 0.1 s each are 20 frames, not max_frames' 40; a car lost 3 frames ago was last seen
    0.3 s ago (it read 0.0 s)."""
    frames = [at(0.0, frame=i + 1) for i in range(30)]
    assert len(PROVIDER.window(frames[-1], frames[:-1])) == 20
    car = obj("car", -3.5, 0.0, 1, oid=3, vy=10.0, sources=("camera", "radar"))
    seen = [at(0.0, frame=i + 1, lanes=2, lane=2, objects=[car]) for i in range(5)]
    lost = [at(0.0, frame=6 + i, lanes=2, lane=2) for i in range(3)]
    assert "remembered(3,300)." in facts(seen + lost)


def test_window_keeps_every_timed_frame_of_its_seconds_however_fast_they_come():
    frames = [at(1.0 + i / 50) for i in range(101)]  # 2 s at 50 Hz
    assert len(PROVIDER.window(frames[-1], frames[:-1])) == 100


@pytest.mark.parametrize("hz", [10, 20, 50])
def test_a_flashing_light_is_seen_flashing_in_every_frame_at_any_frame_rate(hz):
    """Lit for 0.5 s and dark for 0.5 s: at 50 Hz a 40-frame cap cut the window to 0.8 s, and the flash was
    seen in 45 of 150 frames."""
    frames = [at(1.0 + i / hz, lights=RED if (i / hz) % 1.0 < 0.5 else DARK) for i in range(6 * hz)]
    seen = [("light_flashes(red)." in facts(frames[k - 2 * hz:k + 1])) for k in range(3 * hz, 6 * hz)]
    assert all(seen)


def test_the_provider_keeps_no_frame_alive_once_its_callers_let_it_go():
    provider = WindowProvider()
    frames = [at(t, objects=[obj("car", 0, 20, oid=1, sources=("camera", "radar"))]) for t in (0.0, 0.1, 0.2)]
    before = facts(frames, provider)
    gone = [weakref.ref(frame) for frame in frames]
    del frames
    assert before and all(ref() is None for ref in gone)
    again = [at(t, objects=[obj("car", 0, 20, oid=1, sources=("camera", "radar"))]) for t in (0.0, 0.1, 0.2)]
    assert facts(again, provider) == before  # a new frame at a freed frame's address gets its own summary


def test_window_config_rejects_nonsense():
    with pytest.raises(ValueError, match="confirm_frames >= 1"):
        WindowConfig(confirm_frames=0)
    with pytest.raises(ValueError, match="horizon_s must be > 0"):
        WindowConfig(horizon_s=0)
    with pytest.raises(ValueError, match="flash_min_phase_s <= flash_max_phase_s"):
        WindowConfig(flash_min_phase_s=1.5, flash_max_phase_s=1.0)


def test_a_plain_frame_without_history_adds_no_facts():
    plain = scene(objects=[obj("car", 0.0, 20.0, 1, oid=1, vy=10.0, sources=("camera", "radar"))],
                  sensors=[sensor("left", 1.0)], limit=13.0)
    assert PROVIDER.facts(plain, ()) == ""


def test_reading_run_counts_the_frames_in_a_row():
    frames = [at(0.1 * i, limit=v) for i, v in enumerate([20.0, 15.0, 15.0, 15.0])]
    assert "reading_run(1500,3)." in facts(frames)


def test_prior_limit_is_the_last_settled_reading_before_the_current_one():
    frames = [at(0.1 * i, limit=v) for i, v in enumerate([20.0, 20.0, 25.0, 30.0])]
    found = facts(frames)
    assert "prior_limit(2000)." in found and "reading_run(3000,1)." in found


def test_a_one_frame_low_reading_is_no_prior_limit_the_settled_one_before_it_is_with_its_run():
    frames = [at(0.1 * i, limit=v) for i, v in enumerate([30.0, 30.0, 30.0, 2.0, 30.0])]
    found = facts(frames)
    assert {"prior_limit(3000).", "prior_run(3000,3).", "prior_time(3000,300)."} <= found
    assert "prior_limit(200)." not in found


def test_a_limit_read_over_frames_is_remembered_when_the_sign_has_gone():
    frames = [at(0.0, limit=None, signs=[limit_sign(30)]), at(0.1, limit=None, signs=[limit_sign(30)]),
              at(0.2, limit=None)]
    assert f"remembered_limit({round(30 * MPH * 100)})." in facts(frames)


def test_a_light_going_on_and_off_is_flashing_and_a_steady_one_is_not():
    red = [{"colour": "red"}]
    flashing = [at(0.0, lights=red), at(0.25, lights=DARK), at(0.5, lights=red)]
    steady = [at(0.0, lights=red), at(0.25, lights=red), at(0.5, lights=red)]
    assert "light_flashes(red)." in facts(flashing)
    assert not any(f.startswith("light_flashes") for f in facts(steady))


RED = [{"colour": "red"}]
DARK = [{"colour": "none"}]  # a light listed unlit: a dark phase (one not listed is out of view)


def _flashes(frames) -> bool:
    return "light_flashes(red)." in facts(frames)


def test_a_steady_red_that_drops_one_frame_is_not_flashing():
    # 10 frames a second: red, red, dark for 0.1 s, red (the review's red_dropout)
    frames = [at(0.0, lights=RED), at(0.1, lights=RED), at(0.2), at(0.3, lights=RED)]
    assert not _flashes(frames)


def test_a_light_flashing_at_one_hertz_over_ten_frames_a_second_is_flashing():
    lit = [(i // 5) % 2 == 0 for i in range(16)]  # 0.5 s lit, 0.5 s dark, ...
    assert _flashes([at(round(0.1 * i, 1), lights=RED if on else DARK) for i, on in enumerate(lit)])


def test_a_flicker_faster_than_a_flash_is_not_flashing():
    frames = [at(round(0.1 * i, 1), lights=RED if i % 2 == 0 else []) for i in range(9)]
    assert not _flashes(frames)


def test_going_off_and_on_once_is_no_whole_flash_cycle():
    assert not _flashes([at(0.0), at(0.5, lights=RED), at(1.0)])  # off, on, off: no dark phase between two lit ones


def test_a_light_lit_longer_than_a_flash_phase_is_steady_though_it_drops_out():
    frames = [at(round(0.1 * i, 1), lights=RED) for i in range(13)]  # lit 1.3 s
    frames += [at(1.3), at(1.4), at(1.5), at(1.6, lights=RED)]  # then dark 0.3 s
    assert not _flashes(frames)


def test_frames_without_timestamps_never_show_a_flash():
    assert not _flashes([at(0.0, lights=RED), at(0.0), at(0.0, lights=RED), at(0.0)])


def test_the_shortest_flash_phase_is_a_window_parameter():
    frames = [at(0.0, lights=RED), at(0.2, lights=DARK), at(0.4, lights=RED)]
    assert not _flashes(frames)  # dark for 0.2 s: shorter than a flash by default
    assert "light_flashes(red)." in facts(frames, WindowProvider(WindowConfig(flash_min_phase_s=0.2)))


def test_the_frames_that_report_a_light_flashing_are_counted_apart_from_an_inferred_flash():
    yellow = [{"colour": "yellow", "flashing": True}]
    found = facts([at(0.0, lights=yellow), at(0.1), at(0.2, lights=yellow)])
    assert "light_flashing_frames(yellow,2)." in found and "light_flashes(yellow)." not in found


def test_flags_are_counted_back_from_now_to_the_last_steady_report_of_the_colour():
    """A frame that reports the colour steady ends the count: flags either side of it are two glitches."""
    yellow, steady = [{"colour": "yellow", "flashing": True}], [{"colour": "yellow"}]
    found = facts([at(0.0, lights=yellow), at(0.1, lights=steady), at(0.2, lights=yellow)])
    assert "light_flashing_frames(yellow,1)." in found
    assert not any(f.startswith("light_flashing_frames") for f in facts([at(0.0, lights=yellow), at(0.1, lights=steady)]))
    beside = [{"colour": "yellow"}, {"colour": "yellow", "flashing": True}]  # a steady yellow beside a flashing beacon
    assert "light_flashing_frames(yellow,1)." in facts([at(0.0, lights=yellow), at(0.1, lights=beside), at(0.2, lights=yellow)])


def test_flags_and_emergency_lights_count_only_at_a_flashs_pace_up_to_now():
    """The latest flag no longer ago than a flash's longest phase, and none more than that apart."""
    yellow = [{"colour": "yellow", "flashing": True}]
    assert "light_flashing_frames(yellow,2)." in facts([at(0.0, lights=yellow), at(0.9, lights=yellow), at(1.9)])
    assert "light_flashing_frames(yellow,1)." in facts([at(0.0, lights=yellow), at(1.1, lights=yellow), at(1.2)])
    assert not any(f.startswith("light_flashing_frames") for f in facts([at(0.0, lights=yellow), at(1.1)]))
    frames = [at(0.1 * i, objects=[obj("emergency_vehicle", 0.0, -30.0, 1, oid=4, emergency_lights=i in (2, 15),
                                       sources=("camera", "radar"))])
              for i in range(17)]
    assert "lights_frames(4,1)." in facts(frames)
    assert not any(f.startswith("lights_frames") for f in facts(frames[:2] + frames[3:15] + [frames[16]]))


def test_a_red_light_out_of_view_is_remembered():
    assert "light_seen_recently(red)." in facts([at(0.0, lights=[{"colour": "red"}]), at(0.1)])


def test_a_lamp_of_colour_none_does_not_erase_a_red_light_seen_before():
    """A lamp perception reports with colour "none" (glare, unlit, unreadable) shows no colour: the red seen before
    is still the last colour seen, as when the light is out of view."""
    red, none = [{"colour": "red"}], [{"colour": "none"}]
    assert "light_seen_recently(red)." in facts([at(0.0, lights=red), at(0.1, lights=red), at(0.2, lights=none)])
    assert "light_seen_recently(red)." in facts([at(0.0, lights=red), at(0.1, lights=none), at(0.2)])
    assert not any(f.startswith("light_") for f in facts([at(0.0, lights=none), at(0.1, lights=none)]))


def test_a_lost_object_is_remembered_where_its_track_puts_it():
    seen = [at(0.1 * i, speed=10.0,
               objects=[obj("car", -3.5, -10.0, 1, oid=7, vy=20.0, sources=("camera", "radar"))]) for i in range(3)]
    found = facts(seen + [at(0.4, speed=10.0)])
    assert {"remembered(7,200).", "remembered_object(7,car).", "remembered_pos(7,-350,-800).",
            "track_frames(7,3)."} <= found
    # a lane of the ego's road is the one its tracked offset falls in (the rules place it); another kind stays
    assert not any(f.startswith("remembered_lane(7,") for f in found)
    oncoming = [at(0.1 * i, speed=10.0,
                   objects=[obj("car", -3.5, 30.0, 1, oid=8, kind="oncoming", vy=-10.0, sources=("camera", "radar"))])
                for i in range(3)]
    assert "remembered_lane(8,oncoming,1)." in facts(oncoming + [at(0.4, speed=10.0)])


def test_a_lost_object_a_range_sensor_still_reads_is_kept():
    glimpse = at(0.0, speed=10.0, objects=[obj("car", -3.5, -10.0, 1, oid=7, vy=20.0, sources=("camera", "radar"))])
    assert "sensor_still_reads(7,rear_left,radar,900)." in facts([glimpse, at(0.1, speed=10.0, sensors=[sensor("rear_left", 9.0)])])


def test_a_one_frame_glimpse_with_no_sensor_is_forgotten():
    glimpse = at(0.0, objects=[obj("car", -3.5, -10.0, 1, oid=7, vy=20.0, sources=("camera", "radar"))])
    assert not any(f.startswith("remembered") for f in facts([glimpse, at(0.1)]))


def test_earlier_range_sources_of_an_object_are_kept():
    frames = [at(0.0, objects=[obj("car", 0.0, 30.0, 1, oid=9, sources=("camera", "radar"))]),
              at(0.1, objects=[obj("car", 0.0, 29.0, 1, oid=9, sources=("camera",))])]
    assert "obj_source_before(9,radar)." in facts(frames)


def test_emergency_lights_are_counted_over_the_window():
    frames = [at(0.1 * i, objects=[obj("emergency_vehicle", 0.0, -30.0, 1, oid=4, emergency_lights=on,
                                       sources=("camera", "radar"))])
              for i, on in enumerate([True, False, True])]
    assert "lights_frames(4,2)." in facts(frames)


def test_a_pedestrian_walking_into_the_road_meets_the_ego_path():
    walker = scene(speed=8.0, objects=[obj("pedestrian", 5.5, 22.0, oid=3, vy=0.0, vx=-1.5,
                                           sources=("camera", "radar"))], limit=13.0)
    (conflict,) = [f for f in facts([walker]) if f.startswith("predicted_conflict")]
    assert conflict.startswith("predicted_conflict(3,26")


def test_a_child_who_clears_the_ego_path_at_its_speed_but_not_one_accelerate_faster_gets_a_stepped_conflict():
    """VRU review, defect 5: at 10 m/s the child clears the path 0.07 s before the ego gets there; at 10.5 m/s,
    one accelerate step (accel_step, 0.5 m/s) faster, it does not."""
    child = scene(speed=10.0, objects=[obj("pedestrian", 3.5, 18.0, oid=1, vy=0.0, vx=-3.0,
                                           sources=("camera", "radar"))], limit=13.0)
    found = facts([child])
    assert not any(f.startswith("predicted_conflict") for f in found)
    (stepped,) = [f for f in found if f.startswith("stepped_conflict")]
    assert stepped.startswith("stepped_conflict(1,16")  # 1.67 s on
    farther = scene(speed=10.0, objects=[obj("pedestrian", 3.5, 24.0, oid=1, vy=0.0, vx=-3.0,
                                             sources=("camera", "radar"))], limit=13.0)
    assert not any(f.startswith("stepped_conflict") for f in facts([farther]))


def test_objects_walking_along_in_the_ego_lane_or_coming_from_behind_get_no_predicted_crossing():
    along = scene(speed=8.0, objects=[obj("pedestrian", 5.5, 22.0, oid=3, vy=1.2, sources=("camera", "radar"))],
                  limit=13.0)
    ahead = scene(speed=8.0, objects=[obj("car", 0.0, 20.0, 1, oid=4, vy=2.0, sources=("camera", "radar"))], limit=13.0)
    behind = scene(speed=8.0, lanes=2,
                   objects=[obj("car", 3.5, -7.0, 2, oid=5, vy=12.0, vx=-1.0, sources=("camera", "radar"))], limit=13.0)
    assert not facts([along]) and not facts([ahead]) and not facts([behind])


def test_a_camera_only_vehicle_inside_a_confirmed_outline_overlaps_it():
    truck = obj("truck", 0.0, 30.0, 1, oid=2, size={"length": 12.0, "width": 2.5}, sources=("camera", "radar"))
    picture = obj("car", 0.3, 30.2, 1, oid=5, sources=("camera",))
    apart = obj("car", 3.5, 30.2, 2, oid=6, sources=("camera",))
    found = facts([scene(lanes=2, objects=[truck, picture, apart], limit=13.0)])
    assert "overlaps(5,2)." in found and not any(f.startswith("overlaps(6") for f in found)


def test_outlines_reach_away_from_the_ego_from_their_nearest_face():
    ahead = obj("truck", 0.0, 30.0, 1, oid=2, size={"length": 15.0, "width": 2.5}, sources=("camera", "radar"))
    behind = obj("truck", 0.0, -30.0, 1, oid=3, size={"length": 15.0, "width": 2.5}, sources=("radar",))
    before_it = obj("car", 0.0, 23.0, 1, oid=5, sources=("camera",))  # 7 m short of the truck's rear: a real car
    along_it = obj("car", 0.0, 40.0, 1, oid=6, sources=("camera",))
    behind_it = obj("car", 0.0, -40.0, 1, oid=7, sources=("camera",))
    after_it = obj("car", 0.0, -20.0, 1, oid=8, sources=("camera",))
    found = facts([scene(lanes=1, objects=[ahead, behind, before_it, along_it, behind_it, after_it], limit=13.0)])
    assert {f for f in found if f.startswith("overlaps")} == {"overlaps(6,2).", "overlaps(7,3)."}


def test_a_lost_vehicle_of_unknown_speed_is_moved_as_the_catalog_assumes_it(reasoner):
    """Ahead, a motor vehicle keeps pace and anything else stands (a bicycle too); behind, all but things keep pace."""
    bodies = reasoner.providers[0].bodies
    solved = reasoner.solve(scene(limit=13.0), "cruise")
    assert bodies.motor == {ObjectClass(a.arguments[0].name) for a in solved.answer.of("motor_vehicle", 1)} != set()
    assert bodies.stands == {ObjectClass(a.arguments[0].name) for a in solved.answer.of("stands_by_nature", 1)} != set()
    for cls, ahead_after in [("car", 2000), ("bicycle", 1900), ("pedestrian", 1900)]:  # lost for 0.1 s at 10 m/s
        seen = [at(0.1 * i, speed=10.0,
                   objects=[obj(cls, 0.0, 20.0, 1, oid=7, sources=("camera", "radar"))]) for i in range(3)]
        assert f"remembered_pos(7,0,{ahead_after})." in facts(seen + [at(0.3, speed=10.0)]), cls
    behind = [at(0.1 * i, speed=10.0,
                 objects=[obj("pedestrian", -3.5, -5.0, 1, oid=7, sources=("camera", "radar"))]) for i in range(3)]
    assert "remembered_pos(7,-350,-500)." in facts(behind + [at(0.3, speed=10.0)])
    cone = [at(0.1 * i, speed=10.0,
               objects=[obj("traffic_cone", -3.5, -5.0, 1, oid=7, sources=("camera", "radar"))]) for i in range(3)]
    assert "remembered_pos(7,-350,-600)." in facts(cone + [at(0.3, speed=10.0)])


def test_a_lost_object_ahead_of_the_bumper_is_read_by_the_sensor_facing_it():
    """Positions are gaps from the bumper: 1 m ahead on the left is the front-left sensor's, not the left one's."""
    glimpse = at(0.0, speed=10.0, objects=[obj("car", -3.5, 1.0, 1, oid=7, vy=10.0, sources=("camera", "radar"))])
    front = facts([glimpse, at(0.1, speed=10.0, sensors=[sensor("front_left", 3.0)])])
    beside = facts([glimpse, at(0.1, speed=10.0, sensors=[sensor("left", 1.0)])])
    assert "sensor_still_reads(7,front_left,radar,300)." in front and not any("sensor_still_reads" in f for f in beside)


def test_whether_the_ego_stopped_in_the_window_is_the_rules_call_with_their_parameter():
    from discern.rules.facts import Params
    from discern.sanity import window_reasoner

    frames = [at(0.1 * i, speed=0.8) for i in range(3)] + [at(0.3, speed=3.0)]
    assert "slowest_recent_speed(80)." in facts(frames)
    for stopped_speed, stopped in [(0.5, False), (1.0, True)]:
        solved = window_reasoner(params=Params(stopped_speed=stopped_speed)).solve(frames[-1], "cruise", frames[:-1])
        assert solved.answer.holds(Function("stopped_recently")) is stopped


def test_readings_and_tracks_last_as_many_mean_frame_intervals_as_they_have_frames():
    car = obj("car", 0.0, 20.0, 1, oid=7, sources=("camera", "radar"))
    fast = [at(round(0.02 * i, 2), limit=20.0, objects=[car] if i < 3 else []) for i in range(6)]
    found = facts(fast)  # 50 Hz: 6 frames of the reading, 120 ms; the car in 3 frames, 60 ms
    assert {"reading_run(2000,6).", "reading_time(2000,120).", "track_frames(7,3).", "track_time(7,60).",
            "window_param(confirm_ms,200).", "window_param(track_ms,300)."} <= found
    untimed = facts([at(0.0, limit=20.0) for _ in range(3)])  # without timestamps a frame lasts untimed_frame_s
    assert "reading_time(2000,300)." in untimed
    with pytest.raises(ValueError, match="untimed_frame_s > 0"):
        WindowConfig(untimed_frame_s=0)


def test_a_lost_object_whose_track_runs_into_the_ego_is_not_remembered():
    """A car standing 14 m ahead, lost at 12 m/s: once its track reaches the ego's own footprint it was not there (the
    ego would have hit it), and it is no longer remembered; until then it is."""
    seen = [at(round(0.1 * i, 1), speed=12.0,
               objects=[obj("car", 0.0, 14.0 - 1.2 * i, 1, oid=8, vy=0.0, sources=("camera",))])
            for i in range(3)]
    before = facts(seen + [at(0.6, speed=12.0)])  # lost 0.4 s ago at 11.6 m: 6.8 m ahead now
    assert "remembered_pos(8,0,680)." in before
    for t in (1.2, 1.5, 2.1):  # level with the ego, then behind it
        assert not any(f.startswith("remembered") for f in facts(seen + [at(t, speed=12.0)])), t
    beside = [at(round(0.1 * i, 1), speed=12.0,
                 objects=[obj("car", -3.5, 14.0 - 1.2 * i, 1, oid=8, vy=0.0, sources=("camera",))])
              for i in range(3)]
    assert any(f.startswith("remembered_pos(8,-350,0)") for f in facts(beside + [at(1.2, speed=12.0)]))  # passed beside


YELLOW = [{"colour": "yellow"}]


def test_a_steady_yellow_out_of_view_is_remembered_and_a_flashing_one_is_not():
    assert "light_seen_recently(yellow)." in facts([at(0.0, lights=YELLOW), at(0.1, lights=YELLOW), at(0.2)])
    flagged = [{"colour": "yellow", "flashing": True}]  # perception said flashing: caution, not a yellow to stop for
    assert "light_seen_recently(yellow)." not in facts([at(0.0, lights=flagged), at(0.25)])


def test_a_yellow_lit_again_after_one_dark_gap_is_not_yet_seen_flashing():
    """A steady yellow hidden for 0.4 s and back: on, off, on is not enough pattern for a yellow lit now."""
    lit = [True] * 4 + [False] * 4 + [True] * 2
    frames = [at(round(0.1 * i, 1), lights=YELLOW if on else []) for i, on in enumerate(lit)]
    assert all("light_flashes(yellow)." not in facts(frames[:k]) for k in range(1, len(frames) + 1))
    flashing = [(i // 5) % 2 == 0 for i in range(21)]  # 1 Hz: a whole lit and a whole dark phase seen
    frames = [at(round(0.1 * i, 1), lights=YELLOW if on else DARK) for i, on in enumerate(flashing)]
    assert "light_flashes(yellow)." in facts(frames)


SIGN_45, SIGN_65 = [limit_sign(45)], [limit_sign(65)]
CM_45, CM_65 = round(45 * MPH * 100), round(65 * MPH * 100)


def test_one_frame_readings_apart_are_no_run_once_the_sign_has_left_the_view():
    """65 misread in two single frames 0.9 s apart, nothing read between: no reading in two frames in a row, so
    the 45 read before is the limit that held, not a settled 65."""
    signs = [SIGN_45] * 3 + [SIGN_65] + [[]] * 8 + [SIGN_65, []]
    found = facts([at(round(0.1 * i, 1), limit=None, signs=s) for i, s in enumerate(signs)])
    assert f"remembered_limit({CM_45})." in found and f"reading_run({CM_45},3)." in found
    assert not any(f.startswith((f"remembered_limit({CM_65})", f"reading_run({CM_65},")) for f in found)


def test_a_limit_read_again_after_a_gap_is_still_the_settled_limit():
    signs = [SIGN_65] * 3 + [[]] + [SIGN_65] + [[]]
    found = facts([at(round(0.1 * i, 1), limit=None, signs=s) for i, s in enumerate(signs)])
    assert {f"remembered_limit({CM_65}).", f"reading_run({CM_65},3)."} <= found


def test_readings_and_tracks_last_by_their_own_timestamps_not_the_windows_mean_interval():
    """At 50 Hz, after 1.8 s without frames: a 65 read in three frames lasted 60 ms, not three mean intervals of the
    window (742 ms); a car seen in two frames was tracked for 40 ms."""
    times = [0.0, 0.02, 0.04, 0.06, 0.08, 0.1, 1.94, 1.96, 1.98]
    car = obj("car", 0.0, 20.0, 1, oid=7, sources=("camera", "radar"))
    frames = [at(t, limit=None, signs=SIGN_65 if t > 1 else SIGN_45, objects=[car] if t in (1.94, 1.96) else [])
              for t in times]
    found = facts(frames)
    assert {f"reading_run({CM_65},3).", f"reading_time({CM_65},60).", "track_frames(7,2).", "track_time(7,40)."} <= found
    # and a prior read before the dropout lasted its own frames: six at 50 Hz, 120 ms
    assert {f"prior_limit({CM_45}).", f"prior_time({CM_45},120)."} <= found


def test_a_pedestrian_lost_in_front_of_a_braking_ego_stays_ahead_of_it():
    """Lost 1.4 m ahead while the ego brakes from 2 m/s to a stop: the ego covers 0.4 m, not 2 m/s for 0.8 s, so
    the pedestrian is still 1 m ahead and not taken for one the ego would have run into."""
    speeds = [3.0, 2.5, 2.0, 1.5, 1.0, 0.5, 0.0, 0.0, 0.0]
    times = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.8, 1.0]
    walker = [obj("pedestrian", 0.3, y, oid=4, vy=0.0, vx=-0.3, sources=("camera",)) for y in (1.9, 1.6, 1.4)]
    frames = [at(t, speed=v, objects=[walker[i]] if i < 3 else []) for i, (t, v) in enumerate(zip(times, speeds))]
    found = facts(frames)
    assert {"remembered(4,800).", "remembered_pos(4,6,100)."} <= found


INTERSECTION = {"type": "four_way", "stage": "arriving", "stop_line": True}


def _approach(lit: list[bool], distances: list[float], **kw):
    return [at(round(0.1 * i, 1), lights=[{"colour": "green"}] if on else [], **kw,
               intersection={**INTERSECTION, "distance": d}) for i, (on, d) in enumerate(zip(lit, distances))]


def test_a_traffic_light_seen_on_the_approach_is_remembered_once_out_of_view():
    assert "light_seen_on_approach." in facts(_approach([True, True, False, False], [40.0, 38.7, 37.4, 36.1]))
    # the next intersection's approach (the line farther again, or an earlier stage) is not the lit one's
    assert "light_seen_on_approach." not in facts(_approach([True, True, False], [20.0, 18.7, 60.0]))
    entered = [at(0.0, lights=[{"colour": "green"}], intersection={**INTERSECTION, "stage": "enter"}),
               at(0.1, intersection={**INTERSECTION, "distance": 30.0})]
    assert "light_seen_on_approach." not in facts(entered)


def test_a_limit_read_at_a_stop_line_with_a_light_seen_on_the_approach_is_no_misread_stop_sign():
    frames = _approach([True, False, False], [30.0, 28.7, 27.4], limit=None, signs=SIGN_45)
    assert not any(f.startswith("misread_before") for f in facts(frames))
    unlit = _approach([False, False, False], [30.0, 28.7, 27.4], limit=None, signs=SIGN_45)
    assert f"misread_before({CM_45},a_stop_line_and_no_traffic_lights)." in facts(unlit)


def test_a_limit_sign_read_beside_a_stop_sign_is_no_misread_stop_sign():
    mapped = {"type": "four_way", "stage": "arriving", "distance": 70.0, "stop_controlled": True}
    beside = [at(round(0.1 * i, 1), limit=None, signs=[limit_sign(25), {"kind": "stop"}], intersection=mapped)
              for i in range(3)]
    assert not any(f.startswith("misread_before") for f in facts(beside))
    alone = [at(round(0.1 * i, 1), limit=None, signs=[limit_sign(25)], intersection=mapped) for i in range(3)]
    assert any(f.startswith("misread_before") for f in facts(alone))


def test_a_perceived_limit_that_rises_where_a_stop_sign_belongs_is_remembered_as_a_misread_and_is_no_prior():
    """Most stacks carry the limit the camera reads in the perceived limit, with no sign listed: a stop sign read as
    45 there was taken for the limit once the ego had passed it, and for the limit read before a later reading."""
    mapped = {"type": "four_way", "stage": "arriving", "distance": 20.0, "stop_controlled": True}
    limits = [15.6, 15.6, 20.1, 20.1, 20.1, 20.1, 22.4]  # 35 mph settled, the 45 at the approach and after, then 50
    frames = [at(round(0.1 * i, 1), limit=v, intersection=mapped if i in (2, 3) else None)
              for i, v in enumerate(limits)]
    found = facts(frames)
    assert "misread_before(2010,the_map_marks_it_stop_controlled)." in found
    assert "prior_limit(1560)." in found and "prior_limit(2010)." not in found


def test_a_perceived_limit_carried_on_through_a_stop_controlled_approach_is_no_misread():
    """Not higher than the limit read before, or with none read before (a long wait at the line): no sign read there."""
    mapped = {"type": "four_way", "stage": "at", "distance": 0.0, "stop_controlled": True}
    for limits in ([11.2] * 6, [15.6, 15.6, 11.2, 11.2, 11.2, 11.2]):
        frames = [at(round(0.1 * i, 1), limit=v, intersection=mapped if i < 5 else None) for i, v in enumerate(limits)]
        assert not any(f.startswith("misread_before") for f in facts(frames))


def test_an_ultrasonic_reading_beyond_its_reach_neither_clears_nor_keeps_a_lost_car(reasoner):
    """A front ultrasonic sensor reading 60 m is no clear road past a lost car 20 m ahead; a radar reading is."""
    seen = [at(0.1 * i, speed=10.0,
               objects=[obj("car", 0.0, 20.0, 1, oid=7, vy=10.0, sources=("camera", "radar"))]) for i in range(3)]

    def lost_car_kept(kind: str) -> bool:
        now = at(0.3, speed=10.0, sensors=[sensor("front", 60.0, kind)])
        return bool(reasoner.solve(now, "accelerate", history=seen).answer.of("still_there", 2))

    assert lost_car_kept("ultrasonic") and not lost_car_kept("radar")


def test_a_truck_driving_across_the_road_reaches_the_ego_path_with_its_length_not_its_width():
    """Its 10 m length lies across the ego's road: its front enters the corridor 0.87 s from now, not 1.25 s."""
    crossing = scene(speed=8.0, objects=[obj("truck", -15.0, 5.0, 1, oid=3, kind="cross_left", vy=0.0, vx=10.0,
                                             sources=("camera", "radar"))], limit=13.0)
    (conflict,) = [f for f in facts([crossing]) if f.startswith("predicted_conflict")]
    assert conflict.startswith("predicted_conflict(3,870,")


def test_a_size_of_0_in_length_or_width_is_no_size_and_the_class_gives_the_footprint():
    """A detector may give 0 for a size it does not know: the rules and the outlines get no size, not a point."""
    unknown = [{"length": 0.0, "width": 0.0}, {"length": 0.0, "width": 1.8}, {"length": 4.4, "width": 0.0}]
    frame = scene(limit=13.0,
                  objects=[obj("car", 0.0, 10.0 * i, 1, oid=i, size=size, sources=("camera", "radar"))
                           for i, size in enumerate(unknown, 1)]
                  + [obj("car", 0.0, 40.0, 1, oid=4, size={"length": 4.4, "width": 1.8}, sources=("camera", "radar"))])
    assert {f for f in facts([frame]) if f.startswith("obj_size(")} == {"obj_size(4,440,180)."}
    bodies = Bodies.shipped()
    assert [bodies.footprint(o) for o in frame.objects] == [(4.5, 1.8)] * 3 + [(4.4, 1.8)]


def test_the_window_sizes_and_faces_objects_as_its_reasoners_catalog_and_parameters_say(tmp_path):
    """It kept copies of the catalog's tables, held equal to the shipped catalog by tests: a --rules catalog or a
    --param lane_width went unseen by the window's predicted courses and its choice of facing sensor."""
    import shutil

    from discern.rules.catalog import catalog_dirs, load_catalog
    from discern.rules.engine import jurisdiction_pack
    from discern.rules.facts import Params
    from discern.sanity import window_reasoner

    edited = tmp_path / "catalog"
    shutil.copytree(catalog_dirs()[0], edited)
    geometry = edited / "10_geometry.lp"
    assert "typical_length(car, 450)." in geometry.read_text()
    geometry.write_text(geometry.read_text().replace("typical_length(car, 450).", "typical_length(car, 520)."))
    catalog = load_catalog([edited, catalog_dirs()[1]], [jurisdiction_pack("us")])
    bodies = window_reasoner(catalog=catalog, params=Params(lane_width=3.0)).providers[0].bodies
    assert bodies.lengths[ObjectClass.car] == 5.2 and bodies.half_lane == 1.5
    assert bodies.lengths[ObjectClass.pedestrian] == 0.6  # a class the catalog gives no length keeps the window's
    shipped = window_reasoner().providers[0].bodies
    assert shipped.lengths[ObjectClass.car] == 4.5 and shipped.half_lane == 1.75 and shipped == Bodies.shipped()


def test_a_timestamp_too_large_for_the_windows_clock_is_refused_by_the_scene_model():
    """1e306 s overflowed to infinity in whole milliseconds and crashed the window; the model now bounds it."""
    from pydantic import ValidationError

    with pytest.raises(ValidationError, match="timestamp"):
        scene(frame=1, timestamp=1e306, limit=13.0)
    with pytest.raises(ValidationError, match="timestamp"):
        scene(frame=1, timestamp=-1e306, limit=13.0)
    early, late = scene(frame=1, timestamp=1e12 - 0.1, limit=13.0), scene(frame=2, timestamp=1e12, limit=13.0)
    assert WindowProvider().facts(late, [early])  # the largest allowed timestamps still make a window


def test_one_frame_delivered_twice_is_seen_for_one_frame_not_two():
    """Two frames of one timestamp are one picture: a reading in both lasts a frame (100 ms), not the 200 ms that
    confirms it, as it did when the window took them for frames without timestamps."""
    sign = [{"kind": "speed_limit", "value": 20.117}]
    first = scene(frame=1, timestamp=5.0, signs=sign, limit=13.0)
    again = scene(frame=2, timestamp=5.0, signs=sign, limit=13.0)
    assert "reading_time(2012,100)." in facts([first, again])
    untimed = [scene(frame=1, timestamp=0.0, signs=sign, limit=13.0),
               scene(frame=2, timestamp=0.0, signs=sign, limit=13.0)]
    assert "reading_time(2012,200)." in facts(untimed)


def test_an_arrow_flashes_apart_from_the_ball_and_from_the_other_arrows():
    """A flashing yellow left arrow beside a steady yellow ball is no flashing ball, nor a flashing right arrow."""
    ball, left, right = {"colour": "yellow"}, {"colour": "yellow", "direction": "left"}, {"colour": "yellow", "direction": "right"}
    lit = [(i // 5) % 2 == 0 for i in range(21)]  # the left arrow at 1 Hz; the ball and the right arrow steady
    frames = [at(round(0.1 * i, 1), lights=[ball, right, {**left, "flashing": True}] if on
                 else [ball, right, {"colour": "none", "direction": "left"}])
              for i, on in enumerate(lit)]
    found = facts(frames)
    assert {"light_flashes(yellow_left_arrow).", "light_flashing_frames(yellow_left_arrow,11)."} <= found
    assert not any(f.startswith(("light_flashes(yellow)", "light_flashes(yellow_right", "light_flashing_frames(yellow,"))
                   for f in found)


def test_arrows_out_of_view_are_remembered_each_apart_from_the_ball_green_ones_too():
    """A green arrow governed its movement rather than the red ball beside it: its memory keeps the ball off it."""
    lights = [{"colour": "red"}, {"colour": "green", "direction": "left"}, {"colour": "red", "direction": "right"}]
    found = facts([at(0.0, lights=lights), at(0.1)])
    assert {"light_seen_recently(red).", "light_seen_recently(green_left_arrow).",
            "light_seen_recently(red_right_arrow)."} <= found
    assert "light_seen_recently(green)." not in facts([at(0.0, lights=[{"colour": "green"}]), at(0.1)])


def test_an_unlit_arrow_beside_a_lit_ball_is_no_dark_signal():
    frames = [at(round(0.1 * i, 1), lights=[{"colour": "green"}, {"colour": "none", "direction": "left"}]) for i in range(3)]
    assert "signal_dark." not in facts(frames)
