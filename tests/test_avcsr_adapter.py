import pytest

from discern.adapters.avcsr import AvcsrError, read_file
from discern.rules.scene import Action, LaneKind

FRAME = """% Road - test
%%% FRAME 1 %%%
self_speed(14.8, 1).
self_lane(1, 1).
speed_limit(20, 1).
obj_meta(1, 7, truck, pos(6, 5), lane(current, 2), none).
lanes(current, [1,2], 1).
intersection(t_intersect, minor, at, 1).
self_pred_path(sp1, 1).
obj_pred_path(7, op1, 1).
path_intersects(sp1, op1).
traffic_light(red, 1).
left_sensor(0.4, 1).
intent(stay_in_rightmost_lane, 1).
expected_action(change_lane_right, 1).
"""


def test_reads_facts_into_a_scene_with_units_and_paths(tmp_path):
    path = tmp_path / "f.pl"
    path.write_text(FRAME)
    (frame,) = read_file(path)
    scene = frame.scene
    assert frame.environment == "Road" and frame.expected is Action.change_lane_right
    assert scene.ego.speed == 14.8 and scene.speed_limit == 20
    truck = scene.objects[0]
    assert (truck.id, truck.cls.value, truck.position.x, truck.position.y) == (7, "truck", 6, 5)
    assert truck.lane.kind is LaneKind.current and truck.lane.id == 2
    assert scene.intersection.road == "minor" and scene.intersection.stage.value == "at"
    assert [(c.ego_path, c.object_path) for c in scene.path_crossings] == [("sp1", "op1")]
    assert scene.sensors[0].side.value == "left" and scene.sensors[0].distance == 0.4


def test_fact_without_timestamp_holds_in_every_frame(tmp_path):
    two = FRAME + FRAME.replace(", 1).", ", 2).").replace("(1, 7,", "(2, 7,").replace("FRAME 1", "FRAME 2")
    path = tmp_path / "f.pl"
    path.write_text(two)
    frames = read_file(path)
    assert [f.frame for f in frames] == [1, 2]
    assert all(f.scene.path_crossings for f in frames)


@pytest.mark.parametrize(
    "bad, message",
    [
        ("self_speed(5, 1)", "expected ."),
        ("self_speed(X, 1).", "variable X"),
        ("self_speed(5, one).", "timestamp 'one'"),
        ("obj_meta(1, 1, unicorn, pos(0, 5), lane(current, 1), none).", "unknown value 'unicorn'"),
        ("self_speed(5, 1) $", "unexpected character '$'"),
        ("expected_action(c0hange_lane_right, 1).", "expected_action/2 cannot be read: 'c0hange_lane_right' is not one of"),
        ("obj_meta(1, 1, car, 3, lane(current, 1), none).", "obj_meta/6 cannot be read: expected pos(_, _), found 3"),
        ("obj_meta(1, 1, car, pos(0, 5), none).", "obj_meta/5 cannot be read"),
    ],
)
def test_bad_files_name_the_problem(tmp_path, bad, message):
    path = tmp_path / "bad.pl"
    path.write_text("% City\nself_lane(1, 1).\n" + bad + "\n")
    with pytest.raises(AvcsrError) as err:
        read_file(path)
    assert message in str(err.value)
    assert "bad.pl" in str(err.value)
