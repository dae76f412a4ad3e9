"""The MCAP log: what the writer records reads back typed, from whole, rotated, cut and foreign files."""

from __future__ import annotations

import json
import logging
import resource
import shutil
import signal
import time

import pytest

from mcap.reader import make_reader
from mcap.writer import Writer

from discern.monitor.config import LogSettings
from discern.monitor.example_planner import highway_scene
from discern.monitor.log import (LOG_NAME, McapLogWriter, RecoveryReport, RejectedInput, first_log_time_ns,
                                 log_metadata, read_log, vehicle_topic)
from discern.monitor.log.channels import STATUS_TOPIC
from discern.monitor.log.reader import log_files
from discern.monitor.protocol import RULE_BAD_INPUT, failsafe_verdict
from discern.monitor.status import StatusCounters
from discern.rules.scene import Proposal
from discern.sanity import window_reasoner
from tests.monitor_process import wait_until


def write_session(directory, frames=5, **settings) -> list[Proposal]:
    reasoner = window_reasoner()
    writer = McapLogWriter(LogSettings(directory=directory, **settings), "unit")
    proposals = []
    for f in range(frames):
        p = Proposal(vehicle="car_1", action="cruise", scene=highway_scene(f, 6))
        writer.write(vehicle_topic("car_1", "proposal"), "proposal", p)
        writer.write(vehicle_topic("car_1", "verdict"), "verdict", reasoner.decide(p.scene, p.action, vehicle="car_1"))
        proposals.append(p)
    writer.write(
        vehicle_topic("car_2", "rejected"),
        "rejected",
        RejectedInput(vehicle="car_2", key="discern/car_2/check", size=3, error="malformed JSON", excerpt="{{{"),
    )
    writer.write(vehicle_topic("car_2", "verdict"), "verdict", failsafe_verdict("car_2", "malformed JSON", RULE_BAD_INPUT))
    writer.write(STATUS_TOPIC, "status", StatusCounters("unit", "*", 50).snapshot())
    writer.close()
    return proposals


def test_written_records_read_back_as_the_same_models(tmp_path):
    proposals = write_session(tmp_path)
    report = RecoveryReport()
    records = list(read_log(tmp_path, report))
    assert [r.proposal for r in records if r.kind == "proposal"] == proposals
    verdicts = [r.verdict for r in records if r.kind == "verdict"]
    assert [v.frame_id for v in verdicts[:5]] == list(range(5)) and verdicts[-1].failsafe
    [rejected] = [r for r in records if r.kind == "rejected"]
    assert rejected.vehicle == "car_2" and rejected.rejected.excerpt == "{{{"
    assert records[-1].kind == "status" and records[-1].vehicle is None
    assert all(r.log_time_ns > 0 for r in records)
    [f] = report.files
    assert f.state == "complete" and f.records == len(records) == 13 and f.recovered_bytes == f.size_bytes


def test_a_log_directory_that_is_a_file_is_refused_as_one(tmp_path):
    """"cannot create the log directory: File exists" left the operator to find the file themselves."""
    taken = tmp_path / "log"
    taken.write_text("")
    with pytest.raises(OSError, match=f"^the log directory {taken} is a file, not a directory$"):
        McapLogWriter(LogSettings(directory=taken), "m")


def test_channels_are_json_with_json_schemas_foxglove_can_open(tmp_path):
    write_session(tmp_path, frames=1)
    [path] = tmp_path.glob("*.mcap")
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()  # the standard reader: indexed, finished file
    channels = {c.topic: c for c in summary.channels.values()}
    assert set(channels) == {
        "/discern/car_1/proposal", "/discern/car_1/verdict", "/discern/car_2/rejected",
        "/discern/car_2/verdict", "/discern/status",
    }
    for channel in channels.values():
        schema = summary.schemas[channel.schema_id]
        assert channel.message_encoding == "json" and schema.encoding == "jsonschema"
        body = json.loads(schema.data)
        assert body["type"] == "object" and body["properties"] and "$ref" not in schema.data.decode()
    proposal_schema = json.loads(summary.schemas[channels["/discern/car_1/proposal"].schema_id].data)
    objects = proposal_schema["properties"]["scene"]["properties"]["objects"]["items"]["properties"]
    assert "class" in objects  # the wire name, not the Python one


