"""Review of the geometry rules: what lies across the ego's path, who walks in its lane, who comes along the cross road."""

from __future__ import annotations

from discern.rules.engine import Reasoner
from discern.sanity import window_reasoner
from tests.scenes import obj, scene

REASONER = window_reasoner()
CROSS = ("oncoming", "cross_left", "cross_right")
STANDING = {"x": 0.0, "y": 0.0}


def decide(sc, proposed: str, reasoner: Reasoner = REASONER):
    return reasoner.decide(sc, proposed)


def green_3m_before_the_line(*objects):
    return scene(speed=10, limit=15.6, light="green", other_lanes=CROSS, objects=list(objects),
                 intersection={"type": "signaled", "stage": "arriving", "distance": 3})


def test_a_truck_standing_across_the_box_in_front_of_the_ego_is_an_obstacle_though_its_centre_is_to_the_side():
    # 12 m long, centred 5 m to the left: its body reaches 1 m to the right of the ego's line (UVC 11-202(a)(1))
    truck = obj("truck", -5, 9, lane=1, kind="cross_left", velocity=STANDING, size={"length": 12, "width": 2.5})
    for proposed in ("accelerate", "cruise"):
        verdict = decide(green_3m_before_the_line(truck), proposed)
        assert (verdict.decision.value, verdict.action.value) == ("override", "brake")
        assert "brake.obstacle_ahead" in verdict.rules
    # the same truck 8 m long, centred 6.5 m to the left, ends 2.5 m to the left of the ego's line: not in its way
    short = obj("truck", -6.5, 9, lane=1, kind="cross_left", velocity=STANDING, size={"length": 8, "width": 2.5})
    assert decide(green_3m_before_the_line(short), "accelerate").decision.value == "approve"


def test_a_vehicle_of_no_reported_size_across_the_path_is_as_long_as_its_class_typically_is():
    car = obj("car", -3, 8, lane=1, kind="cross_left", velocity=STANDING)  # 4.5 m: -5.25 m to -0.75 m
    verdict = decide(green_3m_before_the_line(car), "accelerate")
    assert verdict.action.value == "brake" and "brake.obstacle_ahead" in verdict.rules
    text = REASONER.decide(green_3m_before_the_line(car), "cruise", explain=True).justification.text
    assert "car 1 is 4.5 m long" in text
    # a typical truck (10 m) centred 6.5 m to the left reaches 1.5 m to the left of the ego's line: in its corridor
    truck = obj("truck", -6.5, 9, lane=1, kind="cross_left", velocity=STANDING)
    assert decide(green_3m_before_the_line(truck), "accelerate").action.value == "brake"
    # one waiting at its own line, to the side of the ego's road, is not in the way
    waiting = obj("car", -8, 8, lane=1, kind="cross_left", velocity=STANDING)
    assert decide(green_3m_before_the_line(waiting), "accelerate").decision.value == "approve"


def test_a_bus_standing_across_the_path_inside_the_intersection_stops_the_ego():
    bus = obj("bus", -4, 6, lane=1, kind="cross_left", velocity=STANDING, size={"length": 12, "width": 2.5})
    inside = scene(speed=10, limit=15.6, light="green", other_lanes=CROSS, objects=[bus],
                   intersection={"type": "signaled", "stage": "enter"})
    for proposed in ("accelerate", "cruise"):
        assert decide(inside, proposed).action.value == "brake"


def test_the_ego_does_not_speed_up_towards_a_pedestrian_standing_in_its_lane_30_m_ahead():
    def ahead(*objects):
        return scene(speed=10, limit=15.6, other_lanes=CROSS, objects=list(objects))

    pedestrian = obj("pedestrian", 0, 30, lane=1)
    verdict = decide(ahead(pedestrian), "accelerate")
    assert verdict.decision.value == "override" and verdict.action.value == "cruise"
    assert "acc.lane_not_clear" in verdict.rules
    # beyond its stopping distance the ego may hold its speed
    assert decide(ahead(pedestrian), "cruise").decision.value == "approve"
    # the same holds for an animal or a cyclist of unknown speed
    for cls in ("animal", "bicycle"):
        assert decide(ahead(obj(cls, 0, 30, lane=1)), "accelerate").action.value == "cruise"
    # beyond the overtaking distance (40 m), or a cyclist riding away faster than the ego, does not hold it back
    assert decide(ahead(obj("pedestrian", 0, 45, lane=1)), "accelerate").decision.value == "approve"
    assert decide(ahead(obj("bicycle", 0, 25, lane=1, vy=12)), "accelerate").decision.value == "approve"
    # a car 30 m ahead keeps pace with the traffic: only the following gap counts for it
    assert decide(ahead(obj("car", 0, 30, lane=1)), "accelerate").decision.value == "approve"


