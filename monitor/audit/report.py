"""An audit for people and for tools: terminal listing, self-contained HTML, CSV and JSON."""

from __future__ import annotations

import csv
import io
import json
from datetime import datetime, timezone
from html import escape
from typing import Optional

from discern.monitor.log import FileRecovery
from discern.rules.render import TREE_CSS, tree_html
from discern.rules.verdict import JustificationNode

from . import plots
from .aggregate import Aggregates, Disagreement, Filters, Kind, Tally
from .runs import RunGap
from .timefmt import iso

CSV_FIELDS = [
    "time",
    "log_time_ns",
    "vehicle",
    "frame_id",
    "scene_time",
    "verdict",
    "proposed",
    "executed",
    "recommended",
    "rules",
    "scenario",
    "latency_ms",
    "justification",
    "error",
    "file",
]


def recovery_lines(files: list[FileRecovery]) -> list[str]:
    """One line per file: how much of it was read, and why reading stopped early."""
    out = []
    for f in files:
        line = f"{f.path}: {f.state}, {f.records} records"
        if f.size_bytes:
            share = 100.0 * f.recovered_bytes / f.size_bytes
            line += f", {f.recovered_bytes}/{f.size_bytes} bytes recovered ({share:.1f}%)"
        if f.skipped:
            line += f", {plural(f.skipped, 'message')} skipped (unknown channel or bad payload)"
        if f.damaged:
            line += f"; damaged: {f.damage}"
        if f.stopped_by:
            line += f"; stopped: {f.stopped_by}"
        out.append(line)
    return out


def gap_lines(gaps: list[RunGap]) -> list[str]:
    """One line per monitor run the files leave incomplete: its files missing, its records lost."""
    return [f"incomplete: {gap.describe()}" for gap in gaps]


def gaps_json(gaps: list[RunGap]) -> list[dict]:
    """The runs the files leave incomplete, for the audit's and the replay's JSON alike."""
    return [
        {
            "monitor": g.monitor,
            "run": g.run,
            "files_read": g.read,
            "files_missing": g.missing,
            "missing_indices": list(g.indices) if g.indices is not None else None,
            "log_files_opened": g.opened,
            "log_dropped": g.dropped,
        }
        for g in gaps
    ]


def gaps_html(gaps: list[RunGap]) -> str:
    return "".join(f"<p class='warn'>{escape(line)}</p>" for line in gap_lines(gaps))


# Below this much driving, a rate per hour or km is a handful of events scaled up: reported, and said to be rough.
SHORT_RUN_H = 0.1


def _rate(value: Optional[float], unit: str) -> str:
    return f"{value:.2f} per {unit}" if value is not None else f"n/a per {unit}"


def _short_run(agg: Aggregates) -> bool:
    return agg.hours < SHORT_RUN_H


def plural(n: int, noun: str) -> str:
    return f"{n} {noun}" + ("" if n == 1 else "s")


def gaps_line(tally: Tally) -> str:
    """What the log holds beside whole frames, if anything."""
    extra = []
    if tally.unanswered:
        extra.append(plural(tally.unanswered, "proposal") + " without a logged verdict")
    if tally.counts.refused:
        extra.append(plural(tally.counts.refused, "refused input") + " (the monitor status's errors)")
    return "; ".join(extra)


def totals_lines(tally: Tally, agg: Aggregates) -> list[str]:
    d = tally.decisions
    lines = [
        f"frames: {tally.frames} (approve {d['approve']}, override {d['override']}, veto {d['veto']}, "
        f"fail-safe {d['failsafe']}); disagreements listed: {len(tally.disagreements)}"
    ]
    if gaps_line(tally):
        lines.append(gaps_line(tally))
    if agg.km > 0 or agg.hours > 0:
        lines.append(
            f"odometry: {agg.km:.2f} km in {agg.hours:.3f} h of driving; disagreements "
            f"{_rate(agg.per_hour, 'hour')}, {_rate(agg.per_km, 'km')}"
            + (f" (under {SHORT_RUN_H:g} h of driving: rough rates)" if _short_run(agg) else "")
        )
    else:
        lines.append("odometry: none (no consecutive scenes of a vehicle); no rates per hour or km")
    lat = agg.latency
    if lat["samples"]:
        lines.append(
            f"latency: p50 {lat['p50_ms']:.2f} ms, p90 {lat['p90_ms']:.2f} ms, p99 {lat['p99_ms']:.2f} ms, "
            f"max {lat['max_ms']:.2f} ms over {plural(lat['samples'], 'verdict')}"
        )
    return lines


