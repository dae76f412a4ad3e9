"""What every benchmark shares: percentiles, timing, the machine, and its section of docs/benchmarks.md."""

from __future__ import annotations

import platform
import re
import subprocess
import time
from pathlib import Path

from discern.monitor.allocator import in_use
from discern.monitor.status import percentile

DOC = Path(__file__).resolve().parents[1] / "docs" / "benchmarks.md"
HEADER = "# Benchmarks\n\nEvery figure below was measured by the command shown with it; none is estimated.\n"


def pct(values: list[float], q: float) -> float:
    """The q-th percentile by nearest rank, as the monitor's status and the audit report it."""
    return percentile(sorted(values), q) if values else float("nan")


def timed(fn, repeats: int, between=None) -> list[float]:
    """Wall-clock milliseconds of `repeats` calls; `between`, if given, runs untimed before each."""
    out = []
    for _ in range(repeats):
        if between is not None:
            between()
        start = time.perf_counter()
        fn()
        out.append((time.perf_counter() - start) * 1000)
    return out


def reference_loop_s() -> float:
    """Seconds for a fixed pure-Python loop (best of 3): how fast this machine runs at the moment.

    A shared VM's speed drifts with its neighbours' load (this loop took 0.11 s and, a quarter of an
    hour later, 0.21 s on the development VM); figures measured at different moments compare through it.
    """
    best = float("inf")
    for _ in range(3):
        start = time.perf_counter()
        total = 0
        for i in range(5_000_000):
            total += i
        best = min(best, time.perf_counter() - start)
    return best


def machine() -> str:
    cpu = "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    cores = subprocess.run(["nproc"], capture_output=True, text=True).stdout.strip() or "?"
    return (f"{cpu}, {cores} cores, Python {platform.python_version()}, {platform.system()} {platform.machine()}, "
            f"{in_use()}, reference loop {reference_loop_s():.2f} s (bench/report.py)")


def write_section(key: str, body: str) -> None:
    text = DOC.read_text(encoding="utf-8") if DOC.exists() else HEADER
    begin, end = f"<!-- bench:{key} -->", f"<!-- /bench:{key} -->"
    block = f"{begin}\n{body.rstrip()}\n{end}"
    pattern = re.compile(re.escape(begin) + ".*?" + re.escape(end), re.S)
    text = pattern.sub(lambda _m: block, text) if pattern.search(text) else text.rstrip() + "\n\n" + block + "\n"
    DOC.parent.mkdir(parents=True, exist_ok=True)
    DOC.write_text(text, encoding="utf-8")
