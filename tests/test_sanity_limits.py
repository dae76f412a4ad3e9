"""Speed-limit plausibility: which reading governs, and what the verdict says about the others."""

from __future__ import annotations

import pytest

from discern.rules.catalog import catalog_dirs, load_catalog
from discern.rules.engine import Reasoner, jurisdiction_pack
from discern.rules.scene import Lane, LaneKind
from discern.sanity import reasoner_for
from tests.scenes import MPH, limit_sign, obj, scene

US = reasoner_for("us")


def limit_in_force(sc, history=(), reasoner=US) -> float:
    answer = reasoner.solve(sc, "cruise", history).answer
    (limit,) = answer.of("effective_limit", 1)
    return limit.arguments[0].number / 100


def test_a_taped_85_in_town_cannot_raise_the_limit_past_the_plausible():
    taped = scene(speed=16.0, limit=85 * MPH, signs=[limit_sign(85)])
    verdict = US.decide(taped, "accelerate")
    assert verdict.decision.value == "override" and "san.limit.implausible" in verdict.rules
    assert "the limit reading of 38.0 m/s (85 mph) is doubted: above any plausible limit for the zone" in verdict.justification.text
    assert limit_in_force(taped) == 15.65


def test_a_map_that_agrees_vouches_for_a_high_reading():
    road = dict(speed=30.0, zone="road", limit=75 * MPH)
    assert limit_in_force(scene(**road)) == 24.59  # above any plausible road limit: the usual one applies
    assert limit_in_force(scene(**road, map_speed_limit=75 * MPH)) == 33.53


def test_the_lower_of_map_and_sign_governs():
    assert limit_in_force(scene(zone="road", limit=20.0, map_speed_limit=24.0)) == 20.0
    assert limit_in_force(scene(zone="road", limit=24.0, map_speed_limit=20.0)) == 20.0


def test_a_reading_that_lowers_or_raises_a_settled_limit_takes_effect_on_its_second_frame():
    before = [scene(frame=i, zone="road", limit=20.0) for i in (1, 2)]
    for reading in (15.0, 24.0):
        assert limit_in_force(scene(frame=3, zone="road", limit=reading), before) == 20.0, reading
        again = before[1:] + [scene(frame=3, zone="road", limit=reading)]
        assert limit_in_force(scene(frame=4, zone="road", limit=reading), again) == reading


def test_a_one_frame_low_reading_on_a_highway_does_not_brake_the_ego_with_a_truck_behind():
    """70 mph settled, then one frame reads 40 (an exit ramp's sign): the ego holds its speed; the 70 read again after
    it is the settled limit still, and stays in force when the sign has left the view."""
    truck = (obj("truck", 0.0, -5.0, 1, oid=9, vy=31.0, sources=("camera", "radar")),)
    readings = [70, 70, 70, 70, 40, 70, None]
    frames = [scene(frame=i + 1, timestamp=0.1 * i, speed=31.0, zone="highway", limit=None, objects=truck,
                    signs=[limit_sign(v)] if v else []) for i, v in enumerate(readings)]
    for last in (5, 6, 7):
        verdict = US.decide(frames[last - 1], "cruise", history=frames[:last - 1])
        assert verdict.decision.value == "approve", (last, verdict.justification.summary)
    assert "san.limit.debounce_drop" in US.decide(frames[4], "cruise", history=frames[:4]).rules


def test_the_plausible_reading_wins_when_the_sign_and_the_perceived_limit_disagree():
    assert limit_in_force(scene(limit=13.0, signs=[limit_sign(85)])) == 13.0


def test_a_doubted_reading_is_reported_with_an_approval():
    verdict = US.decide(scene(speed=10.0, limit=85 * MPH), "cruise")
    assert verdict.decision.value == "approve" and "san.limit.implausible" in verdict.rules
    assert verdict.justification.tree == []  # the fast path still names the rule, without a tree


def test_the_core_catalog_alone_believes_the_perceived_limit():
    core = Reasoner(catalog=load_catalog([catalog_dirs()[0]], extra_files=[jurisdiction_pack("us")]), providers=[])
    answer = core.solve(scene(speed=16.0, limit=85 * MPH), "cruise").answer
    assert [s.arguments[0].number for s in answer.of("effective_limit", 1)] == [3800]