def render_text(tally: Tally, agg: Aggregates, filters: Filters, listing: bool = True) -> str:
    """Without `listing` (-q), the tables per rule, pair, kind and vehicle still follow the totals: a log of
    thousands of disagreements is read from them, its one line per disagreement from the CSV or HTML."""
    lines = ["Logs:"] + ["  " + line for line in recovery_lines(tally.recovery) + gap_lines(tally.gaps)]
    if filters.describe():
        lines.append("filters: " + "; ".join(filters.describe()))
    lines += totals_lines(tally, agg)
    if listing:
        lines += _listing(tally.disagreements)
    lines += _per_rule_lines(agg)
    for title, items in (
        ("per action pair (proposed -> executed)", agg.per_pair),
        # with the frames of the kind and of the vehicle, as docs/audit.md says: a count alone is no rate
        ("per scenario kind", [(f"{k} (of {plural(f, 'frame')})", n) for k, n, f in agg.per_scenario if n]),
        ("per vehicle", [(_vehicle(v, f, km, r), n) for v, n, f, km, r in agg.per_vehicle]),
    ):
        if items:
            lines.append("")
            lines.append(f"Disagreements {title}:")
            lines += [f"  {n:>6}  {key}" for key, n in items]
    return "\n".join(lines) + "\n"


def _vehicle(vehicle: str, frames: int, km: float, refused: int) -> str:
    refusals = f", {plural(refused, 'refused input')}" if refused else ""
    return f"{vehicle} (of {plural(frames, 'frame')}, {km:.2f} km{refusals})"


def unattributed_line(agg: Aggregates) -> str:
    """What the per-rule counts could not tell apart: verdicts logged before they named the rules that forbade."""
    if not agg.unattributed:
        return ""
    return (f"{plural(agg.unattributed, 'disagreement')} logged without vetoed_by (by a monitor before 2026-11-27) "
            "counted as forbidden by every rule cited")


PER_RULE_KEY = ("forbade: the disagreements whose proposal the rule forbade (the verdict's vetoed_by); also cited: "
                "those whose verdict cites it otherwise (a rule its proof used, a sanity note)")


def _per_rule_lines(agg: Aggregates) -> list[str]:
    if not agg.per_rule:
        return []
    lines = ["", "Disagreements per rule:", f"  {'forbade':>7}  {'also cited':>10}  rule"]
    lines += [f"  {n:>7}  {cited:>10}  {rule}" for rule, n, cited in agg.per_rule]
    return lines + [f"  ({note})" for note in (PER_RULE_KEY, unattributed_line(agg)) if note]


def _listing(rows: list[Disagreement]) -> list[str]:
    lines = ["", f"Disagreements ({len(rows)}):" if rows else "No disagreements."]
    frames = ["-" if d.frame_id is None else str(d.frame_id) for d in rows]
    vehicle_width = max((len(d.vehicle) for d in rows), default=0)  # columns line up whatever the names and ids
    frame_width = max((len(f) for f in frames), default=0)
    for d, frame in zip(rows, frames):
        lines.append(
            f"  {iso(d.time_ns)}  {d.vehicle:<{vehicle_width}}  frame {frame:<{frame_width}}  {d.kind.value:<8}  "
            f"{d.pair:<36}  [{', '.join(d.rules)}]  {d.summary}"
        )
    return lines


def _row(d: Disagreement) -> dict:
    return {
        "time": iso(d.time_ns),
        "log_time_ns": d.time_ns,
        "vehicle": d.vehicle,
        "frame_id": d.frame_id,
        "scene_time": d.scene_time,
        "verdict": d.kind.value,
        "proposed": d.proposed,
        "executed": d.executed,
        "recommended": d.recommended,
        "rules": ";".join(d.rules),
        "scenario": d.scenario,
        "latency_ms": d.latency_ms,
        "justification": d.summary,
        "error": d.error,
        "file": d.file,
    }


