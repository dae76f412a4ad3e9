"""`discern audit --replay`: every logged frame decided again, with the shipped rules or an edited copy."""

from __future__ import annotations

import csv
import gc
import shutil
import json
from pathlib import Path

import pytest
from mcap.reader import make_reader

from discern.monitor.audit import replay as replay_module
from discern.monitor.audit.aggregate import Aggregates, audit_logs
from discern.monitor.audit.frames import PENDING_PER_VEHICLE, plan_tasks
from discern.monitor.audit.replay import ReplayCatalog, replay_logs
from discern.monitor.audit.timefmt import iso
from discern.monitor.client import Monitor
from discern.monitor.config import LogSettings
from discern.monitor.log import log_metadata
from discern.monitor.log import writer as writer_module
from discern.monitor.log.writer import McapLogWriter
from discern.rules.catalog import catalog_digest, catalog_dirs, load_catalog
from discern.rules.code_digest import reasoning_code_digest
from discern.rules.engine import jurisdiction_pack
from tests.audit_logs import (
    CLEAR_FRAMES,
    FLEET_A_FRAMES,
    MEMORY_LOST,
    MEMORY_SEEN,
    PEDESTRIAN_FRAMES,
    SHADOW_FRAMES,
    SLOW_FRAMES,
    audit,
    flashing,
    monitor_logs,
    rewrite,
    serve_log,
    tolerant_rules,
    write_log,
)
from tests.scenes import scene


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    return monitor_logs(tmp_path_factory)


@pytest.fixture(scope="module")
def tolerant(tmp_path_factory) -> Path:
    return tolerant_rules(tmp_path_factory.mktemp("rules"))


def replay(capsys, tmp_path, *args: str) -> tuple[int, dict, str]:
    out = tmp_path / "replay.json"
    code, text, err = audit(capsys, "--replay", *args, "--json", str(out))
    assert "Traceback" not in err
    return code, json.loads(out.read_text()), text


def test_replay_with_the_shipped_rules_changes_no_decision(capsys, tmp_path, logs):
    files = [str(logs[k]) for k in ("fleet", "shadow", "slow", "memory")]
    code, doc, text = replay(capsys, tmp_path, *files, "--workers", "1")
    assert code == 0
    assert "no decision would change" in text
    assert (
        doc["frames"] == FLEET_A_FRAMES + PEDESTRIAN_FRAMES + CLEAR_FRAMES + SHADOW_FRAMES + MEMORY_SEEN + MEMORY_LOST
    )
    assert doc["changes"] == [] and doc["decided_in_full"] == 0
    # not decided by the rules: the deadline fail-safes and the malformed payload (which has no proposal logged)
    assert doc["skipped_failsafe"] + doc["skipped_refused"] == SLOW_FRAMES + 1 and doc["skipped_refused"] >= 1
    assert doc["solved"] + doc["reused"] == doc["frames"]


def test_replay_with_an_edited_rule_reports_each_changed_decision_side_by_side(capsys, tmp_path, logs, tolerant):
    code, doc, text = replay(
        capsys, tmp_path, str(logs["fleet"]), str(logs["shadow"]), "--rules", str(tolerant), "--workers", "1"
    )
    assert code == 1  # like diff: decisions changed
    changes = doc["changes"]
    assert len(changes) == FLEET_A_FRAMES // 2 + SHADOW_FRAMES
    assert {(c["vehicle"], c["recorded_decision"], c["replayed_decision"]) for c in changes} == {
        ("car_a", "override", "approve"),
        ("car_s", "veto", "approve"),
    }
    first = changes[0]
    assert first["proposed"] == "accelerate" and first["recorded_rules"] == "acc.at_limit"
    assert first["recorded_justification"] == "override accelerate with cruise: accelerate is forbidden by acc.at_limit"
    assert first["replayed_justification"].startswith("approve accelerate: permitted")
    assert first["replayed_verdict"]["justification"]["tree"], "a changed decision carries its full justification tree"
    assert first["recorded_verdict"]["justification"]["tree"]
    assert doc["transitions"] == {
        "accelerate: override cruise -> approve accelerate": FLEET_A_FRAMES // 2,
        "accelerate: veto accelerate -> approve accelerate": SHADOW_FRAMES,
    }
    assert f"{len(changes)} decisions would change" in text
    assert "    recorded: override cruise [acc.at_limit]  override accelerate with cruise" in text
    assert "    replayed: approve accelerate [dec.permitted]  approve accelerate: permitted" in text


