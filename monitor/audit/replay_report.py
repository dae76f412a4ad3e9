"""A replay for people and for tools: what would change, both justifications side by side."""

from __future__ import annotations

import csv
import io
import json
from html import escape

from discern.monitor.config import MonitorConfig

from .replay import Change, ReplayResult
from .report import (
    files_html, files_json, gap_lines, gaps_html, gaps_json, page, plural, recovery_lines, spreadsheet_safe, table,
    verdict_html,
)
from .timefmt import iso

CSV_FIELDS = [
    "time",
    "log_time_ns",  # as in the audit's CSV: exact, and what --since and --until take back
    "vehicle",
    "frame_id",
    "scenario",
    "proposed",
    "recorded_decision",
    "recorded_action",
    "recorded_rules",
    "recorded_justification",
    "replayed_decision",
    "replayed_action",
    "replayed_rules",
    "replayed_justification",
    "file",
]


def headline(result: ReplayResult) -> list[str]:
    t = result.tally
    lines = ["filters: " + "; ".join(result.filters.describe())] if result.filters.describe() else []
    # a window other than the monitor's default is a setting of the replay, named as its rules and parameters are
    window = f" and a {result.window_s:g} s history window" if result.window_s != MonitorConfig.window_s else ""
    lines += [
        f"replayed {t.frames} frames with {result.catalog.describe()}{window} in {result.wall_s:.2f} s "
        f"({result.frames_per_s:.0f} frames/s, {result.workers} worker{'s' if result.workers != 1 else ''}; "
        f"{t.solved} solved, {t.reused} identical to a frame solved before; {t.decided} decided in full)",
    ]
    skipped = []
    if t.skipped_failsafe:
        skipped.append(plural(t.skipped_failsafe, "fail-safe verdict"))
    if t.skipped_refused:
        skipped.append(plural(t.skipped_refused, "verdict") + " without a logged proposal")
    if t.unanswered:
        skipped.append(plural(t.unanswered, "proposal") + " without a logged verdict")
    if skipped:
        lines.append("not replayed (the rules did not decide them): " + ", ".join(skipped))
    if t.changes:
        lines.append(f"{plural(len(t.changes), 'decision')} would change")
    else:
        lines.append("no decision would change")
    if t.rules_only:
        lines.append(f"{plural(t.rules_only, 'frame')} would keep the decision but cite other rules")
    if not result.compare_rules:
        lines.append(
            "frames whose permitted set and recommendation are unchanged were not compared rule by rule (--compare-rules)"
        )
    return lines


def _side(verdict: dict) -> str:
    return f"{verdict['decision']} {verdict['action']} [{', '.join(verdict.get('rules') or [])}]"


def render_text(result: ReplayResult, listing: bool = True) -> str:
    """The file lines and the headline, then (with `listing`) every change, then the changes counted by
    transition; -q leaves out only the changes one by one, as the audit's leaves out its listing: a file cut
    short or unreadable must not go unsaid."""
    t = result.tally
    lines = ["Logs:"] + ["  " + line for line in recovery_lines(t.recovery) + gap_lines(t.gaps)] + headline(result)
    for c in t.changes if listing else ():
        lines.append("")
        lines.append(
            f"  {iso(c.time_ns)}  {c.vehicle}  frame {c.frame_id}  ({c.scenario})  proposed {c.recorded.get('proposed')}"
        )
        lines.append(f"    recorded: {_side(c.recorded)}  {c.recorded['justification']['summary']}")
        lines.append(f"    replayed: {_side(c.replayed)}  {c.replayed['justification']['summary']}")
    if t.transitions:
        lines.append("")
        lines.append("Changes by transition:")
        lines += [f"  {n:>6}  {k}" for k, n in t.transitions.most_common()]
    if t.rules_only_examples:
        lines.append("")
        lines.append("Same decision, other rules (recorded -> replayed):")
        lines += [f"  {n:>6}  [{a}] -> [{b}]" for (a, b), n in t.rules_only_examples.most_common(10)]
    return "\n".join(lines) + "\n"