def test_a_stop_sign_misread_as_a_limit_does_not_set_the_limit():
    misread = scene(speed=5.0, limit=None, signs=[limit_sign(45)],
                    intersection={"type": "unsignaled", "stage": "arriving", "stop_line": True},
                    objects=[obj("car", -3.5, -20.0, 1, oid=1, sources=("camera", "radar"))], lanes=2, lane=2)
    assert limit_in_force(misread) == 15.65  # the zone's usual limit, not the "45" of the stickered sign


def _stop45_then_through(stop_line: bool = True):
    """A stop sign read as "speed limit 45" while coming up to a stop line; the ego stops, enters, and drives on."""
    def inter(stage, **kw):
        return {"type": "unsignaled", "stage": stage, "stop_line": stop_line, **kw}
    return (scene(frame=1, timestamp=0.0, speed=10.0, limit=None, signs=[limit_sign(45)], intersection=inter("arriving", distance=30.0)),
            scene(frame=2, timestamp=0.1, speed=9.0, limit=None, signs=[limit_sign(45)], intersection=inter("arriving", distance=25.0)),
            scene(frame=3, timestamp=0.6, speed=3.0, limit=None, signs=[limit_sign(45)], intersection=inter("arriving", distance=5.0)),
            scene(frame=4, timestamp=1.1, speed=0.0, limit=None, signs=[limit_sign(45)], intersection=inter("at", distance=0.0)),
            scene(frame=5, timestamp=1.5, speed=3.0, limit=None, signs=[limit_sign(45)], intersection=inter("enter")),
            scene(frame=6, timestamp=1.8, speed=16.0, limit=None))


def test_a_stop_sign_misread_as_45_stays_doubted_once_the_ego_has_entered_and_passed_it():
    frames = _stop45_then_through()
    for last in (5, 6):  # entering with the sign in view, and past it
        assert limit_in_force(frames[last - 1], frames[:last - 1]) == 15.65, last  # the city's usual 35 mph, not 45
    verdict = US.decide(frames[-1], "accelerate", history=frames[:-1], explain=True)
    assert verdict.action.value == "cruise" and "san.stop.misread_limit" in verdict.rules
    # read in many frames with no stop control, 45 is believed (the control: it is the stop line that doubts it)
    plain = _stop45_then_through(stop_line=False)
    assert limit_in_force(plain[-1], plain[:-1]) == 20.12


def _frames(zone: str, readings, dt: float = 0.1):
    """Frames `dt` apart reading the given limits (mph; None: no sign in view) at 17 m/s."""
    return [scene(frame=i + 1, timestamp=round(dt * i, 3), speed=17.0, zone=zone, limit=None,
                  signs=[limit_sign(v)] if v else []) for i, v in enumerate(readings)]


@pytest.mark.parametrize("zone, true, taped, reasoner", [
    ("road", 35, 85, US), ("city", 25, 85, US), ("rural", 30, 80, reasoner_for("uk"))])
def test_a_true_limit_outlives_the_taped_sign_that_followed_it_once_both_leave_view(zone, true, taped, reasoner):
    """35 read over three frames, then a taped 85, then no sign: the 35 stays in force, not the zone's usual limit."""
    frames = _frames(zone, [true] * 3 + [taped] * 3 + [None] * 3)
    for last in range(4, len(frames) + 1):
        answer = reasoner.solve(frames[last - 1], "cruise", frames[:last - 1]).answer
        (limit,) = answer.of("effective_limit", 1)
        assert limit.arguments[0].number == round(true * MPH * 100), (last, limit)


def test_a_lower_limit_read_in_one_frame_is_no_prior_for_a_doubted_reading_after_it():
    frames = _frames("road", [45, 45, 45, 35, 85, 85], dt=0.2)
    for last in (5, 6):
        assert limit_in_force(frames[last - 1], frames[:last - 1]) == 20.12, last  # 45 mph, the settled one


@pytest.mark.parametrize("hz, frames_65, raised", [
    (50, 2, False), (20, 2, False), (10, 1, False),  # 40 ms, 0.1 s, 0.1 s of a 65: a flicker
    (50, 10, True), (20, 4, True), (10, 2, True), (5, 2, True)])  # 0.2 s and more, at least 2 frames: a sign