def test_replay_with_rules_of_ones_own_beside_the_catalog_reports_what_they_change(capsys, tmp_path, logs):
    """As `discern check --add-rules`: the shipped rules still judge, and the added one changes what it forbids."""
    mine = tmp_path / "my_rules"
    mine.mkdir()
    (mine / "mine.lp").write_text("%! rule test.no_cruise\n%! says Never cruise.\n%! source test\n"
                                  "forbidden(cruise) :- ego_speed(_).\n")
    code, doc, _ = replay(capsys, tmp_path, str(logs["fleet"]), "--add-rules", str(mine), "--workers", "1")
    assert code == 1
    changes = doc["changes"]
    cruising = [c for c in changes if c["proposed"] == "cruise"]
    assert all(c["recorded_decision"] == "approve" and c["replayed_rules"] == "test.no_cruise" for c in cruising)
    assert [c["vehicle"] for c in cruising].count("car_c") == CLEAR_FRAMES
    # car_a's speeding up stays forbidden by the shipped acc.at_limit, but is no longer replaced with cruise
    speeding = [c for c in changes if c["proposed"] == "accelerate"]
    assert len(speeding) == FLEET_A_FRAMES // 2
    assert all(c["recorded_rules"] == c["replayed_rules"] == "acc.at_limit" for c in speeding)
    assert all(c["recorded_verdict"]["action"] == "cruise" != c["replayed_verdict"]["action"] for c in speeding)


def test_the_replays_csv_gives_each_changes_log_time_in_nanoseconds_as_the_audits_does(
    capsys, tmp_path, logs, tolerant
):
    out = tmp_path / "replay.csv"
    code, doc, _ = replay(capsys, tmp_path, str(logs["shadow"]), "--rules", str(tolerant), "--csv", str(out),
                          "--workers", "1")
    assert code == 1
    rows = list(csv.DictReader(out.open()))
    assert [int(r["log_time_ns"]) for r in rows] == [c["log_time_ns"] for c in doc["changes"]]
    assert all(iso(int(r["log_time_ns"])) == r["time"] for r in rows) and len(rows) == SHADOW_FRAMES


def test_a_quiet_replay_leaves_out_each_change_and_keeps_the_changes_by_transition(capsys, tmp_path, logs, tolerant):
    args = (str(logs["fleet"]), "--rules", str(tolerant), "--workers", "1")
    _, _, full = replay(capsys, tmp_path, *args)
    code, _, quiet = replay(capsys, tmp_path, *args, "-q")
    assert code == 1
    assert "    recorded: " in full and "    recorded: " not in quiet
    by_transition = "Changes by transition:\n" + full.split("Changes by transition:\n")[1]
    assert quiet.endswith(by_transition) and "override cruise -> approve accelerate" in by_transition
    assert f"{FLEET_A_FRAMES // 2} decisions would change" in quiet


def test_replay_rebuilds_the_history_the_monitor_decided_with(capsys, tmp_path, logs):
    """car_m keeps braking for a pedestrian it lost: only the history window explains those overrides."""
    listing = tmp_path / "memory.json"
    audit(capsys, str(logs["memory"]), "--json", str(listing), "--workers", "1")
    remembered = [d for d in json.loads(listing.read_text())["disagreements"] if d["frame_id"] >= MEMORY_SEEN]
    assert remembered and all(any(r.startswith("san.") for r in d["rules"]) for d in remembered)

    code, same, _ = replay(capsys, tmp_path, str(logs["memory"]), "--workers", "1")
    assert code == 0 and same["changes"] == []
    # the same frames with no history, a window no monitor runs with (nor the CLI's --window takes): the pedestrian is
    # forgotten at once
    forgetful = replay_logs([str(logs["memory"])], window_s=0.01).tally.changes
    assert {c.frame_id for c in forgetful} == {d["frame_id"] for d in remembered}
    assert {(c.recorded["decision"], c.replayed["decision"]) for c in forgetful} == {("override", "approve")}


def test_a_replay_names_a_history_window_other_than_the_monitors_default(capsys, tmp_path, logs):
    """--window 3 changed what was decided, but the headline named the rules and parameters only."""
    code, doc, text = replay(capsys, tmp_path, str(logs["memory"]), "--window", "3", "--workers", "1", "-q")
    assert doc["window_s"] == 3.0 and " and a 3 s history window in " in text
    code, doc, text = replay(capsys, tmp_path, str(logs["memory"]), "--workers", "1", "-q")
    assert doc["window_s"] == 2.0 and "history window" not in text


def test_a_filtered_replay_says_which_frames_it_replayed(capsys, tmp_path, logs, tolerant):
    code, doc, text = replay(
        capsys, tmp_path, str(logs["fleet"]), "--vehicle", "car_a", "--rules", str(tolerant), "--workers", "1", "-q"
    )
    assert code == 1 and doc["frames"] == FLEET_A_FRAMES
    assert doc["filters"] == ["vehicle car_a"] and "filters: vehicle car_a" in text


