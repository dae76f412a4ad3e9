"""Every sanity and jurisdiction rule: its worked example fires it, its near miss does not; and behaviours found in review
(a dropped frame is no flash, range-confirmed objects are real whatever their size, close or vulnerable camera-only
objects are no phantoms)."""

from __future__ import annotations

from pathlib import Path

import pytest
from clingo import Function, Number

from discern.rules.scene import Action, Scene
from discern.rules.verdict import Decision
from discern.sanity import reasoner_for
from tests import worked_examples
from tests.scenes import MPH, obj, scene, sensor
from tests.worked_examples import EXAMPLES, fired

BY_RULE = {e.rule: e for e in EXAMPLES}
DOC = Path(__file__).resolve().parents[1] / "docs" / "sanity.md"


def _layer_rules(jurisdiction: str) -> set[str]:
    return {r.id for r in reasoner_for(jurisdiction).catalog.driving_rules() if r.id.startswith(("san.", "jur."))}


def test_every_sanity_and_jurisdiction_rule_has_a_worked_example():
    assert _layer_rules("us") | _layer_rules("uk") == set(BY_RULE)


@pytest.mark.parametrize("rule", sorted(BY_RULE))
def test_rule_fires_in_its_example(rule):
    example = BY_RULE[rule]
    reasoner, _ = example.reasoners()
    assert rule in fired(reasoner, example.frames, example.proposed)


@pytest.mark.parametrize("rule", sorted(BY_RULE))
def test_rule_does_not_fire_in_its_near_miss(rule):
    example = BY_RULE[rule]
    _, reasoner = example.reasoners()
    assert rule not in fired(reasoner, example.blocked, example.proposed)


def test_uk_pack_rules_have_english_sources_and_templates():
    catalog = reasoner_for("uk").catalog
    assert all(r.says.endswith(".") and r.source for r in catalog.rules)
    assert {r.signature for r in catalog.compiled} - set(catalog.templates) == set()


def test_docs_show_the_engines_own_output_for_every_example():
    text = DOC.read_text(encoding="utf-8")
    block = text[text.index(worked_examples.BEGIN) + len(worked_examples.BEGIN): text.index(worked_examples.END)]
    assert block.strip() == worked_examples.markdown(EXAMPLES).strip(), (
        "docs/sanity.md is out of date: run `python -m tests.worked_examples docs/sanity.md`")


# --- flashing lights: a dropped frame is no flash, and an inferred flash does not release the ego at the line

AT_LINE = {"type": "signaled", "stage": "at", "distance": 0.0}
RED = [{"colour": "red"}]
UNLIT = [{"colour": "none"}]  # a light listed unlit: a dark phase (one not listed is out of view)


def _timed(frames: list[tuple[float, list]], **kw):
    """Frames at the given times with the given lights, the ego stopped at the line unless told otherwise."""
    kw = {"speed": 0.0, "limit": 13.4, "intersection": AT_LINE, **kw}
    return tuple(scene(frame=i + 1, timestamp=t, lights=lights, **kw) for i, (t, lights) in enumerate(frames))


def _decide(frames, proposed: Action):
    return reasoner_for("us").decide(frames[-1], proposed, history=frames[:-1], explain=True)


def test_a_steady_red_with_one_dropped_frame_keeps_the_ego_at_the_stop_line():
    frames = _timed([(0.0, RED), (0.1, RED), (0.2, []), (0.3, RED)])
    verdict = _decide(frames, Action.accelerate)
    assert (verdict.decision, verdict.action) == (Decision.override, Action.brake)
    assert {"brake.red_light", "acc.red_light"} <= set(verdict.rules)


def test_an_inferred_flash_does_not_release_the_ego_at_the_stop_line():
    flashing = _timed([(0.0, RED), (0.5, UNLIT), (1.0, RED), (1.5, UNLIT), (2.0, RED)])
    assert "san.lights.flashing" in fired(reasoner_for("us"), flashing, Action.accelerate)
    verdict = _decide(flashing, Action.accelerate)
    assert (verdict.decision, verdict.action) == (Decision.override, Action.brake)
    assert "brake.red_light" in verdict.rules
    dark = _timed([(0.0, RED), (0.5, UNLIT), (1.0, RED), (1.5, UNLIT), (2.0, RED), (2.5, UNLIT)])
    verdict = _decide(dark, Action.accelerate)  # nor does the dark phase that follows
    assert verdict.decision is Decision.override and "san.memory.red_light" in verdict.rules


def test_a_red_beside_a_green_arrow_is_remembered_when_a_truck_hides_the_lights():
    arrow = RED + [{"colour": "green"}]
    frames = _timed([(0.0, arrow), (0.1, arrow), (0.2, arrow), (0.3, [])], speed=6.0)
    assert _decide(frames[:-1], Action.accelerate).action is Action.brake  # while seen, the red held the ego
    verdict = _decide(frames, Action.accelerate)
    assert verdict.action is Action.brake and "san.memory.red_light" in verdict.rules
    green_only = _timed([(0.0, [{"colour": "green"}]), (0.1, [])], speed=6.0)
    assert "san.memory.red_light" not in _decide(green_only, Action.accelerate).rules


FLASHING_RED = [{"colour": "red", "flashing": True}]


def test_a_flash_perception_reports_releases_the_ego_after_its_stop():
    reported = _timed([(0.0, RED), (0.5, FLASHING_RED), (1.0, FLASHING_RED)])
    assert _decide(reported, Action.accelerate).decision is Decision.approve


def test_one_frame_flagged_flashing_does_not_turn_a_steady_red_into_a_stop_sign():
    glitch = _timed([(0.0, RED), (0.1, FLASHING_RED), (0.2, RED), (0.3, RED)])
    verdict = _decide(glitch, Action.accelerate)
    assert verdict.action is Action.brake and "brake.red_light" in verdict.rules
    first = _timed([(0.0, RED), (0.1, RED), (0.2, FLASHING_RED)])  # the glitch frame itself
    assert _decide(first, Action.accelerate).action is Action.brake


@pytest.mark.parametrize("hz, now", [(10, "flagged"), (10, "hidden"), (50, "hidden")])
def test_two_isolated_flashing_flags_in_a_steady_red_do_not_release_the_ego(hz, now):
    """A steady red flagged flashing in two frames a second apart, red reported steady between them: two glitches."""
    gap = [(RED)] * hz
    lights = [RED] * 3 + [FLASHING_RED] + gap + ([FLASHING_RED] if now == "flagged" else [FLASHING_RED] + [RED] * 3 + [[]])
    frames = _timed([(round(i / hz, 3), lit) for i, lit in enumerate(lights)][-2 * hz:])
    verdict = _decide(frames, Action.accelerate)
    assert (verdict.decision, verdict.action) == (Decision.override, Action.brake), verdict.justification.summary


def test_flashing_flags_over_only_40_ms_at_50_hz_do_not_release_the_ego_at_a_steady_red():
    glint = _timed([(round(i / 50, 3), RED) for i in range(48)] + [(0.96, FLASHING_RED), (0.98, FLASHING_RED)])
    verdict = _decide(glint, Action.accelerate)
    assert (verdict.decision, verdict.action) == (Decision.override, Action.brake), verdict.justification.summary
    flashing = _timed([(round(i / 50, 3), RED) for i in range(35)] + [(round(i / 50, 3), FLASHING_RED) for i in range(35, 50)])
    assert _decide(flashing, Action.accelerate).decision is Decision.approve  # flagged for 0.3 s: a flash


def test_one_camera_frame_delivered_twice_is_not_two_flashing_flags():
    """Perception at 10 Hz, the planner at 20 Hz: the flagged camera frame comes twice, with one timestamp."""
    frames = _timed([(0.0, RED), (0.0, RED), (0.1, RED), (0.1, RED), (0.2, FLASHING_RED), (0.2, FLASHING_RED)])
    verdict = _decide(frames, Action.accelerate)
    assert (verdict.decision, verdict.action) == (Decision.override, Action.brake), verdict.justification.summary


