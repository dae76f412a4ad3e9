"""The report's plots as inline SVG: self-contained, text that a browser (and a test) can read, no plotting library."""

from __future__ import annotations

import math
from html import escape
from typing import Optional, Sequence

from .timefmt import iso

KIND_COLOURS = {"veto": "#d08b1f", "override": "#c0392b", "failsafe": "#6c3483"}
BAR_COLOUR = "#3b6ea5"
AXIS = "#7a8496"
FONT = "font-family='system-ui,sans-serif' font-size='11'"


def _svg(width: int, height: int, label: str, body: list[str]) -> str:
    return (
        f"<svg xmlns='http://www.w3.org/2000/svg' width='100%' style='max-width:{width}px;height:auto' "
        f"viewBox='0 0 {width} {height}' role='img' aria-label='{escape(label)}'>"
        f"<title>{escape(label)}</title>{''.join(body)}</svg>"
    )


def _text(x: float, y: float, text: str, anchor: str = "start", colour: str = "#1d2330") -> str:
    return f"<text x='{x:.1f}' y='{y:.1f}' text-anchor='{anchor}' fill='{colour}' {FONT}>{escape(text)}</text>"


def _nice_max(value: float) -> float:
    if value <= 0:
        return 1.0
    exponent = 10 ** math.floor(math.log10(value))
    for step in (1, 2, 2.5, 5, 10):
        if step * exponent >= value:
            return step * exponent
    return 10 * exponent


def timeline(buckets: Sequence[tuple[int, int, dict[str, int]]], width: int = 900, height: int = 220) -> str:
    """Disagreements per time bucket, stacked by kind."""
    label = "Timeline of disagreements"
    if not buckets:
        return _svg(width, 40, label, [_text(8, 24, "no frames in the selection")])
    left, right, top, bottom = 44, 10, 24, 36
    plot_w, plot_h = width - left - right, height - top - bottom
    peak = _nice_max(max(sum(c.values()) for _, _, c in buckets))
    bar_w = plot_w / len(buckets)
    body = [_legend(left, 14)]
    for i, (start, _width, counts) in enumerate(buckets):
        y = top + plot_h
        for kind, n in counts.items():
            if not n:
                continue
            h = plot_h * n / peak
            y -= h
            body.append(
                f"<rect x='{left + i * bar_w + 0.5:.1f}' y='{y:.1f}' width='{max(bar_w - 1, 1):.1f}' height='{h:.1f}' "
                f"fill='{KIND_COLOURS[kind]}'><title>{escape(iso(start))}: {n} {kind}</title></rect>"
            )
    body += _y_axis(left, top, plot_h, peak)
    body.append(f"<line x1='{left}' y1='{top + plot_h}' x2='{left + plot_w}' y2='{top + plot_h}' stroke='{AXIS}'/>")
    first, last = buckets[0][0], buckets[-1][0] + buckets[-1][1]
    body.append(_text(left, height - 14, iso(first), "start", AXIS))
    body.append(_text(left + plot_w, height - 14, iso(last), "end", AXIS))
    body.append(_text(left + plot_w / 2, height - 2, f"bucket {_duration(buckets[0][1])}", "middle", AXIS))
    return _svg(width, height, label, body)


def bars(items: Sequence[tuple[str, int]], label: str, width: int = 900, limit: int = 30) -> str:
    """Horizontal bars, largest first; the rest beyond `limit` summed in one line."""
    if not items:
        return _svg(width, 40, label, [_text(8, 24, "none")])
    shown = list(items[:limit])
    rest = sum(n for _, n in items[limit:])
    row, label_w, top = 18, min(360, 8 + 7 * max(len(k) for k, _ in shown)), 6
    plot_w = width - label_w - 60
    peak = max(n for _, n in shown)
    body = []
    for i, (key, n) in enumerate(shown):
        y = top + i * row
        w = plot_w * n / peak
        body.append(_text(label_w - 6, y + 12, key, "end"))
        body.append(
            f"<rect x='{label_w}' y='{y + 2}' width='{max(w, 1):.1f}' height='{row - 5}' fill='{BAR_COLOUR}'>"
            f"<title>{escape(key)}: {n}</title></rect>"
        )
        body.append(_text(label_w + w + 4, y + 12, str(n)))
    height = top + len(shown) * row + 8
    if rest:
        body.append(_text(label_w, height + 6, f"... and {len(items) - limit} more ({rest})", "start", AXIS))
        height += 16
    return _svg(width, height, label, body)