def test_identical_frames_are_decided_once(capsys, tmp_path, logs):
    _, doc, text = replay(capsys, tmp_path, str(logs["shadow"]), "--workers", "1")
    # car_s proposes the same acceleration in the same scene every 0.1 s; once its 2 s history window is full,
    # frame after frame is identical but for its id and time, and is answered from the first one's decision
    assert doc["frames"] == SHADOW_FRAMES and doc["solved"] + doc["reused"] == SHADOW_FRAMES
    assert doc["solved"] <= 22 and doc["reused"] >= SHADOW_FRAMES - 22
    assert f"{doc['solved']} solved, {doc['reused']} identical to a frame solved before" in text


def test_a_frame_reused_while_the_cache_overflows_is_still_compared(monkeypatch, tmp_path, reasoner):
    """A parked car repeats one frame while a moving one fills the cache with new ones, more than it holds:
    the repeated frame, counted as reused, must not be evicted by its own chunk's new frames before it is compared."""
    start = 1_790_000_000 * 10**9
    frames = []
    for f in range(150):
        t = start + f * 10**8
        frames.append(("parked", scene(frame=f, timestamp=f * 0.1, speed=0.0), "cruise", t, t + 10**6))
        frames.append(("moving", scene(frame=f, timestamp=f * 0.1, speed=5.0 + f * 0.01), "cruise", t + 1000,
                       t + 1000 + 10**6))
    log = str(write_log(tmp_path / "log", frames, reasoner))
    roomy = replay_logs([log], workers=1).tally
    assert roomy.solved > 150 and roomy.reused > 100  # the parked car's frame repeats once its window is full
    for limit in (100, 5):  # more distinct frames than a chunk holds, and fewer
        monkeypatch.setattr(replay_module, "CACHE_LIMIT", limit)
        tally = replay_logs([log], workers=1).tally
        assert (tally.frames, tally.solved + tally.reused, tally.changes) == (300, 300, [])
        if limit > replay_module.BATCH:  # reused chunk after chunk, the parked car's frame is never evicted
            assert (tally.solved, tally.reused) == (roomy.solved, roomy.reused)


def test_a_replay_in_the_callers_process_leaves_its_heap_unfrozen(logs):
    """The workers freeze what a job leaves (their caches, never rescanned); the caller's objects must stay
    collectable in a program that goes on after the replay."""
    frozen = gc.get_freeze_count()
    replay_logs([str(logs["shadow"])], workers=1)
    assert gc.get_freeze_count() == frozen and gc.isenabled()


def test_worker_processes_find_the_same_changes(capsys, tmp_path, logs, tolerant):
    args = [str(logs["fleet"]), "--rules", str(tolerant)]
    _, one, _ = replay(capsys, tmp_path, *args, "--workers", "1")
    _, two, _ = replay(capsys, tmp_path, *args, "--workers", "2")
    assert two["workers"] == 2
    assert two["changes"] == one["changes"] and two["frames"] == one["frames"]
    for count in ("skipped_failsafe", "skipped_refused", "unanswered_proposals"):  # each vehicle counted once
        assert two[count] == one[count]