def render_csv(tally: Tally) -> str:
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=CSV_FIELDS, lineterminator="\n")
    writer.writeheader()
    for d in tally.disagreements:
        # no proposed action read: '?', as the terminal and the HTML show it (the JSON has null)
        writer.writerow(spreadsheet_safe({**_row(d), "proposed": d.proposed or "?"}))
    return out.getvalue()


_FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def spreadsheet_safe(row: dict) -> dict:
    """Text a spreadsheet would run as a formula (a logged error or summary starting with '=') kept as text, with a
    leading apostrophe, as OWASP advises for CSV files; numbers stay numbers."""
    return {key: f"'{value}" if isinstance(value, str) and value.startswith(_FORMULA_START) else value
            for key, value in row.items()}


def files_json(files: list[FileRecovery]) -> list[dict]:
    """How much of each file was read, for the audit's and the replay's JSON alike."""
    return [
        {
            "path": str(f.path),
            "state": f.state,
            "records": f.records,
            "size_bytes": f.size_bytes,
            "recovered_bytes": f.recovered_bytes,
            "skipped": f.skipped,
            "stopped_by": f.stopped_by,
            "damaged": [
                {"offset": d.offset, "length": d.length, "kind": d.kind, "messages": d.messages, "reason": d.reason}
                for d in f.damaged
            ],
        }
        for f in files
    ]


def render_json(tally: Tally, agg: Aggregates, filters: Filters) -> str:
    doc = {
        "files": files_json(tally.recovery),
        "incomplete_runs": gaps_json(tally.gaps),
        "filters": filters.describe(),
        "frames": tally.frames,
        "decisions": {d: tally.decisions[d] for d in ("approve", *(k.value for k in Kind))},  # zeros too
        "unanswered_proposals": tally.unanswered,
        "refused_inputs": tally.counts.refused,
        "first_log_time": iso(tally.first_ns) if tally.first_ns is not None else None,
        "last_log_time": iso(tally.last_ns) if tally.last_ns is not None else None,
        "odometry": {"km": agg.km, "driving_hours": agg.hours, "per_hour": agg.per_hour, "per_km": agg.per_km},
        "latency_ms": agg.latency,
        "per_kind": agg.per_kind,
        "per_rule": {rule: n for rule, n, _ in agg.per_rule if n},  # the rules that forbade the proposal
        "per_rule_also_cited": {rule: cited for rule, _, cited in agg.per_rule if cited},
        "per_rule_unattributed": agg.unattributed,
        "per_action_pair": dict(agg.per_pair),
        "per_scenario": [{"scenario": k, "disagreements": n, "frames": f} for k, n, f in agg.per_scenario],
        "per_vehicle": [{"vehicle": v, "disagreements": n, "frames": f, "km": km, "refused_inputs": r}
                        for v, n, f, km, r in agg.per_vehicle],
        "over_time": [
            {"start": iso(start), "seconds": width / 1e9, **counts} for start, width, counts in agg.over_time
        ],
        "disagreements": [
            {**_row(d), "rules": d.rules, "vetoed_by": d.vetoed_by, "verdict_json": json.loads(d.verdict_json)}
            for d in tally.disagreements
        ],
    }
    return json.dumps(doc, indent=2) + "\n"


# -- HTML ----------------------------------------------------------------------

CSS = TREE_CSS + """
body{font-family:system-ui,sans-serif;margin:1.5rem 2rem;color:#1d2330;max-width:80rem}
h1{font-size:1.4rem;margin-bottom:.2rem} h2{font-size:1.1rem;margin-top:1.8rem;border-bottom:1px solid #d5d9e0}
.meta{color:#5b6577;font-size:.9rem} table{border-collapse:collapse;margin:.4rem 0;font-size:.9rem}
th,td{padding:.15rem .7rem .15rem 0;text-align:left;vertical-align:top} th{color:#5b6577;font-weight:600}
td.n{text-align:right;font-variant-numeric:tabular-nums}
.cards{display:flex;flex-wrap:wrap;gap:.6rem} .card{border:1px solid #d5d9e0;border-radius:6px;padding:.4rem .8rem}
.card b{display:block;font-size:1.2rem} .card span{color:#5b6577;font-size:.8rem}
.warn{color:#a3262a} .veto{color:#d08b1f} .override{color:#c0392b} .failsafe{color:#6c3483}
details.dis{border-bottom:1px solid #eef1f6;padding:.2rem 0} details.dis>summary{cursor:pointer;font-size:.9rem}
.tree details{margin-left:1.1rem;border-left:1px solid #d5d9e0;padding-left:.6rem}
.tree summary{cursor:pointer} .leaf{margin-left:1.1rem;padding:.05rem .6rem}
tr.changed td{background:#fff3cd;font-weight:600}
.mono{font-family:monospace;font-size:.85em} .side{display:grid;grid-template-columns:1fr 1fr;gap:1rem}
.side>div{border:1px solid #d5d9e0;border-radius:6px;padding:.4rem .8rem;overflow-x:auto}
"""


