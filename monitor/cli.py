"""The `discern` command: one argparse tree; each part contributes its subcommands."""

from __future__ import annotations

import argparse
import functools
import importlib
import json
import os
import sys
from pathlib import Path
from typing import Optional, Sequence

from pydantic import ValidationError

from discern.rules.catalog import CatalogError, catalog_dirs, load_driving_rules
from discern.rules.engine import JURISDICTIONS, Reasoner, jurisdiction_pack
from discern.rules.fact_text import one_fact_a_line
from discern.rules.facts import Params
from discern.rules.render import render_html, render_json
from discern.rules.scene import JSON_AS_SCHEMA, Action, Proposal, Scene, describe_errors
from discern.sanity import default_providers, reasoner_for, window_reasoner

from .config import MAX_PAYLOAD_BYTES, check_max_payload_bytes, path_text
from .protocol import MAX_ERRORS_NAMED

# Parts that add subcommands through a `register(subparsers)` function.
PARTS: list[str] = [
    "discern.monitor.demo",
    "discern.monitor.commands",
    "discern.monitor.audit.cli",
    "discern.scenarios.highway.cli",
]


class UserError(Exception):
    """A mistake in what the user gave us: reported in one line, no traceback."""


def _read_json(path: str, limit: int) -> tuple[str, dict]:
    """The file's text, to validate as the schema reads JSON, and its object, to tell what kind of file it is.

    At most `limit` bytes, the monitor's payload limit: more is no message it takes, and /dev/zero has no end.
    """
    try:
        with open(path, "rb") as stream:
            data = stream.read(limit + 1)
    except OSError as exc:
        raise UserError(f"{path}: cannot read: {exc.strerror}") from None
    if len(data) > limit:
        raise UserError(f"{path}: larger than {limit} bytes, the monitor's limit for a proposal "
                        "(--max-payload-bytes)")
    try:
        text = data.decode("utf-8-sig")  # a byte-order mark, as some Windows editors write, is no error
    except UnicodeDecodeError as exc:
        raise UserError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    try:
        data = json.loads(text, parse_constant=lambda c: float(c))
    except json.JSONDecodeError as exc:
        raise UserError(f"{path}: invalid JSON at line {exc.lineno} column {exc.colno}: {exc.msg}") from None
    except RecursionError:
        raise UserError(f"{path}: JSON nested too deeply to be a scene") from None
    except ValueError:  # Python refuses to convert an integer of over 4300 digits, far past any field's bound
        raise UserError(f"{path}: a number in the JSON has too many digits to be a scene's") from None
    if not isinstance(data, dict):
        raise UserError(f"{path}: expected a JSON object (a scene or a proposal)")
    return text, data


def add_rules_options(parser: argparse.ArgumentParser, verb: str) -> None:
    """--rules replaces the shipped driving rules; --add-rules tries rules of one's own beside them, unedited."""
    parser.add_argument("--rules", type=path_text, action="append", metavar="DIR",
                        help=f"{verb} the driving rules in this directory instead of the shipped ones; repeatable")
    parser.add_argument("--add-rules", type=path_text, action="append", metavar="DIR",
                        help=f"{verb} the driving rules in this directory too, beside the shipped ones (or --rules); "
                             "repeatable")


def _reasoner(args: argparse.Namespace, jurisdiction: Optional[str] = None) -> Reasoner:
    """The shipped catalog, or `--rules DIR` in place of the driving rules, with `--add-rules DIR` beside either;
    sanity rules and the pack still apply.

    `--param NAME=VALUE` sets the reasoning parameters (a vehicle that brakes less firmly, a longer headway).
    """
    jurisdiction = jurisdiction or getattr(args, "jurisdiction", "us")
    values, problems = Params.overrides(getattr(args, "param", None) or [])
    if problems:
        raise UserError("; ".join(problems))
    params = Params(**values)
    try:
        replaced, added = getattr(args, "rules", None) or [], getattr(args, "add_rules", None) or []
        if replaced or added:
            directories = [Path(d) for d in replaced] or [catalog_dirs()[0]]
            providers = default_providers()  # the window the sanity rules read: the loader checks their settings by it
            catalog = load_driving_rules(directories + [Path(d) for d in added],
                                         extra_files=[jurisdiction_pack(jurisdiction)], providers=providers)
            reasoner = Reasoner(catalog=catalog, params=params, providers=providers, jurisdiction=jurisdiction)
        else:
            reasoner = (window_reasoner(params=params, jurisdiction=jurisdiction) if values
                        else reasoner_for(jurisdiction))
    except (CatalogError, ValueError) as exc:
        raise UserError(str(exc)) from None
    for warning in reasoner.catalog.warnings:  # what loads but likely never fires as meant: a misspelt predicate
        print(f"discern {args.command}: warning: {warning}", file=sys.stderr)
    return reasoner


