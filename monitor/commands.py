"""CLI subcommands of the sidecar: serve, status, router, planner-example.

`register(subparsers)` adds them to the `discern` command (monitor/cli.py).
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import time
from typing import Optional

from discern.rules.engine import JURISDICTIONS

from . import keys
from .entry import STOP_SIGNALS
from .config import (
    BUDGET_MAX_MS,
    DEFAULT_ENDPOINT,
    DEFAULT_LOG_DIR,
    LOG_FLUSH_MAX_S,
    LOG_FLUSH_MIN_S,
    LOG_ROTATE_MIN_BYTES,
    LOG_ROTATE_MIN_S,
    MAX_PAYLOAD_BYTES,
    MIB,
    MIN_PAYLOAD_BYTES,
    STATUS_PERIOD_MAX_S,
    STATUS_PERIOD_MIN_S,
    LogSettings,
    MonitorConfig,
    ZenohSettings,
    check_number,
    default_monitor_id,
    path_arg,
    without_rust_locations,
)

log = logging.getLogger("discern.monitor")


def register(subparsers) -> None:
    serve = subparsers.add_parser(
        "serve",
        help="run the sidecar monitor: judge proposals arriving over zenoh",
        description="Serve verdicts over zenoh on discern/<vehicle>/{proposal,check} -> discern/<vehicle>/verdict.",
    )
    _zenoh_arguments(serve, listen_default=DEFAULT_ENDPOINT)
    serve.add_argument("--id", dest="monitor_id", default=None, help="monitor id, for its status key (default: host-pid)")
    serve.add_argument("--vehicles", default="*", help="serve only these vehicles, e.g. 'fleet_a_*' (default: all)")
    serve.add_argument(
        "--budget-ms",
        type=float,
        default=50.0,
        help=f"decision budget, above 0 and at most {BUDGET_MAX_MS:g}; later = fail-safe (default: 50)",
    )
    serve.add_argument("--window-s", type=float, default=2.0, help="per-vehicle history window (default: 2)")
    serve.add_argument("--max-payload-bytes", type=int, default=MAX_PAYLOAD_BYTES,
                       help=f"larger proposals are refused; at least {MIN_PAYLOAD_BYTES} (default: %(default)s)")
    serve.add_argument("--workers", type=int, default=1, help="decision worker processes (default: 1)")
    serve.add_argument("--shadow", action="store_true", help="shadow mode: veto, never override")
    serve.add_argument("--jurisdiction", default="us", choices=JURISDICTIONS, help="rule pack (traffic side, limits)")
    serve.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                       help="set a reasoning parameter for every vehicle it serves (discern.rules.facts.Params), "
                       "e.g. --param decel=4 for a fleet that brakes at 4 m/s²; repeatable; kept in the log's metadata")
    logging_to = serve.add_mutually_exclusive_group()
    logging_to.add_argument("--log-dir", type=path_arg, default=DEFAULT_LOG_DIR,
                            help=f"write the MCAP log here (default: {DEFAULT_LOG_DIR}, under the working directory)")
    logging_to.add_argument("--no-log", action="store_true", help="do not log (a monitor logs by default)")
    serve.add_argument(
        "--log-rotate-mb",
        type=float,
        help=f"start a new log file past this size, at least {LOG_ROTATE_MIN_BYTES / MIB:g} "
        f"(default: {LogSettings.rotate_bytes / MIB:g})",
    )
    serve.add_argument(
        "--log-rotate-s",
        type=float,
        help=f"start a new log file past this age, at least {LOG_ROTATE_MIN_S:g} (default: {LogSettings.rotate_seconds:g})",
    )
    serve.add_argument(
        "--log-flush-s",
        type=float,
        help=f"close a chunk this often, bounding crash loss; {LOG_FLUSH_MIN_S:g} to {LOG_FLUSH_MAX_S:g} "
        f"(default: {LogSettings.flush_seconds:g})",
    )
    serve.add_argument(
        "--log-keep-mb",
        type=float,
        help="delete this monitor's oldest log files (those named with its --id) when they take more than this; "
        "at least --log-rotate-mb (default: keep every file)",
    )
    serve.add_argument("--log-compression", choices=("zstd", "none"),
                       help=f"compression of the log's chunks (default: {LogSettings.compression})")
    serve.add_argument(
        "--status-period-s",
        type=float,
        default=1.0,
        help=f"status record period in the log, {STATUS_PERIOD_MIN_S:g} to {STATUS_PERIOD_MAX_S:g} (default: 1)",
    )
    serve.add_argument(
        "--test-only-decision-delay-ms",
        type=float,
        default=0.0,
        help=argparse.SUPPRESS,  # TEST ONLY: sleep this long before deciding each batch (docs/protocol.md)
    )
    serve.add_argument("-v", "--verbose", action="store_true", help="log every refused proposal (else at most one a second of each kind, "
                       "then how many more) and each log file opened or deleted")
    serve.set_defaults(func=cmd_serve)

    status = subparsers.add_parser("status", help="ask running monitors for their counts and latency")
    _zenoh_arguments(status, listen_default=None, connect_default=DEFAULT_ENDPOINT)
    status.add_argument("--id", dest="monitor_id", default="*", help="monitor id (default: all that answer)")
    status.add_argument("--timeout", type=float, default=2.0, help="seconds to wait for answers (default: 2)")
    status.add_argument("--json", action="store_true",
                        help="print each monitor's status as one JSON object per line (JSON Lines)")
    status.set_defaults(func=cmd_status)

    router = subparsers.add_parser(
        "router", help="run a zenoh router (stand-in for zenohd) that monitors and planners connect to"
    )
    _zenoh_arguments(router, listen_default=DEFAULT_ENDPOINT, modes=False)
    router.set_defaults(func=cmd_router)

    from .example_planner import EXIT_STATUS, add_arguments

    planner = subparsers.add_parser("planner-example", help="an example planner asking the monitor each frame",
                                    description="An example planner: drives a made-up highway scene and asks the "
                                    "monitor about a proposed action each frame.", epilog=EXIT_STATUS)

    add_arguments(planner)
    planner.set_defaults(func=cmd_planner_example)


def _zenoh_arguments(parser, *, listen_default, connect_default=None, modes=True) -> None:
    if modes:
        parser.add_argument("--mode", choices=("peer", "client", "router"), default=None, help="zenoh mode (default: peer)")
    listens = f"{listen_default}; none with --mode client" if listen_default and modes else listen_default or "none"
    parser.add_argument("--listen", action="append", metavar="ENDPOINT", help=f"endpoint to listen on (default: {listens})")
    parser.add_argument(
        "--connect",
        action="append",
        metavar="ENDPOINT",
        help=f"router or peer endpoint to connect to, repeatable (default: {connect_default or 'none'})",
    )
    parser.add_argument("--zenoh-config", type=path_arg, default=None, help="zenoh JSON5 config file (TLS, access control...)")
    parser.add_argument("--multicast-scouting", action="store_true", default=None, help="find peers by UDP multicast")
    parser.set_defaults(_connect_default=connect_default)


def _zenoh_settings(args) -> ZenohSettings:
    connect = args.connect
    if connect is None and args._connect_default and args.zenoh_config is None:
        connect = [args._connect_default]
    return ZenohSettings(
        mode=getattr(args, "mode", None),
        listen=args.listen,
        connect=connect,
        config_file=args.zenoh_config,
        multicast_scouting=args.multicast_scouting,
    )


def _zenoh_refused(args, exc: Exception) -> str:
    """zenoh's own message names the problem, not the flag that caused it: name the settings it was given."""
    given = [f"--{flag.replace('_', '-')} {' '.join(value) if isinstance(value, list) else value}"
             for flag, value in (("listen", args.listen), ("connect", args.connect), ("zenoh_config", args.zenoh_config))
             if value]
    hint = ""
    if "No peer specified" in str(exc):  # a client with nowhere to connect: zenoh names scouting, not the flag
        hint = ": a client must be told where its router or peers are: --connect ENDPOINT (or connect.endpoints)"
    return f"zenoh could not open the session{' (' + '; '.join(given) + ')' if given else ''}: {exc}{hint}"