def _van(lit: bool) -> dict:
    # coming up behind
    return obj("truck", -3.5, -20.0, 1, oid=5, vy=30.0, emergency_lights=lit, sources=("camera", "radar"))


def test_emergency_lights_in_two_frames_20_ms_apart_are_a_glint_but_lit_for_0_3_s_a_beacon():
    def frames(lit_from: int):
        return tuple(scene(frame=i + 1, timestamp=round(i / 50, 3), speed=25.0, lane=2, lanes=2, zone="highway",
                           limit=29.0, objects=[_van(i >= lit_from)]) for i in range(50))

    us = reasoner_for("us")
    assert "san.emergency.flashing" not in fired(us, frames(48))
    assert "san.emergency.flashing" in fired(us, frames(35))


def test_a_flashing_flag_long_ago_does_not_release_the_ego_at_a_red_hidden_since():
    frames = _timed([(0.0, RED), (0.1, FLASHING_RED), (0.2, FLASHING_RED)] + [(0.3 + 0.1 * i, []) for i in range(12)])
    verdict = _decide(frames, Action.accelerate)  # dark for 1.3 s, longer than any phase of a flash
    assert verdict.action is Action.brake and "san.memory.red_light" in verdict.rules


def test_two_isolated_light_glints_do_not_make_an_emergency_vehicle():
    """Sun on chrome in two frames 1.3 s apart, unlit between: no beacon flashes that slowly."""
    frames = tuple(scene(frame=i + 1, timestamp=round(0.1 * i, 1), speed=25.0, lane=2, lanes=2, zone="highway", limit=29.0,
                         objects=[_van(i in (2, 15))]) for i in range(17))
    verdict = _decide(frames, Action.cruise)
    assert verdict.decision is Decision.approve and "san.emergency.flashing" not in verdict.rules
    beacon = tuple(scene(frame=i + 1, timestamp=round(0.1 * i, 1), speed=25.0, lane=2, lanes=2, zone="highway", limit=29.0,
                         objects=[_van(i % 5 < 2)]) for i in range(17))  # lit 0.2 s of every 0.5 s
    assert "san.emergency.flashing" in _decide(beacon, Action.cruise).rules


def test_a_red_reported_steady_now_is_steady_whatever_earlier_frames_flagged():
    frames = _timed([(0.0, FLASHING_RED), (0.1, FLASHING_RED), (0.2, FLASHING_RED), (0.3, RED)])
    assert _decide(frames, Action.accelerate).action is Action.brake


def test_an_inferred_flashing_red_still_stops_the_arriving_ego():
    arriving = {"type": "signaled", "stage": "arriving", "distance": 25.0}
    frames = _timed([(0.0, RED), (0.5, UNLIT), (1.0, RED)], speed=8.0, intersection=arriving)
    verdict = _decide(frames, Action.cruise)
    assert verdict.action is Action.brake and "san.lights.flashing_red_stop" in verdict.rules


def test_an_inferred_flash_with_no_intersection_known_does_not_release_a_stopped_ego():
    frames = _timed([(0.0, RED), (0.5, []), (1.0, RED)], intersection=None)
    assert _decide(frames, Action.accelerate).action is Action.brake


# --- sizes: what a range sensor confirms is real, whatever its size


def test_a_childs_bicycle_confirmed_by_radar_and_lidar_is_braked_for():
    bike = obj("bicycle", 0.0, 9.0, 1, oid=2, vy=0.0, sources=("camera", "radar", "lidar"),
               size={"length": 1.1, "width": 0.5})
    verdict = _decide((scene(speed=10.0, zone="residential", limit=11.0, objects=[bike]),), Action.accelerate)
    assert (verdict.decision, verdict.action) == (Decision.override, Action.brake)
    assert "san.world.size" not in verdict.rules


def test_a_police_motorcycle_with_its_lights_on_is_an_emergency_vehicle_on_duty():
    moto = obj("emergency_vehicle", 0.0, -6.0, 1, oid=4, vy=16.0, sources=("camera", "radar"), emergency_lights=True,
               size={"length": 2.3, "width": 0.9})
    verdict = _decide((scene(speed=12.0, limit=15.6, objects=[moto]),), Action.accelerate)
    assert verdict.decision is Decision.override and "san.emergency.give_way" in verdict.rules


def test_a_camera_only_childs_bicycle_fits_its_class_but_a_camera_only_toy_car_does_not():
    bike = obj("bicycle", 0.0, 25.0, 1, oid=2, vy=0.0, sources=("camera",), size={"length": 0.9, "width": 0.4})
    toy = obj("car", 0.0, 25.0, 1, oid=3, sources=("camera",), size={"length": 0.7, "width": 0.3})
    us = reasoner_for("us")
    radar = [sensor("front", 60.0)]
    assert "san.world.size" not in fired(us, (scene(speed=10.0, limit=11.0, objects=[bike], sensors=radar),))
    assert "san.world.size" in fired(us, (scene(speed=10.0, limit=11.0, objects=[toy], sensors=radar),))


@pytest.mark.parametrize("length", [0.0, 1.2])
def test_a_camera_only_car_of_unlikely_size_is_braked_for_with_no_radar_or_too_close_to_stop(length):
    # A detector may give a length of 0 for one it does not know: a size is an estimate, and a doubt is no reason to
    # hit a car that may be real.
    car = obj("car", 0.0, 6.0, 1, oid=5, vy=0.0, sources=("camera",), size={"length": length, "width": 1.6})
    for sensors in ([], [sensor("front", 60.0)]):  # no radar; a radar reading clear road, but 6 m is too close
        verdict = _decide((scene(speed=8.0, limit=11.0, objects=[car], sensors=sensors),), Action.accelerate)
        assert (verdict.decision, verdict.action) == (Decision.override, Action.brake)
        assert "san.world.size" not in verdict.rules


@pytest.mark.parametrize("size", [{"length": 0.0, "width": 0.0}, {"length": 0.0, "width": 1.8}])
def test_a_camera_only_car_given_a_size_of_0_is_of_unknown_size_not_a_toy(size):
    """A detector may give 0 for a size it does not know: taken as measured, it set a car the running radar did not
    return aside as a toy, and the ego sped up towards it."""
    car = obj("car", 0.0, 45.0, 2, oid=5, vy=0.0, sources=("camera",), size=size)
    radar_car = obj("car", -3.5, 70.0, 1, oid=8, vy=15.0, sources=("camera", "radar"))  # keeps the radar running
    verdict = _decide((scene(speed=15.0, limit=17.9, lanes=2, lane=2, objects=[car, radar_car]),), Action.accelerate)
    assert (verdict.decision, verdict.action) == (Decision.override, Action.brake)
    assert "san.world.size" not in verdict.rules and "san.radar.phantom_caution" in verdict.rules


def test_a_crossing_car_given_a_size_of_0_by_0_reaches_across_the_road_as_long_as_its_class():
    """Its centre is beside the ego's corridor; taken as 0 m long, its body was a point that left the ego's way free."""
    car = obj("car", -2.6, 8.0, 1, oid=3, kind="cross_left", vy=0.0, size={"length": 0.0, "width": 0.0},
              sources=("camera", "radar"))
    verdict = _decide((scene(speed=8.0, limit=11.0, other_lanes=("cross_left",), objects=[car]),), Action.accelerate)
    assert (verdict.decision, verdict.action) == (Decision.override, Action.brake)
    assert "brake.obstacle_ahead" in verdict.rules


# --- possible phantoms: close ones are real, far ones cost speed, people are never doubted

RADAR_CAR = obj("car", -3.5, 60.0, 1, oid=2, vy=15.0, sources=("camera", "radar"))  # keeps the radar running
HW = {"zone": "highway", "limit": 29.0, "lanes": 2, "lane": 2, "speed": 15.0}


