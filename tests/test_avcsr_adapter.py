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


def test_traffic_light_none_is_no_light_in_view_not_a_dark_one(tmp_path):
    path = tmp_path / "f.pl"
    path.write_text(FRAME.replace("traffic_light(red, 1).", "traffic_light(none, 1)."))
    (frame,) = read_file(path)
    assert frame.scene.traffic_lights == []


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
        ("self_speed(5, 1)", "expected ., found the end of the file"),
        ("self_speed(", "expected a term, found the end of the file"),
        ("self_speed(X, 1).", "variable X"),
        ("self_speed(5, one).", "timestamp 'one'"),
        ("obj_meta(1, 1, unicorn, pos(0, 5), lane(current, 1), none).", "unknown value 'unicorn'"),
        ("self_speed(5, 1) $", "unexpected character '$'"),
        ("expected_action(c0hange_lane_right, 1).", "expected_action/2 cannot be read: 'c0hange_lane_right' is not one of"),
        ("obj_meta(1, 1, car, 3, lane(current, 1), none).", "obj_meta/6 cannot be read: expected pos(_, _), found 3"),
        ("obj_meta(1, 1, car, pos(0, 5), none).", "has 5 arguments; AV-CSR writes obj_meta(T, Id, Class, pos(X, Y)"),
    ],
)
def test_bad_files_name_the_problem(tmp_path, bad, message):
    path = tmp_path / "bad.pl"
    path.write_text("% City\nself_lane(1, 1).\n" + bad + "\n")
    with pytest.raises(AvcsrError) as err:
        read_file(path)
    assert message in str(err.value)
    assert "bad.pl" in str(err.value)


BASE = """% City - test
%%% FRAME 1 %%%
self_speed(8, 1).
self_lane(1, 1).
speed_limit(10, 1).
lanes(current, [1], 1).
intent(continue_in_lane, 1).
expected_action(cruise, 1).
"""


OBJECT = "obj_meta(1, 4, car, pos(0, 30), lane(current, 1), none).\n"


def read(tmp_path, text: str):
    path = tmp_path / "f.pl"
    path.write_text(text)
    return read_file(path)


def refused(tmp_path, text: str) -> str:
    with pytest.raises(AvcsrError) as err:
        read(tmp_path, text)
    return str(err.value)


def test_sensor_without_timestamp_belongs_to_the_frame_block_it_sits_in(tmp_path):
    two = BASE + BASE.replace(", 1).", ", 2).").replace("FRAME 1", "FRAME 2").replace("% City - test\n", "")
    frames = read(tmp_path, two + "sensor(left, 0.2).\n")
    assert [[(s.side.value, s.distance) for s in f.scene.sensors] for f in frames] == [[], [("left", 0.2)]]


def test_sensor_without_timestamp_outside_any_frame_block_is_refused(tmp_path):
    message = refused(tmp_path, "% City - test\nsensor(left, 0.2).\n" + BASE.replace("% City - test\n", ""))
    assert "f.pl:2: sensor(left, 0.2) has no frame T and sits under no %%% FRAME n %%% header" in message


@pytest.mark.parametrize("fact, stage", [("at_intersection(0, 1)", "at"), ("in_intersection(0, 1)", "enter")])
def test_template_intersection_takes_the_egos_stage_from_at_and_in_intersection(tmp_path, fact, stage):
    (frame,) = read(tmp_path, BASE + f"intersection(unsignaled, 2, 1).\n{fact}.\n")
    assert frame.scene.intersection.stage.value == stage and frame.scene.intersection.arrival_rank == 2
    assert not any("stage" in note for note in frame.notes)


def test_template_intersection_without_a_stage_is_read_as_arriving_and_says_so(tmp_path):
    (frame,) = read(tmp_path, BASE + "intersection(signaled, none, 1).\n")
    assert frame.scene.intersection.stage.value == "arriving"
    assert (
        "intersection(signaled, none, 1) gives no stage, nor does at_intersection/in_intersection(0, 1): read as arriving"
    ) in frame.notes


@pytest.mark.parametrize(
    "facts, message",
    [
        ("intersection(signaled, none, 1).\nat_intersection(5, 1).",
         "f.pl:10: at_intersection/2 cannot be read: object 5: only 0, the ego, can be read"),
        ("at_intersection(0, 1).", "f.pl:9: at_intersection(0, 1): frame 1 has no intersection(Type, Meta, T)"),
        ("intersection(four_way, major, arriving, 1).\nin_intersection(0, 1).",
         "f.pl:10: in_intersection(0, 1) contradicts intersection(four_way, major, arriving, 1) at line 9"),
        ("intersection(signaled, none, 1).\nat_intersection(0, 1).\nin_intersection(0, 1).",
         "f.pl:11: in_intersection(0, 1) contradicts at_intersection(0, 1) at line 10"),
        ("intersection(signaled, left, 1).", "f.pl:9: intersection/3 cannot be read: meta left is not none, major"),
    ],
)
def test_intersection_stage_facts_that_cannot_be_read_are_refused(tmp_path, facts, message):
    assert message in refused(tmp_path, BASE + facts + "\n")


