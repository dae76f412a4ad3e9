"""`discern demo`: the main job in one command, on embedded defaults."""

from __future__ import annotations

import argparse
import io
import os
import signal
import socket
import subprocess
import sys
import threading
from pathlib import Path

from discern.adapters.avcsr import read_dir
from discern.rules.engine import Reasoner
from discern.sanity import window_reasoner
from discern.scenarios import paper_table, runner

from .config import path_text

REPO = Path(__file__).resolve().parents[1]
KITTI = REPO.parent / "shared" / "avcsr" / "kitti"
SCENARIOS = Path(runner.__file__).resolve().parent


def banner(title: str) -> None:
    print(f"\n=== {title} " + "=" * max(0, 70 - len(title)))


def paper(reasoner: Reasoner, kitti: Path) -> bool:
    banner("1. The AUTO-DISCERN paper's KITTI frames")
    if not kitti.is_dir():  # the main job's first part: the demo goes on, and fails at its end
        print(f"NOT RUN: the paper's frames are not at {kitti} (pass --kitti DIR)")
        return False
    rows = paper_table.run(read_dir(kitti), reasoner, repeats=5)
    print(paper_table.format_rows(rows))
    print()
    print(paper_table.format_table(rows))
    return all(r.agrees for r in rows)


def verdict(reasoner: Reasoner) -> None:
    banner("2. A verdict with its justification (KITTI 0051, merge left in heavy traffic)")
    scenario = runner.load(SCENARIOS / "paper" / "kitti_merge_left_heavy_traffic.json")
    frame = scenario.frames[0]
    print(f"the planner proposes: {frame.proposed.value}\n")
    print(reasoner.decide(frame.scene, frame.proposed).justification.text)


def _endpoint() -> str:
    """The monitor's default endpoint, or a free loopback port if something already holds it."""
    from .config import DEFAULT_ENDPOINT, free_port

    host, port = DEFAULT_ENDPOINT.removeprefix("tcp/").rsplit(":", 1)
    with socket.socket() as probe:
        if probe.connect_ex((host, int(port))) != 0:
            return DEFAULT_ENDPOINT
    return f"tcp/127.0.0.1:{free_port()}"


# The demo's monitor logs into a folder of its own under --out, as this monitor id: `discern serve --log-dir out/log`
# (the README's) is the user's, and the audit of step 4 reads only the demo's frames.
LOG_DIR = "demo-log"
MONITOR_ID = "demo"


def own_logs(log_dir: Path) -> list[Path]:
    """The demo monitor's log files in `log_dir`: any other file there is someone else's, to keep and not to audit."""
    from .log.writer import LOG_NAME

    return sorted(p for p in log_dir.glob("*.mcap") if (named := LOG_NAME.match(p.name)) and named.group(1) == MONITOR_ID)


def clear_logs(log_dir: Path) -> None:
    """Delete the demo's own logs of an earlier run, and nothing else."""
    for old in own_logs(log_dir):
        old.unlink()