def _fail(command: str, message: str) -> int:
    """One line for the user; zenoh's errors carry Rust source locations they have no use for."""
    print(f"discern {command}: error: {without_rust_locations(message)}", file=sys.stderr)
    return 2


class StopAsked:
    """Asked for by SIGTERM, SIGINT or SIGHUP: a plain flag, which a signal handler may set safely.

    A handler setting a threading.Event deadlocked: a signal delivered to one of zenoh's threads runs its handler on
    the main thread at its next bytecode, which could be inside that Event's own wait, holding the lock `set` takes;
    the monitor then ran on and never stopped (seen with `kill -TERM` on a serve started in the background).
    """

    def __init__(self):
        self.asked = False

    def wait(self, seconds: float) -> bool:
        """Whether a stop was asked for, after `seconds`."""
        time.sleep(seconds)
        return self.asked


def _stop_on_signal() -> StopAsked:
    """Set on SIGTERM, SIGINT or SIGHUP: from before the monitor starts, so that a stop while it starts is a clean one."""
    stop = StopAsked()

    def ask(*_) -> None:
        stop.asked = True

    for sig in STOP_SIGNALS:
        if sig == signal.SIGHUP and signal.getsignal(sig) == signal.SIG_IGN:
            continue  # started under nohup, to outlive its terminal: it does
        signal.signal(sig, ask)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP_SIGNALS)  # one that came while it started: held till now
    return stop


