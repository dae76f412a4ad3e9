"""The HTML reports, opened in a real headless Chromium: they render, hold what they should, and fetch nothing."""

from __future__ import annotations

import re
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import pytest

from tests.audit_logs import FLEET_A_FRAMES, FRAMES, SHADOW_FRAMES, audit, monitor_logs, tolerant_rules

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
needs_chromium = pytest.mark.skipif(
    CHROMIUM is None, reason="chromium is not installed (apt-get install -y chromium; `make test` installs it)"
)


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    return monitor_logs(tmp_path_factory)


def dump_dom(page: Path, tmp_path: Path) -> str:
    """The DOM Chromium built from the page, with every network fetch it might try turned off."""
    result = subprocess.run(
        [
            CHROMIUM,
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            f"--user-data-dir={tmp_path / 'chromium-profile'}",
            "--dump-dom",
            page.resolve().as_uri(),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr[-2000:]
    return result.stdout


class References(HTMLParser):
    """Every URL an element would load or link to."""

    def __init__(self):
        super().__init__()
        self.urls: list[str] = []

    def handle_starttag(self, tag, attrs):
        for name, value in attrs:
            if name in ("src", "href", "srcset", "poster", "data", "action", "xlink:href") and value:
                self.urls.append(value)


def external_references(html: str) -> list[str]:
    parser = References()
    parser.feed(html)
    css_urls = re.findall(r"url\(([^)]*)\)|@import", html)
    return [u for u in parser.urls if not u.startswith(("#", "data:"))] + [u for u in css_urls if u]


@needs_chromium
def test_audit_report_renders_in_a_browser_with_plots_and_every_tree(capsys, tmp_path, logs):
    page = tmp_path / "audit.html"
    files = [str(logs[k]) for k in ("fleet", "shadow", "slow")]
    code, _, err = audit(capsys, *files, "--html", str(page), "--workers", "1", "--quiet")
    assert code == 0, err
    html = page.read_text()
    assert external_references(html) == []
    dom = dump_dom(page, tmp_path)
    assert "<title>Discern audit</title>" in dom
    for plot in ("Timeline of disagreements", "Disagreements per rule", "Verdict latency"):
        assert f'aria-label="{plot}"' in dom, plot
    assert dom.count('<details class="dis"') == FLEET_A_FRAMES // 2 + 10 + SHADOW_FRAMES + 4
    assert "The ego does not accelerate where the speed one step of accelerating adds would take it past" in dom  # the rule's own words
    assert f"<b>{FRAMES}</b><span>frames</span>" in dom
    # a disagreement's full justification tree: the prohibition and why it holds, collapsible
    car_a = dom[dom.index("car_a frame 1 ") : dom.index("car_a frame 3 ")]
    assert '<span class="holds">accelerate is forbidden, because</span><span class="rule">acc.at_limit</span>' in car_a
    for premise in ("the ego drives at 31.0 m/s", "the speed limit in force is 30.0 m/s", "31.5 m/s (70.5 mph) &gt; 30.0 m/s (67.1 mph)"):
        assert f'<span class="holds">{premise}' in car_a, premise
    assert car_a.count("<details") >= 3  # nested, each level collapsible
    # the fail-safe rules say what they are in the per-rule table, as the catalog's do
    assert "A proposal the rules did not decide within the budget gets the most cautious permitted" in dom
    # a few seconds of driving: its rates are shown, and said to be rough
    assert "disagreements per hour (short run: rough)" in dom
    assert "width=\"100%\"" in dom and "2.5<" not in dom  # plots shrink with the window; count axes whole


@needs_chromium
def test_replay_report_shows_both_justifications_side_by_side(capsys, tmp_path, logs):
    rules = tolerant_rules(tmp_path)
    page = tmp_path / "replay.html"
    code, _, err = audit(
        capsys, "--replay", str(logs["shadow"]), "--rules", str(rules), "--html", str(page), "--workers", "1"
    )
    assert code == 1, err
    assert external_references(page.read_text()) == []
    dom = dump_dom(page, tmp_path)
    assert "<title>Discern replay</title>" in dom
    assert dom.count('<div class="side">') == SHADOW_FRAMES
    side = dom[dom.index('<div class="side">') :]
    recorded, replayed = side.split("<h3>replayed</h3>", 1)
    assert "<h3>recorded</h3>" in recorded and "veto accelerate: forbidden by acc.at_limit" in recorded
    assert "approve accelerate: permitted" in replayed and "accelerate is permitted" in replayed
    # what the replay decides differently is marked on both sides
    for side in (recorded, replayed):
        assert '<tr class="changed"><th>decision</th>' in side and '<tr class="changed"><th>rules</th>' in side
        assert '<tr class="changed"><th>proposed</th>' not in side