def sidecar(out: Path) -> list[Path]:
    """A real `discern serve` process (peer mode, loopback, no router) judging an example planner."""
    banner("3. The sidecar: an example planner asks `discern serve` over zenoh; everything goes to MCAP")
    from .example_planner import run

    log_dir = out / LOG_DIR
    clear_logs(log_dir)
    endpoint = _endpoint()
    command = [sys.executable, "-m", "discern.monitor.commands", "serve", "--id", MONITOR_ID, "--listen", endpoint,
               "--log-dir", str(log_dir)]
    env = dict(os.environ, PYTHONUNBUFFERED="1", RUST_LOG="error")
    monitor = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env)
    ready = threading.Event()
    lines: list[str] = []

    def read() -> None:
        for line in monitor.stdout:
            lines.append(line.rstrip())
            if " ready" in line:
                ready.set()
        ready.set()

    threading.Thread(target=read, daemon=True).start()
    try:
        if not ready.wait(60) or monitor.poll() is not None:
            raise RuntimeError("the monitor did not start:\n" + "\n".join(lines))
        print(lines[-1])
        transcript = io.StringIO()
        failsafes = run(vehicle="demo_car", frames=200, rate_hz=50.0, connect=[endpoint], out=transcript)
        frames = transcript.getvalue().splitlines()
        disagreements = [line for line in frames if "-> approve" not in line]
        print(f"{len(frames)} frames judged, {len(disagreements)} disagreements, {failsafes} fail-safe; the first few:")
        print("\n".join(disagreements[:6]))
    finally:
        monitor.send_signal(signal.SIGTERM)
        try:
            monitor.wait(30)
        except subprocess.TimeoutExpired:  # never leave a monitor behind: its log may then end cut short
            print("the monitor did not stop within 30 s of SIGTERM: killed", file=sys.stderr)
            monitor.kill()
            monitor.wait()
    logs = own_logs(log_dir)
    print(f"\nMCAP log: {', '.join(str(p) for p in logs)}")
    return logs


def audit(logs: list[Path], out: Path) -> None:
    banner("4. The offline audit of that log: every disagreement, per rule, with an HTML report")
    from .audit import cli as audit_cli

    parser = argparse.ArgumentParser(prog="discern")
    audit_cli.register(parser.add_subparsers())
    report = out / "audit.html"
    # Step 3 showed the first disagreements; the totals and tables here, every disagreement in the CSV and HTML.
    args = parser.parse_args(["audit", *map(str, logs), "--html", str(report), "--csv", str(out / "audit.csv"), "--quiet"])
    audit_cli.run(args)


PLANNER_PACKAGES = {"torch", "highway_env", "gymnasium", "matplotlib", "tqdm", "ad_rss"}  # pyproject's planner extra


def closed_loop(out: Path, episodes: int) -> int:
    banner("5. Closed loop in highway-env: the torch DQN planner alone, with Discern, with RSS")
    try:
        from discern.scenarios.highway.cli import demo
    except ImportError as exc:
        if (exc.name or "").split(".")[0] not in PLANNER_PACKAGES:  # a bug of Discern's own, not a missing extra
            raise
        print(f"skipped: {exc.name} is not installed; pip install -e '.[planner]'")
        return 0
    return demo(out / "highway", episodes=episodes)


def cmd_demo(args: argparse.Namespace) -> int:
    from .cli import UserError

    out = Path(args.out)
    # Refused before anything runs: the closed loop would refuse these only after minutes of the rest.
    if args.episodes < 1:
        raise UserError(f"--episodes must be at least 1, got {args.episodes}")
    if args.kitti is not None and not Path(args.kitti).is_dir():  # named on purpose: a typo must not skip the table
        raise UserError(f"--kitti {args.kitti}: not a directory of AV-CSR frame files")
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out}: not a directory")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UserError(f"--out {out}: cannot create: {exc.strerror or exc}") from None
    reasoner = window_reasoner()
    ok = paper(reasoner, Path(args.kitti) if args.kitti is not None else KITTI)
    verdict(reasoner)
    audit(sidecar(out), out)
    loop = closed_loop(out, args.episodes)
    return 0 if ok and loop == 0 else 1


def register(sub) -> None:
    demo = sub.add_parser("demo", help="run the main job: paper table, a verdict, the sidecar, the closed loop")
    demo.add_argument("--kitti", type=path_text, default=None,
                      help=f"directory of the paper's AV-CSR frame files (default: {KITTI}; without them the demo fails)")
    demo.add_argument("--out", default="out",
                      help=f"directory for logs ({LOG_DIR}/), reports and plots (default: %(default)s)")
    demo.add_argument("--episodes", type=int, default=3,
                      help="closed-loop episodes per variant and fault set (default: %(default)s)")
    demo.set_defaults(func=cmd_demo)