@pytest.mark.parametrize(
    "extra, message",
    [
        ("self_speed(12, 1).",
         "f.pl:9: self_speed(12, 1) contradicts self_speed(8, 1) at line 3: frame 1 holds one self_speed"),
        ("expected_action(brake, 1).",
         "f.pl:9: expected_action(brake, 1) contradicts expected_action(cruise, 1) at line 8"),
        ("intent(enter_left_lane, 1).",
         "f.pl:9: intent(enter_left_lane, 1) contradicts intent(continue_in_lane, 1) at line 7"),
        ("speed_limit(20, 1).", "f.pl:9: speed_limit(20, 1) contradicts speed_limit(10, 1) at line 5"),
        ("lanes(current, [1, 2], 1).",
         "f.pl:9: lanes(current, [1, 2], 1) contradicts lanes(current, [1], 1) at line 6"),
        ("intersection(signaled, none, arriving, 1).\nintersection(t_intersect, minor, enter, 1).",
         "f.pl:10: intersection(t_intersect, minor, enter, 1) contradicts intersection(signaled, none, arriving, 1) "
         "at line 9"),
        ("traffic_light(red, 1).\ntraffic_light(green, 1).",
         "f.pl:10: traffic_light(green, 1) contradicts traffic_light(red, 1)"),
        (OBJECT + "obj_meta(1, 4, car, pos(0, 20), lane(current, 1), none).",
         "f.pl:10: obj_meta(1, 4, car, pos(0, 20), lane(current, 1), none) contradicts obj_meta(1, 4, car, pos(0, 30), "
         "lane(current, 1), none) at line 9: frame 1 holds one obj_meta for object 4"),
        (OBJECT + "obj_pred_path(4, op1, 1).\nobj_pred_path(4, op2, 1).",
         "f.pl:11: obj_pred_path(4, op2, 1) contradicts obj_pred_path(4, op1, 1) at line 10: "
         "frame 1 holds one obj_pred_path for object 4"),
        ("sensor(left, 0.4, 1).\nleft_sensor(0.2, 1).",
         "f.pl:10: left_sensor(0.2, 1) contradicts sensor(left, 0.4, 1) at line 9"),
    ],
)
def test_a_conflicting_repeated_fact_is_refused_naming_both_lines(tmp_path, extra, message):
    assert message in refused(tmp_path, BASE + extra + "\n")


def test_an_exact_duplicate_fact_is_read_once(tmp_path):
    (frame,) = read(tmp_path, BASE + "self_speed(8, 1).\ntraffic_sign(stop, 1).\ntraffic_sign(stop, 1).\n"
                    "lanes(current, [1], 1).\nexpected_action(cruise, 1).\n")
    assert frame.scene.ego.speed == 8 and len(frame.scene.signs) == 1
    assert [l.id for l in frame.scene.lanes if l.kind == "current"] == [1]


@pytest.mark.parametrize(
    "bad, message",
    [
        ("self_speed(8, 2, 1).", "f.pl:9: self_speed(8, 2, 1) has 3 arguments; AV-CSR writes self_speed(Speed, T)"),
        ("speed_limit(25, mph, 1).", "speed_limit(25, mph, 1) has 3 arguments; AV-CSR writes speed_limit(Speed, T)"),
        ("traffic_light(yellow, flashing, 1).", "has 3 arguments; AV-CSR writes traffic_light(Colour, T)"),
        ("intersection(four_way, major, at, ego, 1).",
         "has 5 arguments; AV-CSR writes intersection(Type, Meta, T) or intersection(Type, Meta, Stage, T)"),
        ("lanes([1], 1).", "lanes([1], 1) has 2 arguments; AV-CSR writes lanes(Kind, [Ids], T)"),
        ("sensor(left).", "has 1 arguments; AV-CSR writes sensor(Side, Dist) or sensor(Side, Dist, T)"),
    ],
)
def test_a_known_fact_with_the_wrong_number_of_arguments_is_refused(tmp_path, bad, message):
    assert message in refused(tmp_path, BASE + bad + "\n")