def stopped_at_the_minor_road(intent: str, *objects):
    return scene(speed=0, limit=15.6, intent=intent, sign="stop", other_lanes=CROSS, objects=list(objects),
                 intersection={"type": "t_intersect", "road": "minor", "stage": "at", "distance": 0})


def test_at_a_stop_sign_cross_traffic_of_unknown_speed_is_taken_to_come_at_the_zones_highest_limit():
    # 25 m to the side at 22.4 m/s (50 mph, the most a US city posts) is 1.1 s away, well inside the 5 s turn gap
    # (UVC 11-403(b)); the side road's own 35 mph says nothing of the main road's
    for x, kind in ((-25, "cross_left"), (25, "cross_right")):
        coming = stopped_at_the_minor_road("enter_left_lane", obj("car", x, 4, lane=1, kind=kind))
        verdict = decide(coming, "turn_left")
        assert verdict.decision.value == "override" and "tl.yield_cross_traffic" in verdict.rules
        assert decide(coming, "accelerate").action.value == "brake"
    # 90 m off it would take 4.0 s at 50 mph: still inside the gap; 120 m off, 5.4 s: the way is clear
    near = stopped_at_the_minor_road("enter_left_lane", obj("car", -90, 4, lane=1, kind="cross_left"))
    assert decide(near, "turn_left").decision.value == "override"
    far = stopped_at_the_minor_road("enter_left_lane", obj("car", -120, 4, lane=1, kind="cross_left"))
    assert decide(far, "turn_left").decision.value == "approve"
    # at a green light the cross road has red: a car of unknown speed there is not assumed to come
    green = scene(speed=0, limit=15.6, light="green", other_lanes=CROSS,
                  objects=[obj("car", -25, 4, lane=1, kind="cross_left")],
                  intersection={"type": "signaled", "stage": "at", "distance": 0})
    assert decide(green, "accelerate").decision.value == "approve"
    # at an all-way stop the cross traffic must stop too: the first to arrive goes
    first = scene(speed=0, limit=15.6, sign="stop", other_lanes=CROSS,
                  objects=[obj("car", -25, 4, lane=1, kind="cross_left")],
                  intersection={"type": "four_way", "stage": "at", "distance": 0, "arrival_rank": 1})
    assert decide(first, "accelerate").decision.value == "approve"


def test_in_the_uk_a_right_turn_out_of_a_minor_road_waits_for_cross_traffic_of_unknown_speed():
    uk = window_reasoner(jurisdiction="uk")
    coming = stopped_at_the_minor_road("enter_right_lane", obj("car", 25, 4, lane=1, kind="cross_right"))
    verdict = decide(coming, "turn_right", uk)
    assert verdict.decision.value == "override" and "tr.yield_cross_traffic" in verdict.rules


def test_at_a_stop_sign_cross_traffic_due_within_the_turn_gap_holds_the_ego_on_a_far_lane_of_the_cross_road():
    def stopped(vx: float):
        car = obj("car", 30, 18, lane=2, kind="cross_right", velocity={"x": vx, "y": 0.0})
        return scene(speed=0, limit=15.6, sign="stop", other_lanes=CROSS, objects=[car],
                     intersection={"type": "four_way", "stage": "at", "distance": 0})

    verdict = decide(stopped(-15.0), "accelerate")  # 30 m at 15 m/s: due in 2 s
    assert (verdict.decision.value, verdict.action.value) == ("override", "brake")
    assert "brake.stop_sign_cross_traffic" in verdict.rules
    assert decide(stopped(-5.0), "accelerate").decision.value == "approve"  # due in 6 s, after the turn gap
    assert decide(stopped(15.0), "accelerate").decision.value == "approve"  # driving away


# --- what is dead ahead is in the ego's lane, whatever its label --------------------------------------------------

def head_on(*objects, speed: float = 20, lane: int = 1, lanes: int = 1):
    return scene(speed=speed, limit=24, zone="rural", lane=lane, lanes=lanes, other_lanes=("oncoming",),
                 objects=list(objects))