def verdict_html(verdict: dict, changed: frozenset[str] = frozenset()) -> str:
    """A logged verdict: its facts (those in `changed` marked), then its justification tree (or its prose when
    no tree was logged)."""
    j = verdict.get("justification") or {}
    facts = [
        ("decision", verdict.get("decision")),
        ("proposed", verdict.get("proposed")),
        ("executed", verdict.get("action")),
        ("recommended", verdict.get("recommended")),
        ("permitted", ", ".join(verdict.get("permitted") or [])),
        ("rules", ", ".join(verdict.get("rules") or [])),
        ("latency", f"{verdict['latency_ms']:.2f} ms" if verdict.get("latency_ms") is not None else None),
        ("fail-safe", "yes" if verdict.get("failsafe") else None),
        ("shadow", "yes" if verdict.get("shadow") else None),
        ("error", verdict.get("error")),
    ]
    rows = "".join(f"<tr{' class=changed' if k in changed else ''}><th>{k}</th><td>{escape(str(v))}</td></tr>"
                   for k, v in facts if v not in (None, ""))
    tree = tree_html([JustificationNode.model_validate(n) for n in j.get("tree") or []], open_depth=1)
    if not tree:
        tree = f"<pre class='mono'>{escape(j.get('text') or j.get('summary') or '')}</pre>"
    return f"<p><b>{escape(j.get('summary', ''))}</b></p><table>{rows}</table><div class='tree'>{tree}</div>"


def table(headers: list[str], rows: list[list], numeric: set[int] = frozenset()) -> str:
    head = "".join(f"<th>{escape(h)}</th>" for h in headers)
    body = "".join(
        "<tr>"
        + "".join(f"<td{' class=n' if i in numeric else ''}>{escape(str(c))}</td>" for i, c in enumerate(r))
        + "</tr>"
        for r in rows
    )
    return f"<table><tr>{head}</tr>{body}</table>" if rows else "<p class='meta'>none</p>"


def _card(value: str, label: str) -> str:
    return f"<div class='card'><b>{escape(value)}</b><span>{escape(label)}</span></div>"


def page(title: str, body: str) -> str:
    stamp = datetime.now(timezone.utc).isoformat(timespec="seconds").replace("+00:00", "Z")
    return (
        "<!doctype html><html lang='en'><head><meta charset='utf-8'>"
        f"<title>{escape(title)}</title><style>{CSS}</style></head><body>"
        f"<h1>{escape(title)}</h1><p class='meta'>generated {stamp} by discern audit</p>{body}</body></html>"
    )


def files_html(files: list[FileRecovery]) -> str:
    rows = [
        [
            str(f.path), f.state, f.records, f"{f.recovered_bytes}/{f.size_bytes}", f.skipped, f.damage or "",
            f.stopped_by or "",
        ]
        for f in files
    ]
    return table(["file", "state", "records", "bytes recovered", "skipped", "damaged", "stopped by"], rows, {2, 4})


RETIRED = "(no rule of this version's catalog: the log was decided by another)"