def test_every_logged_message_validates_against_its_channel_schema(tmp_path):
    import jsonschema
    from mcap.reader import make_reader

    write_session(tmp_path, frames=3)
    [path] = tmp_path.glob("*.mcap")
    checked = 0
    with open(path, "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            jsonschema.validate(json.loads(message.data), json.loads(schema.data), cls=jsonschema.Draft202012Validator)
            checked += 1
    assert checked == 9  # 3 proposals, 3 verdicts, a refusal, its verdict, a status


def test_a_cut_file_is_recovered_up_to_its_last_complete_chunk(tmp_path):
    writer = McapLogWriter(LogSettings(directory=tmp_path, flush_seconds=0.05), "cut")
    for f in range(6):
        p = Proposal(vehicle="v", action="cruise", scene=highway_scene(f, 4))
        writer.write(vehicle_topic("v", "proposal"), "proposal", p)
        time.sleep(0.15)  # one chunk per proposal
    writer.close()
    [path] = tmp_path.glob("*.mcap")
    data = path.read_bytes()
    whole = list(read_log(path))
    assert len(whole) == 6
    cut = tmp_path / "cut.mcap"
    previous = -1
    for size in range(len(data) // 3, len(data), max(1, len(data) // 40)):
        cut.write_bytes(data[:size])
        report = RecoveryReport()
        records = list(read_log(cut, report))
        frames = [r.proposal.scene.frame_id for r in records]
        assert frames == list(range(len(frames)))  # a prefix, never a damaged record
        assert len(frames) >= previous  # more file, never fewer records
        previous = len(frames)
        [f] = report.files
        assert f.state == "truncated" and f.records == len(frames) and f.recovered_bytes <= size
    assert previous >= 5


def test_a_file_still_being_written_is_read_as_it_was_when_opened(tmp_path):
    """A running monitor appends while the audit reads: what is read and the size then describe the same bytes."""
    data, chunks = write_chunked(tmp_path, 6)
    live = tmp_path / "live.mcap"
    live.write_bytes(data[: chunks[3][0]])  # three chunks written so far
    report = RecoveryReport()
    records = read_log(live, report)
    first = next(records)  # the file is open and its size taken
    with open(live, "ab") as grow:
        grow.write(data[chunks[3][0]:])  # the monitor writes on
    frames = [first.proposal.scene.frame_id] + [r.proposal.scene.frame_id for r in records]
    assert frames == [0, 1, 2]
    [f] = report.files
    assert f.size_bytes == chunks[3][0] and f.recovered_bytes <= f.size_bytes
    assert f.state == "truncated" and f.stopped_by.endswith("before its footer (the monitor was killed, or is still writing it)")


def rotated_log(directory, frames: int):
    """A writer that rotates at 4 KiB, given `frames` proposals slowly enough that its flushes fill several files."""
    writer = McapLogWriter(LogSettings(directory=directory, flush_seconds=0.02, rotate_bytes=4096), "rot")
    for f in range(frames):
        writer.write(vehicle_topic("v", "proposal"), "proposal", Proposal(action="cruise", scene=highway_scene(f, 8)))
        time.sleep(0.05)
    writer.close()
    return writer


def test_files_rotate_by_size_and_read_back_in_order(tmp_path):
    writer = rotated_log(tmp_path, 12)
    assert len(writer.files) >= 3 and all(p.exists() for p in writer.files)
    report = RecoveryReport()
    frames = [r.proposal.scene.frame_id for r in read_log(tmp_path, report)]
    assert frames == list(range(12)) and all(f.complete for f in report.files)


def test_a_size_to_keep_deletes_the_monitors_oldest_files_first_and_no_one_elses(tmp_path):
    """A sidecar runs for months: with keep_bytes its files stay within it, an earlier run's going before its own."""
    earlier_run = tmp_path / "discern-rot-20260101T000000-0badcafe-0000.mcap"
    earlier_run.write_bytes(b"x" * 4096)
    others = [tmp_path / "discern-rot-2-20260101T000000-0badcafe-0000.mcap",  # a monitor whose id starts alike
              tmp_path / "discern-other-20260101T000000-0badcafe-0000.mcap", tmp_path / "notes.mcap"]
    for path in others:
        path.write_bytes(b"y" * 8192)
    settings = LogSettings(directory=tmp_path, flush_seconds=0.02, rotate_bytes=4096, keep_bytes=40_000)
    writer = McapLogWriter(settings, "rot")
    for f in range(30):
        writer.write(vehicle_topic("v", "proposal"), "proposal", Proposal(action="cruise", scene=highway_scene(f, 8)))
        time.sleep(0.03)
    writer.close()
    assert not earlier_run.exists() and all(path.read_bytes()[:1] == b"y" for path in others)
    kept = sorted((int(m.group(3)), tmp_path / m.group(0)) for m in map(LOG_NAME.match, (p.name for p in tmp_path.iterdir()))
                  if m is not None and m.group(1) == "rot")
    assert [index for index, _ in kept] == list(range(writer.opened - len(kept), writer.opened))  # the newest
    assert [path for _, path in kept] == writer.files and writer.deleted == writer.opened - len(kept) + 1 > 1
    assert sum(path.stat().st_size for path in writer.files[:-1]) <= 40_000  # and the last, as it was started
    report = RecoveryReport()
    frames = [r.proposal.scene.frame_id for r in read_log(writer.files, report)]
    assert frames == list(range(frames[0], 30)) and frames[0] > 0 and all(f.complete for f in report.files)


def test_under_a_size_to_keep_an_idle_monitors_status_records_do_not_delete_the_files_of_its_drive(tmp_path):
    """Status records alone still fill file after file by size; the keep cap deletes those first, not the drive."""
    settings = LogSettings(directory=tmp_path, flush_seconds=0.02, rotate_bytes=16_384, keep_bytes=80_000,
                           compression="none")
    writer = McapLogWriter(settings, "idle")
    for f in range(2):
        writer.write(vehicle_topic("v", "proposal"), "proposal", Proposal(action="cruise", scene=highway_scene(f, 8)))
    status = StatusCounters("idle", "*", 50).snapshot()
    for _ in range(10_000):  # idle: a status record every few ms, until the cap has deleted several files
        if writer.deleted >= 3:
            break
        writer.write(STATUS_TOPIC, "status", status)
        time.sleep(0.002)
    writer.close()
    assert writer.deleted >= 3 and writer.files[0].name.endswith("-0000.mcap")
    assert [r.proposal.scene.frame_id for r in read_log(writer.files[0]) if r.kind == "proposal"] == [0, 1]
    assert all({r.kind for r in read_log(path)} == {"status"} for path in writer.files[1:-1])


def test_each_file_records_its_run_and_index_among_the_runs_files(tmp_path):
    """What an audit goes by, so that a file renamed or copied away still says where it belongs."""
    writer = rotated_log(tmp_path, 6)
    assert len(writer.files) >= 2
    recorded = [log_metadata(path) for path in writer.files]
    assert [(m["run"], m["index"]) for m in recorded] == [(writer.run, str(i)) for i in range(len(writer.files))]


def test_two_writers_sharing_an_id_are_warned_and_never_delete_each_others_file_being_written(tmp_path, caplog):
    settings = LogSettings(directory=tmp_path, flush_seconds=0.02, rotate_bytes=4096, keep_bytes=12_000)
    with caplog.at_level(logging.INFO, logger="discern.monitor.log.writer"):
        first = McapLogWriter(settings, "dup")
        second = McapLogWriter(settings, "dup")
        for f in range(30):
            for writer in (first, second):
                writer.write(vehicle_topic("v", "proposal"), "proposal", Proposal(action="cruise", scene=highway_scene(f, 8)))
            time.sleep(0.03)
        assert all(w.files[-1].exists() for w in (first, second))  # each one's file being written, now
        first.close()
        second.close()
    assert first.dropped == second.dropped == 0 and first.deleted + second.deleted > 0
    assert "another monitor with the id 'dup' is logging in" in caplog.text
    assert "deleted or moved away" not in caplog.text


def test_reading_since_a_time_skips_earlier_messages_undecoded(tmp_path):
    writer = McapLogWriter(LogSettings(directory=tmp_path, flush_seconds=0.02), "since")
    for f in range(8):
        writer.write(vehicle_topic("v", "proposal"), "proposal", Proposal(action="cruise", scene=highway_scene(f, 2)))
        time.sleep(0.05)
    writer.close()
    times = [r.log_time_ns for r in read_log(tmp_path)]
    assert first_log_time_ns(writer.files[0]) == times[0]
    report = RecoveryReport()
    later = [r.proposal.scene.frame_id for r in read_log(tmp_path, report, since_ns=times[5])]
    assert later == [5, 6, 7] and report.files[0].complete


def test_readers_split_by_vehicle_decode_their_own_records_and_their_counts_add_up(tmp_path):
    write_session(tmp_path)
    shares = {}
    for name, pick in (("car_1", lambda v: v == "car_1"), ("rest", lambda v: v != "car_1")):
        report = RecoveryReport()
        shares[name] = ([(r.vehicle, r.kind) for r in read_log(tmp_path, report, vehicles=pick)], report.files[0])
    records, recovery = shares["car_1"]
    assert set(records) == {("car_1", "proposal"), ("car_1", "verdict")} and len(records) == 10
    rest, rest_recovery = shares["rest"]  # the other vehicle's, and the monitor-wide status (no vehicle)
    assert rest == [("car_2", "rejected"), ("car_2", "verdict"), (None, "status")]
    assert recovery.records + rest_recovery.records == 13 and recovery.complete and rest_recovery.complete


def test_files_rotate_by_age(tmp_path):
    writer = McapLogWriter(LogSettings(directory=tmp_path, flush_seconds=0.02, rotate_seconds=0.1), "age")
    writer.write(vehicle_topic("v", "proposal"), "proposal", Proposal(action="cruise", scene=highway_scene(0, 2)))
    time.sleep(0.4)
    writer.write(vehicle_topic("v", "proposal"), "proposal", Proposal(action="cruise", scene=highway_scene(1, 2)))
    writer.close()
    assert len(writer.files) >= 2
    assert [r.proposal.scene.frame_id for r in read_log(writer.files)] == [0, 1]


def test_an_idle_writer_does_not_rotate_into_files_with_no_message(tmp_path):
    writer = McapLogWriter(LogSettings(directory=tmp_path, flush_seconds=0.02, rotate_seconds=0.1), "idle")
    writer.write(vehicle_topic("v", "proposal"), "proposal", Proposal(action="cruise", scene=highway_scene(0, 2)))
    time.sleep(0.5)  # five rotation periods, the first with a message, the others idle
    writer.close()
    assert len(writer.files) == 2  # the one with the message, and the one opened after it that stayed empty
    assert [r.proposal.scene.frame_id for r in read_log(writer.files)] == [0]


def test_merge_interleaves_files_by_log_time(tmp_path):
    for name, frames in (("a", (0, 2, 4)), ("b", (1, 3))):
        writer = McapLogWriter(LogSettings(directory=tmp_path / name), name)
        for f in frames:
            p = Proposal(vehicle=name, action="cruise", scene=highway_scene(f, 2))
            writer.write(vehicle_topic(name, "proposal"), "proposal", p, log_time_ns=1_000 + f)
        writer.close()
    merged = [r.proposal.scene.frame_id for r in read_log([tmp_path / "a", tmp_path / "b"], merge=True)]
    assert merged == [0, 1, 2, 3, 4]


def test_unknown_channels_and_bad_messages_are_skipped_with_one_warning_per_channel(tmp_path, caplog):
    path = tmp_path / "mixed.mcap"
    with open(path, "wb") as f:
        w = Writer(f)
        w.start()
        other = w.register_schema("camera.Image", "jsonschema", b'{"type":"object"}')
        ours = w.register_schema("discern.Proposal", "jsonschema", b'{"type":"object"}')
        cam = w.register_channel("/camera/front", "json", other)
        prop = w.register_channel("/discern/v/proposal", "json", ours)
        w.add_message(cam, log_time=1, publish_time=1, data=b'{"pixels": []}')
        p = Proposal(vehicle="v", action="brake", scene=highway_scene(0, 2))
        w.add_message(prop, log_time=2, publish_time=2, data=p.model_dump_json(by_alias=True).encode())
        for t in range(3, 6):
            w.add_message(prop, log_time=t, publish_time=t, data=b'{"not": "a proposal"}')
        w.finish()
    report = RecoveryReport()
    with caplog.at_level(logging.WARNING, logger="discern.monitor.log.reader"):
        records = list(read_log(path, report))
    assert [r.proposal for r in records] == [p]
    assert report.skipped == 4
    assert caplog.text.count("unknown channel '/camera/front'") == 1
    assert caplog.text.count("skipping /discern/v/proposal messages that fail their schema") == 1
    assert "first: action: Field required" in caplog.text

    before = len(caplog.records)  # readers split by vehicle: the unknown channel is warned about once in all
    shares = [RecoveryReport(), RecoveryReport()]
    with caplog.at_level(logging.WARNING, logger="discern.monitor.log.reader"):
        for share, pick in zip(shares, (lambda v: v is None, lambda v: v is not None)):
            list(read_log(path, share, vehicles=pick))
    warned = [r.getMessage() for r in caplog.records[before:] if "unknown channel '/camera/front'" in r.getMessage()]
    assert len(warned) == 1
    assert [share.skipped for share in shares] == [1, 3]  # the foreign message; the bad proposals of v


def test_empty_missing_and_foreign_files_yield_nothing_but_are_reported(tmp_path):
    (tmp_path / "empty.mcap").write_bytes(b"")
    (tmp_path / "junk.mcap").write_bytes(b"this is not an mcap file at all")
    report = RecoveryReport()
    records = list(read_log([tmp_path / "empty.mcap", tmp_path / "junk.mcap", tmp_path / "gone.mcap"], report))
    assert records == []
    empty, junk, gone = report.files
    assert empty.size_bytes == 0 and empty.state == "empty" and empty.stopped_by is None
    assert junk.state == "unreadable" and "magic" in junk.stopped_by
    assert gone.state == "unreadable" and "cannot open" in gone.stopped_by
    lines = report.summary().splitlines()
    assert lines[0].startswith(f"{tmp_path / 'empty.mcap'}: empty, 0 records")
    assert lines[1].startswith(f"{tmp_path / 'junk.mcap'}: unreadable, 0 records")
    assert lines[2].startswith(f"{tmp_path / 'gone.mcap'}: unreadable, 0 records") and "cannot open" in lines[2]


def test_a_disk_error_drops_and_counts_records_until_a_new_file_opens(tmp_path, caplog):
    """A write past RLIMIT_FSIZE fails like one on a full disk (EFBIG instead of ENOSPC)."""
    writer = McapLogWriter(LogSettings(directory=tmp_path, flush_seconds=0.02, compression="none"), "full")

    def write(frames) -> None:
        for f in frames:
            proposal = Proposal(action="cruise", scene=highway_scene(f, 4))
            writer.write(vehicle_topic("v", "proposal"), "proposal", proposal)

    def logged() -> list[int]:
        return [r.proposal.scene.frame_id for r in read_log(writer.files)]

    write(range(0, 5))
    assert wait_until(lambda: logged() == [0, 1, 2, 3, 4])
    limit = resource.getrlimit(resource.RLIMIT_FSIZE)
    sigxfsz = signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # else the kernel kills the process
    try:
        with caplog.at_level(logging.INFO, logger="discern.monitor.log.writer"):
            resource.setrlimit(resource.RLIMIT_FSIZE, (1, limit[1]))  # no file may grow: the disk is full
            write(range(5, 10))  # in the chunk that cannot be written
            assert wait_until(lambda: writer.dropped == 5)
            write(range(10, 15))  # while no file can be opened
            assert wait_until(lambda: writer.dropped == 10)
            resource.setrlimit(resource.RLIMIT_FSIZE, limit)
            assert wait_until(lambda: len(writer.files) == 2)
            write(range(15, 20))
            writer.close()
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, limit)
        signal.signal(signal.SIGXFSZ, sigxfsz)
    assert (writer.records, writer.dropped) == (10, 10)  # every record either in a file or counted
    report = RecoveryReport()
    assert [r.proposal.scene.frame_id for r in read_log(writer.files, report)] == [0, 1, 2, 3, 4, *range(15, 20)]
    assert [f.complete for f in report.files] == [False, True]  # the first file stays readable up to its error
    errors = [r.getMessage() for r in caplog.records if r.levelno == logging.ERROR]
    assert len(errors) == 1 and "cannot write the log" in errors[0]  # once, though every flush tried a new file
    assert f"logging again, to {writer.files[1]}" in caplog.text


def test_readers_split_by_vehicle_all_name_a_file_of_another_schema_version_unreadable(tmp_path):
    from tests.audit_logs import rewrite

    write_session(tmp_path / "v1")
    other = tmp_path / "v2.mcap"
    rewrite(next((tmp_path / "v1").glob("*.mcap")), [other], version=2)
    shares = []
    for pick in (lambda v: v == "car_9", lambda v: v == "car_1"):  # one meets no message of the file
        report = RecoveryReport()
        assert list(read_log(other, report, vehicles=pick)) == []
        shares.append(report.files[0])
    merged, theirs = shares
    merged.add_share(theirs)
    assert (merged.recovered_bytes, merged.complete, merged.records, merged.skipped) == (0, False, 0, 0)
    assert merged.stopped_by == "schema version 2; this discern reads version 1"


def test_a_directory_named_like_a_log_is_expanded_not_opened_as_a_file(tmp_path):
    (tmp_path / "a.mcap").write_bytes(b"")
    nested = tmp_path / "b.mcap"
    nested.mkdir()
    (nested / "c.mcap").write_bytes(b"")
    assert log_files([tmp_path, nested / "c.mcap"]) == [tmp_path / "a.mcap", nested / "c.mcap"]


def test_a_deleted_log_directory_is_noticed_recreated_and_its_lost_records_counted(tmp_path, caplog):
    """Writes into a deleted file fail silently: the writer must notice at its next flush, not lose the log."""
    directory = tmp_path / "log"
    writer = McapLogWriter(LogSettings(directory=directory, flush_seconds=1.0), "gone")

    def write(frames) -> None:
        for f in frames:
            writer.write(vehicle_topic("v", "proposal"), "proposal", Proposal(action="cruise", scene=highway_scene(f, 4)))

    with caplog.at_level(logging.INFO, logger="discern.monitor.log.writer"):
        write(range(0, 5))
        # Just after a flush: the next one, a second away, is the first to see the directory gone.
        assert wait_until(lambda: len(list(read_log(writer.files))) == 5, step=0.01)
        shutil.rmtree(directory)
        write(range(5, 10))  # into the unlinked file
        first = writer.files[0]
        assert wait_until(lambda: writer.files and writer.files[0] != first and writer.files[0].exists())
        write(range(10, 15))
        writer.close()
    assert writer.dropped == 5 and writer.records == 10  # the first file's 5, then the new one's
    assert writer.files == [next(directory.glob("*.mcap"))]  # the files still on disk, as the status lists them
    assert [r.proposal.scene.frame_id for r in read_log(directory)] == list(range(10, 15))
    errors = [r.getMessage() for r in caplog.records if r.levelno == logging.ERROR]
    assert len(errors) == 1 and f"{first.name} was deleted or moved away" in errors[0]
    assert f"logging again, to {writer.files[0]}" in caplog.text


def write_chunked(directory, frames: int) -> tuple[bytes, list[tuple[int, int]]]:
    """A cleanly closed log of one proposal per chunk: (its bytes, each chunk record's (start, end))."""
    writer = McapLogWriter(LogSettings(directory=directory, flush_seconds=0.02), "chunks")
    for f in range(frames):
        writer.write(vehicle_topic("v", "proposal"), "proposal", Proposal(vehicle="v", action="cruise", scene=highway_scene(f, 4)))
        time.sleep(0.1)  # one chunk per proposal
    writer.close()
    [path] = directory.glob("*.mcap")
    chunks = []
    with open(path, "rb") as f:
        from mcap.records import Chunk
        from mcap.stream_reader import StreamReader

        before = 8
        for record in StreamReader(f, emit_chunks=True).records:
            if isinstance(record, Chunk):
                chunks.append((before, f.tell()))
            before = f.tell()
    return path.read_bytes(), chunks


def test_a_damaged_chunk_is_skipped_and_named_and_the_chunks_after_it_are_read(tmp_path):
    data, chunks = write_chunked(tmp_path, 8)
    assert len(chunks) == 8, chunks
    start, end = chunks[3]
    damaged = bytearray(data)
    damaged[(start + end) // 2] ^= 0x40  # one bit of the fourth chunk's compressed data
    path = tmp_path / "damaged.mcap"
    path.write_bytes(bytes(damaged))
    report = RecoveryReport()
    frames = [r.proposal.scene.frame_id for r in read_log(path, report)]
    assert frames == [0, 1, 2, 4, 5, 6, 7]  # only the damaged chunk's proposal is lost
    [f] = report.files
    assert f.state == "damaged" and f.complete and f.stopped_by is None  # read to its footer: not truncated
    [chunk] = f.damaged
    assert (chunk.offset, chunk.length, chunk.kind, chunk.messages) == (start, end - start, "chunk", 1)
    assert f.recovered_bytes == len(data) - (end - start)
    assert f"damaged: chunk at byte {start} ({end - start} bytes, 1 message) skipped: " in report.summary()


def test_a_chunk_whose_opcode_is_damaged_is_named_from_the_summary_not_passed_over(tmp_path):
    """mcap's StreamReader passes over a record of an unknown opcode without a word."""
    data, chunks = write_chunked(tmp_path, 6)
    start, end = chunks[2]
    damaged = bytearray(data)
    damaged[start] = 0x7F  # no opcode MCAP knows
    path = tmp_path / "opcode.mcap"
    path.write_bytes(bytes(damaged))
    report = RecoveryReport()
    frames = [r.proposal.scene.frame_id for r in read_log(path, report)]
    assert frames == [0, 1, 3, 4, 5]
    [f] = report.files
    assert f.state == "damaged"
    [chunk] = f.damaged
    assert (chunk.offset, chunk.length, chunk.kind, chunk.messages) == (start, end - start, "chunk", 1)
    assert f"chunk at byte {start} ({end - start} bytes, 1 message) skipped: indexed in the file's summary but not " \
           "read" in report.summary()


def test_the_messages_after_a_passed_over_chunk_that_declared_their_channels_are_read_from_the_summarys_channels(
        tmp_path):
    """The first chunk declares the channels: passed over unseen, it took every later message with it, counted as
    on an unknown channel, and the audit reported no disagreement."""
    data, chunks = write_chunked(tmp_path, 6)
    start, end = chunks[0]
    damaged = bytearray(data)
    damaged[start] = 0x7F
    path = tmp_path / "first.mcap"
    path.write_bytes(bytes(damaged))
    report = RecoveryReport()
    assert [r.proposal.scene.frame_id for r in read_log(path, report)] == [1, 2, 3, 4, 5]
    [f] = report.files
    assert f.skipped == 0 and [(d.offset, d.kind) for d in f.damaged] == [(start, "chunk")]


def test_a_last_chunk_of_an_impossible_length_is_where_reading_stops_not_the_record_before_it(tmp_path):
    data, chunks = write_chunked(tmp_path, 4)
    start, _ = chunks[-1]
    damaged = bytearray(data)
    damaged[start + 1: start + 9] = (1 << 40).to_bytes(8, "little")  # past any record the reader takes
    path = tmp_path / "length.mcap"
    path.write_bytes(bytes(damaged))
    report = RecoveryReport()
    frames = [r.proposal.scene.frame_id for r in read_log(path, report)]
    assert frames == [0, 1, 2]
    [f] = report.files
    assert f.damaged == [] and f.state == "damaged"  # the intact records before it are not named as damage
    assert f.stopped_by.startswith(f"damaged at byte {start}, not read past")


def test_a_damaged_chunk_of_a_cut_file_is_skipped_and_the_file_still_reads_as_truncated(tmp_path):
    data, chunks = write_chunked(tmp_path, 6)
    start, end = chunks[2]
    damaged = bytearray(data[: chunks[5][0]])  # cut before the last chunk: no footer
    damaged[(start + end) // 2] ^= 0x01
    path = tmp_path / "cut.mcap"
    path.write_bytes(bytes(damaged))
    report = RecoveryReport()
    frames = [r.proposal.scene.frame_id for r in read_log(path, report)]
    assert frames == [0, 1, 3, 4]
    [f] = report.files
    assert f.state == "truncated" and [d.offset for d in f.damaged] == [start]
    assert f.stopped_by.startswith("cut short ")


def test_a_file_missing_its_closing_magic_is_truncated_not_complete(tmp_path):
    write_session(tmp_path)
    [whole] = tmp_path.glob("*.mcap")
    data = whole.read_bytes()
    cut = tmp_path / "cut.mcap"
    for missing in range(1, 9):
        cut.write_bytes(data[:-missing])
        with open(cut, "rb") as f, pytest.raises(Exception):
            make_reader(f).get_summary()  # the standard reader (and Foxglove) cannot open it
        report = RecoveryReport()
        assert len(list(read_log(cut, report))) == 13  # every message is still read
        [f] = report.files
        assert f.state == "truncated" and not f.complete, missing
        assert f.stopped_by == f"cut short after its footer, inside the closing magic at byte {len(data) - 8}"
        assert f.recovered_bytes == len(data) - 8
        # mcap's reader looks for the footer a whole magic before the end: short of it, it read garbage there, and
        # the summary the footer points to was reported unreadable, a damaged file, where only the magic is cut
        assert f.damaged == [] and "cannot be read" not in report.summary(), (missing, f.damaged)


def test_a_file_missing_its_closing_magic_still_has_what_its_summary_indexes_checked(tmp_path):
    """A chunk whose opcode is damaged is named, not passed over unseen, when the summary is read from the footer."""
    cut = tmp_path / "cut.mcap"
    data, chunks = write_chunked(tmp_path / "chunked", 6)
    start, end = chunks[2]
    damaged = bytearray(data[:-4])
    damaged[start] = 0x7F
    cut.write_bytes(bytes(damaged))
    report = RecoveryReport()
    assert [r.proposal.scene.frame_id for r in read_log(cut, report)] == [0, 1, 3, 4, 5]
    [f] = report.files
    assert [(d.offset, d.kind) for d in f.damaged] == [(start, "chunk")] and f.state == "truncated"


def test_a_file_cut_short_is_said_so_in_plain_words_wherever_the_cut_falls(tmp_path):
    write_session(tmp_path, frames=2)
    [whole] = tmp_path.glob("*.mcap")
    data = whole.read_bytes()
    cut = tmp_path / "cut.mcap"
    reasons = set()
    for size in list(range(1, 64)) + list(range(64, len(data), 7)):
        cut.write_bytes(data[:size])
        report = RecoveryReport()
        list(read_log(cut, report))
        [f] = report.files
        assert f.state in ("truncated", "unreadable") and f.stopped_by.startswith("cut short "), (size, f.stopped_by)
        assert not any(word in f.stopped_by for word in ("unpack", "buffer", "Error", "EndOfFile")), f.stopped_by
        reasons.add(f.stopped_by)
    assert "cut short inside a record at byte 8" in reasons  # `head -c 10`: the magic and a piece of the header
    assert "cut short inside its opening magic, at byte 4" in reasons



def test_a_file_out_of_channel_ids_rotates_and_no_new_vehicles_record_is_lost(tmp_path):
    """MCAP channel ids are 16-bit and each vehicle has channels of its own: the 65,536th channel starts a new file."""
    writer = McapLogWriter(LogSettings(directory=tmp_path), "fleet")
    record = RejectedInput(vehicle="v", key="k", size=1, error="e", excerpt="x").model_dump_json().encode()
    for v in range(65_536):
        writer.write(vehicle_topic(f"car_{v}", "rejected"), "rejected", record)
    writer.close()
    assert writer.dropped == 0 and writer.records == 65_536 and len(writer.files) == 2
    report = RecoveryReport()
    [last] = read_log(writer.files[-1], report)
    assert last.vehicle == "car_65535" and report.files[0].state == "complete"


def test_a_closed_file_whose_footer_points_to_no_readable_summary_is_damaged_and_its_records_still_read(tmp_path):
    proposals = write_session(tmp_path / "log")
    [path] = (tmp_path / "log").glob("*.mcap")
    data = bytearray(path.read_bytes())
    at = len(data) - 8 - 20  # the footer's summary_start: before its summary_offset_start, CRC and the closing magic
    data[at:at + 8] = (int.from_bytes(data[at:at + 8], "little") ^ 0x5A5A5A).to_bytes(8, "little")
    path.write_bytes(bytes(data))
    with open(path, "rb") as stream, pytest.raises(Exception):
        make_reader(stream).get_summary()  # the standard reader cannot read it
    report = RecoveryReport()
    assert [r.proposal for r in read_log(path, report) if r.kind == "proposal"] == proposals
    [f] = report.files
    assert f.state == "damaged" and f.records == 13
    assert "the footer at byte " in report.summary() and "that cannot be read" in report.summary()