def histogram(
    values: Sequence[float],
    label: str,
    unit: str,
    markers: dict[str, Optional[float]],
    width: int = 900,
    height: int = 220,
    bins: int = 40,
) -> str:
    """Distribution of values with vertical markers (percentiles)."""
    if not values:
        return _svg(width, 40, label, [_text(8, 24, "no values")])
    left, right, top, bottom = 44, 10, 10, 36
    plot_w, plot_h = width - left - right, height - top - bottom
    lo, hi = 0.0, max(values)
    hi = hi if hi > lo else lo + 1.0
    step = (hi - lo) / bins
    counts = [0] * bins
    for v in values:
        counts[min(bins - 1, int((v - lo) / step))] += 1
    peak = _nice_max(max(counts))
    bar_w = plot_w / bins
    body = []
    for i, n in enumerate(counts):
        if n:
            h = plot_h * n / peak
            body.append(
                f"<rect x='{left + i * bar_w + 0.5:.1f}' y='{top + plot_h - h:.1f}' width='{max(bar_w - 1, 1):.1f}' "
                f"height='{h:.1f}' fill='{BAR_COLOUR}'><title>{lo + i * step:.2f}-{lo + (i + 1) * step:.2f} {unit}: {n}</title></rect>"
            )
    for j, (name, value) in enumerate(markers.items()):
        if value is None:
            continue
        x = left + plot_w * (value - lo) / (hi - lo)
        body.append(
            f"<line x1='{x:.1f}' y1='{top}' x2='{x:.1f}' y2='{top + plot_h}' stroke='#1d2330' stroke-dasharray='3,3'/>"
        )
        right_half = x > left + plot_w / 2
        body.append(
            _text(
                x - 3 if right_half else x + 3,
                top + 10 + 12 * j,
                f"{name} {value:.2f} {unit}",
                "end" if right_half else "start",
            )
        )
    body += _y_axis(left, top, plot_h, peak)
    body.append(f"<line x1='{left}' y1='{top + plot_h}' x2='{left + plot_w}' y2='{top + plot_h}' stroke='{AXIS}'/>")
    body.append(_text(left, height - 18, f"{lo:g} {unit}", "start", AXIS))
    body.append(_text(left + plot_w, height - 18, f"{hi:.2f} {unit}", "end", AXIS))
    body.append(_text(left + plot_w / 2, height - 4, f"{len(values)} samples", "middle", AXIS))
    return _svg(width, height, label, body)


def _legend(x: float, y: float) -> str:
    parts = []
    for kind, colour in KIND_COLOURS.items():
        parts.append(f"<rect x='{x:.1f}' y='{y - 9:.1f}' width='10' height='10' fill='{colour}'/>")
        parts.append(_text(x + 14, y, kind))
        x += 90
    return "".join(parts)


def _y_axis(left: float, top: float, plot_h: float, peak: float) -> list[str]:
    out = [f"<line x1='{left}' y1='{top}' x2='{left}' y2='{top + plot_h}' stroke='{AXIS}'/>"]
    for frac in (0.0, 0.5, 1.0):
        value = peak * frac
        if value != int(value):  # the axes count frames and verdicts: no tick between two whole numbers
            continue
        out.append(_text(left - 4, top + plot_h * (1 - frac) + 4, str(int(value)), "end", AXIS))
    return out


def _duration(ns: int) -> str:
    s = ns / 1e9
    if s < 60:
        return f"{s:g} s"
    if s < 3600:
        return f"{s / 60:g} min"
    if s < 86400:
        return f"{s / 3600:g} h"
    return f"{s / 86400:g} d"
