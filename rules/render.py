"""Justifications for people: indented prose, JSON, and a self-contained HTML page."""

from __future__ import annotations

import html
import json
from typing import Optional

from .verdict import Justification, JustificationNode, Verdict


def _line(node: JustificationNode, again: bool = False, folded: str = "", cut: bool = False) -> str:
    text = node.text
    if again:
        text += ", as shown above"
    elif folded:
        text += folded
    elif cut:
        text += ", because …"
    elif node.children and node.kind in ("derived", "negation", "blocked"):
        text += ", because"
    if node.rule and node.kind != "blocked":
        text += f"  [{node.rule}]"
    return text


SHARED_REASONS = 3  # a list of this many reasons or more, argued before under another line, points back to it
# A negative proof over this many rules or more (the 26 rules that find no hazard) reads as one line naming them: the
# text says which rules were tried, the tree (JSON, HTML one click away, `Justification.full_text()`) why each failed.
FOLD_RULES = 3
# The proofs that support a verdict without deciding it (what replaces a forbidden proposal, what is recommended, what
# the sanity layer noted) are cut this many levels below their first line in the text; the tree keeps them whole.
SUPPORT_DEPTH = 4
_DECIDING = ("forbidden(", "permitted(", "applicable(")  # the roots a verdict rests on: proved in full


def folded_rules(node: JustificationNode) -> list[str]:
    """The rules a negative proof tried, in order, where it reads as one line: a `negation` (or a rule `blocked` on
    something there is no evidence of) whose reasons are, each, one rule's, over FOLD_RULES rules or more. Empty
    where the node is shown with its reasons."""
    if node.kind not in ("negation", "blocked") or len(node.children) < FOLD_RULES:
        return []
    tried: list[str] = []
    for child in node.children:
        if child.rule_tried is None:
            return []
        if child.rule_tried not in tried:
            tried.append(child.rule_tried)
    return tried if len(tried) >= FOLD_RULES else []


def _folded_words(tried: list[str]) -> str:
    return f"; none of the {len(tried)} rules for it applies: {', '.join(tried)}"


class _Shown:
    """The reasons a page has argued, by what they say all the way down: two reasons worded alike whose
    own reasons differ are both shown ("50.0 m < 10.0 m" once for the gap, once for the headway). A long list
    of reasons is argued once too, whatever line it came under: the 26 rules that find no hazard are the same
    under the rule that forbids accelerating for a hazard and the one that forbids changing lanes for it."""

    def __init__(self) -> None:
        self._ids: dict[tuple, int] = {}  # a node's line and its children's ids -> its id: shallow to hash
        self._of: dict[int, int] = {}  # id(node) -> its id, for nodes the proof shares
        self._argued: set = set()  # the ids of the nodes argued, and the lists of reasons argued

    def _id(self, node: JustificationNode) -> int:
        found = self._of.get(id(node))
        if found is None:
            key = (node.kind, node.literal, node.text, node.rule, node.holds, tuple(self._id(c) for c in node.children))
            found = self._of[id(node)] = self._ids.setdefault(key, len(self._ids))
        return found

    def again(self, node: JustificationNode, note: bool = True) -> bool:
        """Whether this reason, with reasons of its own, was argued before; notes it as argued now unless `note`
        is False (a line whose reasons the text cuts: a later one shows them)."""
        if not node.children:
            return False
        key = self._id(node)
        reasons = tuple(self._id(c) for c in node.children) if len(node.children) >= SHARED_REASONS else None
        if key in self._argued or reasons in self._argued:
            return True
        if note:
            self._argued.add(key)
            if reasons is not None:
                self._argued.add(reasons)
        return False


def render_text(justification: Justification, full: bool = False) -> str:
    """Each reason is argued once: where the same conclusion comes up again, the line points back to it
    instead of repeating its whole subtree, so a proof that leans on one fact five times stays readable.

    The deciding proof comes first with its numbers; a negative proof over many rules reads as one line naming them
    (FOLD_RULES), and the proofs that only support the verdict (the replacement's, the notes') are cut at
    SUPPORT_DEPTH. `full`: every line of the tree, as `discern check --explain full` prints it."""
    lines = [justification.summary]
    shown = _Shown()
    for root in justification.tree:
        limit = None if full or root.literal.startswith(_DECIDING) else SUPPORT_DEPTH
        _walk(root, 1, lines, shown, not full, limit)
    return "\n".join(lines)


def _walk(node: JustificationNode, depth: int, lines: list[str], shown: _Shown, fold: bool,
          limit: Optional[int]) -> None:
    # A module function, not a closure that calls itself: that is a reference cycle per verdict, the only
    # garbage a decision worker left for the full collections it now keeps to a minimum (decision_worker.py).
    cut = limit is not None and depth > limit and bool(node.children)
    again = shown.again(node, note=not cut)
    tried = folded_rules(node) if fold and not again else []
    lines.append("  " * depth + "- " + _line(node, again, _folded_words(tried) if tried else "", cut and not tried))
    if again or tried or cut:
        return
    for child in node.children:
        _walk(child, depth + 1, lines, shown, fold, limit)


def render_json(verdict: Verdict) -> str:
    return json.dumps(verdict.model_dump(mode="json"), indent=2)


