import os
import subprocess
import sys
from pathlib import Path

import pytest

from discern.monitor import allocator
from discern.monitor.allocator import AllocatorError, chosen

DISCERN = Path(sys.executable).with_name("discern")
SHOW = (
    "import os; print('started', flush=True)\n"
    "from discern.monitor.allocator import relaunch; relaunch()\n"
    "print('LD_PRELOAD=' + os.environ.get('LD_PRELOAD', ''))\n"
)


def mapped(name: str) -> str:
    """The path of a library this Python process already maps (libc, libm): harmless to preload."""
    for line in Path("/proc/self/maps").read_text().splitlines():
        if f"/{name}.so" in line or f"/{name}-" in line:
            return line.split()[-1]
    pytest.fail(f"no {name} in this process's memory map")


def run(code: str, **env: str) -> subprocess.CompletedProcess:
    environ = {k: v for k, v in os.environ.items() if k not in ("LD_PRELOAD", allocator.VARIABLE)}
    return subprocess.run([sys.executable, "-c", code], env={**environ, **env}, capture_output=True, text=True,
                          timeout=60)


def test_system_keeps_glibc_malloc():
    assert chosen({allocator.VARIABLE: "system"}) is None


def test_auto_takes_the_first_library_that_exists(tmp_path, monkeypatch):
    present = tmp_path / "libjemalloc.so.2"
    present.write_bytes(b"")
    monkeypatch.setattr(allocator, "LIBRARIES", (str(tmp_path / "missing.so"), str(present)))
    assert chosen({}) == str(present)
    assert chosen({allocator.VARIABLE: "auto"}) == str(present)


def test_auto_without_any_library_keeps_glibc_malloc(tmp_path, monkeypatch):
    monkeypatch.setattr(allocator, "LIBRARIES", (str(tmp_path / "missing.so"),))
    assert chosen({}) is None


def test_a_missing_library_is_named_in_the_error(tmp_path):
    with pytest.raises(AllocatorError, match=r"DISCERN_MALLOC='.*nowhere\.so': no such file"):
        chosen({allocator.VARIABLE: str(tmp_path / "nowhere.so")})


def test_relaunch_runs_the_process_again_once_with_the_library_preloaded():
    library = mapped("libc")
    result = run(SHOW, DISCERN_MALLOC=library)
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines() == ["started", "started", f"LD_PRELOAD={library}"]


def test_a_process_with_the_library_preloaded_is_not_relaunched():
    library = mapped("libc")
    result = run(SHOW, DISCERN_MALLOC=library, LD_PRELOAD=f"other.so:{library}")
    assert result.stdout.splitlines() == ["started", f"LD_PRELOAD=other.so:{library}"]


def test_relaunch_keeps_what_ld_preload_already_had():
    library, other = mapped("libc"), mapped("libm")
    result = run(SHOW, DISCERN_MALLOC=library, LD_PRELOAD=other)
    assert result.stdout.splitlines() == ["started", "started", f"LD_PRELOAD={library} {other}"]


def test_a_relaunch_that_cannot_start_warns_and_goes_on():
    code = "import sys; sys.executable = '/nonexistent/python'\n" + SHOW
    result = run(code, DISCERN_MALLOC=mapped("libc"))
    assert result.returncode == 0
    assert result.stdout.splitlines() == ["started", "LD_PRELOAD="]
    assert "discern: warning: could not restart with" in result.stderr and "glibc's malloc" in result.stderr


def test_system_does_not_relaunch():
    result = run(SHOW, DISCERN_MALLOC="system")
    assert result.stdout.splitlines() == ["started", "LD_PRELOAD="]


def test_the_discern_command_refuses_a_bad_allocator_in_one_line(tmp_path):
    environ = {**os.environ, allocator.VARIABLE: str(tmp_path / "nowhere.so")}
    result = subprocess.run([str(DISCERN), "catalog"], env=environ, capture_output=True, text=True, timeout=60)
    assert result.returncode == 2
    assert result.stderr.startswith("discern: error: DISCERN_MALLOC=") and "Traceback" not in result.stderr
