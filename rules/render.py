"""Justifications for people: indented prose, JSON, and a self-contained HTML page."""

from __future__ import annotations

import html
import json
from typing import Optional

from .verdict import Justification, JustificationNode, Verdict


def _line(node: JustificationNode, again: bool = False) -> str:
    text = node.text
    if again:
        text += ", as shown above"
    elif node.children and node.kind in ("derived", "negation", "blocked"):
        text += ", because"
    if node.rule and node.kind != "blocked":
        text += f"  [{node.rule}]"
    return text


def _key(node: JustificationNode) -> tuple:
    return node.kind, node.text, node.rule, node.holds


def render_text(justification: Justification) -> str:
    """Each reason is argued once: where the same conclusion comes up again, the line points back to it
    instead of repeating its whole subtree, so a proof that leans on one fact five times stays readable."""
    lines = [justification.summary]
    shown: set[tuple] = set()
    for root in justification.tree:
        _walk(root, 1, lines, shown)
    return "\n".join(lines)


def _walk(node: JustificationNode, depth: int, lines: list[str], shown: set[tuple]) -> None:
    # A module function, not a closure that calls itself: that is a reference cycle per verdict, the only
    # garbage a decision worker left for the full collections it now keeps to a minimum (decision_worker.py).
    key = _key(node)
    again = bool(node.children) and key in shown
    lines.append("  " * depth + "- " + _line(node, again))
    if again:
        return
    if node.children:
        shown.add(key)
    for child in node.children:
        _walk(child, depth + 1, lines, shown)


def render_json(verdict: Verdict) -> str:
    return json.dumps(verdict.model_dump(mode="json"), indent=2)


_CSS = """
body{font-family:system-ui,sans-serif;margin:2rem;max-width:70rem;color:#1d2330}
h1{font-size:1.3rem} .summary{font-weight:600;margin:.5rem 0 1rem}
details{margin-left:1.2rem;border-left:1px solid #d5d9e0;padding-left:.6rem}
summary{cursor:pointer;padding:.1rem 0} .leaf{margin-left:1.2rem;padding:.1rem .6rem}
.holds{color:#1f6f3f} .fails{color:#a3262a} .rule{font-family:monospace;font-size:.85em;
background:#eef1f6;border-radius:3px;padding:0 .3rem;margin-left:.4rem;color:#39485e}
.kind{font-size:.75em;color:#7a8496;margin-left:.3rem} table{border-collapse:collapse;margin:.5rem 0}
td{padding:.15rem .8rem .15rem 0}
"""


def tree_html(nodes: list[JustificationNode], open_depth: Optional[int] = None) -> str:
    """Nested <details>, open down to open_depth (all when None); the verdict page and the audit share it."""
    shown: set[tuple] = set()
    return "".join(_html_node(node, shown, open_depth, 0) for node in nodes)


def _html_node(node: JustificationNode, shown: set[tuple], open_depth: Optional[int], depth: int) -> str:
    cls = "holds" if node.holds else "fails"
    rule = f'<span class="rule">{html.escape(node.rule)}</span>' if node.rule and node.kind != "blocked" else ""
    label = f'<span class="{cls}">{html.escape(_line(node).split("  [")[0])}</span>{rule}<span class="kind">{node.kind}</span>'
    if not node.children:
        return f'<div class="leaf">{label}</div>'
    # A reason argued earlier on the page stays folded where it comes up again: one click opens it.
    key = _key(node)
    opened = key not in shown and (open_depth is None or depth < open_depth)
    shown.add(key)
    inner = "".join(_html_node(c, shown, open_depth, depth + 1) for c in node.children)
    return f"<details{' open' if opened else ''}><summary>{label}</summary>{inner}</details>"


def render_html(verdict: Verdict) -> str:
    j = verdict.justification
    facts = [
        ("decision", verdict.decision.value),
        ("proposed", verdict.proposed.value if verdict.proposed else "-"),
        ("action", verdict.action.value),
        ("recommended", verdict.recommended.value if verdict.recommended else "-"),
        ("permitted", ", ".join(a.value for a in verdict.permitted)),
        ("rules", ", ".join(verdict.rules)),
        ("frame", str(verdict.frame_id)),
    ]
    rows = "".join(f"<tr><td>{k}</td><td>{html.escape(v)}</td></tr>" for k, v in facts)
    tree = tree_html(j.tree)
    return (
        "<!doctype html><html><head><meta charset='utf-8'>"
        f"<title>Discern verdict, frame {verdict.frame_id}</title><style>{_CSS}</style></head><body>"
        f"<h1>Discern verdict</h1><div class='summary'>{html.escape(j.summary)}</div>"
        f"<table>{rows}</table><h2>Justification</h2>{tree}</body></html>"
    )