LOG_FLAGS = {"log_rotate_mb": "--log-rotate-mb", "log_rotate_s": "--log-rotate-s", "log_flush_s": "--log-flush-s",
             "log_keep_mb": "--log-keep-mb", "log_compression": "--log-compression"}


def _log_settings(args) -> Optional[LogSettings]:
    """The log's settings: LogSettings' defaults, with those given; None with --no-log, which takes none."""
    given = [flag for dest, flag in LOG_FLAGS.items() if getattr(args, dest) is not None]
    if args.no_log:
        if given:
            raise ValueError(f"--no-log leaves nothing for {', '.join(given)} to set: give a log or leave them out")
        return None
    settings = LogSettings(directory=args.log_dir)
    # int() of NaN or infinity would raise first, without naming the flag.
    for dest, field in (("log_rotate_mb", "rotate_bytes"), ("log_keep_mb", "keep_bytes")):
        megabytes = getattr(args, dest)
        if megabytes is not None:
            check_number(LOG_FLAGS[dest], megabytes, LOG_ROTATE_MIN_BYTES / MIB, unit=" MiB")
            setattr(settings, field, int(megabytes * MIB))
    for dest, field in (("log_rotate_s", "rotate_seconds"), ("log_flush_s", "flush_seconds"),
                        ("log_compression", "compression")):
        if getattr(args, dest) is not None:
            setattr(settings, field, getattr(args, dest))
    return settings


def cmd_serve(args) -> int:
    from .decision_pool import WorkerStartError
    from .server import MonitorServer

    # The worker holds the GIL while it reasons; the default 5 ms switch interval would let it
    # sit on arriving proposals that long. 0.5 ms keeps the zenoh threads' latency low.
    sys.setswitchinterval(0.0005)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
    )
    stop = _stop_on_signal()
    try:
        config = MonitorConfig(
            monitor_id=default_monitor_id() if args.monitor_id is None else args.monitor_id,
            zenoh=_zenoh_settings(args),
            vehicles=args.vehicles,
            budget_ms=args.budget_ms,
            window_s=args.window_s,
            max_payload_bytes=args.max_payload_bytes,
            workers=args.workers,
            shadow=args.shadow,
            jurisdiction=args.jurisdiction,
            params=tuple(args.param),
            log=_log_settings(args),
            status_period_s=args.status_period_s,
            test_decision_delay_ms=args.test_only_decision_delay_ms,
        )
        server = MonitorServer(config)
        server.start()
    except (ValueError, OSError, ImportError, WorkerStartError) as exc:
        return _fail("serve", str(exc))
    except Exception as exc:  # zenoh refuses an endpoint or config: say so, no traceback
        return _fail("serve", _zenoh_refused(args, exc))
    try:
        chunk = server.vehicles_chunk
        print(
            f"discern serve: monitor {config.monitor_id} ready; "
            f"listening on {', '.join(server.listen_endpoints) or 'nothing'}; "
            f"serving {keys.proposal_key(chunk)} and {keys.check_key(chunk)}; budget {config.budget_ms:g} ms"
            + (f"; logging to {config.log.directory}" if config.log else "; not logging (--no-log)"),
            flush=True,
        )
        while not stop.wait(0.5):
            pass
    finally:
        server.stop()
    s = server.status()
    print(
        f"discern serve: stopped after {s.proposals} proposals: {s.approvals} approved, {s.overrides} overridden, "
        f"{s.vetoes} vetoed, {s.failsafes} fail-safe, {s.errors} refused",
        flush=True,
    )
    return 0