def test_a_camera_only_pedestrian_inside_the_stopping_distance_is_braked_for():
    walker = obj("pedestrian", 0.0, 16.0, 2, oid=3, sources=("camera",))
    verdict = _decide((scene(**HW, objects=[RADAR_CAR, walker]),), Action.cruise)
    assert (verdict.decision, verdict.action) == (Decision.override, Action.brake)
    assert "brake.obstacle_ahead" in verdict.rules and "san.radar.phantom" not in verdict.rules


@pytest.mark.parametrize("cls", ["pedestrian", "bicycle", "animal"])
def test_a_vulnerable_road_user_is_never_doubted_for_lack_of_a_radar_echo(cls):
    far = obj(cls, 0.0, 60.0, 2, oid=3, vy=0.0, sources=("camera",))
    assert "san.radar.phantom" not in fired(reasoner_for("us"), (scene(**HW, objects=[RADAR_CAR, far]),))


def test_a_standing_camera_only_car_closer_than_braking_takes_is_treated_as_real():
    # closing at 15 m/s, braking at once takes 18.75 m: at 17 m there is no waiting for the radar
    stopped = obj("car", 0.0, 17.0, 2, oid=9, vy=0.0, sources=("camera",))
    verdict = _decide((scene(**HW, objects=[RADAR_CAR, stopped]),), Action.cruise)
    assert "brake.obstacle_ahead" in verdict.rules and "san.radar.phantom" not in verdict.rules


def test_a_close_camera_only_car_the_front_radar_reads_past_is_slowed_for_and_only_that_reading_doubts_it():
    """Inside the distance the ego cannot wait in, a front radar reading past the car, straight ahead in its beam,
    contradicts it: the ego slows down, no hard brake, no swerve. A reading short of it, one past a car off the beam, a
    radar-confirmed car and a pedestrian (a weak echo) stay obstacles."""
    def ahead(x: float = 0.0, sources: tuple = ("camera",), cls: str = "car", reading: float = 60.0):
        stopped = obj(cls, x, 12.0, 2, oid=9, vy=0.0, sources=sources)
        return (scene(**HW, objects=[RADAR_CAR, stopped], sensors=[sensor("front", reading)]),)

    verdict = _decide(ahead(), Action.cruise)
    assert (verdict.decision, verdict.action) == (Decision.override, Action.brake)
    assert {"san.radar.read_past_close", "san.radar.phantom_caution"} <= set(verdict.rules)
    assert "brake.obstacle_ahead" not in verdict.rules and "san.radar.ranged_past" not in verdict.rules
    for case, frames in {"reading short of it": ahead(reading=8.0), "off the beam": ahead(x=1.9),
                         "radar-confirmed": ahead(sources=("camera", "radar")), "pedestrian": ahead(cls="pedestrian")}.items():
        assert "san.radar.read_past_close" not in fired(reasoner_for("us"), frames), case
        assert "brake.obstacle_ahead" in _decide(frames, Action.cruise).rules or case == "reading short of it", case


def test_a_possible_phantom_nearer_than_a_comfortable_stop_is_slowed_for_as_a_confirmed_car_is():
    """Beyond the gap needed, a standing car makes the ego begin slowing comfortably; doubting it must not let the ego
    speed up instead (at 20 m/s braking at 3 m/s² takes 86.7 m)."""
    road = {"zone": "road", "limit": 22.0, "lanes": 2, "lane": 1, "speed": 20.0}
    radar_beside = obj("car", 3.5, 60.0, 2, oid=9, vy=20.0, sources=("radar",))

    def standing(distance: float, sources: tuple):
        return (scene(**road, objects=[obj("car", 0.0, distance, 1, oid=1, vy=0.0, sources=sources), radar_beside]),)

    for distance in (55.0, 75.0):
        doubted = _decide(standing(distance, ("camera",)), Action.accelerate)
        assert doubted.decision is Decision.override and doubted.action is Action.brake
        assert "san.radar.phantom_caution" in doubted.rules and "brake.obstacle_ahead" not in doubted.rules
        assert _decide(standing(distance, ("camera", "radar")), Action.accelerate).decision is Decision.override
    assert _decide(standing(95.0, ("camera",)), Action.accelerate).decision is Decision.approve


def test_a_far_possible_phantom_forbids_holding_speed_as_well_as_accelerating():
    phantom = obj("car", 0.0, 16.0, 2, oid=9, vy=5.0, sources=("camera",))
    frames = (scene(**HW, objects=[RADAR_CAR, phantom]),)
    cruise, accelerate = _decide(frames, Action.cruise), _decide(frames, Action.accelerate)
    assert (cruise.decision, cruise.action) == (Decision.override, Action.brake)
    assert "san.radar.phantom_caution" in cruise.rules and "brake.obstacle_ahead" not in cruise.rules
    assert accelerate.decision is Decision.override
    assert _decide(frames, Action.brake).decision is Decision.approve  # slowing down, not an emergency stop


def test_a_camera_only_pedestrian_in_front_of_a_bus_is_no_picture_on_it():
    bus = obj("bus", 0.0, 30.0, 1, oid=2, vy=0.0, size={"length": 12.0, "width": 2.5}, sources=("camera", "radar"))
    walker = obj("pedestrian", 0.3, 23.5, 1, oid=5, sources=("camera",))
    assert "san.world.picture_on_object" not in fired(reasoner_for("us"), (scene(speed=10.0, limit=13.0,
                                                                                   objects=[bus, walker]),))


def test_traffic_is_no_stop_evidence_for_the_ego_on_the_major_road():
    def frames(road):
        crossing = obj("car", -15.0, 25.0, 1, oid=5, kind="cross_left", vy=0.0, vx=10.0, sources=("camera", "radar"))
        braking = obj("car", 0.0, 20.0, 1, oid=6, vy=8.0, indicator="brake_light", sources=("camera", "radar"))
        intersection = {"type": "t_intersect", "stage": "arriving", "road": road}
        return (scene(limit=11.0, intersection=intersection, other_lanes=("cross_left",),
                      signs=[{"kind": "speed_limit", "value": 20.1, "source": "camera"}], objects=[crossing, braking]),)

    assert "san.stop.evidence_traffic" in fired(reasoner_for("us"), frames("minor"))
    assert "san.stop.evidence_traffic" not in fired(reasoner_for("us"), frames("major"))
    assert "san.stop.misread_sign" not in _decide(frames("major"), Action.cruise).rules


# --- stop control the sanity layer finds holds at the line as a stop sign does

AT_STOP_LINE = {"type": "four_way", "stage": "at", "distance": 0.0}
ROLLING = 6.0  # m/s at the line: a rolling stop
LIMIT_45 = {"kind": "speed_limit", "value": 20.1, "source": "camera"}


@pytest.mark.parametrize("case, frames", [
    ("the map", [scene(speed=ROLLING, intersection={**AT_STOP_LINE, "stop_controlled": True}, limit=13.0)]),
    ("a stop line and no lights", [scene(speed=ROLLING, intersection={**AT_STOP_LINE, "stop_line": True}, limit=13.0)]),
    ("a stop sign read as 45 from a fused source", [scene(speed=ROLLING, limit=13.0,
                                                          signs=[{**LIMIT_45, "source": "fused"}],
                                                          intersection={**AT_STOP_LINE, "stop_line": True})]),
    ("a stop sign hidden now", [scene(frame=1, speed=8.0, limit=13.0, signs=[{"kind": "stop"}],
                                      intersection={**AT_STOP_LINE, "stage": "arriving"}),
                                scene(frame=2, speed=ROLLING, limit=13.0, intersection=AT_STOP_LINE)]),
    ("a flashing red light", [scene(frame=i, speed=ROLLING, limit=13.0, lights=[{"colour": "red", "flashing": True}],
                                    intersection=AT_STOP_LINE) for i in (1, 2)]),
])
def test_stop_control_the_sanity_layer_finds_forbids_a_rolling_stop_at_the_line(case, frames):
    verdict = _decide(tuple(frames), Action.accelerate)
    assert (verdict.decision, verdict.action) == (Decision.override, Action.brake), case
    assert "brake.stop_sign_full_stop" in verdict.rules, case


