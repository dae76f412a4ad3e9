"""What the status key says of a monitor: what it has in hand, and its log files (kept by rules of their own)."""

import itertools
import subprocess
import sys
import time
from pathlib import Path

import pytest
import zenoh

from discern.monitor.client import Monitor
from discern.monitor.config import ZenohSettings, free_port
from discern.monitor.example_planner import highway_scene
from discern.monitor.log import RecoveryReport, read_log
from discern.monitor.protocol import encode
from discern.monitor.status import LOG_FILES_LISTED
from discern.rules.scene import Proposal
from tests.monitor_process import REPO, DiscernProcess, endpoint, serve, status, wait_until

pytestmark = pytest.mark.wall_clock  # run alone: see the marker in pyproject.toml


def test_the_status_counts_the_proposals_open_and_how_long_the_oldest_has_waited():
    """A monitor sitting on its proposals looked like an idle one: nothing said it had them and was not answering."""
    proc, ep = serve("--id", "busy", "--budget-ms", "20000", "--test-only-decision-delay-ms", "6000")
    session = zenoh.open(ZenohSettings(listen=[], connect=[ep]).to_zenoh())
    try:
        [idle] = status(ep, "busy")
        replies = [session.get("discern/car_1/check", timeout=30, payload=encode(
            Proposal(vehicle="car_1", action="cruise", scene=highway_scene(frame, 4)))) for frame in range(2)]
        time.sleep(0.5)
        [busy] = status(ep, "busy")
        text = subprocess.run([sys.executable, "-m", "discern.monitor.commands", "status", "--connect", ep, "--id",
                               "busy"], cwd=REPO, capture_output=True, text=True, timeout=60).stdout
        verdicts = [reply.ok for replied in replies for reply in replied]
        [done] = status(ep, "busy")
    finally:
        session.close()
        assert proc.stop() == 0, proc.output
    assert (idle["open_proposals"], idle["oldest_open_ms"]) == (0, None)
    assert busy["open_proposals"] == 2 and busy["oldest_open_ms"] >= 500 and busy["proposals"] == 0
    assert "  open 2 (received, not answered yet), the oldest for " in text, text
    assert len(verdicts) == 2 and all(verdicts)
    assert (done["open_proposals"], done["oldest_open_ms"], done["proposals"]) == (0, None, 2)


def test_the_status_lists_the_last_log_files_still_on_disk_and_counts_every_one_opened(tmp_path):
    """The list grew by every file of the run, each looked for on disk at every status; a closed file deleted from
    outside (an operator freeing room) stayed listed as this run's log."""
    proc, ep = serve("--id", "files", "--log-dir", str(tmp_path), "--log-rotate-s", "1", "--budget-ms", "5000")
    try:
        with Monitor("car_1", connect=[ep], timeout=5) as planner:
            frames = itertools.count()

            def rotated_past_the_list():  # a proposal in each period, so that each ends its file
                planner.check(highway_scene(next(frames), 4), "cruise")
                [now] = status(ep, "files")
                return now if now["log_files_opened"] > LOG_FILES_LISTED + 1 else None

            now = wait_until(rotated_past_the_list, timeout=60, step=0.3)
        assert now, "the log did not rotate"
        listed = now["log_files"]
        written = sorted(str(p) for p in tmp_path.glob("*.mcap"))  # by index: one run, its stamps in order
        assert len(listed) == LOG_FILES_LISTED and listed == written[:now["log_files_opened"]][-LOG_FILES_LISTED:]
        Path(listed[0]).unlink()
        [after] = status(ep, "files")
        assert listed[0] not in after["log_files"] and all(Path(f).exists() for f in after["log_files"])
        assert after["log_files_opened"] >= now["log_files_opened"]
    finally:
        assert proc.stop() == 0, proc.output


def test_the_status_names_log_files_an_operator_elsewhere_can_find_whatever_the_monitors_directory(tmp_path):
    """--log-dir given relative to the monitor's working directory: the status once listed `logs/...` as given."""
    ep = endpoint(free_port())
    proc = DiscernProcess("serve", "--listen", ep, "--id", "rel", "--log-dir", "logs", cwd=tmp_path).wait_ready()
    try:
        [now] = status(ep, "rel")
        assert now["log_files"] and all(Path(f).is_absolute() and Path(f).exists() for f in now["log_files"]), now
        assert all(Path(f).parent == (tmp_path / "logs").resolve() for f in now["log_files"]), now
    finally:
        assert proc.stop() == 0, proc.output


def test_an_idle_monitor_does_not_rotate_into_files_of_status_records_alone(tmp_path):
    """Its status record every period counted as a message: idle at --log-rotate-s 1, it left a file a second."""
    proc, ep = serve("--id", "idle", "--log-dir", str(tmp_path), "--log-rotate-s", "1", "--status-period-s", "0.1",
                     "--budget-ms", "5000")
    try:
        with Monitor("car_1", connect=[ep], timeout=5) as planner:
            assert not planner.check(highway_scene(0, 4), "cruise").failsafe
        time.sleep(4)  # four rotation periods, idle but for forty status records
        [now] = status(ep, "idle")
    finally:
        assert proc.stop() == 0, proc.output
    first, kept = sorted(tmp_path.glob("*.mcap"))  # the proposal's, and the one after it, kept open since
    assert now["log_files_opened"] == 2
    kinds = [{r.kind for r in read_log([path], RecoveryReport())} for path in (first, kept)]
    assert kinds == [{"proposal", "verdict", "status"}, {"status"}]