def cmd_status(args) -> int:
    import zenoh
    from pydantic import ValidationError

    from discern.rules.scene import describe_errors

    from .client import TIMEOUT_MAX_S
    from .status import MonitorStatus

    try:
        selector = keys.status_key(keys.monitor_selector(args.monitor_id))
        check_number("--timeout", args.timeout, 0, TIMEOUT_MAX_S, unit=" s", above=True)  # zenoh overflows past that
        session = zenoh.open(_zenoh_settings(args).to_zenoh(default_listen=[]))
    except ValueError as exc:
        return _fail("status", str(exc))
    except Exception as exc:
        return _fail("status", _zenoh_refused(args, exc))
    answered = found = 0
    ids: set[str] = set()
    heard: list = []
    try:
        deadline = time.monotonic() + args.timeout
        # A freshly opened peer needs a moment to learn the routes: retry until something answers. Every reply is
        # wanted (no consolidation): zenoh would otherwise keep one of two monitors started with the same id.
        while not answered and time.monotonic() < deadline:
            for reply in session.get(selector, consolidation=zenoh.ConsolidationMode.NONE,
                                     timeout=max(0.1, deadline - time.monotonic())):
                if reply.ok is None:
                    continue
                answered += 1
                try:
                    status = MonitorStatus.model_validate_json(reply.ok.payload.to_bytes(), strict=True)
                except ValidationError as exc:  # not a monitor of this version: say who, show the others
                    print(
                        f"discern status: warning: skipped an unreadable status from {reply.ok.key_expr} "
                        f"(zenoh id {reply.replier_id.zid if reply.replier_id else 'unknown'}): "
                        f"{'; '.join(describe_errors(exc).splitlines())}",
                        file=sys.stderr,
                        flush=True,
                    )
                    continue
                found += 1
                if status.monitor_id in ids:
                    print(f"discern status: warning: more than one monitor answers as {status.monitor_id}: give each "
                          "its own --id", file=sys.stderr, flush=True)
                ids.add(status.monitor_id)
                print(status.model_dump_json() if args.json else _status_text(status), flush=True)
                heard.append(status)
            if not answered:
                time.sleep(0.1)
    finally:
        session.close()
    for i, first in enumerate(heard):
        for second in heard[i + 1:]:
            if keys.filters_overlap(first.vehicles_filter, second.vehicles_filter):
                warning = keys.overlap_warning(first.monitor_id, first.vehicles_filter, second.monitor_id,
                                               second.vehicles_filter)
                print(f"discern status: warning: {warning}", file=sys.stderr, flush=True)
    if not answered:
        return _fail("status", f"no monitor answered on {selector} within {args.timeout:g} s")
    if not found:
        return _fail("status", f"no readable status on {selector}: {answered} unreadable")
    return 0


def _status_text(s) -> str:
    lat = s.latency_ms
    latency = (
        f"latency p50 {lat.p50_ms} ms, p90 {lat.p90_ms} ms, p99 {lat.p99_ms} ms, max {lat.max_ms} ms"
        if lat.samples
        else "no decisions yet"
    )
    errors = ", ".join(f"{k} {v}" for k, v in sorted(s.errors_by_kind.items())) or "none"
    waiting = (f"open {s.open_proposals} (received, not answered yet), the oldest for {s.oldest_open_ms:g} ms"
               if s.open_proposals else "none open")
    return (
        f"monitor {s.monitor_id} (vehicles {s.vehicles_filter}, up {s.uptime_s:.0f} s, budget {s.budget_ms:g} ms)\n"
        f"  proposals {s.proposals}: {s.approvals} approved, {s.vetoes} vetoed, {s.overrides} overridden by the rules, "
        f"{s.failsafes} fail-safe (deadline {s.deadline_misses}, internal {s.internal_errors}), "
        f"refused {s.errors} ({errors})\n"
        f"  {latency}\n"
        f"  {waiting}\n"
        f"  vehicles {s.vehicles}, log records {s.log_records} (dropped {s.log_dropped})"
    )


def cmd_router(args) -> int:
    import zenoh

    from .config import check_listen_ports, listen_endpoints, listens_by_default
    from .router import router_config

    stop = _stop_on_signal()
    try:
        config = router_config(_zenoh_settings(args))
        listen = listen_endpoints(config)
        check_listen_ports(listen, defaulted=listens_by_default(config))
        session = zenoh.open(config)
    except ValueError as exc:
        return _fail("router", str(exc))
    except Exception as exc:
        return _fail("router", _zenoh_refused(args, exc))
    try:
        print(f"discern router: zenoh router {session.zid()} ready; listening on {', '.join(listen)}", flush=True)
        while not stop.wait(0.5):
            pass
    finally:
        session.close()
    return 0


def cmd_planner_example(args) -> int:
    from .example_planner import run_arguments

    try:
        failsafes = run_arguments(args)
    except ValueError as exc:
        return _fail("planner-example", str(exc))
    return 1 if failsafes else 0


def main(argv=None) -> int:
    """The monitor's subcommands on their own: `python -m discern.monitor.commands serve ...`."""
    parser = argparse.ArgumentParser(prog="discern")
    register(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