def test_a_stop_line_without_lights_stops_the_arriving_ego_though_no_sign_is_seen():
    arriving = {"type": "unsignaled", "stage": "arriving", "distance": 20.0, "stop_line": True}
    verdict = _decide((scene(speed=8.0, intersection=arriving, limit=13.0),), Action.accelerate)
    assert verdict.action is Action.brake and "san.stop.line_controlled" in verdict.rules
    signalised = {**arriving, "type": "signaled"}
    assert _decide((scene(speed=8.0, intersection=signalised, limit=13.0),),
                   Action.accelerate).decision is Decision.approve


# --- what is set aside as not on the road


def test_a_camera_only_car_pulling_out_from_the_side_is_no_roadside_advert():
    lead = obj("car", -3.5, 40.0, 1, oid=2, vy=15.0, sources=("camera", "radar"))
    pulling_out = obj("car", 6.0, 20.0, oid=7, vy=0.0, vx=-4.0, sources=("camera",))
    verdict = _decide((scene(speed=10.0, limit=13.4, objects=[lead, pulling_out]),), Action.accelerate)
    assert verdict.action is Action.brake and "san.world.no_echo_off_lane" not in verdict.rules
    assert "car 7 is not on the road:" not in verdict.justification.text


def test_a_range_confirmed_object_high_above_the_road_is_set_aside_only_beyond_the_stopping_distance():
    """At 20 m/s the ego stops in 53 m: 5 m up, 20 m ahead, is a car on a rising road or a misjudged height as well as
    a bridge, and a range sensor says something is there; 60 m ahead the ego can still stop once it is nearer."""
    def cruise_past(elevation: float, y: float = 20.0, sources: tuple = ("camera", "radar", "lidar")):
        truck = obj("truck", 0.0, y, 1, oid=2, vy=0.0, sources=sources, elevation=elevation)
        return _decide((scene(speed=20.0, zone="highway", limit=29.0, objects=[truck]),), Action.cruise)

    trailer = cruise_past(1.2)
    assert trailer.action is Action.brake and "brake.obstacle_ahead" in trailer.rules
    near = cruise_past(5.0)
    assert near.action is Action.brake and "brake.obstacle_ahead" in near.rules and "san.world.elevated" not in near.rules
    far = cruise_past(5.0, y=60.0)
    assert far.decision is Decision.approve and "san.world.elevated" in far.rules
    billboard = cruise_past(5.0, sources=("camera",))  # the camera alone, the least trusted for presence
    assert billboard.decision is Decision.approve and "san.world.elevated" in billboard.rules


def _past_a_floating_object(y: float, speed: float, radar: bool, cls: str = "truck"):
    """A camera-only object in the ego's lane whose base the camera puts 1.2 m up; with `radar`, the radar reports a car
    in the next lane, so it runs ahead."""
    floating = obj(cls, 0.0, y, 2, oid=3, vx=-4.0 if cls == "truck" else 0.0, vy=0.0, sources=("camera",),
                   elevation=1.2)
    lead = [obj("car", -3.5, 90.0, 1, oid=8, vy=speed, sources=("camera", "radar"))] if radar else []
    return _decide((scene(speed=speed, zone="highway", limit=29.0, lane=2, lanes=2, objects=[floating, *lead]),),
                   Action.cruise)


@pytest.mark.parametrize("radar", [False, True])
@pytest.mark.parametrize("y, speed, cls", [(35.0, 29.0, "truck"), (10.0, 20.0, "car")])
def test_a_camera_only_object_above_the_road_is_an_obstacle_without_a_running_radar_or_room_to_stop(y, speed, cls, radar):
    """NTSB HAR-17/02: a trailer crossing 35 m ahead at 29 m/s that only the camera sees, its base 1.2 m up, was set
    aside as an advert with no radar running and well inside the 99 m the ego needs to stop."""
    verdict = _past_a_floating_object(y, speed, radar, cls)
    assert verdict.decision is Decision.override and "brake.obstacle_ahead" in verdict.rules
    assert "san.world.elevated" not in verdict.rules


def test_a_camera_only_advert_above_the_road_is_set_aside_only_while_a_running_radar_misses_it_with_room_to_stop():
    """At 12 m/s the ego stops in 24 m: an advert 30 m ahead is set aside, one 20 m ahead only doubted (slow down)."""
    advert = _past_a_floating_object(30.0, 12.0, radar=True)
    assert advert.decision is Decision.approve and "san.world.elevated" in advert.rules
    assert "san.world.elevated" not in _past_a_floating_object(30.0, 12.0, radar=False).rules
    # a person's radar echo is weak: a missing one does not set a pedestrian aside
    assert "san.world.elevated" not in _past_a_floating_object(30.0, 12.0, radar=True, cls="pedestrian").rules
    nearer = _past_a_floating_object(20.0, 12.0, radar=True)
    assert nearer.action is Action.brake and "san.radar.phantom_caution" in nearer.rules
    assert "san.world.elevated" not in nearer.rules


# --- range readings: within their sensor's reach


def _cruise_with_front_readings(*readings: tuple[float, str], objects: tuple = ()):
    """At 29 m/s on a highway (the ego needs 99 m to stop), a car 90 m ahead that the radar reports."""
    car = obj("car", 0.0, 90.0, 1, oid=8, vy=29.0, sources=("camera", "radar"))
    return scene(speed=29.0, zone="highway", limit=29.0, objects=[car, *objects],
                 sensors=[sensor("front", d, kind) for d, kind in readings])


def test_an_ultrasonic_reading_at_60_m_does_not_brake_the_ego_where_the_front_radar_reads_the_lane_clear():
    """Ultrasonic sensors reach a few metres: a reading of 60 m is a fault, and the verdict says so."""
    fault = _decide((_cruise_with_front_readings((60.0, "ultrasonic"), (90.0, "radar")),), Action.cruise)
    assert fault.decision is Decision.approve and "san.range.beyond_reach" in fault.rules
    assert "the front ultrasonic sensor's reading of 60.0 m is beyond its reach" in fault.justification.text
    # within its reach it still brakes; a radar reading of the same 60 m still does
    for readings in [((6.0, "ultrasonic"), (90.0, "radar")), ((60.0, "ultrasonic"), (60.0, "radar"))]:
        verdict = _decide((_cruise_with_front_readings(*readings),), Action.cruise)
        assert verdict.action is Action.brake and "brake.front_range_obstacle" in verdict.rules, readings
    # nor does the faulty reading confirm a camera-only car at 60 m: it may be a phantom
    ghost = obj("car", 0.0, 60.0, 1, oid=9, vy=20.0, sources=("camera",))
    doubted = reasoner_for("us").solve(_cruise_with_front_readings((60.0, "ultrasonic"), objects=(ghost,)), Action.cruise)
    assert Function("doubtful", [Number(9)]) in doubted.answer.of("doubtful", 1)


def test_a_front_reading_confirms_a_camera_object_within_the_range_match_parameter():
    """The same tolerance that lets a front reading explain an object lets it confirm one (no phantom then)."""
    from discern.rules.facts import Params
    from discern.sanity import window_reasoner

    car = scene(speed=10.0, objects=[obj("car", 0.0, 20.0, 1, oid=1, sources=("camera",))],
                sensors=[{"side": "front", "distance": 24.0, "kind": "radar"}], limit=13.0)
    for range_match, confirmed in [(3.0, False), (5.0, True)]:
        answer = window_reasoner(params=Params(range_match=range_match)).solve(car, Action.cruise).answer
        assert (Function("confirmed", [Number(1)]) in answer.of("confirmed", 1)) is confirmed
        assert (Function("doubtful", [Number(1)]) in answer.of("doubtful", 1)) is not confirmed