@pytest.mark.parametrize("unknown", ["foo(4, 9).", "foo(4, 1).", "trafic_light(red, 1)."])
def test_an_unknown_fact_is_refused_before_its_timestamp_is_read(tmp_path, unknown):
    message = refused(tmp_path, BASE + unknown + "\n")
    name = unknown.split("(")[0]
    assert f"f.pl:9: unknown fact {name}/2; the AV-CSR facts are at_intersection/2, " in message
    assert "traffic_light/2" in message and "frame" not in message


def test_an_object_path_without_its_obj_meta_is_refused(tmp_path):
    message = refused(tmp_path, BASE + "self_pred_path(sp1, 1).\nobj_pred_path(5, op1, 1).\n")
    assert "f.pl:10: obj_pred_path(5, op1, 1): frame 1 has no obj_meta for object 5" in message


PATHS = BASE + OBJECT + "self_pred_path(sp1, 1).\nobj_pred_path(4, op1, 1).\n"


def test_path_intersects_with_the_object_path_first_is_refused_as_av_csr_would_never_apply_it(tmp_path):
    message = refused(tmp_path, PATHS + "path_intersects(op1, sp1).\n")
    assert "f.pl:12: path_intersects(op1, sp1) names the object's path first" in message
    assert "write path_intersects(sp1, op1)" in message


def test_path_intersects_that_no_frame_can_use_is_refused(tmp_path):
    message = refused(tmp_path, PATHS + "path_intersects(sp1, op9).\n")
    assert (
        "f.pl:12: path_intersects(sp1, op9) applies in no frame: none has both self_pred_path(sp1, T) "
        "and obj_pred_path(_, op9, T)"
    ) in message


def test_path_intersects_holds_in_every_frame_that_has_both_paths(tmp_path):
    (frame,) = read(tmp_path, PATHS + "path_intersects(sp1, op1).\n")
    assert [(c.ego_path, c.object_path) for c in frame.scene.path_crossings] == [("sp1", "op1")]


@pytest.mark.parametrize(
    "first_lines, environment, zone",
    [
        ("% City: basic driving\n", "City", "city"),
        ("%CITY\u2013basic driving\n", "City", "city"),
        ("%\n% residential - quiet street\n", "Residential", "residential"),
        ("%Highway: merge\n", "Highway", "highway"),
        ("% campus.\n", "Campus", "campus"),
    ],
)
def test_the_environment_word_is_matched_whatever_its_case_and_punctuation(tmp_path, first_lines, environment, zone):
    (frame,) = read(tmp_path, first_lines + BASE.replace("% City - test\n", ""))
    assert (frame.environment, frame.scene.ego.zone.value) == (environment, zone)
    assert not any("zone is assumed" in note for note in frame.notes)


@pytest.mark.parametrize(
    "first_lines, environment, said",
    [
        ("% Motorway - merge\n", "Motorway", "the first comment line names environment 'Motorway'"),
        ("", "Unknown", "no comment line before the facts names the environment"),
        ("self_speed(8, 1).\n% City - after a fact\n", "Unknown", "no comment line before the facts names the environment"),
    ],
)
def test_an_unknown_or_missing_environment_is_read_as_city_with_a_note(tmp_path, first_lines, environment, said):
    (frame,) = read(tmp_path, first_lines + BASE.replace("% City - test\n", ""))
    assert (frame.environment, frame.scene.ego.zone.value) == (environment, "city")
    assert any(note.startswith(said) and note.endswith("the zone is assumed to be city") for note in frame.notes)


@pytest.mark.parametrize("text", ["", "% City - nothing here\n", "% City\npath_intersects(sp1, op1).\n"])
def test_a_file_without_frames_is_refused(tmp_path, text):
    assert refused(tmp_path, text).endswith("f.pl: no frames: no fact names a frame T")