def cmd_check(args: argparse.Namespace) -> int:
    try:
        check_max_payload_bytes(args.max_payload_bytes)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    if Path(args.scene).suffix == ".pl":
        raise UserError(f"{args.scene}: AV-CSR frames, not a scene: run them with `discern scenarios run {args.scene}`")
    text, data = _read_json(args.scene, args.max_payload_bytes)
    try:
        if "frames" in data and "scene" not in data:
            raise UserError(f"{args.scene}: a scenario file, not a scene: `discern scenarios run {args.scene}` "
                            "decides its frames and checks their expected verdicts")
        kind = "proposal" if "scene" in data else "scene"
        if kind == "proposal":
            # The whole file is checked, its own action too, as the monitor would check it: --proposed only
            # judges another action in a message the monitor takes.
            proposal = Proposal.model_validate_json(text, **JSON_AS_SCHEMA)
            scene, vehicle = proposal.scene, proposal.vehicle
            action = Action(args.proposed) if args.proposed else proposal.action
        else:
            if not args.proposed:
                raise UserError(f"{args.scene}: a bare scene needs --proposed ACTION")
            scene, action, vehicle = Scene.model_validate_json(text, **JSON_AS_SCHEMA), Action(args.proposed), "ego"
    except ValidationError as exc:
        raise UserError(f"{args.scene}: invalid {kind}:\n{describe_errors(exc, limit=MAX_ERRORS_NAMED)}") from None
    reasoner = _reasoner(args)
    if args.explain == "facts":  # what clingo is given for this frame, for a rule's author to write against
        facts = reasoner.frame_facts(scene, action, ())
        _print(one_fact_a_line(facts))
        return 0
    verdict = reasoner.decide(scene, action, explain=True, shadow=args.shadow, vehicle=vehicle)
    if args.explain == "json":
        output = render_json(verdict)
    elif args.explain == "html":
        output = render_html(verdict)
    else:
        output = verdict.justification.full_text() if args.explain == "full" else verdict.justification.text
        if verdict.notes:
            output += "\nnotes:\n" + "\n".join(f"  {n}" for n in verdict.notes)
    if args.out is not None:
        try:
            Path(args.out).write_text(output, encoding="utf-8")
        except OSError as exc:
            raise UserError(f"--out {args.out}: cannot write: {exc.strerror or exc}") from None
        print(f"{verdict.justification.summary}\nwritten to {args.out}")
    else:
        _print(output)
    return 0


def _print(text: str) -> None:
    """Print and flush, so that a full disk (`> /dev/full`) is one error line, not a traceback at exit."""
    try:
        print(text, flush=True)
    except BrokenPipeError:
        raise
    except OSError as exc:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # what is left in the buffer goes nowhere
        raise UserError(f"cannot write the output: {exc.strerror or exc}") from None


def cmd_catalog(args: argparse.Namespace) -> int:
    catalog = _reasoner(args).catalog
    rules = catalog.rules if args.all else catalog.driving_rules()
    if args.json:
        print(json.dumps([r.__dict__ for r in rules], indent=2))
        return 0
    width = max(len(r.id) for r in rules)
    current_file = None
    for rule in rules:
        if rule.file != current_file:
            current_file = rule.file
            print(f"\n# {Path(rule.file).name}")
        print(f"{rule.id:<{width}}  {rule.says}\n{'':<{width}}  source: {rule.source}")
    kind = "rules" if args.all else "driving and sanity rules (definitions: --all)"
    print(f"\n{len(rules)} {kind}; {len(catalog.templates)} predicate templates")
    return 0