@pytest.mark.parametrize("length", [0.6, 3.3])
def test_a_cyclist_only_the_camera_sees_is_never_set_aside_for_its_size(length):
    """A child's bicycle or one with a trailer: its size does not fit a bicycle, and it is still a cyclist."""
    cyclist = obj("bicycle", 0.0, 9.0, 1, oid=3, vy=2.0, size={"length": length, "width": 0.7}, sources=("camera",))
    verdict = _decide((scene(speed=10.0, limit=13.4, objects=[cyclist]),), Action.accelerate)
    assert verdict.action is Action.brake and "san.world.size" not in verdict.rules


def test_a_lead_car_braking_at_speed_is_no_sign_that_the_ego_must_stop():
    """Brake lights at 14 m/s, 40 m short of a junction, are a car slowing, not a car stopping at a stop line."""
    def lead(vy: float):
        return scene(speed=17.0, zone="rural", limit=20.1, signs=[{"kind": "speed_limit", "value": 20.1}],
                     intersection={"type": "four_way", "stage": "arriving", "distance": 60.0},
                     objects=[obj("car", 0.0, 40.0, 1, oid=3, vy=vy, indicator="brake_light",
                                  sources=("camera", "radar"))])
    assert _decide((lead(14.0),), Action.cruise).decision is Decision.approve
    assert "san.stop.evidence_traffic" not in fired(reasoner_for("us"), (lead(14.0),))
    stopping = fired(reasoner_for("us"), (lead(2.0),))
    assert "san.stop.evidence_traffic" in stopping
    # weak evidence: the 45 mph sign, usual on a rural road, is still a limit sign, not a stop sign
    assert "san.stop.misread_sign" not in stopping


# --- object permanence: what a range reading past a lost object says


def _walker_then_hidden(sources: tuple, cls: str = "pedestrian"):
    """A road user seen over three frames stepping towards the ego's path, then hidden; the front-right radar reads 40 m."""
    radar = [{"side": "front_right", "distance": 40.0, "kind": "radar"}]
    seen = [scene(frame=i + 1, limit=13.4, sensors=radar, other_lanes=("sidewalk_right",),
                  objects=[obj(cls, 4.0 - 0.15 * i, 20.0 - i, 1, oid=2, kind="sidewalk_right", vy=0.0, vx=-1.5,
                               sources=sources)])
            for i in range(3)]
    return (*seen, scene(frame=4, limit=13.4, sensors=radar, other_lanes=("sidewalk_right",)))


def test_a_range_reading_past_a_hidden_pedestrian_that_never_echoed_does_not_clear_it():
    """A pedestrian barely echoes: a radar that never reported it reading clear road past it says nothing."""
    verdict = _decide(_walker_then_hidden(("camera",)), Action.accelerate)
    assert verdict.action is Action.brake and "san.memory.object_permanence" in verdict.rules


def test_a_range_reading_past_a_hidden_road_user_that_echoed_before_clears_it():
    echoed = _decide(_walker_then_hidden(("camera", "radar")), Action.accelerate)
    assert echoed.decision is Decision.approve and "san.memory.object_permanence" not in echoed.rules
    car = _decide(_walker_then_hidden(("camera",), cls="car"), Action.accelerate)  # a car echoes: none means none
    assert "san.memory.object_permanence" not in car.rules


# --- weak stop evidence: traffic alone does not make a plausible limit sign a stop sign


def _lead_stopping_at_a_crossing(mph: float):
    """Arriving at an uncontrolled four-way in a city behind a lead car braking to 4 m/s; the camera reads a limit sign."""
    lead = obj("car", 0.0, 30.0, 1, oid=3, vy=4.0, indicator="brake_light", sources=("camera", "radar"))
    return (scene(speed=8.0, limit=None, signs=[{"kind": "speed_limit", "value": round(mph * MPH, 3)}],
                  intersection={"type": "four_way", "stage": "arriving", "distance": 20.0}, objects=[lead]),)


def test_a_real_25_sign_is_not_taken_for_a_stop_sign_because_the_lead_car_slows():
    verdict = _decide(_lead_stopping_at_a_crossing(25), Action.cruise)
    assert verdict.decision is Decision.approve and "san.stop.misread_sign" not in verdict.rules
    answer = reasoner_for("us").solve(_lead_stopping_at_a_crossing(25)[-1], Action.cruise).answer
    assert [a.arguments[0].number for a in answer.of("effective_limit", 1)] == [1118]  # the 25 mph read


def test_traffic_evidence_with_a_reading_unusual_for_the_zone_still_makes_a_stop_sign():
    """The sticker attack's 45 in a town (usual 35) where the car ahead stops: a stop sign, as before."""
    verdict = _decide(_lead_stopping_at_a_crossing(45), Action.cruise)
    assert verdict.action is Action.brake and {"san.stop.misread_sign", "san.stop.evidence_traffic"} <= set(verdict.rules)


# --- "the radar is running": current returns, on the object's side


def _crossing_car_with(radar_objects_by_frame):
    """A camera-only car crossing 28 m ahead in the last frame; earlier frames as given."""
    cross = obj("car", 14.0, 28.0, oid=9, vy=0.0, vx=-6.0, sources=("camera",))
    frames = [scene(frame=i + 1, timestamp=round(0.1 * i, 1), speed=12.0, lane=2, lanes=2, limit=13.4, objects=objs)
              for i, objs in enumerate(radar_objects_by_frame)]
    crossing = [*frames[-1].objects, *scene(objects=[cross], limit=13.0).objects]
    return tuple(frames[:-1]) + (frames[-1].model_copy(update={"objects": crossing}),)


def test_a_radar_that_fell_silent_is_not_running_because_of_a_car_it_reported_before():
    """The radar reported car 2 for three frames, then fell silent; the camera lost car 2 and sees a crossing car."""
    car2 = obj("car", -3.5, 40.0, 1, oid=2, vy=12.0, sources=("camera", "radar"))
    frames = _crossing_car_with([[car2], [car2], [car2], []])
    verdict = _decide(frames, Action.cruise)
    assert verdict.action is Action.brake and "san.radar.phantom" not in verdict.rules


def test_a_rear_radar_return_is_no_sign_the_radar_would_see_a_car_ahead():
    rear = obj("car", -3.5, -15.0, 1, oid=2, vy=12.0, sources=("radar",))
    verdict = _decide(_crossing_car_with([[rear]]), Action.cruise)
    assert verdict.action is Action.brake and "san.radar.phantom" not in verdict.rules
    ahead = obj("car", -3.5, 40.0, 1, oid=2, vy=12.0, sources=("radar",))  # a forward return now: a possible phantom
    assert "san.radar.phantom" in _decide(_crossing_car_with([[ahead]]), Action.cruise).rules


# --- tracks are established by how long they were seen, at any frame rate


