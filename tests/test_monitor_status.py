"""The status key: what it says of the monitor's log."""

from tests.monitor_process import serve, status, wait_until


def test_the_status_lists_only_the_log_files_still_on_disk(tmp_path):
    """A closed file deleted from outside (an operator freeing room) stayed listed as this run's log."""
    proc, ep = serve("--id", "files", "--log-dir", str(tmp_path), "--log-rotate-s", "1")
    try:
        first, *rest = wait_until(lambda: [r for r in status(ep, "files") if len(r["log_files"]) >= 2])[0]["log_files"]
        assert first.startswith(str(tmp_path)) and rest
        (tmp_path / first.rsplit("/", 1)[1]).unlink()
        [after] = status(ep, "files")
        assert first not in after["log_files"] and after["log_files"]
    finally:
        assert proc.stop() == 0, proc.output