def test_a_higher_reading_is_confirmed_by_how_long_it_was_read_whatever_the_frame_rate(hz, frames_65, raised):
    """45 read for 0.5 s, then 65 (above the road's usual 55) for some frames, then no sign: the 65 raises the limit only
    once read for 0.2 s and in 2 frames, while in view and after."""
    readings = [45] * (hz // 2) + [65] * frames_65 + [None] * hz
    frames = _frames("road", readings, dt=1 / hz)
    expected = 29.06 if raised else 20.12
    for last in (hz // 2 + frames_65, len(frames)):  # the last frame the 65 is read in, and 1 s after it
        assert limit_in_force(frames[last - 1], frames[:last - 1]) == expected, (hz, frames_65, last)


# --- readings far below what the zone allows

def _tailgated_highway(signs, frame: int = 1, timestamp: float = 0.1, **kw):
    """30 m/s on a highway, a truck 5 m behind at the same speed."""
    return scene(frame=frame, timestamp=timestamp, speed=30.0, zone="highway", signs=signs,
                 objects=[obj("truck", 0.0, -5.0, 1, oid=2, vy=30.0, sources=("radar",))], **{"limit": None, **kw})


@pytest.mark.parametrize("jurisdiction", ["us", "uk"])
def test_a_one_frame_5_mph_reading_on_a_highway_does_not_make_the_tailgated_ego_brake(jurisdiction):
    reasoner = reasoner_for(jurisdiction)
    misread = _tailgated_highway([{"kind": "speed_limit", "value": 2.2, "source": "camera"}])
    cruise = reasoner.decide(misread, "cruise", explain=True)
    assert cruise.decision.value == "approve" and "san.limit.highway_floor" in cruise.rules
    assert ("the limit reading of 2.2 m/s (4.9 mph) is doubted: below any limit a highway posts"
            in cruise.justification.text)
    brake = reasoner.decide(misread, "brake")
    assert brake.decision.value == "override" and "brake.no_phantom_braking" in brake.rules


def test_a_speed_limit_of_0_on_a_highway_is_doubted():
    zero = scene(speed=30.0, zone="highway", limit=0.0)
    assert limit_in_force(zero) == 31.29  # the highway's usual 70 mph
    verdict = US.decide(zero, "cruise")
    assert verdict.decision.value == "approve" and "san.limit.highway_floor" in verdict.rules


@pytest.mark.parametrize("zone", ["highway", "city"])
def test_a_limit_of_0_read_in_every_frame_is_no_limit(zone):
    frames = [scene(frame=i + 1, timestamp=0.1 * i, speed=10.0, zone=zone, limit=None, signs=[limit_sign(0)])
              for i in range(10)]
    assert limit_in_force(frames[-1], frames[:-1]) == {"highway": 31.29, "city": 15.65}[zone]
    assert "san.limit.zero" in US.decide(frames[-1], "cruise", history=frames[:-1]).rules


def test_a_mapped_limit_of_0_is_no_limit_and_the_sign_read_governs():
    """Map data may give 0 for a limit they do not know: braking to 0 on a highway would be a phantom brake."""
    unknown = _tailgated_highway([limit_sign(70)]).model_copy(update={"map_speed_limit": 0.0})
    assert limit_in_force(unknown) == 31.29  # the 70 mph read
    verdict = US.decide(unknown, "cruise", explain=True)
    assert verdict.decision.value == "approve" and "san.limit.map_zero" in verdict.rules
    assert "the mapped limit of 0.0 m/s (0 mph) is doubted" in verdict.justification.text
    city = scene(speed=10.0, limit=None, signs=[limit_sign(25)])
    lane_zero = city.model_copy(update={"lanes": [Lane(kind=LaneKind.current, id=1, speed_limit=0.0)]})
    assert limit_in_force(lane_zero) == limit_in_force(city) == 11.18  # the ego's lane mapped at 0: the 25 mph read


def test_a_5_mph_highway_reading_held_over_many_frames_is_still_doubted_without_the_map():
    """A defaced or misread sign reads the same in every frame: only the map vouches for so low a highway limit."""
    frames = [_tailgated_highway([limit_sign(5)], frame=i + 1, timestamp=0.1 * i) for i in range(10)]
    assert limit_in_force(frames[-1], frames[:-1]) == 31.29
    assert US.decide(frames[-1], "cruise", history=frames[:-1]).decision.value == "approve"
    mapped = [f.model_copy(update={"map_speed_limit": 2.0}) for f in frames]
    assert limit_in_force(mapped[-1], mapped[:-1]) == 2.0
    assert US.decide(mapped[-1], "cruise", history=mapped[:-1]).decision.value == "override"


@pytest.mark.parametrize("jurisdiction", ["us", "uk"])
def test_a_30_mph_highway_limit_read_steadily_is_believed_without_the_map(jurisdiction):
    """Dual carriageways and work zones post 30 mph: unusually low for a highway, but confirmed by being read on."""
    frames = [_tailgated_highway([limit_sign(30)], frame=i + 1, timestamp=0.1 * i) for i in range(20)]
    reasoner = reasoner_for(jurisdiction)
    assert "san.limit.unusually_low" in reasoner.decide(frames[0], "cruise").rules  # one frame: doubted
    assert limit_in_force(frames[-1], frames[:-1], reasoner) == 13.41
    assert reasoner.decide(frames[-1], "cruise", history=frames[:-1]).decision.value == "override"


def test_an_unusually_low_town_reading_is_believed_once_the_map_or_enough_frames_confirm_it():
    assert limit_in_force(scene(speed=10.0, zone="city", limit=None, signs=[limit_sign(5)], map_speed_limit=2.0)) == 2.0
    assert limit_in_force(scene(speed=10.0, zone="city", limit=None, signs=[limit_sign(5)])) == 15.65  # one frame
    frames = [scene(frame=i + 1, timestamp=0.1 * i, speed=10.0, zone="city", limit=None, signs=[limit_sign(5)])
              for i in range(3)]
    assert limit_in_force(frames[-1], frames[:-1]) == 2.24  # read for 0.3 s: a sign, not a misread
    assert US.decide(frames[-1], "cruise", history=frames[:-1]).decision.value == "override"


@pytest.mark.parametrize("zone, mph", [("highway", 45), ("highway", 40), ("road", 25), ("city", 15), ("school", 10)])
def test_a_work_zone_or_village_limit_takes_effect_at_once(zone, mph):
    """A highway's work zone, a village on a fast road, a slow town street: low, but not unusually so."""
    assert limit_in_force(scene(speed=10.0, zone=zone, limit=None, signs=[limit_sign(mph)])) == round(mph * MPH, 2)


def test_a_one_frame_low_misread_between_two_settled_readings_is_no_limit_to_fall_back_on():
    """70 mph for 0.3 s, 5 mph for one frame, 70 mph again: the 70 is a rise over the 5 read before, so it is
    doubted until confirmed, but the one-frame 5 is no plausible limit to fall back on: the zone's 70 applies."""
    frames = [_tailgated_highway([limit_sign(v)], frame=i + 1, timestamp=0.1 * i) for i, v in enumerate([70, 70, 70, 5, 70])]
    assert limit_in_force(frames[-1], frames[:-1]) == 31.29
    assert US.decide(frames[-1], "cruise", history=frames[:-1]).decision.value == "approve"
    gone = frames[:4] + [_tailgated_highway([], frame=5, timestamp=0.4)]  # the 5 mph sign has left the view
    assert limit_in_force(gone[-1], gone[:-1]) == 31.29


@pytest.mark.parametrize("reading, misread", [(11.2, False), (13.4, True)])
def test_a_25_mph_sign_read_as_11_2_m_s_is_no_unusual_reading_for_the_stop_sign_evidence(reading, misread):
    """11.2 m/s is 25 mph rounded, the usual residential limit (11.18 m/s); with a car braking ahead at a crossing, it
    was once still read as a stickered stop sign, while 30 mph (13.4 m/s) rightly is."""
    sc = scene(speed=8, limit=reading, zone="residential",
               intersection={"type": "four_way", "stage": "arriving", "distance": 20.0},
               objects=[obj("car", 0, 12, lane=1, vy=1.0, indicator="brake_light")],
               signs=[{"kind": "speed_limit", "value": reading, "source": "camera"}])
    assert ("san.stop.misread_sign" in US.decide(sc, "cruise").rules) is misread
