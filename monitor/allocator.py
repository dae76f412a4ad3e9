"""Run Discern on jemalloc instead of glibc's malloc, when the machine has it.

Every frame is grounded in its own clingo Control, freed after the verdict:
many small allocations. Sampled with perf on the development VM, glibc's
malloc and free took about a quarter of the time of a loop of KITTI
decisions; with jemalloc preloaded the same decisions ran about a fifth
faster (docs/benchmarks.md). A malloc is only replaced when the dynamic
loader preloads it, before the process starts, so the `discern` command and
the benchmarks re-execute themselves once with LD_PRELOAD set; the processes
they spawn (the sidecar's deciders) inherit it.

DISCERN_MALLOC: "auto" (the default: the first of LIBRARIES that exists),
"system" (glibc's malloc), or the path of a malloc library to preload.
"""

from __future__ import annotations

import os
import re
import sys
from pathlib import Path
from typing import Mapping, Optional

VARIABLE = "DISCERN_MALLOC"
LIBRARIES = (  # Debian and Ubuntu (package libjemalloc2), then Fedora and RHEL (package jemalloc)
    "/usr/lib/x86_64-linux-gnu/libjemalloc.so.2",
    "/usr/lib/aarch64-linux-gnu/libjemalloc.so.2",
    "/usr/lib64/libjemalloc.so.2",
)
_SEPARATORS = re.compile(r"[\s:]+")  # LD_PRELOAD separates its entries with spaces or colons


class AllocatorError(ValueError):
    """DISCERN_MALLOC names something that cannot be preloaded."""


def chosen(environ: Mapping[str, str] = os.environ) -> Optional[str]:
    """The malloc library to preload, or None for glibc's."""
    value = environ.get(VARIABLE, "").strip() or "auto"
    if value == "system":
        return None
    if value == "auto":
        return next((path for path in LIBRARIES if Path(path).is_file()), None)
    if not Path(value).is_file():
        raise AllocatorError(
            f"{VARIABLE}={value!r}: no such file; use auto, system, or the path of a malloc library "
            "such as /usr/lib/x86_64-linux-gnu/libjemalloc.so.2"
        )
    return value


def relaunch(environ: Mapping[str, str] = os.environ) -> None:
    """Re-execute this process with the chosen malloc preloaded; returns if it is, none is chosen, or exec failed.

    The test is on LD_PRELOAD, not on what the loader managed to load, so a
    library the loader refuses (it says why on stderr) cannot cause a loop.
    """
    if not sys.platform.startswith("linux"):  # LD_PRELOAD is the Linux loader's
        return
    library = chosen(environ)
    preload = [entry for entry in _SEPARATORS.split(environ.get("LD_PRELOAD", "")) if entry]
    if library is None or library in preload:
        return
    env = dict(environ, LD_PRELOAD=" ".join([library, *preload]))
    sys.stdout.flush()
    sys.stderr.flush()
    try:
        os.execve(sys.executable, [sys.executable, *sys.orig_argv[1:]], env)
    except OSError as exc:  # only slower on glibc's malloc: not a reason to stop
        print(f"discern: warning: could not restart with {library} preloaded ({exc}); "
              "running on glibc's malloc", file=sys.stderr)


def in_use() -> str:
    """Which malloc this process runs on, read from its memory map: for benchmark reports."""
    try:
        maps = Path("/proc/self/maps").read_text()
    except OSError:
        return "unknown malloc"
    for name in ("jemalloc", "mimalloc", "tcmalloc"):
        found = re.search(rf"\S*lib{name}\S*\.so\S*", maps)
        if found:
            return f"{name} ({found.group(0)}, preloaded)"
    return "glibc malloc"