def _row(c: Change) -> dict:
    r, p = c.recorded, c.replayed
    return {
        "time": iso(c.time_ns),
        "log_time_ns": c.time_ns,
        "vehicle": c.vehicle,
        "frame_id": c.frame_id,
        "scenario": c.scenario,
        "proposed": r.get("proposed"),
        "recorded_decision": r["decision"],
        "recorded_action": r["action"],
        "recorded_rules": ";".join(r.get("rules") or []),
        "recorded_justification": r["justification"]["summary"],
        "replayed_decision": p["decision"],
        "replayed_action": p["action"],
        "replayed_rules": ";".join(p.get("rules") or []),
        "replayed_justification": p["justification"]["summary"],
        "file": c.file,
    }


def render_csv(result: ReplayResult) -> str:
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=CSV_FIELDS, lineterminator="\n")
    writer.writeheader()
    for c in result.tally.changes:
        writer.writerow(spreadsheet_safe(_row(c)))
    return out.getvalue()


def render_json(result: ReplayResult) -> str:
    t = result.tally
    doc = {
        "files": files_json(t.recovery),
        "incomplete_runs": gaps_json(t.gaps),
        "catalog": list(result.catalog.dirs),
        "jurisdiction": result.catalog.jurisdiction,
        "window_s": result.window_s,
        "frames": t.frames,
        "solved": t.solved,
        "reused": t.reused,
        "decided_in_full": t.decided,
        "compared_rules": result.compare_rules,
        "filters": result.filters.describe(),
        "wall_s": result.wall_s,
        "worker_cpu_s": t.cpu_s,
        "solver_s": t.solve_s,
        "frames_per_s": result.frames_per_s,
        "workers": result.workers,
        "skipped_failsafe": t.skipped_failsafe,
        "skipped_refused": t.skipped_refused,
        "unanswered_proposals": t.unanswered,
        "rules_only_changes": t.rules_only,
        "transitions": dict(t.transitions),
        "changes": [{**_row(c), "recorded_verdict": c.recorded, "replayed_verdict": c.replayed} for c in t.changes],
    }
    return json.dumps(doc, indent=2) + "\n"


def render_html(result: ReplayResult) -> str:
    t = result.tally
    parts = [f"<h2>Logs</h2>{files_html(t.recovery)}{gaps_html(t.gaps)}", "<h2>Summary</h2>"]
    parts += [f"<p>{escape(line)}</p>" for line in headline(result)]
    parts.append(
        "<h2>Changes by transition</h2>"
        + table(["proposed: recorded -> replayed", "frames"], [list(x) for x in t.transitions.most_common()], {1})
    )
    parts.append(f"<h2>Changed decisions ({len(t.changes)})</h2>")
    parts.append("<p class='meta'>Marked rows differ. The recorded proof is the one the monitor logged (a veto's "
                 "to 4 levels, an approval's only when the planner asked for it); the replayed one is in full.</p>")
    for i, c in enumerate(t.changes):
        head = (
            f"<span class='mono'>{escape(iso(c.time_ns))}</span> {escape(c.vehicle)} frame {c.frame_id} "
            f"&mdash; {escape(c.transition)}"
        )
        changed = _changed_fields(c.recorded, c.replayed)
        sides = (
            f"<div class='side'><div><h3>recorded</h3>{verdict_html(c.recorded, changed)}</div>"
            f"<div><h3>replayed</h3>{verdict_html(c.replayed, changed)}</div></div>"
        )
        where = f"<p class='meta'>scenario {escape(c.scenario)} &middot; {escape(c.file)}</p>"
        parts.append(f"<details class='dis' id='c{i}' open><summary>{head}</summary>{where}{sides}</details>")
    return page("Discern replay", "".join(parts))


# the verdict fields a rule edit can change, by the labels verdict_html gives them
_COMPARED = {"decision": "decision", "action": "executed", "recommended": "recommended", "permitted": "permitted",
             "rules": "rules"}


def _changed_fields(recorded: dict, replayed: dict) -> frozenset[str]:
    """The rows to mark on both sides: what the replay decides differently. The trees are not compared: the
    monitor logs a veto's proof to a few levels and the replay proves in full."""
    return frozenset(label for key, label in _COMPARED.items() if recorded.get(key) != replayed.get(key))