def _scenario_inputs(paths: Sequence[str]) -> tuple[list[Path], list[Path]]:
    """The AV-CSR frame files (.pl) and scenario files (.json) that the given files and directories hold.

    A directory is searched, subdirectories too, for both: its .pl files make the paper's table, its .json files
    run as scenarios; one kind never hides the other.
    """
    frames: list[Path] = []
    scenarios: list[Path] = []
    for name in paths:
        path = Path(name)
        if path.is_dir():
            from discern.scenarios.runner import scenario_files

            found_frames, found_scenarios = sorted(path.rglob("*.pl")), scenario_files(path)
            if not found_frames and not found_scenarios:
                raise UserError(f"{path}: no scenario files (*.json) and no AV-CSR frame files (*.pl)")
            frames += found_frames
            scenarios += found_scenarios
        elif not path.exists():
            raise UserError(f"{path}: no such file or directory")
        elif path.suffix == ".pl":
            frames.append(path)
        elif path.suffix == ".json":
            scenarios.append(path)
        else:
            raise UserError(f"{path}: not a scenario file (.json) or an AV-CSR frame file (.pl)")
    return frames, scenarios


def _indented(text: str) -> str:
    return "\n".join("        " + line for line in text.splitlines())


def _repeats(text: str) -> int:
    """--repeats: how many timed runs give a frame's median; fewer than one gives no time at all."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number of runs, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1 (the time is the median of that many runs), got {value}")
    return value


def cmd_scenarios(args: argparse.Namespace) -> int:
    frame_files, scenario_files = _scenario_inputs(args.paths)
    ok = True
    unreadable_frames: list[str] = []
    if frame_files:
        from discern.adapters.avcsr import AvcsrError, read_file
        from discern.scenarios import paper_table

        frames = []
        for path in frame_files:  # a broken file is named, and the others still make the table
            try:
                frames += read_file(path)
            except AvcsrError as exc:
                unreadable_frames.append(str(exc))
        if frames:
            rows = paper_table.run(frames, _reasoner(args), repeats=args.repeats)
            print(paper_table.format_rows(rows))
            print()
            print(paper_table.format_table(rows))
            for row in rows if args.explain else ():
                print(f"\n{row.frame.scenario} frame {row.frame.frame}:\n{_indented(row.verdict.justification.text)}")
            ok = all(r.agrees is not False for r in rows)  # a frame without expected_action is not scored
        for reason in unreadable_frames:
            print(f"discern {args.command}: error: {reason}", file=sys.stderr)
        if unreadable_frames and len(frame_files) > 1:
            print(f"{len(unreadable_frames)} of {len(frame_files)} AV-CSR files not read")
    if scenario_files:
        from discern.scenarios import runner

        if frame_files:
            print()
        # One reasoner per jurisdiction for all files: loading a --rules catalog per file took 30 times longer.
        outcomes, unreadable = runner.run_files(scenario_files, functools.lru_cache(maxsize=None)(lambda j: _reasoner(args, j)))
        for outcome in outcomes:
            status = "FAIL" if not outcome.passed else "pass" if outcome.checked else "hist"
            summary = outcome.verdict.justification.summary if outcome.verdict else "no verdict"
            print(f"{status}  {outcome.scenario} #{outcome.index}: {summary}")
            for problem in outcome.problems:
                print(f"        {problem}")
            if args.explain and outcome.verdict:
                print(_indented(outcome.verdict.justification.text))
        failed = sum(not o.passed for o in outcomes)
        history = sum(o.passed and not o.checked for o in outcomes)
        for reason in unreadable:
            print(f"discern {args.command}: error: {reason}", file=sys.stderr)
        cannot = f", {len(unreadable)} file{'s' if len(unreadable) > 1 else ''} not read" if unreadable else ""
        kept = f", {history} history frame{'s' if history != 1 else ''} (nothing expected)" if history else ""
        print(f"{len(outcomes) - failed - history} passed, {failed} failed{kept}{cannot}")
        if unreadable:
            return 2  # bad input, as for one file alone
        ok = ok and failed == 0
    if unreadable_frames:
        return 2
    return 0 if ok else 1


def cmd_schema(args: argparse.Namespace) -> int:
    from discern.rules.schema import write_schemas

    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out}: not a directory (the schemas are written into one)")
    try:
        written = write_schemas(out)
    except OSError as exc:
        raise UserError(f"--out {out}: cannot write the schemas: {exc.strerror or exc}") from None
    for path in written:
        print(path)
    return 0


class CommandParser(argparse.ArgumentParser):
    """A subcommand's parser: an argument it does not know is refused with its usage and name (`discern serve:
    error: ...`), where argparse leaves it to the top parser, whose usage names no subcommand."""

    def parse_known_args(self, args=None, namespace=None):
        namespace, extra = super().parse_known_args(args, namespace)
        if extra:
            self.error(f"unrecognized arguments: {' '.join(extra)}")
        return namespace, extra


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="discern", description="Explainable safety cross-checker for ML driving planners.")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND", parser_class=CommandParser)

    check = sub.add_parser("check", help="judge a proposed action in a scene and explain the verdict")
    check.add_argument("scene", type=path_text, help="scene JSON (or a proposal JSON with action and scene)")
    check.add_argument("--proposed", choices=[a.value for a in Action], help="the planner's proposed action; with a proposal file, judged instead of the file's own (what if it had "
                       "proposed this?), which must still be valid")
    check.add_argument("--explain", choices=["text", "full", "json", "html", "facts"], default="text",
                       help="print the verdict with its justification as text (the deciding proof whole, long lists "
                       "of rules that did not apply as one line, the rest cut short), as every line of the proof "
                       "(full), as a JSON verdict or as a self-contained HTML page (both with the whole proof); or, instead of a verdict, the facts the rules are given for the "
                       "frame, one a line, to write a rule against (default: %(default)s)")
    check.add_argument("--out", type=path_text, help="write the output to this file")
    check.add_argument("--shadow", action="store_true", help="judge only: veto instead of override")
    add_rules_options(check, "use")
    check.add_argument("--jurisdiction", default="us", choices=JURISDICTIONS, help="rule pack (traffic side, limits)")
    check.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                       help="set a reasoning parameter (discern.rules.facts.Params), e.g. --param decel=4; repeatable")
    check.add_argument("--max-payload-bytes", type=int, default=MAX_PAYLOAD_BYTES,
                       help=f"larger files are refused, as the monitor refuses larger proposals (default: {MAX_PAYLOAD_BYTES})")
    check.set_defaults(func=cmd_check)

    catalog = sub.add_parser("catalog", help="list the rules with their English and sources")
    catalog.add_argument("--all", action="store_true", help="include definitions and entity rules")
    catalog.add_argument("--json", action="store_true",
                         help="print the rules as a JSON list, one object per rule (id, English, source, file...)")
    add_rules_options(catalog, "list")
    catalog.add_argument("--jurisdiction", default="us", choices=JURISDICTIONS, help="rule pack to list with the catalog")
    catalog.set_defaults(func=cmd_catalog)

    scenarios = sub.add_parser("scenarios", help="run scenario files or the paper's KITTI frames")
    scen_sub = scenarios.add_subparsers(dest="action", required=True, metavar="ACTION")
    run = scen_sub.add_parser("run", help="run scenario JSON files or AV-CSR .pl frames, or directories of them")
    run.add_argument("paths", nargs="+", type=path_text, metavar="PATH", help="a scenario .json, an AV-CSR .pl, or a directory")
    run.add_argument("--explain", action="store_true", help="print every verdict's justification")
    run.add_argument("--repeats", type=_repeats, default=5, help="timing repeats per KITTI frame (median), at least 1 (default: %(default)s)")
    add_rules_options(run, "use")
    run.set_defaults(func=cmd_scenarios)

    schema = sub.add_parser("schema", help="write the JSON Schemas of the message models")
    schema.add_argument("--out", type=path_text, default=".", help="directory to write into (default: the current one)")
    schema.set_defaults(func=cmd_schema)

    for module in PARTS:
        importlib.import_module(module).register(sub)
    return parser


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    args.argv = list(sys.argv[1:] if argv is None else argv)  # as given: for a subcommand that records what ran it
    try:
        return args.func(args)
    except UserError as exc:  # as argparse names its own errors: `discern check: error: ...`
        print(f"discern {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:  # the reader left (`discern catalog | head`): no traceback, nothing more to write
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141


if __name__ == "__main__":
    sys.exit(main())