def _seen_then_hidden(hz: int, seen: int, cls: str = "pedestrian", sources=("camera",)):
    """A road user 20 m ahead on the right walking towards the ego's path, seen in `seen` frames, then hidden 0.2 s."""
    dt = 1 / hz
    frames = [scene(frame=i + 1, timestamp=round(dt * i, 3), limit=13.4,
                    objects=[obj(cls, 4.0 - 1.5 * dt * i, 20.0 - 10 * dt * i, oid=2, vy=0.0, vx=-1.5, sources=sources)])
              for i in range(seen)]
    hidden = [scene(frame=seen + i + 1, timestamp=round(dt * (seen + i), 3), limit=13.4) for i in range(max(1, hz // 5))]
    return tuple(frames + hidden)


@pytest.mark.parametrize("hz, seen, kept", [(5, 2, True), (10, 3, True), (20, 6, True), (50, 15, True),
                                            (10, 2, False), (20, 3, False), (50, 3, False), (50, 10, False)])
def test_a_track_is_established_by_0_3_s_and_2_frames_at_any_frame_rate(hz, seen, kept):
    verdict = _decide(_seen_then_hidden(hz, seen), Action.accelerate)
    assert ("san.memory.object_permanence" in verdict.rules) is kept, (hz, seen, verdict.justification.summary)


def test_a_pedestrian_tracked_for_weeks_is_still_remembered_when_hidden():
    """Its tracker's age in milliseconds is past clingo's 32-bit integers: it must not wrap into a brief track."""
    dt = 0.05
    frames = tuple(scene(frame=i + 1, timestamp=round(dt * i, 3), speed=10.0, limit=13.4,
                         objects=[obj("pedestrian", 0.0, 25.0 - 0.5 * i, 1, oid=7, vy=0.0, sources=("camera",),
                                      track_age=2**31 - 30 + i)])
                   for i in range(10))
    hidden = scene(frame=11, timestamp=round(dt * 10, 3), speed=10.0, limit=13.4)
    verdict = _decide(frames + (hidden,), Action.accelerate)
    assert verdict.action is Action.brake and "san.memory.object_permanence" in verdict.rules, verdict.justification.summary


def test_a_camera_only_ghost_seen_for_60_ms_at_50_hz_is_not_kept():
    ghost = obj("car", 0.0, 14.0, 1, oid=8, vy=0.0, sources=("camera",))
    frames = tuple(scene(frame=i + 1, timestamp=round(0.02 * i, 2), speed=12.0, limit=13.4,
                         objects=[ghost] if 5 <= i < 8 else []) for i in range(20))
    verdict = _decide(frames, Action.cruise)
    assert verdict.decision is Decision.approve and "san.memory.object_permanence" not in verdict.rules


def test_a_steady_yellow_hidden_for_0_4_s_is_still_a_yellow_and_no_flash_when_back():
    arriving = {"type": "signaled", "stage": "arriving"}
    lit = [True] * 4 + [False] * 4 + [True] * 2
    frames = tuple(scene(frame=i + 1, timestamp=round(0.1 * i, 1), speed=10.0, limit=13.4,
                         lights=[{"colour": "yellow"}] if on else [],
                         intersection={**arriving, "distance": 36.0 - i}) for i, on in enumerate(lit))
    for last in range(5, len(frames) + 1):
        verdict = _decide(frames[:last], Action.cruise)
        assert (verdict.decision, verdict.action) == (Decision.override, Action.brake), last
        assert "brake.yellow_light_can_stop" in verdict.rules, last
        assert ("san.memory.yellow_light" in verdict.rules) is (not lit[last - 1]), last


# --- emergency vehicles: only one near and coming (or that the ego comes up to) calls for giving way

def _ambulance(x: float, y: float, vy=None, speed: float = 20.0):
    siren = obj("emergency_vehicle", x, y, 1, oid=9, vy=vy, emergency_lights=True, sources=("radar", "camera"))
    return (scene(speed=speed, zone="road", limit=25.0, objects=[siren]),)


def test_an_ambulance_ahead_pulling_away_is_not_pulled_over_for():
    verdict = _decide(_ambulance(0.0, 120.0, vy=35.0), Action.cruise)
    assert verdict.decision is Decision.approve and "san.emergency.give_way" not in verdict.rules


def test_an_ambulance_far_behind_is_not_pulled_over_for():
    verdict = _decide(_ambulance(0.0, -800.0), Action.cruise)
    assert verdict.decision is Decision.approve and "san.emergency.give_way" not in verdict.rules


@pytest.mark.parametrize("y, vy", [(-100.0, None), (-100.0, 30.0), (60.0, None), (120.0, 15.0), (100.0, -10.0)])
def test_an_ambulance_near_and_coming_or_being_caught_up_is_pulled_over_for(y, vy):
    """Behind within the move-over distance and keeping pace or closing; ahead of unknown speed, slower, or coming
    back (one measured to stand is passed: test_a_standing_emergency_vehicle_is_passed_slowly_not_waited_for)."""
    verdict = _decide(_ambulance(0.0, y, vy=vy), Action.cruise)
    assert verdict.decision is Decision.override and "san.emergency.give_way" in verdict.rules, (y, vy)
    assert verdict.action in (Action.pull_over, Action.brake), (y, vy)  # head-on in the ego's lane, it brakes
    assert "is an emergency vehicle on duty coming near the ego, not standing and not moving away from it" in verdict.justification.text


# --- lane labels that contradict the measured position: the position wins, close ahead only

def _labelled(x: float, y: float, lane: int, kind: str = "current", cls: str = "car", **kw):
    labelled = obj(cls, x, y, lane, oid=1, kind=kind, sources=("camera", "lidar"))
    return scene(speed=10.0, limit=15.0, objects=[labelled], **kw)


def test_an_object_straight_ahead_in_a_lane_the_scene_does_not_list_is_in_the_ego_lane():
    verdict = _decide((_labelled(0.0, 5.0, 7),), Action.accelerate)
    assert (verdict.decision, verdict.action) == (Decision.override, Action.brake)
    # Placed by its measured offset as one with no lane is (def.lane_from_offset, the proof's first reason since
    # 2026-11-28); the position-over-label rule holds too.
    assert "car 1 is labelled in a lane the scene does not list" in verdict.justification.text
    assert "san.lane.position_over_label" in fired(reasoner_for("us"), (_labelled(0.0, 5.0, 7),))


def test_a_pedestrian_labelled_on_the_sidewalk_but_straight_ahead_is_in_the_ego_lane():
    verdict = _decide((_labelled(0.0, 5.0, 1, "sidewalk_right", "pedestrian", other_lanes=("sidewalk_right",)),),
                      Action.accelerate)
    assert (verdict.decision, verdict.action) == (Decision.override, Action.brake)
    assert "the lane label of pedestrian 1 contradicts where it is measured: it is labelled off the road" in verdict.justification.text


@pytest.mark.parametrize("case, frame", [
    ("a car in the listed lane on the right, in line ahead on a curve beyond the label check", _labelled(0.0, 30.0, 2, lanes=2)),
    ("a car in a lane the scene does not list, far ahead", _labelled(0.0, 30.0, 7)),
    ("a car in a lane the scene does not list, beside the ego's lane", _labelled(3.5, 5.0, 7)),
    ("a pedestrian on the sidewalk beside the lane", _labelled(5.5, 5.0, 1, "sidewalk_right", "pedestrian",
                                                               other_lanes=("sidewalk_right",))),
])
def test_labels_that_fit_or_are_far_keep_their_lane(case, frame):
    assert "san.lane.position_over_label" not in _decide((frame,), Action.accelerate).rules, case


@pytest.mark.parametrize("y, overruled", [(16.0, True), (25.0, True), (40.0, True), (54.0, True), (58.0, False), (70.0, False)])
def test_at_highway_speed_the_label_check_reaches_as_far_as_a_highway_bend_cannot_bring_the_next_lane_into_line(y, overruled):
    """At 30 m/s the tightest bend a road is built for (v²/a, a = 2 m/s²) moves the next lane a lane's width at 56 m."""
    frame = scene(speed=30.0, zone="highway", limit=31.3, lanes=2,
                  objects=[obj("car", 0.0, y, 2, oid=1, vy=0.0, sources=("camera", "radar"))])
    assert ("san.lane.position_over_label" in fired(reasoner_for("us"), (frame,))) is overruled, y


# --- emergency vehicles standing or coming: passed with room, or given way to without cutting in front of them

def _run(frames, proposed: Action, jurisdiction: str = "us"):
    return reasoner_for(jurisdiction).decide(frames[-1], proposed, history=frames[:-1], explain=True)


def _police_on_the_shoulder(speed: float):
    police = obj("emergency_vehicle", 3.5, 100.0, 1, oid=4, kind="shoulder", vy=0.0, emergency_lights=True,
                 sources=("camera", "radar"))
    return tuple(scene(frame=i, speed=speed, zone="road", limit=24.5, other_lanes=("shoulder",), objects=[police])
                 for i in (1, 2, 3))


def test_a_standing_emergency_vehicle_is_passed_slowly_not_waited_for():
    fast = _run(_police_on_the_shoulder(24.0), Action.cruise)
    assert (fast.decision, fast.action) == (Decision.override, Action.brake)
    assert {"san.emergency.move_over", "san.caution.slow_down"} <= set(fast.rules)
    assert "san.emergency.give_way" not in fast.rules
    assert "is an emergency vehicle on duty standing beside the ego's path" in fast.justification.text
    assert "the cautious speed relative to the road's is 15.6 m/s (34.8 mph)" in fast.justification.text
    for proposed in (Action.accelerate, Action.cruise):
        standing = _run(_police_on_the_shoulder(0.0), proposed)
        assert standing.decision is Decision.approve, proposed


def test_an_ambulance_parked_across_an_undivided_road_is_passed_slowly_but_one_coming_is_given_way_to():
    def ambulance(vy):
        siren = obj("emergency_vehicle", -3.5, 80.0, 1, oid=4, kind="oncoming", vy=vy, emergency_lights=True,
                    sources=("camera", "radar"))
        return tuple(scene(frame=i, speed=0.0, zone="road", limit=24.5, other_lanes=("oncoming",), objects=[siren])
                     for i in (1, 2, 3))

    assert _run(ambulance(0.0), Action.accelerate).decision is Decision.approve
    coming = _run(ambulance(-15.0), Action.accelerate)
    assert (coming.decision, coming.action) == (Decision.override, Action.pull_over)
    assert "san.emergency.give_way" in coming.rules


def _fire_truck(ego_lane: int, x: float):
    truck = obj("emergency_vehicle", x, 60.0, 2, oid=4, vy=0.0, emergency_lights=True, sources=("camera", "radar"))
    return tuple(scene(frame=i, speed=25.0, lane=ego_lane, lanes=2, zone="highway", limit=29.0, objects=[truck])
                 for i in (1, 2))  # above the cautious speed on this highway: 29 m/s less 20 mph


def test_the_ego_never_moves_into_the_lane_of_a_stopped_emergency_vehicle():
    cruise = _run(_fire_truck(1, 3.5), Action.cruise)
    assert (cruise.decision, cruise.action) == (Decision.override, Action.brake)  # slows to pass it, no lane away
    towards = _run(_fire_truck(1, 3.5), Action.change_lane_right)
    assert towards.decision is Decision.override and towards.action is not Action.change_lane_right
    assert "san.emergency.move_over" in towards.rules
    assert "change lane right is forbidden" in towards.justification.text


def test_in_the_lane_of_a_stopped_emergency_vehicle_the_ego_moves_out_of_it():
    for jurisdiction in ("us", "uk"):
        away = _run(_fire_truck(2, 0.0), Action.change_lane_left, jurisdiction)
        assert away.decision is Decision.approve, jurisdiction
        cruise = _run(_fire_truck(2, 0.0), Action.cruise, jurisdiction)
        assert (cruise.decision, cruise.action) == (Decision.override, Action.change_lane_left), jurisdiction
        assert "san.emergency.move_over" in cruise.rules


@pytest.mark.parametrize("jurisdiction, ego_lane, x, kerb", [("us", 1, 3.5, Action.change_lane_right),
                                                             ("uk", 2, -3.5, Action.change_lane_left)])
def test_the_ego_does_not_cut_in_front_of_an_emergency_vehicle_coming_up_in_the_kerb_lane(jurisdiction, ego_lane, x, kerb):
    siren = obj("emergency_vehicle", x, -30.0, 3 - ego_lane, oid=4, vy=30.0, emergency_lights=True,
                sources=("camera", "radar"))
    frames = tuple(scene(frame=i, speed=20.0, lane=ego_lane, lanes=2, zone="highway", limit=29.0, objects=[siren])
                   for i in (1, 2))
    cruise = _run(frames, Action.cruise, jurisdiction)
    assert cruise.decision is Decision.override and cruise.action is not kerb
    assert "san.emergency.give_way" in cruise.rules
    cut_in = _run(frames, kerb, jurisdiction)
    assert cut_in.decision is Decision.override and cut_in.action is not kerb


def test_a_lane_change_away_from_an_emergency_vehicle_on_the_kerb_side_answers_it():
    siren = obj("emergency_vehicle", 3.5, -30.0, 3, oid=4, vy=30.0, emergency_lights=True, sources=("camera", "radar"))
    frames = tuple(scene(frame=i, speed=20.0, lane=2, lanes=3, zone="highway", limit=29.0, objects=[siren]) for i in (1, 2))
    assert _run(frames, Action.change_lane_left).decision is Decision.approve
    towards = _run(frames, Action.change_lane_right)
    assert towards.decision is Decision.override and {"clr.hazard", "san.emergency.give_way"} <= set(towards.rules)


# --- flashing red: a stop sign only at a US intersection; elsewhere the ego stays stopped while it flashes

FLASHING_RED = [{"colour": "red", "flashing": True}]


def _stopping_at_a_flashing_red(**kw):
    return tuple(scene(frame=i, speed=max(0.0, 3.0 - i), limit=13.0, lights=FLASHING_RED, **kw) for i in range(1, 6))


@pytest.mark.parametrize("jurisdiction", ["us", "uk"])
def test_a_flashing_red_away_from_an_intersection_holds_the_stop(jurisdiction):
    verdict = _run(_stopping_at_a_flashing_red(), Action.accelerate, jurisdiction)
    assert (verdict.decision, verdict.action) == (Decision.override, Action.brake)
    assert "san.lights.flashing_red_stop" in verdict.rules
    assert "a red light flashes where traffic stops and waits while it flashes" in verdict.justification.text


def test_a_flashing_red_at_an_intersection_is_a_stop_sign_in_the_us_and_holds_the_stop_in_the_uk():
    frames = _stopping_at_a_flashing_red(intersection={"type": "four_way", "stage": "at", "distance": 0.0})
    assert _run(frames, Action.accelerate, "us").decision is Decision.approve  # stopped: go when clear
    uk = _run(frames, Action.accelerate, "uk")
    assert (uk.decision, uk.action) == (Decision.override, Action.brake)
    assert "san.lights.flashing_red_stop" in uk.rules


def test_a_flashing_red_left_arrow_is_a_stop_for_the_left_turn_and_not_for_the_traffic_going_straight():
    lights = [{"colour": "green"}, {"colour": "red", "direction": "left", "flashing": True}]
    rolling = tuple(scene(frame=i, speed=2.0, limit=13.0, lights=lights, intent="enter_left_lane",
                          intersection={"type": "signaled", "stage": "at", "distance": 0.0}) for i in range(1, 6))
    for jurisdiction in ("us", "uk"):
        turn = _run(rolling, Action.turn_left, jurisdiction)
        assert (turn.decision, turn.action) == (Decision.override, Action.brake)
        assert "san.lights.flashing_red_stop" in turn.rules
        assert _run(rolling, Action.cruise, jurisdiction).decision is Decision.approve


# --- caution is a speed cap, not a standstill

def _flashing_yellow(speed: float):
    at = {"type": "four_way", "stage": "at", "distance": 0.0}
    return tuple(scene(frame=i, speed=speed, limit=13.0, lights=[{"colour": "yellow", "flashing": True}], intersection=at)
                 for i in range(1, 5))


@pytest.mark.parametrize("speed", [0.0, 3.0])
def test_at_a_flashing_yellow_the_ego_may_move_off_up_to_the_cautious_speed(speed):
    assert _run(_flashing_yellow(speed), Action.accelerate).decision is Decision.approve


def test_at_a_flashing_yellow_the_ego_is_told_to_slow_down_but_may_hold_its_speed():
    """A flashing yellow beacon is advisory (MUTCD 4D.04: proceed with caution, no speed set): braking is recommended
    above the cautious speed, holding the speed stays permitted, speeding up past it does not."""
    verdict = _run(_flashing_yellow(12.0), Action.cruise)
    assert (verdict.decision, verdict.recommended) == (Decision.approve, Action.brake)
    near = _run(_flashing_yellow(6.5), Action.accelerate)
    assert near.decision is Decision.override and "san.caution.no_speeding_up" in near.rules


def test_a_standing_emergency_vehicle_beside_a_fast_road_slows_the_ego_by_20_mph_not_to_15():
    """Move Over laws: 20 mph below the limit where the ego cannot change lanes, not a crawl on a highway."""
    police = obj("emergency_vehicle", 3.5, 100.0, 1, oid=4, kind="shoulder", vy=0.0, emergency_lights=True,
                 sources=("camera", "radar"))
    frames = tuple(scene(frame=i, speed=21.0, lanes=1, zone="highway", limit=31.3, other_lanes=("shoulder",),
                         objects=[police]) for i in (1, 2, 3))
    assert _run(frames, Action.cruise).decision is Decision.approve  # 47 mph, under 70 less 20
    faster = tuple(f.model_copy(update={"ego": f.ego.model_copy(update={"speed": 28.0})}) for f in frames)
    slowed = _run(faster, Action.cruise)
    assert (slowed.decision, slowed.action) == (Decision.override, Action.brake)
    assert "the ego goes no faster than 22.4 m/s (50 mph) under the caution called for" in slowed.justification.text


def test_a_uk_school_bus_is_passed_slowly_from_a_standstill():
    bus = obj("bus", -3.5, 20.0, 1, oid=4, kind="shoulder", vy=0.0, emergency_lights=True, sources=("camera", "radar"))
    frames = tuple(scene(frame=i, speed=0.0, limit=13.0, other_lanes=("shoulder",), objects=[bus]) for i in (1, 2, 3))
    assert _run(frames, Action.accelerate, "uk").decision is Decision.approve
    assert _run(frames, Action.accelerate, "us").decision is Decision.override  # the US stops for it


# --- a dark signal is still a signal

DARK = {"type": "signaled", "stage": "arriving", "distance": 20.0, "stop_line": True}


def test_a_dark_signal_is_an_all_way_stop_in_the_us():
    verdict = _run((scene(speed=12.0, limit=15.6, lights=[{"colour": "none"}], intersection=DARK),), Action.accelerate)
    assert (verdict.decision, verdict.action) == (Decision.override, Action.brake)
    assert {"san.lights.dark_signal", "brake.stop_sign"} <= set(verdict.rules)
    assert "the traffic lights in view are all dark" in verdict.justification.text


def test_a_dark_lamp_at_an_unsignalled_intersection_is_no_signal_out():
    unsignalled = {**DARK, "type": "unsignaled", "road": "major", "stop_line": False}
    verdict = _run((scene(speed=8.0, limit=15.6, lights=[{"colour": "none"}], intersection=unsignalled),), Action.cruise)
    assert verdict.decision is Decision.approve
    assert "san.lights.dark_signal" not in verdict.rules


def test_a_dark_signal_is_passed_with_great_care_in_the_uk_giving_way_to_cross_traffic():
    dark = [{"colour": "none"}]
    verdict = _run((scene(speed=12.0, limit=15.6, lights=dark, intersection=DARK),), Action.accelerate, "uk")
    assert (verdict.decision, verdict.action) == (Decision.override, Action.brake)
    assert {"san.lights.dark_signal", "san.caution.no_speeding_up"} <= set(verdict.rules)
    slow = _run((scene(speed=4.0, limit=15.6, lights=dark, intersection=DARK),), Action.accelerate, "uk")
    assert slow.decision is Decision.approve
    car = obj("car", -12.0, 20.0, 1, oid=5, kind="cross_left", vy=0.0, vx=10.0, sources=("camera", "radar"))
    crossing = _run((scene(speed=4.0, limit=15.6, lights=dark, other_lanes=("cross_left",), objects=[car],
                           intersection={**DARK, "distance": 3.0}),), Action.accelerate, "uk")
    assert crossing.decision is Decision.override and "san.lights.dark_signal" in crossing.rules


def test_inside_a_uk_junction_with_dark_signals_the_ego_clears_it_rather_than_stopping_for_cross_traffic():
    car = obj("car", 8.0, 6.0, 1, oid=5, kind="cross_right", sources=("camera", "radar"))
    inside = (scene(speed=6.0, limit=13.4, lights=[{"colour": "none"}], other_lanes=("cross_right",), objects=[car],
                    intersection={"type": "signaled", "stage": "enter"}),)
    assert _run(inside, Action.cruise, "uk").decision is Decision.approve


def test_a_red_seen_before_the_lights_went_dark_still_holds_the_ego():
    near = {**DARK, "distance": 12.0}  # within a comfortable stop: farther out, no light holds the ego yet
    frames = (scene(frame=1, speed=6.0, limit=15.6, lights=[{"colour": "red"}], intersection=near),
              scene(frame=2, speed=5.0, limit=15.6, lights=[{"colour": "none"}], intersection=near))
    for jurisdiction in ("us", "uk"):
        verdict = _run(frames, Action.accelerate, jurisdiction)
        assert verdict.decision is Decision.override and "san.memory.red_light" in verdict.rules, jurisdiction


def test_the_examples_command_explains_itself_and_names_a_file_it_cannot_fill_in_one_line(tmp_path, capsys):
    """`--help` was taken for the file to write into, and ended in a FileNotFoundError traceback."""
    with pytest.raises(SystemExit) as done:
        worked_examples.main(["--help"])
    assert done.value.code == 0 and capsys.readouterr().out.startswith("usage: python -m tests.worked_examples")
    for name, problem in (("missing.md", "No such file or directory"), ("plain.md", "no examples block")):
        if name == "plain.md":
            (tmp_path / name).write_text("# no block here\n")
        with pytest.raises(SystemExit) as done:
            worked_examples.main([str(tmp_path / name)])
        err = capsys.readouterr().err
        assert done.value.code == 2 and f"error: {tmp_path / name}: {problem}" in err and "Traceback" not in err


# --- one stop at the line per arrival: pulling off slowly, the stop outlives the window's memory of it

def _at_line(speeds: list[float], step: float, **extra) -> tuple[Scene, ...]:
    return tuple(scene(frame=i + 1, timestamp=round(step * i, 1), speed=v, limit=11.0, intersection=AT_STOP_LINE, **extra)
                 for i, v in enumerate(speeds))


def test_after_a_full_stop_at_a_stop_sign_the_ego_pulling_off_slowly_is_not_stopped_again():
    """0 to 2 m/s over 3 s at the line: the stop left the 2 s window at 2.5 s, and a second stop was ordered."""
    frames = _at_line([0.0, 0.3, 0.8, 1.2, 1.5, 1.8, 2.0], 0.5, signs=[{"kind": "stop"}])
    for last in range(1, len(frames) + 1):
        assert _decide(frames[:last], Action.accelerate).decision is Decision.approve, last


def test_after_a_full_stop_at_a_red_the_ego_creeping_into_its_right_turn_is_not_stopped_again():
    frames = _at_line([0.0, 0.8, 1.5, 2.0], 1.0, lights=[{"colour": "red"}], intent="enter_right_lane")
    for last in range(1, len(frames) + 1):
        assert _decide(frames[:last], Action.turn_right).decision is Decision.approve, last


@pytest.mark.parametrize("speeds", [[3.0, 2.0, 1.2, 0.8, 1.0, 1.3],  # slowing at the line, never stopping
                                    [1.0, 1.2, 1.4]])  # gaining speed at the line for less than a window
def test_a_rolling_stop_at_the_line_is_still_held_for_a_full_stop(speeds):
    verdict = _decide(_at_line(speeds, 0.5, signs=[{"kind": "stop"}]), Action.accelerate)
    assert verdict.action is Action.brake and "brake.stop_sign_full_stop" in verdict.rules
