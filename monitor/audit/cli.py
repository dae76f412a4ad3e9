"""`discern audit`: list, count and report the disagreements of MCAP logs, or replay them against other rules.

Exit status: 0 done (replay: no decision changed), 1 replay found changed
decisions, 2 a usage or input error (named on stderr, no traceback).
"""

from __future__ import annotations

import argparse
import filecmp
import sys
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Callable, Optional, Sequence

from discern.monitor.config import DEFAULT_LOG_DIR, check_window, path_text
from discern.monitor.log import log_files
from discern.rules.catalog import CatalogError, catalog_digest, load_catalog
from discern.rules.code_digest import reasoning_code_digest
from discern.rules.engine import JURISDICTIONS, jurisdiction_pack
from discern.rules.facts import Params

from .aggregate import Aggregates, Filters, Kind, audit_logs
from .parallel import default_workers
from .runs import copies
from .timefmt import parse_time

EXIT_OK, EXIT_CHANGED, EXIT_USAGE = 0, 1, 2
MAX_WORKERS = 64  # as the monitor's --workers: each is a process, and a replay makes files x workers jobs


class UsageError(ValueError):
    """A mistake on the command line: reported in one line."""


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "audit",
        help="disagreements in MCAP logs: list, aggregate, report; --replay re-decides them with other rules",
        description=(
            "Read the monitor's MCAP logs (files cut short by a crash included), list every veto, override and "
            "fail-safe with its rules and justification, aggregate them, and write HTML/CSV/JSON reports. "
            "With --replay, decide every logged frame again with the current or another rules catalog and "
            "report the decisions that would change."
        ),
    )
    p.add_argument("logs", nargs="*", type=path_text, metavar="LOG",
                   help=f"MCAP log files, or directories of them (default: {DEFAULT_LOG_DIR}, where `discern serve` logs)")
    p.add_argument("--replay", action="store_true", help="re-decide every frame and report what would change")
    p.add_argument(
        "--rules",
        action="append",
        type=path_text,
        metavar="DIR",
        help="with --replay: a driving-rules directory (*.lp) to use instead of the shipped rules/catalog "
        "(the sanity rules stay); repeatable",
    )
    p.add_argument(
        "--add-rules",
        action="append",
        type=path_text,
        metavar="DIR",
        help="with --replay: a directory of driving rules of one's own (*.lp) to use beside the shipped ones (or "
        "--rules); repeatable",
    )
    p.add_argument(
        "--compare-rules",
        action="store_true",
        help="with --replay: decide every frame in full, to also list frames that keep their decision but cite other rules",
    )
    p.add_argument(
        "--param",
        action="append",
        metavar="NAME=VALUE",
        help="with --replay: decide with this reasoning parameter (discern.rules.facts.Params) instead of the one "
        "the log recorded, e.g. --param decel=4; repeatable",
    )
    p.add_argument(
        "--jurisdiction",
        choices=JURISDICTIONS,
        help="with --replay: decide with this rule pack (default: the one the log recorded, else us)",
    )
    p.add_argument(
        "--vehicle", action="append", default=[], metavar="PATTERN", help="only these vehicles (shell pattern)"
    )
    p.add_argument(
        "--since",
        metavar="TIME",
        help="only frames logged at or after TIME (ISO 8601, UTC default; epoch seconds; or epoch ns, as in the CSV)",
    )
    p.add_argument("--until", metavar="TIME", help="only frames logged at or before TIME")
    p.add_argument(
        "--rule", action="append", default=[], metavar="ID", help="only disagreements citing this rule (shell pattern)"
    )
    p.add_argument(
        "--verdict", action="append", default=[], choices=[k.value for k in Kind], help="only this kind of disagreement"
    )
    p.add_argument("--html", type=path_text, metavar="FILE", help="write a self-contained HTML report")
    p.add_argument("--csv", type=path_text, metavar="FILE", help="write the listing as CSV")
    p.add_argument("--json", type=path_text, metavar="FILE", help="write everything as JSON")
    p.add_argument("--workers", type=int, default=default_workers(), help="worker processes (default: one per core)")
    p.add_argument(
        "--window",
        type=float,
        metavar="SECONDS",
        help="with --replay: decide with this history window, as the monitor's --window-s allows (default: the one the "
        "log recorded, else the monitor's default)",
    )
    p.add_argument("-q", "--quiet", action="store_true",
                   help="leave out the line per disagreement (per change with --replay); the totals and tables stay")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    try:
        return _run(args)
    except UsageError as exc:
        print(f"discern audit: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except BrokenProcessPool as exc:
        print(f"discern audit: error: a worker process died ({exc}); --workers 1 runs in this process", file=sys.stderr)
        return EXIT_USAGE


def _run(args: argparse.Namespace) -> int:
    paths = _log_paths(args.logs)
    if not 1 <= args.workers <= MAX_WORKERS:
        raise UsageError(f"--workers must be 1 to {MAX_WORKERS}, got {args.workers}")
    filters = _filters(args)
    _check_outputs(args, paths)
    paths = _read_once(paths)
    if args.replay:
        return _replay(args, paths, filters)
    for flag in ("rules", "add_rules", "window", "jurisdiction", "compare_rules", "param"):
        if getattr(args, flag) not in (None, False):
            raise UsageError(f"--{flag.replace('_', '-')} only applies with --replay")
    from . import report

    tally = audit_logs(paths, filters, args.workers)
    nothing_read = _warn_unreadable(tally.recovery)
    agg = Aggregates.of(tally)
    sys.stdout.write(report.render_text(tally, agg, filters, listing=not args.quiet))
    _write(args.csv, lambda: report.render_csv(tally))
    _write(args.json, lambda: report.render_json(tally, agg, filters))
    _write(args.html, lambda: report.render_html(tally, agg, filters, _rule_text()))
    return EXIT_USAGE if nothing_read else EXIT_OK


def _replay(args: argparse.Namespace, paths: list[str], filters: Filters) -> int:
    if filters.rules or filters.kinds:
        raise UsageError("--rule and --verdict filter the audit listing; a replay takes --vehicle, --since, --until")
    if args.window is not None:
        try:  # as the monitor's --window-s: a replay decides as a monitor could have
            check_window("--window", args.window)
        except ValueError as exc:
            raise UsageError(str(exc)) from None
    from . import replay_report
    from .replay import ReplayCatalog, recorded_setup, replay_logs

    values, problems = Params.overrides(args.param or [])
    if problems:
        raise UsageError("; ".join(problems))
    try:
        recorded = recorded_setup(paths)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    params = {**recorded.params, **values}
    window = args.window if args.window is not None else recorded.window_s
    catalog = ReplayCatalog.of(args.rules, args.jurisdiction or recorded.jurisdiction or "us", params, args.add_rules)
    try:
        loaded = catalog.load()
    except CatalogError as exc:  # names the file and line it could not read
        raise UsageError(f"rules catalog: {exc}") from None
    for warning in loaded.warnings:  # what loads but likely never fires as meant: a misspelt predicate
        print(f"discern audit: warning: rules catalog: {warning}", file=sys.stderr)
    # this version's catalog with the pack the logs were decided with, whatever --jurisdiction replays them with
    shipped = catalog_digest(extra_files=[jurisdiction_pack(recorded.jurisdiction or "us")])
    if recorded.catalog is not None and recorded.catalog != shipped:
        print(f"discern audit: warning: the logs were decided by the rules catalog {recorded.catalog}, not this "
              f"version's ({shipped}): the changes reported include the catalog's own since then", file=sys.stderr)
    other_code = [digest for digest in recorded.code if digest != reasoning_code_digest()]
    if other_code:
        print(f"discern audit: warning: the logs were decided by reasoning code {', '.join(other_code)}, not this "
              f"version's ({reasoning_code_digest()}): the changes reported include the code's own since then",
              file=sys.stderr)
    result = replay_logs(paths, catalog, filters, args.workers, window, args.compare_rules)
    nothing_read = _warn_unreadable(result.tally.recovery)
    sys.stdout.write(replay_report.render_text(result, listing=not args.quiet))
    _write(args.csv, lambda: replay_report.render_csv(result))
    _write(args.json, lambda: replay_report.render_json(result))
    _write(args.html, lambda: replay_report.render_html(result))
    if nothing_read:
        return EXIT_USAGE
    return EXIT_CHANGED if result.tally.changes else EXIT_OK


def _warn_unreadable(files) -> bool:
    """Name each file nothing could be read from; True when that is every file given (no log at all)."""
    states = [f.state for f in files]
    for f, state in zip(files, states):
        if state == "unreadable":
            print(f"discern audit: warning: nothing could be read from {f.path}: {f.stopped_by}", file=sys.stderr)
    return bool(states) and all(state == "unreadable" for state in states)


def _log_paths(logs: Sequence[str]) -> list[str]:
    """The files to read, each checked before a long audit starts: nothing given is passed over unsaid."""
    try:
        return [str(path) for path in log_files(logs or [DEFAULT_LOG_DIR], strict=True)]
    except ValueError as exc:
        unsaid = "" if logs else " (the log `discern serve` writes by default; name the logs to read)"
        raise UsageError(f"{exc}{unsaid}") from None


def _read_once(paths: list[str]) -> list[str]:
    """A monitor run's file given twice, under two paths (the run pulled into two folders), is read once, and said
    so; two files that claim to be the same one of a run but differ are refused: which is its log?"""
    twice = copies(paths)
    for copy, first, place in twice:
        which = f"file {place.index:04d} of monitor {place.monitor}'s run {place.short_run}"
        if not filecmp.cmp(copy, first, shallow=False):
            raise UsageError(f"{copy} and {first} are both {which}, but they differ: give the one to audit")
        print(f"discern audit: note: {copy} is a copy of {first} ({which}): read once", file=sys.stderr)
    dropped = {copy for copy, _, _ in twice}
    return [path for path in paths if path not in dropped]


def _filters(args: argparse.Namespace) -> Filters:
    try:
        # an empty value (an unset shell variable) is a mistake, not the absence of the filter
        since = parse_time(args.since, "--since") if args.since is not None else None
        until = parse_time(args.until, "--until", through=True) if args.until is not None else None
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    if since is not None and until is not None and since > until:
        raise UsageError(f"--since {args.since} is after --until {args.until}")
    for flag in ("vehicle", "rule"):
        if any(not pattern.strip() for pattern in getattr(args, flag)):
            raise UsageError(f"--{flag} is empty: it would match nothing (an unset shell variable?)")
    return Filters(
        vehicles=tuple(args.vehicle),
        since_ns=since,
        until_ns=until,
        rules=tuple(args.rule),
        kinds=tuple(Kind(k) for k in args.verdict),
    )


def _check_outputs(args: argparse.Namespace, logs: list[str]) -> None:
    """Refuse a report that could not be written before the logs are read, not after a long replay.

    Nor may a report overwrite a log: one of those given, however spelt (a link to it, hard or symbolic), or any
    *.mcap (`--csv out/*.mcap`, the shell's glob giving its first log to --csv).
    """
    inputs = {_identity(Path(log)): log for log in logs}
    named: dict[object, str] = {}
    for flag in ("html", "csv", "json"):
        path = getattr(args, flag)
        if not path:
            continue
        target = Path(path)
        key = _identity(target)
        if key in inputs:
            raise UsageError(f"--{flag} {path}: the report would overwrite the log {inputs[key]}")
        if target.name.lower().endswith(".mcap"):
            raise UsageError(
                f"--{flag} {path}: a report named *.mcap could overwrite a log (did a shell glob give --{flag} a log?)"
            )
        if target.is_dir():
            raise UsageError(f"cannot write {path}: Is a directory")
        if not target.parent.is_dir():
            raise UsageError(f"cannot write {path}: No such file or directory")
        if key in named:
            raise UsageError(f"--{named[key]} and --{flag} name the same file {path}: one would overwrite the other")
        named[key] = flag


def _identity(path: Path) -> object:
    """A file however spelt: its device and inode where it exists (a hard link has its file's), else where its
    resolved path would make it."""
    try:
        found = path.stat()
    except OSError:
        return path.resolve()
    return found.st_dev, found.st_ino


def _write(path: Optional[str], render: Callable[[], str]) -> None:
    if not path:
        return
    try:
        Path(path).write_text(render(), encoding="utf-8")
    except OSError as exc:
        raise UsageError(f"cannot write {path}: {exc.strerror or exc}") from None
    print(f"wrote {path}", file=sys.stderr)


def _rule_text() -> dict[str, str]:
    """What each shipped rule says, of every rule pack, for the report's per-rule table."""
    from discern.monitor.protocol import FAILSAFE_RULES

    says = dict(FAILSAFE_RULES)
    for name in JURISDICTIONS:
        says.update((r.id, r.says) for r in load_catalog(extra_files=[jurisdiction_pack(name)]).rules)
    return says