def test_what_is_dead_ahead_is_in_the_egos_lane_though_perception_labels_it_in_another_lane():
    """12 m ahead, in line with the ego: no bend brings another lane there within the 15 m label check."""
    scenes = {
        "a car coming head-on": head_on(obj("car", 0, 12, lane=1, kind="oncoming", vy=-20)),
        "a car labelled oncoming, of unknown speed": head_on(obj("car", 0, 12, lane=1, kind="oncoming")),
        "a truck standing": head_on(obj("truck", 0, 12, lane=1, kind="oncoming", velocity=STANDING)),
        "a pedestrian": head_on(obj("pedestrian", 0, 12, lane=1, kind="oncoming")),
        "a pedestrian labelled in the next lane": head_on(obj("pedestrian", 0, 12, lane=1), lane=2, lanes=2),
    }
    for what, sc in scenes.items():
        for proposed in ("accelerate", "cruise"):
            verdict = REASONER.decide(sc, proposed, explain=True)
            assert (verdict.decision.value, verdict.action.value) == ("override", "brake"), (what, proposed)
            assert {"brake.obstacle_ahead", "san.lane.position_over_label"} <= set(verdict.rules), (what, proposed)
            assert "over its lane label" in verdict.justification.text, what
            assert "it names another lane of the road yet is in line with the ego" in verdict.justification.text


def test_beyond_the_label_check_distance_a_lane_label_is_kept_as_a_curve_may_bring_that_lane_into_line():
    oncoming_on_a_bend = head_on(obj("car", 0, 60, lane=1, kind="oncoming", vy=-20))
    verdict = decide(oncoming_on_a_bend, "cruise")
    assert verdict.decision.value == "approve" and "san.lane.position_over_label" not in verdict.rules


# --- overtaking a lead that is faster than the ego --------------------------------------------------------------

def test_a_lead_faster_than_the_ego_is_not_overtaken_and_a_forbidden_accelerate_is_held_at_cruise():
    faster = obj("car", 0, 35, lane=2, vy=24.9)
    sc = scene(speed=24.8, limit=25, zone="highway", lane=2, lanes=2, objects=[faster])
    verdict = decide(sc, "accelerate")
    assert (verdict.decision.value, verdict.action.value) == ("override", "cruise")
    assert "acc.at_limit" in verdict.rules and "cll.overtake" not in verdict.rules
    assert decide(sc, "cruise").recommended.value == "cruise"
    # a lead slower than the ego still is overtaken
    slower = scene(speed=24.8, limit=25, zone="highway", lane=2, lanes=2, objects=[obj("car", 0, 35, lane=2, vy=20)])
    verdict = decide(slower, "cruise")
    assert verdict.recommended.value == "change_lane_left"
    assert "cll.overtake" in decide(slower, "change_lane_left").rules


# --- the lane's edges, and vulnerable road users just beside it ---------------------------------------------------

def test_an_object_on_the_lane_edge_is_in_the_lane_on_either_side_alike():
    for x in (1.75, -1.75):
        verdict = decide(scene(speed=13, limit=15.6, objects=[obj("pedestrian", x, 10)]), "accelerate")
        assert (verdict.decision.value, verdict.action.value) == ("override", "brake"), x
        assert "brake.obstacle_ahead" in verdict.rules, x


def test_a_vulnerable_road_user_just_beside_the_egos_lane_is_not_passed_accelerating():
    """1.8 m to either side, 0.05 m beyond the lane's edge: well within the 1 m side clearance (Highway Code 163, 213)."""
    for x in (1.8, -1.8, 2.7):
        verdict = REASONER.decide(scene(speed=13, limit=15.6, objects=[obj("pedestrian", x, 10)]), "accelerate",
                                  explain=True)
        assert (verdict.decision.value, verdict.action.value) == ("override", "brake"), x  # down to pass slowly
        assert "acc.lane_not_clear" in verdict.rules and "[brake.pass_vulnerable_slowly]" in verdict.justification.text
        assert "is a vulnerable road user on the road ahead just beside the ego's lane" in verdict.justification.text
    # beyond the side clearance (1.75 m + 1 m), or behind the ego, they do not hold it back
    for x, y in ((2.8, 10), (1.8, -3)):
        assert decide(scene(speed=13, limit=15.6, objects=[obj("pedestrian", x, y)]), "accelerate").decision.value == "approve"


def test_a_pedestrian_beside_the_lane_lets_the_ego_move_off_and_one_on_the_sidewalk_does_not_slow_it():
    """Passing slowly is a speed, not a standstill; and a kerb separates a sidewalk's pedestrians from the road."""
    waiting = obj("pedestrian", 2.6, 30, velocity=STANDING)
    assert decide(scene(speed=0, limit=13.4, objects=[waiting]), "accelerate").decision.value == "approve"
    on_sidewalk = obj("pedestrian", 2.6, 30, lane=1, kind="sidewalk_right", velocity=STANDING)
    assert decide(scene(speed=8, limit=13.4, other_lanes=("sidewalk_right",), objects=[on_sidewalk]),
                  "accelerate").decision.value == "approve"