TREE_CSS = """
.holds{color:#1d2330} .fails{color:#5f6b7d} .again{font-style:italic} .rule{font-family:monospace;font-size:.85em;
background:#eef1f6;border-radius:3px;padding:0 .3rem;margin-left:.4rem;color:#39485e}
.kind{font-size:.75em;color:#5f6b7d;margin-left:.3rem}
"""  # a proof tree's lines (tree_html), on the verdict page and in the audit's reports alike

_CSS = TREE_CSS + """
body{font-family:system-ui,sans-serif;margin:2rem;max-width:70rem;color:#1d2330}
h1{font-size:1.3rem} .summary{font-weight:600;margin:.5rem 0 1rem}
.decision{display:inline-block;font-weight:700;font-size:1.1rem;padding:.3rem .8rem;border-radius:4px;color:#fff}
.approve{background:#1f6f3f} .override{background:#b45309} .veto{background:#a3262a} .failsafe{background:#6b3fa0}
details{margin-left:1.2rem;border-left:1px solid #d5d9e0;padding-left:.6rem}
summary{cursor:pointer;padding:.1rem 0} .leaf{margin-left:1.2rem;padding:.1rem .6rem}
table{border-collapse:collapse;margin:.5rem 0}
td{padding:.15rem .8rem .15rem 0} .legend{font-size:.85em;color:#39485e;margin:.3rem 0 1rem}
"""

# Why something did not happen: shown folded, one click away, so that what did happen reads first.
_FOLDED_KINDS = ("negation", "blocked")


def tree_html(nodes: list[JustificationNode], open_depth: Optional[int] = None) -> str:
    """Nested <details>, open down to open_depth (all when None) except the reasons why something did not
    happen; the verdict page and the audit share it."""
    shown = _Shown()
    return "".join(_html_node(node, shown, open_depth, 0) for node in nodes)


def _html_node(node: JustificationNode, shown: _Shown, open_depth: Optional[int], depth: int) -> str:
    cls = "holds" if node.holds and node.kind != "blocked" else "fails"  # why a rule did not apply: grey
    rule = f'<span class="rule">{html.escape(node.rule)}</span>' if node.rule and node.kind != "blocked" else ""
    again = shown.again(node)
    tried = [] if again else folded_rules(node)  # one line naming the rules tried; their reasons one click away
    text = html.escape(_line(node, again, _folded_words(tried) if tried else "").split("  [")[0])
    label = f'<span class="{cls}{" again" if again else ""}">{text}</span>{rule}<span class="kind">{node.kind}</span>'
    if not node.children:
        return f'<div class="leaf">{label}</div>'
    # A reason argued earlier on the page stays folded where it comes up again: one click opens it.
    opened = not again and node.kind not in _FOLDED_KINDS and (open_depth is None or depth < open_depth)
    inner = "".join(_html_node(c, shown, open_depth, depth + 1) for c in node.children)
    return f"<details{' open' if opened else ''}><summary>{label}</summary>{inner}</details>"


_LEGEND = (
    "Each line holds in this frame and is followed by its reasons; the chip names the catalog rule that "
    "derives it. Tags: <b>derived</b> proved by a rule, <b>fact</b> given by the scene or the catalog, "
    "<b>builtin</b> a comparison of numbers, <b>negation</b> there is no evidence of it, <b>blocked</b> why a "
    "rule did not apply (grey). Reasons why something did not happen, and reasons given above, start folded."
)


def render_html(verdict: Verdict) -> str:
    j = verdict.justification
    kind = "failsafe" if verdict.failsafe else verdict.decision.value
    headline = f"{verdict.decision.value}: {verdict.action.value.replace('_', ' ')}" + (" (fail-safe)" if verdict.failsafe else "")
    facts = [
        ("vehicle", verdict.vehicle),
        ("frame", str(verdict.frame_id)),
        ("timestamp", "-" if verdict.timestamp is None else f"{verdict.timestamp:g} s"),
        ("decision", verdict.decision.value + (" (shadow mode: judged, not enforced)" if verdict.shadow else "")),
        ("proposed", verdict.proposed.value if verdict.proposed else "-"),
        ("action", verdict.action.value),
        ("recommended", verdict.recommended.value if verdict.recommended else "-"),
        ("permitted", ", ".join(a.value for a in verdict.permitted)),
        ("rules", ", ".join(verdict.rules)),
        ("latency", "-" if verdict.latency_ms is None else f"{verdict.latency_ms:.2f} ms"),
    ]
    if verdict.error:
        facts.append(("error", verdict.error))
    facts.extend(("note", note) for note in verdict.notes)
    rows = "".join(f"<tr><td>{k}</td><td>{html.escape(v)}</td></tr>" for k, v in facts)
    tree = tree_html(j.tree)
    return (
        "<!doctype html><html lang='en'><head><meta charset='utf-8'>"
        f"<title>Discern verdict, frame {verdict.frame_id}</title><style>{_CSS}</style></head><body>"
        f"<h1>Discern verdict</h1><div class='decision {kind}'>{html.escape(headline.upper())}</div>"
        f"<div class='summary'>{html.escape(j.summary)}</div>"
        f"<table>{rows}</table><h2>Justification</h2><div class='legend'>{_LEGEND}</div>{tree}</body></html>"
    )
