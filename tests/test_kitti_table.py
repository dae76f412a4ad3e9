import pytest

from discern.adapters.avcsr import read_dir
from discern.monitor.cli import main
from discern.scenarios import paper_table


def test_all_24_paper_frames_agree_with_expected_action(avcsr_dir, reasoner):
    rows = paper_table.run(read_dir(avcsr_dir), reasoner, repeats=1)
    assert len(rows) == 24
    disagreements = [(r.frame.scenario, r.frame.frame, r.decision) for r in rows if not r.agrees]
    assert disagreements == []


def test_the_recommended_action_of_each_paper_frame_does_not_depend_on_the_action_proposed(avcsr_dir, reasoner):
    """The table proposes the annotated action (the approve path it times); the answer scored is the recommendation,
    which must not be the proposal echoed back."""
    for frame in read_dir(avcsr_dir):
        recommended = {reasoner.decide(frame.scene, proposed).recommended for proposed in
                       ("cruise", "brake", "accelerate", "change_lane_left", frame.expected)}
        assert recommended == {frame.expected}, (frame.scenario, frame.frame, recommended)


def test_table_groups_frames_by_the_papers_four_environments(avcsr_dir, reasoner):
    rows = paper_table.run(read_dir(avcsr_dir), reasoner, repeats=1)
    table = paper_table.format_table(rows)
    for env, (avg, worst) in paper_table.PAPER_MS.items():
        line = next(l for l in table.splitlines() if l.startswith(env))
        assert " 6/6 " in line and str(avg) in line and str(worst) in line
    assert "24/24" in table
    assert table.splitlines()[-1] == paper_table.TIME_NOTE  # which times the columns hold, under them


def test_misstamped_fact_is_read_by_its_timestamp_and_reported(avcsr_dir):
    frames = {(f.scenario, f.frame): f for f in read_dir(avcsr_dir)}
    frame2 = frames[("2011_09_26_drive_0029", 2)]
    assert any("stamped T=1 but sits under FRAME 2" in n for n in frames[("2011_09_26_drive_0029", 1)].notes)
    assert any("no current lanes given" in n for n in frame2.notes)
    assert [l.id for l in frame2.scene.lanes if l.kind == "current"] == [1]


def test_misstamped_facts_give_frame_1_the_cross_right_lane_of_frame_2(avcsr_dir):
    frames = {(f.scenario, f.frame): f for f in read_dir(avcsr_dir)}
    lanes = [(lane.kind.value, lane.id) for lane in frames[("2011_09_26_drive_0029", 1)].scene.lanes]
    assert lanes == [("current", 1), ("current", 2), ("current", 3), ("cross_right", 1)]


def test_each_frames_notes_are_printed_under_its_row_without_explain(avcsr_dir, capsys):
    assert main(["scenarios", "run", str(avcsr_dir / "2011_09_26_drive_0029.pl"), "--repeats", "1"]) == 0
    lines = capsys.readouterr().out.splitlines()
    row = next(i for i, line in enumerate(lines) if line.startswith("Road") and " 1  change_lane_left " in line)
    assert lines[row + 1] == (
        "        note: 2011_09_26_drive_0029.pl:26: lanes(current, [1, 2, 3], 1) is stamped T=1 but sits under FRAME 2; "
        "read as T=1"
    )
    assert lines[row + 2].startswith("        note: 2011_09_26_drive_0029.pl:27: lanes(cross_right, [1], 1)")


NO_EXPECTED = """% City - no expected action in frame 2
%%% FRAME 1 %%%
self_speed(6, 1).
self_lane(1, 1).
speed_limit(10, 1).
lanes(current, [1], 1).
expected_action(accelerate, 1).
%%% FRAME 2 %%%
self_speed(6, 2).
self_lane(1, 2).
speed_limit(10, 2).
lanes(current, [1], 2).
"""


def test_a_frame_without_expected_action_is_not_scored(tmp_path, capsys):
    path = tmp_path / "noexp.pl"
    path.write_text(NO_EXPECTED)
    assert main(["scenarios", "run", str(path), "--repeats", "1"]) == 0
    out = capsys.readouterr().out
    row = next(line.split() for line in out.splitlines() if line.startswith("City ") and line.split()[2] == "2")
    assert row[3:6] == ["-", "accelerate", "-"]  # expected, discern, agree
    assert "City              2   1/1 " in out
    assert "agreement with expected_action: 1/1 frames (1 without expected_action, not scored)" in out


@pytest.mark.parametrize("repeats", ["0", "-3"])
def test_repeats_below_one_are_refused_by_the_parser(avcsr_dir, capsys, repeats):
    with pytest.raises(SystemExit) as exit_:
        main(["scenarios", "run", str(avcsr_dir), "--repeats", repeats])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert f"argument --repeats: must be at least 1 (the time is the median of that many runs), got {repeats}" in err
    with pytest.raises(ValueError, match="repeats must be at least 1"):
        paper_table.run(read_dir(avcsr_dir)[:1], None, repeats=int(repeats))


def test_a_frame_file_without_frames_is_an_error(tmp_path, capsys):
    path = tmp_path / "empty.pl"
    path.write_text("% City - nothing here\npath_intersects(sp1, op1).\n")
    assert main(["scenarios", "run", str(path)]) == 2
    assert capsys.readouterr().err == f"discern scenarios: error: {path}: no frames: no fact names a frame T\n"
