"""Real `discern serve` / `discern router` processes for the monitor tests, on loopback free ports.

Each process is started with `python -m discern.monitor.commands` (the same
subcommands `discern` wires) and stopped by the fixture that started it.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Optional

import pytest

from discern.monitor.config import free_port

REPO = Path(__file__).resolve().parents[1]
START_TIMEOUT_S = 30



def endpoint(port: int) -> str:
    return f"tcp/127.0.0.1:{port}"


def _hangup_as_by_default() -> None:
    signal.signal(signal.SIGHUP, signal.SIG_DFL)


class DiscernProcess:
    """One `discern <command>` child; its output is collected for assertions and failure messages.

    A monitor logs by default, into its working directory: one started here without `--log-dir` gets `--no-log`,
    so that tests leave nothing in the repository.
    """

    def __init__(self, *args: str, own_group: bool = False, cwd: Path = REPO):
        """`own_group`: in a process group of its own, as a service manager starts it (see `stop_group`), with the
        hangup signal's default action, which a test run under `nohup` would otherwise pass on as ignored."""
        if args[:1] == ("serve",) and "--log-dir" not in args and "--no-log" not in args and cwd == REPO:
            args = (*args, "--no-log")
        self.args = [sys.executable, "-m", "discern.monitor.commands", *args]
        env = dict(os.environ, PYTHONUNBUFFERED="1", RUST_LOG="error")
        self.proc = subprocess.Popen(
            self.args, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
            start_new_session=own_group, preexec_fn=_hangup_as_by_default if own_group else None,
        )
        self.lines: list[str] = []
        self._ready = threading.Event()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.lines.append(line.rstrip("\n"))
            if " ready" in line:
                self._ready.set()
        self._ready.set()  # exited: stop waiting

    def wait_ready(self) -> "DiscernProcess":
        self._ready.wait(START_TIMEOUT_S)
        if self.proc.poll() is not None or not any(" ready" in l for l in self.lines):
            self.stop()
            pytest.fail(f"{' '.join(self.args[3:])} did not start:\n" + self.output)
        return self

    @property
    def output(self) -> str:
        return "\n".join(self.lines)

    def stop(self, timeout: float = 15) -> Optional[int]:
        """SIGTERM, then SIGKILL if it does not exit; returns the exit code."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self._reader.join(5)
        return self.proc.returncode

    def stop_group(self, timeout: float = 15) -> Optional[int]:
        """SIGTERM to its whole process group, workers included, as systemd stops a service; returns the exit code."""
        os.killpg(self.proc.pid, signal.SIGTERM)
        try:
            self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait()
        self._reader.join(5)
        return self.proc.returncode

    def kill9(self) -> None:
        self.proc.send_signal(signal.SIGKILL)
        self.proc.wait()
        self._reader.join(5)


def serve(*args: str, port: Optional[int] = None) -> tuple[DiscernProcess, str]:
    """Start a monitor listening on a free loopback port; returns it with its endpoint."""
    ep = endpoint(port or free_port())
    return DiscernProcess("serve", "--listen", ep, *args).wait_ready(), ep


def status(ep: str, monitor_id: str = "*") -> list[dict]:
    """The JSON status of the monitors reachable at `ep`, through `discern status --json`."""
    import json

    out = subprocess.run(
        [sys.executable, "-m", "discern.monitor.commands", "status", "--connect", ep, "--id", monitor_id, "--json"],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert out.returncode == 0, out.stderr
    return [json.loads(line) for line in out.stdout.splitlines()]  # JSON Lines: one monitor's status a line


def wait_until(predicate, timeout: float = 10.0, step: float = 0.05):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(step)
    return predicate()