def render_html(tally: Tally, agg: Aggregates, filters: Filters, rule_text: dict[str, str]) -> str:
    d = tally.decisions
    lat = agg.latency
    cards = [
        _card(str(tally.frames), "frames"),
        _card(str(len(tally.disagreements)), "disagreements listed"),
        _card(str(d["override"]), "overrides"),
        _card(str(d["veto"]), "vetoes"),
        _card(str(d["failsafe"]), "fail-safes"),
        _card(f"{agg.km:.2f} km", "distance (from scene speeds)"),
        _card(f"{agg.hours:.3f} h", "driving time"),
        _card(f"{agg.per_hour:.2f}" if agg.per_hour is not None else "n/a",
              "disagreements per hour" + (" (short run: rough)" if _short_run(agg) else "")),
        _card(f"{agg.per_km:.2f}" if agg.per_km is not None else "n/a",
              "disagreements per km" + (" (short run: rough)" if _short_run(agg) else "")),
        _card(f"{lat['p99_ms']:.2f} ms" if lat["samples"] else "n/a", "latency p99"),
    ]
    parts = [f"<h2>Logs</h2>{files_html(tally.recovery)}{gaps_html(tally.gaps)}"]
    notes = [gaps_line(tally)] if gaps_line(tally) else []
    if filters.describe():
        notes.append("filters: " + "; ".join(filters.describe()))
    parts += [f"<p class='meta'>{escape(n)}</p>" for n in notes]
    parts.append(f"<h2>Summary</h2><div class='cards'>{''.join(cards)}</div>")
    parts.append("<h2>Timeline of disagreements</h2>" + plots.timeline(agg.over_time))
    forbade = [(rule, n) for rule, n, _ in agg.per_rule if n]
    parts.append("<h2>Disagreements per rule</h2>" + plots.bars(forbade, "Disagreements per rule"))
    parts.append(
        "<h2>Latency distribution</h2>"
        + plots.histogram(
            tally.latencies_ms,
            "Verdict latency",
            "ms",
            {"p50": lat["p50_ms"], "p99": lat["p99_ms"]},
        )
    )
    parts.append(
        "<h2>Per rule</h2>"
        + "".join(f"<p class='meta'>{escape(note)}</p>" for note in (PER_RULE_KEY, unattributed_line(agg)) if note)
        + table(["rule", "forbade", "also cited", "says"],
                [[r, n, cited, rule_text.get(r, RETIRED)] for r, n, cited in agg.per_rule], {1, 2})
    )
    parts.append(
        "<h2>Per action pair (proposed &rarr; executed)</h2>"
        + table(["proposed -> executed", "disagreements"], [list(p) for p in agg.per_pair], {1})
    )
    parts.append(
        "<h2>Per scenario kind</h2>"
        + table(
            ["scenario", "disagreements", "frames", "share"],
            [[k, n, f, f"{100.0 * n / f:.1f}%"] for k, n, f in agg.per_scenario],
            {1, 2, 3},
        )
    )
    parts.append(
        "<h2>Per vehicle</h2>"
        + table(
            ["vehicle", "disagreements", "frames", "km", "refused inputs"],
            [[v, n, f, f"{km:.2f}", r] for v, n, f, km, r in agg.per_vehicle],
            {1, 2, 3, 4},
        )
    )
    busy = [(s, w, c) for s, w, c in agg.over_time if any(c.values())]
    parts.append(
        "<h2>Over time</h2>"
        + table(
            ["from", "veto", "override", "fail-safe"],
            [[iso(s), c["veto"], c["override"], c["failsafe"]] for s, _, c in busy],
            {1, 2, 3},
        )
    )
    parts.append(f"<h2>Disagreements ({len(tally.disagreements)})</h2>")
    parts.extend(_disagreement_html(i, d) for i, d in enumerate(tally.disagreements))
    return page("Discern audit", "".join(parts))


def _disagreement_html(i: int, d: Disagreement) -> str:
    frame = "-" if d.frame_id is None else str(d.frame_id)
    head = (
        f"<span class='mono'>{escape(iso(d.time_ns))}</span> {escape(d.vehicle)} frame {frame} "
        f"<b class='{d.kind.value}'>{d.kind.value}</b> {escape(d.pair)} "
        f"<span class='rule'>{escape(', '.join(d.rules))}</span> &mdash; {escape(d.summary)}"
    )
    where = f"<p class='meta'>scenario {escape(d.scenario)} &middot; {escape(d.file)}</p>"
    return f"<details class='dis' id='d{i}'><summary>{head}</summary>{where}{verdict_html(json.loads(d.verdict_json))}</details>"
