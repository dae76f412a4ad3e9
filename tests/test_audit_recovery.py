"""Logs that are not whole: cut by a crash, split by rotation, carrying foreign channels, empty, or not MCAP at all."""

from __future__ import annotations

import json
import logging
import shutil
from pathlib import Path

import pytest
from mcap.reader import make_reader

from discern.monitor.client import Monitor
from discern.monitor.log import log_metadata, read_log
from tests.audit_logs import audit, highway, monitor_logs, rewrite, serve_log
from tests.monitor_process import wait_until


@pytest.fixture(scope="module")
def fleet(tmp_path_factory) -> Path:
    return monitor_logs(tmp_path_factory)["fleet"]


@pytest.fixture(scope="module")
def shadow(tmp_path_factory) -> Path:
    """Another monitor's log: no copy of the fleet's."""
    return monitor_logs(tmp_path_factory)["shadow"]


def audit_json(capsys, tmp_path, *paths) -> dict:
    out = tmp_path / f"audit-{len(list(tmp_path.iterdir()))}.json"
    code, _, err = audit(capsys, *map(str, paths), "--json", str(out), "--workers", "1", "--quiet")
    assert code == 0, err
    return json.loads(out.read_text())


def test_a_file_cut_by_a_crash_is_read_up_to_its_last_complete_chunk(capsys, tmp_path, fleet):
    whole = audit_json(capsys, tmp_path, fleet)
    data = fleet.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: int(len(data) * 0.6)])
    code, out, err = audit(capsys, str(cut), "--workers", "1")
    assert code == 0, err
    assert f"{cut}: truncated, " in out and "bytes recovered" in out and "stopped: " in out
    doc = audit_json(capsys, tmp_path, cut)
    (f,) = doc["files"]
    assert f["state"] == "truncated" and 0 < f["recovered_bytes"] <= len(data) * 0.6
    assert 0 < doc["frames"] < whole["frames"]
    # what was recovered is exactly the beginning of the whole log
    n = len(doc["disagreements"])
    assert n > 0
    strip = lambda rows: [{k: v for k, v in r.items() if k != "file"} for r in rows]  # noqa: E731
    assert strip(doc["disagreements"]) == strip(whole["disagreements"][:n])


def test_a_quiet_replay_still_says_how_much_of_each_file_was_read(capsys, tmp_path, fleet):
    data = fleet.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: int(len(data) * 0.6)])
    code, out, err = audit(capsys, "--replay", str(cut), "--workers", "1", "-q")
    assert code == 0, err
    assert f"{cut}: truncated, " in out and "stopped: " in out and "no decision would change" in out


def test_replay_json_reports_recovered_files(capsys, tmp_path, fleet, shadow):
    data = shadow.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: int(len(data) * 0.6)])
    audited = audit_json(capsys, tmp_path, cut, fleet)["files"]
    assert [f["state"] for f in audited] == ["truncated", "complete"] and all(f["records"] for f in audited)
    for workers in ("1", "3"):  # with several, each reads its vehicles' share of a file: the shares add up
        out = tmp_path / f"replay-{workers}.json"
        code, _, err = audit(capsys, "--replay", str(cut), str(fleet), "--json", str(out), "--workers", workers, "-q")
        assert code == 0, err
        assert json.loads(out.read_text())["files"] == audited, workers


def test_a_pair_split_by_file_rotation_is_joined(capsys, tmp_path, fleet):
    whole = audit_json(capsys, tmp_path, fleet)
    with open(fleet, "rb") as f:
        topics = [c.topic for _, c, _ in make_reader(f).iter_messages(log_time_order=False)]
    split = next(i for i, t in enumerate(topics) if i > 20 and t.endswith("/proposal"))
    assert topics[split + 1].endswith("/verdict")
    rotated = tmp_path / "rotated"
    rotated.mkdir()
    parts = [rotated / "discern-m1-20260101T000000-0000.mcap", rotated / "discern-m1-20260101T000100-0001.mcap"]
    rewrite(fleet, parts, splits=(split,))
    doc = audit_json(capsys, tmp_path, rotated)
    assert [f["state"] for f in doc["files"]] == ["complete", "complete"]
    assert doc["frames"] == whole["frames"] and doc["unanswered_proposals"] == 0
    assert doc["per_scenario"] == whole["per_scenario"]  # every verdict found its proposal's scene
    assert doc["odometry"] == pytest.approx(whole["odometry"])