@pytest.mark.parametrize("fact, message", [
    ("obj_meta(1, 4, motorbike, pos(0, 30), lane(current, 1), none).",
     "f.pl:9: obj_meta(1, 4, motorbike, pos(0, 30), lane(current, 1), none): class: unknown value 'motorbike'"),
    ("obj_meta(1, 4, car, pos(0, 100000), lane(current, 1), none).",
     "f.pl:9: obj_meta(1, 4, car, pos(0, 100000), lane(current, 1), none): position.y: Input should be less than"),
    ("traffic_light(blue, 1).", "f.pl:9: traffic_light(blue, 1): colour: unknown value 'blue'"),
    ("obj_meta(1, 4, car, pos(0, f(3)), lane(current, 1), none).",
     "f.pl:9: obj_meta(1, 4, car, pos(0, f(3)), lane(current, 1), none): position.y: Input should be a valid number (got 'f(3)')"),
    ("obj_meta(1, 4, car, pos(0, 3, 4), lane(current, 1), none).",
     "f.pl:9: obj_meta/6 cannot be read: expected pos(_, _), found pos(0, 3, 4)"),
    ("lanes(oncoming, abc, 1).", "f.pl:9: lanes/3 cannot be read: expected a list of lane ids such as [1, 2], found abc"),
    ("obj_meta(1, '4', car, pos(0, 30), lane(current, 1), none).",  # a quoted atom is no number, as in Prolog
     "f.pl:9: obj_meta(1, 4, car, pos(0, 30), lane(current, 1), none): id: Input should be a valid integer (got '4')"),
])
def test_a_value_the_scene_refuses_is_named_by_its_fact_and_line(tmp_path, fact, message):
    """Once 'frame 1:' and 'objects.0.class', a list position the file never wrote, on a second line."""
    said = refused(tmp_path, BASE + fact + "\n")
    assert said.startswith(str(tmp_path / message.split(":", 1)[0]) + ":" + message.split(":", 1)[1]) and "\n" not in said


def test_the_speed_of_a_frame_is_named_by_its_fact_when_the_scene_refuses_it(tmp_path):
    said = refused(tmp_path, BASE.replace("self_speed(8, 1).", "self_speed(-8, 1)."))
    assert said == f"{tmp_path / 'f.pl'}:3: self_speed(-8, 1): Input should be greater than or equal to 0 (got -8)"


def test_too_many_lanes_are_named_by_the_lanes_fact_shortened(tmp_path):
    lanes = ", ".join(str(i) for i in range(1, 3001))
    said = refused(tmp_path, BASE.replace("lanes(current, [1], 1).", f"lanes(current, [{lanes}], 1)."))
    assert said.startswith(f"{tmp_path / 'f.pl'}:6: lanes(current, [1, 2, 3, ") and "at most 1000 items" in said
    assert len(said) < 500, said


@pytest.mark.parametrize("text, message", [
    ("self_speed(" + "[" * 500 + "]" * 500 + ", 1).", "f.pl:9: a term nested more than 16 deep"),
    ("self_speed(" + "9" * 5000 + ", 1).", "f.pl:9: the number 999999999999... has 5000 digits, more than 30"),
    ("%%% FRAME " + "9" * 5000 + " %%%", "f.pl:9: the number 999999999999... has 5000 digits, more than 30"),
])
def test_a_term_too_deep_or_a_number_too_long_is_named_by_its_line(tmp_path, text, message):
    said = refused(tmp_path, BASE + text + "\n")
    assert said == str(tmp_path / message.split(":", 1)[0]) + ":" + message.split(":", 1)[1]


def test_prologs_own_spellings_read_as_prolog_reads_them(tmp_path):
    """'car' is the atom car, /* */ a comment and 1.2e1 a float: once each was an 'unexpected character'."""
    (frame,) = read(tmp_path, BASE + "/* a\n block */ obj_meta(1, 4, 'car', pos(0, 1.2e1), lane(current, 1), none).\n")
    car = frame.scene.objects[0]
    assert (car.cls.value, car.position.y) == ("car", 12.0)
    assert "unexpected character '\"' (a double-quoted string: not part of a fact)" in refused(
        tmp_path, BASE + 'intent("continue_in_lane", 1).\n')


@pytest.mark.parametrize("indicator, said", [
    ("turn_signals", "a turn signal without its side, which the scene's left and right need"),
    ("tail_lights", "tail lights, which signal nothing"),
])
def test_av_csrs_own_indicator_words_are_read_as_none_with_a_note(tmp_path, indicator, said):
    (frame,) = read(tmp_path, BASE + OBJECT.replace("none)", f"{indicator})"))
    assert frame.scene.objects[0].indicator.value == "none"
    assert any(f"indicator {indicator} is {said}: read as none" in note for note in frame.notes)


@pytest.mark.parametrize("fact, said", [
    ("lanes(current, '[' 1], 1).", "f.pl:9: expected ), found '1'"),  # a quoted '[' is an atom, not a list's start
    ("obj_meta(1, 4, car, pos(0, 30), lane(current, 1), [x]).", "f.pl:9: obj_meta(1, 4, car, pos(0, 30), lane(current, 1), [x]): indicator:"),
])
def test_a_quoted_mark_is_no_punctuation_and_a_list_is_no_indicator(tmp_path, fact, said):
    assert said in refused(tmp_path, BASE + fact + "\n")
