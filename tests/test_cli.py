import json
import subprocess
import sys
from pathlib import Path

import pytest

from discern.monitor.cli import main
from discern.monitor.config import free_port
from tests.monitor_process import endpoint
from tests.scenes import obj, scene

ROOT = Path(__file__).resolve().parents[1]
GOOD = scene(speed=12, lane=2, lanes=3, limit=20, objects=[obj("car", -3.5, 2, lane=1)])


def write(tmp_path, data, name="scene.json"):
    path = tmp_path / name
    path.write_text(data if isinstance(data, str) else json.dumps(data))
    return str(path)


def good_dict():
    return json.loads(GOOD.model_dump_json(by_alias=True))


def test_check_prints_verdict_and_justification(tmp_path, capsys):
    assert main(["check", write(tmp_path, good_dict()), "--proposed", "change_lane_left"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("override change_lane_left with")
    assert "cll.lane_taken" in out and "car 1 is 2.0 m ahead and 3.5 m to the left" in out


def test_check_json_is_a_verdict(tmp_path, capsys):
    main(["check", write(tmp_path, good_dict()), "--proposed", "accelerate", "--explain", "json"])
    verdict = json.loads(capsys.readouterr().out)
    assert verdict["decision"] == "approve" and verdict["justification"]["tree"]


def test_check_html_writes_a_page(tmp_path, capsys):
    out = tmp_path / "v.html"
    main(["check", write(tmp_path, good_dict()), "--proposed", "change_lane_left", "--explain", "html", "--out", str(out)])
    page = out.read_text()
    assert page.startswith("<!doctype html>") and "<details" in page and "cll.lane_taken" in page


@pytest.mark.parametrize("explain", ["text", "json", "html"])
def test_check_shows_the_scenes_warnings_in_every_format(tmp_path, capsys, explain):
    data = good_dict()
    data["objects"][0]["lane"] = {"kind": "current", "id": 9}
    main(["check", write(tmp_path, data), "--proposed", "cruise", "--explain", explain])
    out = capsys.readouterr().out
    note = "object 1 is in lane current/9, which the scene does not list; kept, and placed by its measured position, as one reported without a lane is"
    assert note in out
    if explain == "json":
        assert json.loads(out)["notes"] == [note]


def test_check_reads_a_file_with_a_byte_order_mark_and_refuses_an_empty_out_name(tmp_path, capsys):
    path = tmp_path / "bom.json"
    path.write_text(json.dumps(good_dict()), encoding="utf-8-sig")
    assert main(["check", str(path), "--proposed", "cruise"]) == 0
    assert capsys.readouterr().out.startswith("approve cruise")
    with pytest.raises(SystemExit) as refused:
        main(["check", str(path), "--proposed", "cruise", "--out", ""])
    assert refused.value.code == 2 and "argument --out: empty path" in capsys.readouterr().err


def test_scenarios_run_reads_a_scenario_file_with_a_byte_order_mark_as_check_reads_a_scene(tmp_path, capsys):
    path = tmp_path / "acc.cut_in.json"
    path.write_bytes(b"\xef\xbb\xbf" + (ROOT / "scenarios" / "rules" / "acc.cut_in.json").read_bytes())
    assert main(["scenarios", "run", str(path)]) == 0
    assert "pass  acc.cut_in #0" in capsys.readouterr().out


@pytest.mark.parametrize("argv", [
    ["scenarios", "run", ""], ["audit", ""], ["audit", "--replay", "x.mcap", "--rules", ""], ["serve", "--log-dir", ""],
    ["eval", "highway", "--out", ""], ["check", "", "--proposed", "brake"], ["schema", "--out", ""],
    ["serve", "--zenoh-config", ""],
])
def test_an_empty_path_is_refused_not_taken_for_the_current_directory(argv, capsys, tmp_path, monkeypatch):
    """`scenarios run ""` (an unset variable) read every file under the working directory; `serve --log-dir ""` logged there."""
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as refused:  # argparse's usage error: exit status 2
        main(argv)
    assert refused.value.code == 2 and "empty path: give a file or directory name" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_the_html_banner_names_the_action_in_words(tmp_path, capsys):
    out = tmp_path / "v.html"
    main(["check", write(tmp_path, good_dict()), "--proposed", "change_lane_left", "--shadow", "--explain", "html",
          "--out", str(out)])
    page = out.read_text()
    assert "VETO: CHANGE LANE LEFT" in page and "CHANGE_LANE_LEFT" not in page


def test_check_accepts_a_proposal_message(tmp_path, capsys):
    data = {"version": 1, "vehicle": "v1", "action": "change_lane_left", "scene": good_dict()}
    assert main(["check", write(tmp_path, data)]) == 0
    assert "override change_lane_left" in capsys.readouterr().out


def test_shadow_mode_vetoes_without_replacing(tmp_path, capsys):
    main(["check", write(tmp_path, good_dict()), "--proposed", "change_lane_left", "--shadow", "--explain", "json"])
    verdict = json.loads(capsys.readouterr().out)
    assert verdict["decision"] == "veto" and verdict["action"] == "change_lane_left" and verdict["shadow"]


def mutate(path, value):
    data = good_dict()
    node = data
    for key in path[:-1]:
        node = node[key]
    if value is KeyError:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return data


@pytest.mark.parametrize(
    "data, message",
    [
        (mutate(["objects", 0, "class"], "unicorn"), "objects.0.class: unknown value 'unicorn'"),
        ('{"frame_id": 1, "ego": {"speed": NaN, "lane": 1}}', "ego.speed: Input should be a finite number"),
        (mutate(["ego", "speed"], -4), "ego.speed: Input should be greater than or equal to 0"),
        (mutate(["ego"], KeyError), "ego: is required but missing"),
        (mutate(["ego", "lane"], 7), "invalid scene:\nlanes: ego.lane 7 does not exist: current lanes are [1, 2, 3]"),
        (mutate(["sensors"], [{"side": "left", "distance": -1}]), "sensors.0.distance: Input should be greater than or equal to 0"),
        (mutate(["objects", 0, "position", "y"], "far"), "objects.0.position.y"),
        (mutate(["ego", "speed"], 500), "ego.speed: Input should be less than or equal to 150"),
        ("{not json", "invalid JSON at line 1 column 2"),
        ("[1, 2]", "expected a JSON object"),
    ],
)
def test_invalid_input_exits_2_naming_the_field(tmp_path, capsys, data, message):
    code = main(["check", write(tmp_path, data), "--proposed", "brake"])
    err = capsys.readouterr().err
    assert code == 2 and message in err and "Traceback" not in err


def test_every_problem_of_a_scene_is_named_at_once_not_one_per_run(tmp_path, capsys):
    """A duplicate object id once hid that the ego's lane does not exist: the user fixed one, then met the other."""
    data = good_dict()
    data["ego"]["lane"] = 7
    data["objects"].append(dict(data["objects"][0]))
    code = main(["check", write(tmp_path, data), "--proposed", "brake"])
    err = capsys.readouterr().err
    assert code == 2
    assert "lanes: ego.lane 7 does not exist: current lanes are [1, 2, 3]" in err
    assert f"objects: object id {data['objects'][0]['id']} appears twice" in err


def test_missing_file_and_missing_action_are_user_errors(tmp_path, capsys):
    assert main(["check", str(tmp_path / "nope.json"), "--proposed", "brake"]) == 2
    assert "cannot read" in capsys.readouterr().err
    assert main(["check", write(tmp_path, good_dict())]) == 2
    assert "needs --proposed" in capsys.readouterr().err


@pytest.mark.parametrize("command, name", [
    (["check", "{file}", "--proposed", "brake"], "scene.json"),
    (["scenarios", "run", "{dir}"], "frame.pl"),
    (["scenarios", "run", "{dir}"], "scenario.json"),
    (["check", "{good}", "--proposed", "brake", "--rules", "{dir}"], "rules.lp"),
])
def test_a_file_that_is_not_utf8_is_named_without_a_traceback(tmp_path, capsys, command, name):
    files = tmp_path / "files"
    files.mkdir()
    (files / name).write_bytes(b'{"frame_id": 1, \xff}')
    good = write(tmp_path, good_dict())
    argv = [a.format(file=files / name, dir=files, good=good) for a in command]
    assert main(argv) == 2
    assert f"{files / name}: not UTF-8 text (invalid start byte at byte 16)" in capsys.readouterr().err


def unreadable(path: Path, kind: str) -> None:
    """A file name that cannot be read: a broken symlink, or a directory."""
    if kind == "broken symlink":
        path.symlink_to(path.parent / "gone")
    else:
        path.mkdir()


UNREADABLE = {"broken symlink": "No such file or directory", "directory": "Is a directory"}


@pytest.mark.parametrize("kind", UNREADABLE)
@pytest.mark.parametrize("command", [
    ["check", "{good}", "--proposed", "brake", "--rules", "{dir}"],
    ["catalog", "--rules", "{dir}"],
    ["scenarios", "run", "{scenario}", "--rules", "{dir}"],
])
def test_a_rules_file_that_cannot_be_read_is_named_without_a_traceback(tmp_path, capsys, command, kind):
    import shutil

    rules = tmp_path / "rules"
    shutil.copytree(ROOT / "rules" / "catalog", rules)
    unreadable(rules / "zz.lp", kind)
    scenario = ROOT / "scenarios" / "rules" / "acc.cut_in.json"
    argv = [a.format(good=write(tmp_path, good_dict()), dir=rules, scenario=scenario) for a in command]
    assert main(argv) == 2
    assert capsys.readouterr().err == f"discern {argv[0]}: error: {rules / 'zz.lp'}: cannot read: {UNREADABLE[kind]}\n"


NEAR_JUNCTION = """%! pred near_junction :: "the ego is within 30 m of an intersection"

%! rule cll.near_junction
%! says The ego does not change lanes within 30 m of an intersection.
%! source Driving manual (do not change lanes in or near an intersection)
near_junction :- intersection_distance(D), D < 3000.
forbidden(change_lane_left) :- near_junction.
"""


def test_a_rule_of_ones_own_is_tried_beside_the_shipped_ones_without_copying_them(tmp_path, capsys):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "near.lp").write_text(NEAR_JUNCTION)
    data = good_dict()
    data["lanes"] = [{"kind": "current", "id": 1}, {"kind": "current", "id": 2}]
    data["ego"]["lane"] = 2
    data["intersection"] = {"type": "four_way", "stage": "arriving", "distance": 20.0}
    data["objects"] = []
    scene = write(tmp_path, data)
    assert main(["check", str(scene), "--proposed", "change_lane_left"]) == 0
    assert capsys.readouterr().out.startswith("approve change_lane_left")
    assert main(["check", str(scene), "--proposed", "change_lane_left", "--add-rules", str(mine)]) == 0
    said = capsys.readouterr().out
    assert said.startswith("override change_lane_left") and "forbidden by cll.near_junction" in said, said
    assert main(["catalog", "--add-rules", str(mine)]) == 0
    listed = capsys.readouterr().out
    assert "cll.near_junction" in listed and "brake.obstacle_ahead" in listed


def test_check_prints_the_frames_facts_one_a_line_for_a_rules_author(tmp_path, capsys):
    data = good_dict()
    data["ego"]["predicted_path"] = "a.param"  # a quoted id's dot ends no fact
    assert main(["check", write(tmp_path, data), "--proposed", "cruise", "--explain", "facts"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "proposed(cruise)." in lines and 'ego_path("a.param").' in lines and "ego_speed(1200)." in lines
    assert all(line.endswith(".") for line in lines)


@pytest.mark.parametrize("kind", UNREADABLE)
def test_scenarios_run_names_a_frame_file_in_a_directory_that_cannot_be_read(avcsr_dir, tmp_path, capsys, kind):
    import shutil

    frames = tmp_path / "frames"
    shutil.copytree(avcsr_dir, frames)
    unreadable(frames / "zz.pl", kind)
    assert main(["scenarios", "run", str(frames), "--repeats", "1"]) == 2
    assert capsys.readouterr().err == f"discern scenarios: error: {frames / 'zz.pl'}: cannot read: {UNREADABLE[kind]}\n"


def test_catalog_lists_rules_with_english_and_source(capsys):
    assert main(["catalog"]) == 0
    out = capsys.readouterr().out
    assert "brake.obstacle_ahead" in out and "source: AUTO-DISCERN (obstacle ahead)" in out


def test_scenarios_run_kitti_prints_the_paper_table(avcsr_dir, capsys):
    assert main(["scenarios", "run", str(avcsr_dir), "--repeats", "1"]) == 0
    out = capsys.readouterr().out
    assert "paper s(CASP) avg ms" in out and "agreement with expected_action: 24/24 frames" in out


def test_scenarios_run_on_an_empty_directory_is_an_error(tmp_path, capsys):
    assert main(["scenarios", "run", str(tmp_path)]) == 2
    assert "no scenario files" in capsys.readouterr().err


def test_check_param_sets_a_reasoning_parameter_and_names_a_bad_one(tmp_path, capsys):
    """A car at 2 m/s 38 m ahead, closed in on at 13 m/s: outside the following gap at 6 m/s² (15 m of headway and
    (15² - 2²) / 12 = 18.4 m more to stop than the car), inside it at 4 (15 + 27.6 m). A moving car, since one
    standing is slowed for early, at the comfortable rate, whatever the firm one."""
    path = write(tmp_path, json.loads(scene(speed=15, limit=20, objects=[obj("car", 0, 38, lane=1, vy=2.0)])
                                      .model_dump_json(by_alias=True)))
    assert main(["check", path, "--proposed", "cruise"]) == 0
    assert capsys.readouterr().out.startswith("approve cruise")
    assert main(["check", path, "--proposed", "cruise", "--param", "decel=4"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("override cruise with brake") and "the firm braking deceleration is 4.0 m/s²" in out
    assert main(["check", path, "--proposed", "cruise", "--param", "decel=0", "--param", "brakes=1"]) == 2
    err = capsys.readouterr().err
    assert "--param decel needs a number from 0.01 to 100, got '0'" in err and "unknown --param 'brakes'" in err
    assert main(["check", path, "--proposed", "cruise", "--param", "decel"]) == 2
    assert "--param 'decel': expected NAME=VALUE, such as decel=4" in capsys.readouterr().err


def test_check_param_past_its_bound_is_refused_rather_than_wrapped_into_a_permissive_verdict(tmp_path, capsys):
    """A reaction time of 800 s once wrapped clingo's 32-bit arithmetic and approved cruising at a stopped car."""
    path = write(tmp_path, json.loads(scene(speed=30, limit=35, objects=[obj("car", 0, 60, lane=1, vy=0.0)])
                                      .model_dump_json(by_alias=True)))
    for setting in ("reaction_s=800", "headway_s=800", "accel_step=1000", "min_gap=1e7", "decel=4_0"):
        assert main(["check", path, "--proposed", "cruise", "--param", setting]) == 2
        err = capsys.readouterr().err
        name, _, value = setting.partition("=")
        assert f"--param {name} needs a number from 0.01 to" in err and f"got '{value}'" in err
        assert "Traceback" not in err
    assert main(["check", path, "--proposed", "cruise", "--param", "reaction_s=60"]) == 0
    assert capsys.readouterr().out.startswith("override cruise with brake")


def test_check_names_a_bad_proposal_as_a_proposal_with_proposed_or_without(tmp_path, capsys):
    """--proposed once replaced an action of 'fly' before the check: a message the monitor refuses was accepted."""
    data = {"action": "fly", "scene": json.loads(scene(speed=10, limit=15).model_dump_json(by_alias=True))}
    path = write(tmp_path, data, "proposal.json")
    for proposed in ([], ["--proposed", "cruise"]):
        assert main(["check", path, *proposed]) == 2
        assert "invalid proposal:\naction: unknown value 'fly'" in capsys.readouterr().err
    data["action"] = "brake"
    assert main(["check", write(tmp_path, data, "proposal.json"), "--proposed", "cruise"]) == 0
    assert capsys.readouterr().out.startswith("approve cruise")


def test_scenarios_run_takes_single_files_of_either_kind_and_explains_each_verdict(avcsr_dir, capsys):
    scenario = ROOT / "scenarios" / "rules" / "acc.cut_in.json"
    frames = sorted(avcsr_dir.glob("*.pl"))[0]
    assert main(["scenarios", "run", str(scenario), str(frames), "--repeats", "1", "--explain"]) == 0
    out = capsys.readouterr().out
    assert "pass  acc.cut_in #0: override accelerate with brake" in out and "1 passed, 0 failed" in out
    assert "agreement with expected_action: 3/3 frames" in out
    # --explain: each verdict's proof under its line, the scenario's and the paper frames' alike
    assert "            - car 1 is heading into lane 2 within the gap it needs, because  [def.lane_claimed]" in out
    assert f"{frames.stem} frame 1:\n        approve accelerate: permitted" in out


@pytest.mark.parametrize("example, command", [("scene.json", "--proposed ACTION"), ("proposal.json", "")])
def test_scenarios_run_says_a_scene_or_proposal_is_one_for_check(capsys, example, command):
    """A scene given to `scenarios run` printed ten schema errors, and no word of what the file was."""
    path = ROOT / "docs" / "examples" / example
    assert main(["scenarios", "run", str(path)]) == 2
    kind = example.removesuffix(".json")
    assert capsys.readouterr().err == (f"discern scenarios: error: {path}: a {kind}, not a scenario file: "
                                       f"`discern check {path}{' ' + command if command else ''}` judges it\n")


def test_scenarios_run_names_the_first_problems_of_a_file_and_counts_the_rest(tmp_path, capsys):
    """Every problem was listed, however many: `check` and the monitor name five, then `... and N more`."""
    data = {"name": 3, "frames": "x", **{f"extra_{i}": i for i in range(6)}}
    assert main(["scenarios", "run", write(tmp_path, data, "many.json")]) == 2
    problems = capsys.readouterr().err.splitlines()[1:]
    assert len(problems) == 6 and problems[-1] == "... and 5 more"


def test_scenarios_run_fails_when_any_expectation_fails(tmp_path, capsys):
    data = json.loads((ROOT / "scenarios" / "rules" / "acc.cut_in.json").read_text())
    data["frames"][0]["expect"]["action"] = "cruise"
    assert main(["scenarios", "run", write(tmp_path, data, "wrong.json")]) == 1
    out = capsys.readouterr().out
    assert "FAIL  acc.cut_in #0" in out and "action brake, expected cruise" in out and "0 passed, 1 failed" in out


def test_a_frame_that_expects_nothing_is_counted_as_history_and_a_scenario_that_checks_nothing_is_refused(tmp_path,
                                                                                                        capsys):
    """An empty `expect` printed "pass" and counted as passed: a file of such frames passed whatever the rules said."""
    data = json.loads((ROOT / "scenarios" / "rules" / "acc.cut_in.json").read_text())
    data["frames"] = [{**data["frames"][0], "expect": {}}, data["frames"][0]]
    assert main(["scenarios", "run", write(tmp_path, data, "history.json")]) == 0
    out = capsys.readouterr().out
    assert "hist  acc.cut_in #0: override accelerate" in out and "pass  acc.cut_in #1" in out
    assert "1 passed, 0 failed, 1 history frame (nothing expected)" in out
    data["frames"] = [data["frames"][0]]
    assert main(["scenarios", "run", write(tmp_path, data, "nothing.json")]) == 2
    captured = capsys.readouterr()
    assert "no frame expects anything" in captured.err and "0 passed, 0 failed, 1 file not read" in captured.out


def test_scenarios_run_on_a_directory_runs_its_frame_files_and_its_scenarios_subdirectories_too(avcsr_dir, tmp_path,
                                                                                                capsys):
    frames = sorted(avcsr_dir.glob("*.pl"))[0]
    (tmp_path / frames.name).write_text(frames.read_text())
    data = json.loads((ROOT / "scenarios" / "rules" / "acc.cut_in.json").read_text())
    data["frames"][0]["expect"]["action"] = "cruise"
    (tmp_path / "deeper").mkdir()
    write(tmp_path / "deeper", data, "wrong.json")
    assert main(["scenarios", "run", str(tmp_path), "--repeats", "1"]) == 1  # the failing scenario is not hidden
    out = capsys.readouterr().out
    assert "agreement with expected_action: 3/3 frames" in out and "0 passed, 1 failed" in out


def test_scenarios_run_runs_every_readable_file_and_names_each_broken_one(tmp_path, capsys):
    (tmp_path / "acc.cut_in.json").write_text((ROOT / "scenarios" / "rules" / "acc.cut_in.json").read_text())
    (tmp_path / "a_broken.json").write_text('{"name": "broken", "frames": [\n')
    (tmp_path / "b_empty.json").write_text('{"name": "b"}')
    assert main(["scenarios", "run", str(tmp_path)]) == 2
    out, err = capsys.readouterr()
    assert "pass  acc.cut_in #0" in out and "1 passed, 0 failed, 2 files not read" in out
    assert f"discern scenarios: error: {tmp_path / 'a_broken.json'}:" in err and f"discern scenarios: error: {tmp_path / 'b_empty.json'}:" in err


def test_a_scenario_file_of_an_unknown_jurisdiction_is_named_and_the_others_still_run(tmp_path, capsys):
    (tmp_path / "acc.cut_in.json").write_text((ROOT / "scenarios" / "rules" / "acc.cut_in.json").read_text())
    data = json.loads((ROOT / "scenarios" / "rules" / "acc.cut_in.json").read_text())
    write(tmp_path, {**data, "jurisdiction": "mars"}, "a_mars.json")
    assert main(["scenarios", "run", str(tmp_path)]) == 2
    out, err = capsys.readouterr()
    assert "pass  acc.cut_in #0" in out and "1 passed, 0 failed, 1 file not read" in out
    assert f"discern scenarios: error: {tmp_path / 'a_mars.json'}:\njurisdiction: unknown jurisdiction 'mars': choose from us, uk" in err


@pytest.mark.parametrize("name, message", [
    ("missing.json", "no such file or directory"),
    ("notes.txt", "not a scenario file (.json) or an AV-CSR frame file (.pl)"),
])
def test_scenarios_run_names_a_path_it_cannot_run(tmp_path, capsys, name, message):
    if name.endswith(".txt"):
        (tmp_path / name).write_text("hello")
    assert main(["scenarios", "run", str(tmp_path / name)]) == 2
    assert f"{tmp_path / name}: {message}" in capsys.readouterr().err


def test_check_on_a_scenario_or_frame_file_points_to_scenarios_run(avcsr_dir, capsys):
    scenario = ROOT / "scenarios" / "rules" / "acc.cut_in.json"
    frames = sorted(avcsr_dir.glob("*.pl"))[0]
    for path in (scenario, frames):
        assert main(["check", str(path)]) == 2
        assert f"`discern scenarios run {path}`" in capsys.readouterr().err


def test_console_script_runs_as_a_process(tmp_path):
    result = subprocess.run([sys.executable, "-m", "discern.monitor.cli", "check", write(tmp_path, good_dict()),
                             "--proposed", "cruise"], capture_output=True, text=True, timeout=60)
    assert result.returncode == 0 and result.stdout.startswith("approve cruise")


def test_a_reader_that_leaves_early_gets_no_traceback():
    """`discern catalog | head`: the pipe closes before the catalog is written."""
    process = subprocess.Popen([sys.executable, "-m", "discern.monitor.cli", "catalog"], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    process.stdout.close()
    err = process.communicate(timeout=60)[1]
    assert process.returncode == 141 and "Traceback" not in err and "BrokenPipe" not in err


@pytest.mark.parametrize("monitor_id, message", [
    ("a//b", "monitor id 'a//b' must be one key chunk (no '/')"),
    ("a#b", "monitor id 'a#b' may hold only letters, digits, '_', '-' and the wildcard '*'"),
    ("a$b", "monitor id 'a$b' may hold only letters, digits, '_', '-' and the wildcard '*'"),
    ("shard_[12]", "monitor id 'shard_[12]' may hold only letters, digits, '_', '-' and the wildcard '*'"),
    ("shard_?", "monitor id 'shard_?' may hold only letters, digits, '_', '-' and the wildcard '*'"),
])
def test_status_refuses_an_id_that_is_not_one_key_chunk(capsys, monitor_id, message):
    assert main(["status", "--id", monitor_id, "--connect", endpoint(free_port())]) == 2
    assert capsys.readouterr().err == f"discern status: error: {message}\n"


def test_status_skips_an_unreadable_reply_naming_the_replier_and_prints_the_others(capsys):
    import zenoh

    from discern.monitor.config import ZenohSettings
    from discern.monitor.status import MonitorStatus

    good = MonitorStatus(monitor_id="good", vehicles_filter="*", uptime_s=1.0, budget_ms=50.0).model_dump_json()
    ep = endpoint(free_port())
    peer = zenoh.open(ZenohSettings(listen=[ep]).to_zenoh())
    try:
        for monitor_id, payload in (("other", b'{"version": 2}'), ("good", good)):
            key = f"discern/monitor/{monitor_id}/status"
            peer.declare_queryable(key, lambda q, key=key, payload=payload: q.reply(key, payload))
        code = main(["status", "--connect", ep, "--json", "--timeout", "10"])
    finally:
        peer.close()
    out, err = capsys.readouterr()
    assert code == 0 and json.loads(out)["monitor_id"] == "good"
    [warning] = err.splitlines()
    assert warning.startswith("discern status: warning: skipped an unreadable status from discern/monitor/other/status")
    assert "version: Input should be 1" in warning


def test_status_prints_every_monitor_that_answers_and_warns_of_two_with_one_id(capsys):
    import zenoh

    from discern.monitor.config import ZenohSettings
    from discern.monitor.status import MonitorStatus

    ep, other = endpoint(free_port()), endpoint(free_port())
    first = zenoh.open(ZenohSettings(listen=[ep]).to_zenoh())
    second = zenoh.open(ZenohSettings(listen=[other]).to_zenoh())
    key = "discern/monitor/dup/status"
    try:
        for peer, uptime, vehicles in ((first, 1.0, "car_$*"), (second, 2.0, "not_a chunk")):  # shards (one of another make), one id
            payload = MonitorStatus(monitor_id="dup", vehicles_filter=vehicles, uptime_s=uptime,
                                    budget_ms=50.0).model_dump_json()
            peer.declare_queryable(key, lambda q, payload=payload: q.reply(key, payload))
        code = main(["status", "--connect", ep, "--connect", other, "--id", "dup", "--timeout", "10"])
    finally:
        second.close()
        first.close()
    out, err = capsys.readouterr()
    assert code == 0 and sorted(line.split(", up ")[1][:3] for line in out.splitlines() if line.startswith("monitor dup")) == ["1 s", "2 s"]
    assert err.strip() == "discern status: warning: more than one monitor answers as dup: give each its own --id"


def test_serve_names_a_decision_worker_that_cannot_start_not_zenoh(capsys):
    import multiprocessing.resource_tracker
    import multiprocessing.spawn

    multiprocessing.resource_tracker.ensure_running()  # with the real interpreter: it is no decision worker
    python = multiprocessing.spawn.get_executable()
    multiprocessing.spawn.set_executable("/bin/false")  # a worker whose interpreter exits at once
    try:
        code = main(["serve", "--listen", endpoint(free_port()), "--no-log"])
    finally:
        multiprocessing.spawn.set_executable(python)
    [line] = capsys.readouterr().err.splitlines()
    assert code == 2 and line == "discern serve: error: decision worker exited at start (exit code 1)"


@pytest.mark.parametrize("command, arguments, message", [
    ("serve", ["--listen", "tcp/127.0.0.1:99999"], "zenoh could not open the session (--listen tcp/127.0.0.1:99999): invalid port value"),
    ("router", ["--listen", "foo/127.0.0.1:7447"], "zenoh could not open the session (--listen foo/127.0.0.1:7447): Unicast not supported for foo protocol"),
])
def test_an_endpoint_zenoh_refuses_is_named_with_its_flag(capsys, command, arguments, message):
    assert main([command, *arguments]) == 2
    [line] = capsys.readouterr().err.splitlines()
    assert line == f"discern {command}: error: {message}"


@pytest.mark.parametrize("arguments, message", [
    (["--rate", "0"], "--rate must be a finite number of frames per second above 0, got 0"),
    (["--rate", "-2"], "--rate must be a finite number of frames per second above 0, got -2"),
    (["--rate", "inf"], "--rate must be a finite number of frames per second above 0, got inf"),
    (["--frames", "0"], "--frames must be at least 1, got 0"),
    (["--vehicle", "bad id"], "vehicle 'bad id' must match [A-Za-z0-9_-]{1,128}"),
    (["--connect", "nonsense"], "bad zenoh endpoint 'nonsense': Endpoints must be of the form <protocol>/<address>"),
    (["--connect", "foo/bar:1"], "cannot connect to foo/bar:1: Unicast not supported for foo protocol"),
    (["--connect", "tcp/127.0.0.1:notaport"], "cannot connect to tcp/127.0.0.1:notaport: invalid port 'notaport'"),
])
def test_planner_example_refuses_bad_arguments_in_one_line(capsys, arguments, message):
    assert main(["planner-example", "--frames", "1", *arguments]) == 2
    [line] = capsys.readouterr().err.splitlines()
    assert line.startswith(f"discern planner-example: error: {message}") and ".rs:" not in line


def test_check_names_the_vehicle_of_a_proposal_file(tmp_path, capsys):
    data = {"version": 1, "vehicle": "car_7", "action": "cruise", "scene": good_dict()}
    assert main(["check", write(tmp_path, data), "--explain", "json"]) == 0
    assert json.loads(capsys.readouterr().out)["vehicle"] == "car_7"


def test_a_rule_whose_arithmetic_clingo_leaves_undefined_is_explained_not_raised(tmp_path, capsys):
    import shutil

    rules = tmp_path / "rules"
    shutil.copytree(ROOT / "rules" / "catalog", rules)
    with open(rules / "40_lane_change.lp", "a") as f:
        f.write("\n%! rule test.arith\n%! says Never.\n%! source test\nforbidden(cruise) :- ego_speed(S), X = S/0, X < 1.\n")
    empty = {"frame_id": 1, "ego": {"speed": 12.0, "lane": 1}, "speed_limit": 13.0, "lanes": [{"kind": "current", "id": 1}]}
    assert main(["check", write(tmp_path, empty), "--proposed", "cruise", "--rules", str(rules), "--explain", "full"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("approve cruise")
    assert "rule test.arith needs that X = (S/0) can be evaluated (a division by zero), which is false" in out


@pytest.mark.parametrize("files, message", [
    ({}, "has no *.lp files: no driving rules to load"),
    ({"notes.txt": "not rules"}, "has no *.lp files: no driving rules to load"),
    ({"empty.lp": "% nothing here\n"}, "defines no driving rules (no `%! rule` other than def.* and ent.*)"),
    ({"defs.lp": "%! rule def.only\n%! says A definition.\n%! source test\nthing(a).\n"},
     "defines no driving rules (no `%! rule` other than def.* and ent.*)"),
])
@pytest.mark.parametrize("flag", ["--rules", "--add-rules"])
def test_a_rules_directory_without_driving_rules_is_refused(tmp_path, capsys, files, message, flag):
    rules = tmp_path / "emptyrules"
    rules.mkdir()
    for name, text in files.items():
        (rules / name).write_text(text)
    assert main(["check", write(tmp_path, good_dict()), "--proposed", "cruise", flag, str(rules)]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err == f"discern check: error: rules directory {rules} {message}\n"


def test_a_rules_directory_not_made_yet_is_named_missing(tmp_path, capsys):
    missing = tmp_path / "my_rules"
    assert main(["check", write(tmp_path, good_dict()), "--proposed", "cruise", "--add-rules", str(missing)]) == 2
    assert capsys.readouterr().err == f"discern check: error: rules directory {missing} does not exist\n"


@pytest.mark.parametrize("command, target, message", [
    (["check", "{good}", "--proposed", "cruise", "--out", "{target}"], "missing/x.txt", "cannot write: No such file or directory"),
    (["check", "{good}", "--proposed", "cruise", "--out", "{target}"], "", "cannot write: Is a directory"),
    (["schema", "--out", "{target}"], "scene.json", "not a directory (the schemas are written into one)"),
    (["schema", "--out", "{target}"], "scene.json/sub", "cannot write the schemas: Not a directory"),
    (["demo", "--out", "{target}"], "scene.json", "not a directory"),
    (["demo", "--out", "{target}"], "scene.json/sub", "cannot create: Not a directory"),
])
def test_an_out_path_that_cannot_be_written_is_one_error_line(tmp_path, capsys, command, target, message):
    good = write(tmp_path, good_dict())
    path = tmp_path / target
    assert main([a.format(good=good, target=path) for a in command]) == 2
    assert capsys.readouterr().err == f"discern {command[0]}: error: --out {path}: {message}\n"


@pytest.mark.parametrize("value", ["-1", "0", "1023"])
def test_check_refuses_a_payload_limit_the_monitor_refuses(tmp_path, capsys, value):
    """`check --max-payload-bytes -1` was taken, and refused every file as larger than -1 bytes."""
    assert main(["check", write(tmp_path, good_dict()), "--proposed", "cruise", "--max-payload-bytes", value]) == 2
    assert capsys.readouterr().err == f"discern check: error: --max-payload-bytes must be at least 1024, got {value}\n"


def test_demo_refuses_no_episodes_before_running_anything(tmp_path, capsys, monkeypatch):
    from discern.monitor import demo

    monkeypatch.setattr(demo, "paper", lambda *a: pytest.fail("the demo ran before refusing --episodes 0"))
    assert main(["demo", "--episodes", "0", "--out", str(tmp_path / "out")]) == 2
    assert capsys.readouterr().err == "discern demo: error: --episodes must be at least 1, got 0\n"
    assert not (tmp_path / "out").exists()


def test_demo_refuses_a_kitti_folder_named_on_purpose_that_is_not_there(tmp_path, capsys, monkeypatch):
    """Only the default folder may be missing (a machine without the paper's frames): a typo must not skip the table."""
    from discern.monitor import demo

    monkeypatch.setattr(demo, "paper", lambda *a: pytest.fail("the demo ran before refusing --kitti"))
    missing = tmp_path / "kiti"
    assert main(["demo", "--kitti", str(missing), "--out", str(tmp_path / "out")]) == 2
    assert capsys.readouterr().err == f"discern demo: error: --kitti {missing}: not a directory of AV-CSR frame files\n"


def test_the_demo_clears_only_its_own_logs_of_an_earlier_run(tmp_path):
    """It deleted every *.mcap in out/log, where the README's `discern serve --log-dir out/log` keeps the user's."""
    from discern.monitor.demo import clear_logs, own_logs

    own = tmp_path / "discern-demo-20261128T101010-0123abcd-0000.mcap"
    users = [tmp_path / "discern-myhost-4242-20261128T101010-89abcdef-0000.mcap", tmp_path / "drive.mcap"]
    for path in (own, *users):
        path.write_bytes(b"")
    assert own_logs(tmp_path) == [own]
    clear_logs(tmp_path)
    assert sorted(tmp_path.iterdir()) == sorted(users)


def test_check_says_a_json_file_nested_too_deeply_is_no_scene(tmp_path, capsys):
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000)
    assert main(["check", str(deep), "--proposed", "cruise"]) == 2
    [line] = capsys.readouterr().err.splitlines()
    assert line == f"discern check: error: {deep}: JSON nested too deeply to be a scene"


def test_check_names_a_number_of_thousands_of_digits_without_a_traceback(tmp_path, capsys):
    path = write(tmp_path, json.dumps(good_dict())[:-1] + ', "frame_id": 1' + "0" * 5000 + "}")
    assert main(["check", path, "--proposed", "cruise"]) == 2
    [line] = capsys.readouterr().err.splitlines()
    assert line == f"discern check: error: {path}: a number in the JSON has too many digits to be a scene's"


def test_scenarios_run_with_own_rules_loads_them_once_for_all_files(tmp_path, monkeypatch):
    import shutil

    from discern.monitor import cli

    rules = tmp_path / "rules"
    shutil.copytree(Path(__file__).parent.parent / "rules" / "catalog", rules)
    loads = []
    real = cli.load_driving_rules
    monkeypatch.setattr(cli, "load_driving_rules", lambda *a, **k: loads.append(a) or real(*a, **k))
    files = sorted((Path(__file__).parent.parent / "scenarios" / "rules").glob("*.json"))[:3]
    assert main(["scenarios", "run", *map(str, files), "--rules", str(rules)]) == 0
    assert len(loads) == 1


@pytest.mark.parametrize("change, field", [
    (lambda d: d["ego"].update(speed="25"), "ego.speed"),
    (lambda d: d.update(frame_id=True), "frame_id"),
])
def test_check_reads_a_scene_file_as_the_schema_and_the_wire_do(tmp_path, capsys, change, field):
    data = good_dict()
    change(data)
    assert main(["check", write(tmp_path, data), "--proposed", "cruise"]) == 2
    assert field in capsys.readouterr().err


@pytest.mark.parametrize("timeout", ["0", "1e20", "nan"])
def test_status_refuses_a_timeout_it_cannot_wait_in_one_line(capsys, timeout):
    assert main(["status", "--timeout", timeout]) == 2
    [line] = capsys.readouterr().err.splitlines()
    assert line.startswith("discern status: error: --timeout must be a finite number above 0 s and at most")


def test_the_readmes_example_tree_is_what_check_prints_for_the_shipped_example_scene(capsys):
    """The README showed a tree no file in the repository gave; the example scene now gives it, line for line."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    shown = readme.split("```\n", 2)[1].splitlines()
    assert main(["check", str(ROOT / "docs" / "examples" / "scene.json"), "--proposed", "change_lane_left"]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert shown[-1].strip() == "..." and printed[:len(shown) - 1] == shown[:-1]


def test_the_example_proposal_is_judged_as_its_own_action_or_as_the_one_given_instead(capsys):
    proposal = str(ROOT / "docs" / "examples" / "proposal.json")
    assert main(["check", proposal]) == 0
    assert capsys.readouterr().out.startswith("override change_lane_left with brake")
    assert main(["check", proposal, "--proposed", "brake"]) == 0
    assert capsys.readouterr().out.startswith("approve brake")


def test_a_broken_frame_file_among_good_ones_is_named_and_the_others_still_make_the_table(tmp_path, capsys, avcsr_dir):
    """One bad .pl in a folder once stopped the whole table: no row for the good files."""
    good = sorted(avcsr_dir.glob("*.pl"))[0]
    (tmp_path / good.name).write_text(good.read_text())
    (tmp_path / "broken.pl").write_text(good.read_text().replace("car,", "motorbike,", 1))
    assert main(["scenarios", "run", str(tmp_path), "--repeats", "1"]) == 2
    captured = capsys.readouterr()
    assert good.stem in captured.out and "1 of 2 AV-CSR files not read" in captured.out
    assert "broken.pl:" in captured.err and "class: unknown value 'motorbike'" in captured.err


def test_a_scenario_frame_that_raises_fails_with_a_message_and_a_nonzero_exit(tmp_path, capsys, monkeypatch):
    """A frame the engine could not judge printed a traceback and left the run's exit status 0."""
    from discern.rules.engine import Reasoner

    def boom(self, scene, proposed, history=(), **kw):
        raise OverflowError("cannot convert float infinity to integer")

    monkeypatch.setattr(Reasoner, "decide", boom)
    scenario = ROOT / "scenarios" / "rules" / "acc.cut_in.json"
    assert main(["scenarios", "run", str(scenario)]) == 1
    out = capsys.readouterr().out
    assert "FAIL" in out and "deciding the frame raised OverflowError: cannot convert float infinity to integer" in out
    assert "Traceback" not in out and "0 passed" in out


def test_check_names_the_first_five_problems_of_a_file_and_counts_the_rest_as_the_monitor_does(tmp_path, capsys):
    data = {**good_dict(), **{f"unknown_{i}": i for i in range(20_000)}}
    assert main(["check", write(tmp_path, data), "--proposed", "cruise"]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 7 and lines[1].startswith("unknown_0: ") and lines[-1] == "... and 19995 more"


def test_check_into_a_full_disk_is_one_error_line_and_a_nonzero_exit():
    with open("/dev/full", "w") as full:
        result = subprocess.run([sys.executable, "-m", "discern.monitor.cli", "check",
                                 str(ROOT / "docs" / "examples" / "scene.json"), "--proposed", "brake"],
                                stdout=full, stderr=subprocess.PIPE, text=True, timeout=60)
    assert result.returncode == 2
    assert result.stderr == "discern check: error: cannot write the output: No space left on device\n"


def test_check_refuses_a_file_past_the_monitors_payload_limit_without_reading_it_all(tmp_path, capsys):
    assert main(["check", "/dev/zero", "--proposed", "brake"]) == 2
    assert capsys.readouterr().err == ("discern check: error: /dev/zero: larger than 1048576 bytes, the monitor's limit "
                                       "for a proposal (--max-payload-bytes)\n")
    path = write(tmp_path, json.dumps(good_dict()) + " " * 2000)
    assert main(["check", path, "--proposed", "brake", "--max-payload-bytes", "1024"]) == 2
    assert "larger than 1024 bytes" in capsys.readouterr().err


def test_check_refuses_a_scene_note_with_a_terminal_escape_or_past_its_length_instead_of_printing_it(tmp_path, capsys):
    for note, problem in (("\x1b]0;owned\x07", "String should match pattern"),
                          ("x" * 1001, "String should have at most 1000 characters")):
        assert main(["check", write(tmp_path, good_dict() | {"notes": [note]}), "--proposed", "cruise"]) == 2
        captured = capsys.readouterr()
        assert f"notes.0: {problem}" in captured.err and "\x1b" not in captured.err + captured.out


@pytest.mark.parametrize("command", [
    ["catalog", "--rules", "{rules}"],
    ["check", "{good}", "--proposed", "accelerate", "--rules", "{rules}"],
])
def test_a_misspelt_predicate_in_a_rules_directory_is_warned_of_on_stderr_naming_its_line_and_rule(
        tmp_path, capsys, command):
    import shutil

    rules = tmp_path / "rules"
    shutil.copytree(ROOT / "rules" / "catalog", rules)
    (rules / "35_trucks.lp").write_text(
        "%! rule acc.truck_ahead\n%! says Not behind a truck.\n%! source review\n"
        "forbidden(accelerate) :- in_ego_lane(O), object(O, C), large_vehicles(C).\n")
    argv = [a.format(rules=rules, good=write(tmp_path, good_dict())) for a in command]
    assert main(argv) == 0
    out, err = capsys.readouterr()
    assert out and err == (f"discern {argv[0]}: warning: {rules / '35_trucks.lp'}:4: acc.truck_ahead: nothing gives large_vehicles/1: "
                           "no catalog fact, rule or frame fact, and no '%! pred' declares it"
                           " (did you mean emergency_vehicle/1?)\n")


@pytest.mark.parametrize("jurisdiction", ["us", "uk"])
def test_the_shipped_rules_load_without_a_warning(capsys, jurisdiction):
    assert main(["catalog", "--jurisdiction", jurisdiction]) == 0
    assert capsys.readouterr().err == ""
    assert main(["catalog", "--jurisdiction", jurisdiction, "--rules", str(ROOT / "rules" / "catalog")]) == 0
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize("argv, command, unknown", [
    (["planner-example", "--budget-ms", "5"], "planner-example", "--budget-ms 5"),  # serve's flag, to the planner
    (["scenarios", "run", "scenarios", "--bogus"], "scenarios run", "--bogus"),
    (["check", "x.json", "--proposed", "cruise", "--bogus"], "check", "--bogus"),
])
def test_a_flag_a_subcommand_does_not_know_is_refused_with_its_usage_and_name(capsys, argv, command, unknown):
    with pytest.raises(SystemExit) as done:
        main(argv)
    err = capsys.readouterr().err
    assert done.value.code == 2 and err.startswith(f"usage: discern {command} ")
    assert err.endswith(f"discern {command}: error: unrecognized arguments: {unknown}\n")


def test_a_refused_value_is_quoted_as_the_json_the_sender_wrote(tmp_path, capsys):
    assert main(["check", write(tmp_path, {"version": True, "action": None, "scene": good_dict()})]) == 2
    err = capsys.readouterr().err
    assert "version: Input should be 1 (got true)" in err and "action: unknown value null (expected one of" in err