def test_proposals_without_a_logged_verdict_are_those_the_audited_files_leave_unanswered_whatever_lies_beside(
        capsys, tmp_path, fleet):
    """A file's lead-in (the run's file before it, beside it in the directory) pairs the proposal its last verdict
    answers; that proposal once cancelled one of the audited file's own, counted by no task when the lead-in
    file was not audited itself."""
    with open(fleet, "rb") as f:
        topics = [c.topic for _, c, _ in make_reader(f).iter_messages(log_time_order=False)]
    cuts = [i for i, t in enumerate(topics) if i > 10 and t.endswith("/proposal") and topics[i + 1].endswith("/verdict")]
    rotated = tmp_path / "rotated"
    rotated.mkdir()
    parts = [rotated / f"discern-m1-20260101T00000{k}-0badcafe-000{k}.mcap" for k in range(3)]
    rewrite(fleet, parts, splits=(cuts[0], cuts[len(cuts) // 2]))  # each of the first two ends on a proposal

    def unanswered(*paths) -> int:
        return audit_json(capsys, tmp_path, *paths)["unanswered_proposals"]

    assert unanswered(rotated) == 0
    assert unanswered(parts[1]) == 1  # its last proposal's verdict is in the next file, not audited
    assert unanswered(parts[0]) == 1
    assert unanswered(parts[0], parts[2]) == 1


def test_unknown_channels_are_skipped_with_a_warning(capsys, tmp_path, fleet, caplog):
    mixed = tmp_path / "mixed.mcap"
    rewrite(fleet, [mixed], foreign=True)
    with caplog.at_level(logging.WARNING):
        code, out, err = audit(capsys, str(mixed), "--workers", "1", "--quiet")
    assert code == 0, err
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert any("skipping unknown channel '/camera/front/info'" in w for w in warnings)
    assert any("skipping unknown channel '/discern/car_a/debug'" in w for w in warnings)
    assert "messages skipped (unknown channel or bad payload)" in out
    assert audit_json(capsys, tmp_path, mixed)["disagreements"] == [
        {**d, "file": str(mixed)} for d in audit_json(capsys, tmp_path, fleet)["disagreements"]
    ]


def test_an_empty_file_audits_to_nothing(capsys, tmp_path):
    empty = tmp_path / "empty.mcap"
    empty.write_bytes(b"")
    code, out, err = audit(capsys, str(empty), "--workers", "1")
    assert code == 0 and err == ""
    assert f"{empty}: empty, 0 records" in out
    assert "frames: 0 " in out and "No disagreements." in out


def test_a_file_that_is_not_mcap_is_named_with_the_reason(capsys, tmp_path):
    wrong = tmp_path / "notes.mcap"
    wrong.write_text('{"this is": "json"}')
    code, out, err = audit(capsys, str(wrong), "--workers", "1")
    assert code == 2, "nothing at all could be read: not a clean audit"
    assert f"{wrong}: unreadable, 0 records" in out
    assert f"warning: nothing could be read from {wrong}: not an MCAP file: it does not start with the MCAP magic" in err
    assert "Traceback" not in err
    assert audit(capsys, "--replay", str(wrong), "--workers", "1")[0] == 2


def test_an_unreadable_file_beside_good_logs_is_named_and_the_rest_audited(capsys, tmp_path, fleet):
    wrong = tmp_path / "notes.mcap"
    wrong.write_text('{"this is": "json"}')
    code, out, err = audit(capsys, str(fleet), str(wrong), "--workers", "1", "--quiet")
    assert code == 0
    assert f"warning: nothing could be read from {wrong}" in err
    assert "frames: 0 " not in out


def test_a_log_of_another_schema_version_is_named_unreadable_once_not_read_message_by_message(
    capsys, tmp_path, fleet, caplog
):
    other = tmp_path / "v2.mcap"
    rewrite(fleet, [other], metadata={"monitor_id": "future", "schema_version": "2", "pid": "1"})
    with caplog.at_level(logging.WARNING):
        code, out, err = audit(capsys, str(other), "--workers", "1", "--quiet")
    assert code == 2, "nothing at all could be read: not a clean audit"
    reason = "schema version 2; this discern reads version 1"
    assert f"{other}: unreadable, 0 records" in out and reason in out and "skipped" not in out
    assert err.count(f"warning: nothing could be read from {other}: {reason}") == 1 and "Traceback" not in err
    assert not [r for r in caplog.records if "fail their schema" in r.getMessage()]
    assert audit(capsys, "--replay", str(other), "--workers", "1")[0] == 2

    same = tmp_path / "v1.mcap"
    rewrite(fleet, [same], metadata={"monitor_id": "now", "schema_version": "1", "pid": "1"})
    assert audit_json(capsys, tmp_path, same)["frames"] == audit_json(capsys, tmp_path, fleet)["frames"]
    code, out, err = audit(capsys, str(other), str(same), "--workers", "1", "--quiet")
    assert code == 0 and reason in err


def test_a_log_of_another_schema_version_without_metadata_is_named_unreadable_by_its_messages(
    capsys, tmp_path, fleet, caplog
):
    other = tmp_path / "v2.mcap"
    rewrite(fleet, [other], version=2)
    reason = "schema version 2; this discern reads version 1"
    with caplog.at_level(logging.WARNING):
        code, out, err = audit(capsys, str(other), "--workers", "1", "--quiet")
    assert code == 2, "nothing at all could be read: not a clean audit"
    assert f"{other}: unreadable, 0 records" in out and reason in out and "skipped" not in out
    assert err.count(f"warning: nothing could be read from {other}: {reason}") == 1
    assert not [r for r in caplog.records if "fail their schema" in r.getMessage()]
    for workers in ("1", "4"):  # split by vehicle, only some readers meet the file's messages
        code, out, err = audit(capsys, "--replay", str(other), "--workers", workers)
        assert code == 2 and f"{other}: unreadable, 0 records" in out and reason in err, workers
    code, out, err = audit(capsys, str(other), str(fleet), "--workers", "1", "--quiet")
    assert code == 0 and reason in err and "frames: 0 " not in out


def test_a_file_given_twice_is_read_once(capsys, tmp_path, fleet):
    once = audit_json(capsys, tmp_path, fleet.parent)
    twice = audit_json(capsys, tmp_path, fleet.parent, fleet, Path(str(fleet).replace("/fleet/", "/fleet/./")))
    assert [f["path"] for f in twice["files"]] == [f["path"] for f in once["files"]]
    assert twice["frames"] == once["frames"] and twice["disagreements"] == once["disagreements"]


def test_a_runs_file_given_twice_from_two_folders_is_read_once_and_said_so(capsys, tmp_path, fleet):
    """A run pulled into two folders: the same monitor, run and index in their metadata are one file, whatever
    the path; two that differ (one cut short) are refused, as neither can be told to be the log."""
    first, second = tmp_path / "upload_a" / fleet.name, tmp_path / "upload_b" / fleet.name
    for copy in (first, second):
        copy.parent.mkdir()
        shutil.copy(fleet, copy)
    once = audit_json(capsys, tmp_path, first.parent)
    out = tmp_path / "twice.json"
    code, _, err = audit(capsys, str(first.parent), str(second.parent), "--json", str(out), "--workers", "1", "-q")
    twice = json.loads(out.read_text())
    assert code == 0 and [f["path"] for f in twice["files"]] == [str(first)]
    assert (twice["frames"], twice["odometry"]) == (once["frames"], once["odometry"])
    run = log_metadata(fleet)["run"][:8]
    assert err.splitlines()[0] == (
        f"discern audit: note: {second} is a copy of {first} (file 0000 of monitor audit-fleet's run {run}): read once")
    second.write_bytes(fleet.read_bytes()[: fleet.stat().st_size // 2])
    for mode in ([], ["--replay"]):
        code, out, err = audit(capsys, str(first.parent), str(second.parent), *mode, "--workers", "1")
        assert code == 2 and out == ""
        assert err == (f"discern audit: error: {second} and {first} are both file 0000 of monitor audit-fleet's run "
                       f"{run}, but they differ: give the one to audit\n")


def run_files(source: Path, directory: Path, parts: int) -> list[Path]:
    """The source log cut into `parts` files of its run, named and recorded as its monitor would have."""
    with open(source, "rb") as f:
        count = sum(1 for _ in make_reader(f).iter_messages(log_time_order=False))
    written = log_metadata(source)
    names = [directory / f"discern-{written['monitor_id']}-20260101T00000{i}-{written['run'][:8]}-{i:04d}.mcap"
             for i in range(parts)]
    directory.mkdir()
    rewrite(source, names, splits=tuple(count * (i + 1) // parts for i in range(parts - 1)),
            metadata=[{**written, "index": str(i)} for i in range(parts)])
    return names


def test_a_file_missing_from_a_runs_sequence_is_named_though_every_file_read_is_complete(capsys, tmp_path, fleet):
    parts = run_files(fleet, tmp_path / "gap", 4)
    parts[1].unlink()
    parts[2].unlink()
    run = log_metadata(fleet)["run"]
    line = f"incomplete: run {run[:8]} of monitor audit-fleet: files 0001-0002 are not among the files read"
    for mode in ([], ["--replay"]):
        reports = {kind: tmp_path / f"report{len(mode)}.{kind}" for kind in ("json", "html")}
        code, out, err = audit(capsys, str(tmp_path / "gap"), *mode, "--workers", "1", "-q",
                               *(arg for kind, path in reports.items() for arg in (f"--{kind}", str(path))))
        assert code in (0, 1) and out.count(": complete, ") == 2, err
        assert f"  {line} (its last status record says it opened 1)\n" in out
        doc = json.loads(reports["json"].read_text())
        assert doc["incomplete_runs"] == [{"monitor": "audit-fleet", "run": run, "files_read": 2, "files_missing": 2,
                                           "missing_indices": [1, 2], "log_files_opened": 1, "log_dropped": 0}]
        assert line in reports["html"].read_text()
    assert "incomplete" not in audit(capsys, str(fleet), "--workers", "1", "-q")[1]  # a whole run: nothing to say


def test_a_log_whose_directory_was_deleted_mid_drive_is_said_to_miss_a_file_and_the_records_its_monitor_lost(
        capsys, tmp_path):
    """The monitor notices at its next flush and logs on into a new file; its status counts what it lost."""
    directory = tmp_path / "log"

    def drive(endpoint: str) -> None:
        with Monitor("car_d", connect=[endpoint], timeout=10.0) as car:
            for i in range(5):
                car.check(highway(i), "cruise")
            [first] = directory.glob("*.mcap")
            # just after a flush: what comes next goes into the deleted file, until the flush a second later
            assert wait_until(lambda: sum(r.kind == "verdict" for r in read_log(first)) == 5, step=0.01)
            shutil.rmtree(directory)
            for i in range(5, 10):
                car.check(highway(i), "cruise")
            assert wait_until(lambda: directory.is_dir() and any(directory.glob("*.mcap")))
            for i in range(10, 15):
                car.check(highway(i), "cruise")

    [kept] = serve_log(directory, "gone", drive, log={"flush_seconds": 1.0}, budget_ms=1000.0)
    last = [r.status for r in read_log(kept) if r.kind == "status"][-1]
    assert last.log_files_opened == 2 and last.log_dropped >= 10  # car_d's 5 proposals and verdicts at least
    doc = audit_json(capsys, tmp_path, directory)
    assert [f["state"] for f in doc["files"]] == ["complete"]
    [gap] = doc["incomplete_runs"]
    assert (gap["missing_indices"], gap["log_files_opened"], gap["log_dropped"]) == ([0], 2, last.log_dropped)
    out = audit(capsys, str(directory), "--workers", "1", "-q")[1]
    assert (f"file 0000 is not among the files read (its last status record says it opened 2); its monitor dropped "
            f"{last.log_dropped} log records (log_dropped in its last status record: a full queue or a disk error)\n"
            in out)


def test_a_directory_named_like_a_log_inside_a_log_directory_is_walked_and_an_empty_one_named(
        capsys, tmp_path, fleet, shadow):
    run = tmp_path / "run"
    (run / "more.mcap").mkdir(parents=True)
    shutil.copy(fleet, run / "a.mcap")
    shutil.copy(shadow, run / "more.mcap" / "b.mcap")
    doc = audit_json(capsys, tmp_path, run)
    assert [f["path"] for f in doc["files"]] == [str(run / "a.mcap"), str(run / "more.mcap" / "b.mcap")]
    each = [audit_json(capsys, tmp_path, log)["frames"] for log in (fleet, shadow)]
    assert doc["frames"] == sum(each)
    (run / "none.mcap").mkdir()
    for mode in ([], ["--replay"]):
        code, out, err = audit(capsys, str(run), *mode, "--workers", "1")
        assert code == 2 and out == ""
        assert err == f"discern audit: error: {run / 'none.mcap'}: directory holds no *.mcap files\n"


def verdict_chunk_spans(path: Path) -> list[tuple[int, int]]:
    """The (start, end) in a log of each chunk record that holds a verdict: losing one loses a frame."""
    from mcap.records import Channel, Chunk, Message
    from mcap.stream_reader import StreamReader, breakup_chunk

    spans, before, topics = [], 8, {}
    with open(path, "rb") as f:
        for record in StreamReader(f, emit_chunks=True).records:
            if isinstance(record, Channel):
                topics[record.id] = record.topic
            elif isinstance(record, Chunk):
                held = breakup_chunk(record)
                topics.update((r.id, r.topic) for r in held if isinstance(r, Channel))
                if any(isinstance(r, Message) and topics[r.channel_id].endswith("/verdict") for r in held):
                    spans.append((before, f.tell()))
            before = f.tell()
    return spans


def test_a_damaged_chunk_in_a_closed_log_is_skipped_named_and_the_rest_audited(capsys, tmp_path, fleet):
    whole = audit_json(capsys, tmp_path, fleet)
    spans = verdict_chunk_spans(fleet)
    assert len(spans) >= 4, spans
    start, end = spans[len(spans) // 2]
    data = bytearray(fleet.read_bytes())
    data[(start + end) // 2] ^= 0x10
    damaged = tmp_path / "damaged.mcap"
    damaged.write_bytes(bytes(data))
    code, out, err = audit(capsys, str(damaged), "--workers", "1", "-q")
    assert code == 0, err
    assert f"{damaged}: damaged, " in out and f"; damaged: chunk at byte {start} ({end - start} bytes, " in out
    assert "truncated" not in out and "stopped:" not in out
    doc = audit_json(capsys, tmp_path, damaged)
    (f,) = doc["files"]
    assert f["state"] == "damaged" and f["recovered_bytes"] == len(data) - (end - start)
    [chunk] = f["damaged"]
    assert (chunk["offset"], chunk["length"], chunk["kind"]) == (start, end - start, "chunk") and chunk["messages"] > 0
    # what came after the damaged chunk is audited too: the last disagreements are all there
    assert 0 < doc["frames"] < whole["frames"]
    strip = lambda rows: [{k: v for k, v in r.items() if k != "file"} for r in rows]  # noqa: E731
    assert strip(doc["disagreements"][-3:]) == strip(whole["disagreements"][-3:])