@pytest.fixture(scope="module")
def rotated(tmp_path_factory, logs) -> list[Path]:
    """The fleet's log rotated twice, as a monitor with a small size limit would have written it."""
    directory = tmp_path_factory.mktemp("rotated")
    with open(logs["fleet"], "rb") as f:
        count = sum(1 for _ in make_reader(f).iter_messages(log_time_order=False))
    parts = [directory / f"discern-m1-20260101T0{i}0000-000{i}.mcap" for i in range(3)]
    rewrite(logs["fleet"], parts, splits=(count // 3, 2 * count // 3))
    return parts


def test_a_monitors_rotated_files_are_cut_into_runs_each_led_in_by_the_file_before(rotated, tmp_path):
    other = tmp_path / "discern-m2-20260101T000000-0000.mcap"  # another monitor's file: never a lead-in
    other.write_bytes(rotated[0].read_bytes())
    tasks = plan_tasks([str(p) for p in rotated] + [str(other)], parts=2)
    mine = [t for t in tasks if t.paths[0] != str(other)]
    assert [p for t in mine for p in t.paths] == [str(p) for p in rotated] and len(mine) == 2
    assert mine[0].lead_in == () and mine[1].lead_in == mine[0].paths  # the log is short: all of it leads in
    assert [t for t in tasks if t not in mine] == [type(tasks[0])((str(other),), ())]
    assert len(plan_tasks([str(p) for p in rotated], parts=1)) == 1


def test_a_rotated_file_replayed_alone_is_led_in_by_the_files_before_it_in_its_directory(logs, tmp_path):
    """car_m's overrides rest on a pedestrian seen in frames the earlier file holds: replayed alone, the later file
    still gets that history from the file its monitor run wrote before it, so nothing reads as changed."""
    with open(logs["memory"], "rb") as f:
        count = sum(1 for _ in make_reader(f).iter_messages(log_time_order=False))
    parts = [tmp_path / f"discern-m1-20260101T00000{i}-0a1b2c3d-000{i}.mcap" for i in range(2)]
    rewrite(logs["memory"], parts, splits=(count // 2,))
    [task] = plan_tasks([str(parts[1])])
    assert task.lead_in == (str(parts[0]),)
    catalog = ReplayCatalog.of(catalog_dirs())
    alone = replay_logs([str(parts[1])], catalog, workers=1).tally
    assert alone.frames > 0 and alone.changes == []


def test_a_rotated_log_replays_as_the_whole_one_in_one_process_or_split_by_vehicle(logs, rotated, tolerant):
    catalog = ReplayCatalog.of([str(tolerant)])
    whole = replay_logs([str(logs["fleet"])], catalog, workers=1).tally
    assert whole.changes
    for workers in (1, 2, 3):
        t = replay_logs([str(p) for p in rotated], catalog, workers=workers).tally
        assert (t.frames, t.unanswered, t.skipped_refused) == (whole.frames, 0, whole.skipped_refused)
        assert [(c.vehicle, c.frame_id, c.transition) for c in t.changes] == [
            (c.vehicle, c.frame_id, c.transition) for c in whole.changes
        ]
        assert [f.path for f in t.recovery] == rotated  # every file once, its shards' records added up
        assert sum(f.records for f in t.recovery) == whole.recovery[0].records


def test_rotated_files_given_out_of_order_are_read_in_the_order_the_monitor_wrote_them(logs, rotated, tolerant):
    backwards = [str(p) for p in reversed(rotated)]
    in_order = audit_logs([str(p) for p in rotated], workers=1)
    tally = audit_logs(backwards, workers=1)
    assert [f.path for f in tally.recovery] == rotated
    assert (tally.frames, tally.unanswered) == (in_order.frames, 0)
    assert tally.odometer.distance_mm == in_order.odometer.distance_mm
    assert Aggregates.of(tally).per_scenario == Aggregates.of(in_order).per_scenario
    catalog = ReplayCatalog.of([str(tolerant)])
    whole = replay_logs([str(logs["fleet"])], catalog, workers=1).tally
    t = replay_logs(backwards, catalog, workers=2).tally
    assert [(c.vehicle, c.frame_id, c.transition) for c in t.changes] == [
        (c.vehicle, c.frame_id, c.transition) for c in whole.changes
    ]


def test_a_runs_files_stamped_by_a_clock_set_back_are_read_by_their_index(logs, rotated, tmp_path):
    directory = tmp_path / "clock"
    directory.mkdir()
    for i, part in enumerate(rotated):  # the clock went back an hour at each rotation: names sort backwards
        (directory / f"discern-m1-20260101T0{2 - i}0000-0a1b2c3d-000{i}.mcap").write_bytes(part.read_bytes())
    [task] = plan_tasks([str(directory)], parts=1)
    assert [Path(p).name[-9:] for p in task.paths] == ["0000.mcap", "0001.mcap", "0002.mcap"]
    whole = audit_logs([str(logs["fleet"])], workers=1)
    for workers in (1, 2):
        tally = audit_logs([str(directory)], workers=workers)
        assert (tally.frames, tally.unanswered) == (whole.frames, 0)
        assert tally.odometer.distance_mm == whole.odometer.distance_mm


@pytest.mark.parametrize("recorded", ["run and index", "run only"])
def test_a_runs_files_renamed_are_read_as_the_sequence_their_metadata_names(capsys, tmp_path, logs, recorded):
    """An uploader renames a run's files (drive_partN.mcap; here the first sorts last). car_m's overrides rest on a
    pedestrian seen in frames the first file holds: read as two unrelated files, the second replays as decisions
    changed that are not. The run and index in their metadata say what they are; without the index (files written
    before 2026-11-28), the time of their first message orders them."""
    with open(logs["memory"], "rb") as f:
        count = sum(1 for _ in make_reader(f).iter_messages(log_time_order=False))
    written = log_metadata(logs["memory"])
    directory = tmp_path / "upload"
    directory.mkdir()
    parts = [directory / "drive_part2.mcap", directory / "drive_part1.mcap"]
    metadata = [{**{k: written[k] for k in ("monitor_id", "schema_version", "run")},
                 **({"index": str(i)} if recorded == "run and index" else {})} for i in range(len(parts))]
    rewrite(logs["memory"], parts, splits=(count // 2,), metadata=metadata)
    apart = tmp_path / "apart"
    apart.mkdir()
    shutil.copy(parts[1], apart / parts[1].name)
    code, alone, _ = replay(capsys, tmp_path, str(apart), "--workers", "1")
    assert code == 1 and alone["changes"]  # without the file before it, its history is lost
    _, whole, _ = replay(capsys, tmp_path, str(logs["memory"]), "--workers", "1")
    for workers in ("1", "2"):
        code, doc, _ = replay(capsys, tmp_path, str(directory), "--workers", workers)
        assert code == 0 and doc["changes"] == [] and doc["frames"] == whole["frames"]
        assert [f["path"] for f in doc["files"]] == [str(p) for p in parts]  # in the order the monitor wrote them
    assert audit_logs([str(directory)]).odometer.distance_mm == audit_logs([str(logs["memory"])]).odometer.distance_mm
    # given alone, the later file is led in by the file before it in its directory, where its index is known
    [task] = plan_tasks([str(parts[1])])
    assert task.lead_in == ((str(parts[0]),) if recorded == "run and index" else ())


def test_a_runs_files_spelt_relative_and_absolute_are_read_as_one_sequence(logs, rotated, monkeypatch, tolerant):
    monkeypatch.chdir(rotated[0].parent.parent)
    directory = rotated[0].parent.name
    spelt = [f"{directory}/{rotated[0].name}", str(rotated[1]), f"{directory}/../{directory}/{rotated[2].name}"]
    [task] = plan_tasks(spelt, parts=1)
    assert task.paths == tuple(spelt)
    assert [t.lead_in for t in plan_tasks(spelt, parts=3)] == [(), tuple(spelt[:1]), tuple(spelt[:2])]
    whole = audit_logs([str(logs["fleet"])], workers=1)
    catalog = ReplayCatalog.of([str(tolerant)])
    replayed = replay_logs([str(logs["fleet"])], catalog, workers=1).tally
    for workers in (1, 3):
        tally = audit_logs(spelt, workers=workers)
        assert (tally.frames, tally.unanswered) == (whole.frames, 0)
        assert tally.odometer.distance_mm == whole.odometer.distance_mm
        t = replay_logs(spelt, catalog, workers=workers).tally
        assert (t.frames, t.unanswered, t.skipped_refused) == (replayed.frames, 0, replayed.skipped_refused)
        assert [(c.vehicle, c.frame_id, c.transition) for c in t.changes] == [
            (c.vehicle, c.frame_id, c.transition) for c in replayed.changes
        ]


def test_a_proposal_the_lead_in_gives_up_on_is_counted_unanswered_once(tmp_path, reasoner):
    """Verdicts lost: more proposals wait than are kept (PENDING_PER_VEHICLE). One given up on while the lead-in's
    files are read again was counted by their own task; read with a lead-in or without, the count is the same."""
    start = 1_800_000_000 * 10**9
    frames = [
        ("car_a", scene(frame=f, timestamp=f * 0.1), "cruise", start + f * 10**7,
         start + f * 10**7 + 1 if f % 3 == 0 else None)
        for f in range(600)
    ]
    log = write_log(tmp_path / "src", frames, reasoner)
    directory = tmp_path / "rotated"
    directory.mkdir()
    parts = [directory / f"discern-m1-20260101T0{i}0000-000{i}.mcap" for i in range(2)]
    rewrite(log, parts, splits=(600,))  # frames 0 to 449 first: 300 proposals left waiting, more than are kept
    assert 300 > PENDING_PER_VEHICLE
    assert [t.lead_in for t in plan_tasks([str(directory)], parts=2)] == [(), (str(parts[0]),)]
    for workers in (1, 2):
        assert audit_logs([str(directory)], workers=workers).unanswered == 400
        assert replay_logs([str(directory)], workers=workers).tally.unanswered == 400


def test_a_run_led_in_by_short_files_reads_back_far_enough_whatever_the_workers(logs, tmp_path, tolerant):
    """Files of one or two messages: a lead-in of one file would not reach the pairs and scenes before it."""
    directory = tmp_path / "short"
    directory.mkdir()
    splits = (20, 21, 50, 80, 81, 100)
    parts = [directory / f"discern-m1-20260101T0000{i:02d}-{i:04d}.mcap" for i in range(len(splits) + 1)]
    rewrite(logs["fleet"], parts, splits=splits)
    whole = audit_logs([str(logs["fleet"])], workers=1)
    catalog = ReplayCatalog.of([str(tolerant)])
    replayed = replay_logs([str(logs["fleet"])], catalog, workers=1).tally

    def listing(tally):
        return [(d.time_ns, d.vehicle, d.frame_id, d.kind) for d in tally.disagreements]

    for workers in (2, 3, 4):
        tally = audit_logs([str(directory)], workers=workers)
        assert (tally.frames, tally.unanswered, listing(tally)) == (whole.frames, 0, listing(whole))
        assert tally.odometer.distance_mm == whole.odometer.distance_mm
        assert Aggregates.of(tally).per_scenario == Aggregates.of(whole).per_scenario
        t = replay_logs([str(directory)], catalog, workers=workers).tally
        assert [(c.vehicle, c.frame_id, c.transition) for c in t.changes] == [
            (c.vehicle, c.frame_id, c.transition) for c in replayed.changes
        ]


def test_a_restarted_monitors_files_are_not_read_as_the_previous_runs_continuation(capsys, tmp_path):
    """Across a restart nothing pairs and no history carries, however long a window the replay is given."""
    directory = tmp_path / "restarts"

    def send(frame: int, lights: bool, action: str):
        def drive(endpoint: str) -> None:
            with Monitor("car_r", connect=[endpoint], timeout=10.0) as car:
                verdict = car.check(flashing(frame, lights), "cruise")
                assert not verdict.failsafe and verdict.action.value == action

        return drive

    [before] = serve_log(directory, "m1", send(1, False, "cruise"), budget_ms=1000.0)
    # a new monitor knows no earlier frame: lights seen in this one frame are an emergency vehicle on duty
    [after] = serve_log(directory, "m1", send(2, True, "pull_over"), budget_ms=1000.0)
    assert before != after and before.exists()
    tasks = plan_tasks([str(directory)], parts=2)
    assert sorted(t.paths for t in tasks) == sorted([(str(before),), (str(after),)])
    assert all(t.lead_in == () for t in tasks)
    code, doc, _ = replay(capsys, tmp_path, str(directory), "--window", "60", "--workers", "1")
    assert code == 0 and doc["changes"] == [] and doc["frames"] == 2


def test_older_logs_named_without_a_run_continue_one_another_only_within_one_process(logs, tmp_path):
    names = ["discern-m1-20260101T000000-0000.mcap", "discern-m1-20260101T000100-0001.mcap"]
    for label, pids in (("same", ("7", "7")), ("restarted", ("7", "8")), ("renumbered", None)):
        directory = tmp_path / label
        directory.mkdir()
        for name, pid in zip(names, pids or ("7", "7")):
            rewrite(logs["fleet"], [directory / name], metadata={"monitor_id": "m1", "schema_version": "1", "pid": pid})
        if pids is None:  # the same process, but the second file does not follow the first: a restart
            (directory / names[1]).rename(directory / names[1].replace("-0001", "-0000"))
        tasks = plan_tasks([str(directory)], parts=1)
        assert len(tasks) == (1 if label == "same" else 2), label


def test_deciding_every_frame_in_full_finds_the_same_changes(capsys, tmp_path, logs, tolerant):
    """The fast path trusts the logged permitted set and recommendation; deciding every frame must agree with it."""
    args = [str(logs[k]) for k in ("fleet", "shadow", "memory")] + ["--rules", str(tolerant), "--workers", "1"]
    _, fast, _ = replay(capsys, tmp_path, *args)
    _, full, _ = replay(capsys, tmp_path, *args, "--compare-rules")
    assert full["decided_in_full"] == full["solved"] > fast["decided_in_full"]
    assert full["changes"] == fast["changes"] and len(fast["changes"]) == FLEET_A_FRAMES // 2 + SHADOW_FRAMES


def test_compare_rules_finds_frames_citing_other_rules(capsys, tmp_path, logs):
    renamed = tolerant_rules(tmp_path)  # a fresh copy; then undo the tolerance and rename the rule instead
    for path in renamed.glob("*.lp"):
        text = path.read_text()
        if "%! rule acc.at_limit\n" in text:
            text = text.replace("V + D > S + 500.", "V + D > S.").replace(
                "%! rule acc.at_limit\n", "%! rule acc.not_over_limit\n"
            )
            path.write_text(text)
    args = [str(logs["fleet"]), "--rules", str(renamed), "--workers", "1"]
    code, fast, _ = replay(capsys, tmp_path, *args)
    assert code == 0 and fast["changes"] == [] and fast["rules_only_changes"] == 0
    code, full, text = replay(capsys, tmp_path, *args, "--compare-rules")
    assert code == 0 and full["changes"] == []
    assert full["rules_only_changes"] == FLEET_A_FRAMES // 2
    assert f"{FLEET_A_FRAMES // 2} frames would keep the decision but cite other rules" in text
    assert "[acc.at_limit] -> [acc.not_over_limit]" in text


def test_a_rules_directory_given_twice_is_loaded_once(capsys, tmp_path, logs, tolerant):
    code, once, _ = replay(capsys, tmp_path, str(logs["fleet"]), "--rules", str(tolerant), "--workers", "1")
    assert code == 1
    again = [str(tolerant), f"{tolerant}/", str(tolerant.parent / "." / tolerant.name)]
    code, twice, _ = replay(capsys, tmp_path, str(logs["fleet"]), *(f"--rules={d}" for d in again), "--workers", "1")
    assert code == 1
    assert twice["catalog"] == once["catalog"] and twice["catalog"][0] == str(tolerant)
    assert twice["changes"] == once["changes"]


def refused_rules(capsys, tmp_path, logs, text: str) -> tuple[Path, str]:
    """Replay with a rules directory holding one file of `text`; it must be refused: (the file, stderr)."""
    rules = tmp_path / "rules"
    rules.mkdir()
    (rules / "10_rules.lp").write_text(text)
    code, out, err = audit(capsys, "--replay", str(logs["fleet"]), "--rules", str(rules), "--workers", "1")
    assert code == 2 and out == ""
    return rules / "10_rules.lp", err


def test_a_rules_directory_without_driving_rules_is_refused_as_check_refuses_it(capsys, tmp_path, logs):
    lp, err = refused_rules(capsys, tmp_path, logs, "%! rule def.only\n%! says A definition.\n%! source test\nthing(a).\n")
    assert err == (f"discern audit: error: rules catalog: rules directory {lp.parent} defines no driving rules "
                   "(no `%! rule` other than def.* and ent.*)\n")


def test_a_rules_file_that_cannot_be_read_is_named(capsys, tmp_path, logs):
    rules = tmp_path / "rules"
    rules.mkdir()
    (rules / "zz.lp").symlink_to(tmp_path / "gone.lp")
    code, out, err = audit(capsys, "--replay", str(logs["fleet"]), "--rules", str(rules), "--workers", "1")
    assert code == 2 and out == ""
    assert err == f"discern audit: error: rules catalog: {rules / 'zz.lp'}: cannot read: No such file or directory\n"


def test_a_broken_rules_directory_is_named(capsys, tmp_path, logs):
    lp, err = refused_rules(capsys, tmp_path, logs, "%! rule x.bad\n%! says Nothing.\n%! source none\nforbidden(A) :- action(A\n")
    assert err.startswith(f"discern audit: error: rules catalog: {lp}: cannot parse: ")
    assert f"{lp}:5:1" in err and "syntax error" in err
    assert "Traceback" not in err


def test_a_replacement_rule_changed_alone_is_reported_though_permitted_and_recommended_stay(capsys, tmp_path, reasoner):
    """Holding the speed instead of a recommended acceleration changes what an override executes, nothing else."""
    start = 1_790_000_000 * 10**9
    frames = [("car_r", scene(frame=f, speed=10.0, limit=15), "change_lane_left", start + f * 10**8,
               start + f * 10**8 + 10**6) for f in range(3)]
    log = str(write_log(tmp_path / "log", frames, reasoner))
    speeding_up = tmp_path / "rules" / "catalog"
    shutil.copytree(catalog_dirs()[0], speeding_up)
    decision = speeding_up / "90_decision.lp"
    text = decision.read_text()
    assert "held_instead(accelerate) :- permitted(cruise).\n" in text
    decision.write_text(text.replace("held_instead(accelerate) :- permitted(cruise).\n",
                                     "held_instead(accelerate) :- permitted(cruise), proposed(accelerate).\n"))
    code, doc, out = replay(capsys, tmp_path, log, "--rules", str(speeding_up), "--workers", "1")
    assert code == 1 and len(doc["changes"]) == 3
    assert "change_lane_left: override cruise -> override accelerate" in out


def test_a_misspelt_rule_annotation_in_an_edited_catalog_is_refused_naming_its_file_and_line(capsys, tmp_path, logs):
    text = ("%! rule x.a\n%! says A.\n%! source s\nforbidden(accelerate) :- action(accelerate).\n"
            "%! rules x.b\n%! says B.\n%! source s\nforbidden(brake) :- action(brake).\n")
    lp, err = refused_rules(capsys, tmp_path, logs, text)
    assert err.startswith(f"discern audit: error: rules catalog: {lp}:5: not an annotation: '%! rules x.b'")
    assert "Traceback" not in err


def test_a_replay_decides_with_the_jurisdiction_and_window_the_monitor_logged(capsys, tmp_path):
    """A UK monitor's approvals near a school-zone sign are the UK pack's: replayed on the US default they read as
    rule changes. The log records the pack and the window, and the replay takes them."""
    def send(endpoint: str) -> None:
        with Monitor("car_uk", connect=[endpoint], timeout=10.0) as car:
            for i in range(5):
                school = scene(speed=12, limit=13, sign="school_zone", frame=i + 1, timestamp=(i + 1) * 0.1)
                assert car.check(school, "accelerate").decision.value == "approve"

    files = serve_log(tmp_path / "uk", "uk", send, jurisdiction="uk", window_s=1.5)
    metadata = log_metadata(files[0])
    assert (metadata["jurisdiction"], metadata["window_s"]) == ("uk", "1.5")
    assert metadata["catalog"] == load_catalog(extra_files=[jurisdiction_pack("uk")]).digest
    code, doc, _ = replay(capsys, tmp_path, str(tmp_path / "uk"), "--workers", "1")
    assert code == 0 and doc["changes"] == []
    code, doc, _ = replay(capsys, tmp_path, str(tmp_path / "uk"), "--workers", "1", "--jurisdiction", "us")
    assert code == 1 and len(doc["changes"]) == 5


def test_a_replay_of_logs_other_reasoning_code_decided_says_so(capsys, tmp_path, monkeypatch):
    """Same rules, other code (the facts a scene becomes, the window): its changes must not read as the rules'."""
    McapLogWriter(LogSettings(directory=tmp_path / "now"), "m").close()
    assert log_metadata(next((tmp_path / "now").iterdir()))["code"] == reasoning_code_digest()
    code, _, err = audit(capsys, "--replay", str(tmp_path / "now"), "-q", "--workers", "1")
    assert code == 0 and "warning" not in err
    monkeypatch.setattr(writer_module, "reasoning_code_digest", lambda: "feedc0defeedc0de")
    McapLogWriter(LogSettings(directory=tmp_path / "old"), "m").close()
    code, _, err = audit(capsys, "--replay", str(tmp_path / "old"), str(tmp_path / "now"), "-q", "--workers", "1")
    assert code == 0 and "warning: the logs were decided by reasoning code feedc0defeedc0de, not this version's" in err


def test_recorded_settings_this_version_cannot_use_are_refused_naming_the_file(capsys, tmp_path):
    for name, params in (("unknown", {"bogus": 1.0}), ("negative", {"decel": -3.0})):
        McapLogWriter(LogSettings(directory=tmp_path / name), "m", params).close()
        code, _, err = audit(capsys, "--replay", str(tmp_path / name), "-q")
        assert code == 2 and "recorded reasoning parameters this version cannot use" in err and name in err
        assert "Traceback" not in err


def test_a_replay_of_logs_another_catalog_decided_says_so_and_logs_of_two_catalogs_are_replayed_apart(capsys, tmp_path):
    """Without the catalog's digest in the log, the changes a newer catalog brought read as the edit's own."""
    McapLogWriter(LogSettings(directory=tmp_path / "old"), "m", catalog="0123456789abcdef").close()
    code, _, err = audit(capsys, "--replay", str(tmp_path / "old"), "-q", "--workers", "1")
    assert code == 0 and "warning: the logs were decided by the rules catalog 0123456789abcdef, not this version's" in err
    current = catalog_digest(extra_files=[jurisdiction_pack("us")])
    McapLogWriter(LogSettings(directory=tmp_path / "new"), "m", catalog=current).close()
    code, _, err = audit(capsys, "--replay", str(tmp_path / "new"), "-q", "--workers", "1")
    assert code == 0 and "warning" not in err
    code, _, err = audit(capsys, "--replay", str(tmp_path / "old"), str(tmp_path / "new"), "-q")
    assert code == 2 and "different settings" in err and f"catalog {current}" in err


def test_a_catalogs_digest_is_that_of_its_files_names_and_texts(tmp_path):
    copy = tmp_path / "catalog"
    shutil.copytree(catalog_dirs()[0], copy)
    pack = [jurisdiction_pack("us")]
    assert catalog_digest([copy, catalog_dirs()[1]], pack) == catalog_digest(extra_files=pack)  # wherever installed
    assert load_catalog(extra_files=pack).digest == catalog_digest(extra_files=pack)
    assert catalog_digest(extra_files=[jurisdiction_pack("uk")]) != catalog_digest(extra_files=pack)
    edited = copy / "30_speed.lp"
    edited.write_text(edited.read_text() + "\n")
    assert catalog_digest([copy, catalog_dirs()[1]], pack) != catalog_digest(extra_files=pack)


def test_a_file_without_the_writers_metadata_does_not_block_a_replay(capsys, tmp_path):
    McapLogWriter(LogSettings(directory=tmp_path), "m", {"decel": 4.0}).close()
    (tmp_path / "discern-m-20260101T000000-0000.mcap").write_bytes(b"")  # an empty file beside it
    code, _, err = audit(capsys, "--replay", str(tmp_path), "-q", "--workers", "1")
    assert code == 0 and "different settings" not in err


def test_a_rules_catalog_with_a_misspelt_predicate_is_replayed_and_warned_of(capsys, tmp_path, logs):
    rules = tmp_path / "rules"
    shutil.copytree(catalog_dirs()[0], rules)
    (rules / "35_trucks.lp").write_text(
        "%! rule acc.truck_ahead\n%! says Not behind a truck.\n%! source review\n"
        "forbidden(accelerate) :- in_ego_lane(O), object(O, C), large_vehicles(C).\n")
    code, out, err = audit(capsys, "--replay", str(logs["fleet"]), "--rules", str(rules), "--workers", "1")
    assert code == 0 and "no decision would change" in out
    assert (f"discern audit: warning: rules catalog: {rules / '35_trucks.lp'}:4: acc.truck_ahead: nothing gives "
            "large_vehicles/1: ") in err
