"""`discern audit` on real monitor logs: the listing, its filters, the aggregates and the exports."""

from __future__ import annotations

import csv
import json
import os
import shutil
from datetime import datetime, timezone
from fractions import Fraction

import pytest

from bench.report import pct
from discern.monitor.audit.aggregate import Odometer, latency_summary
from discern.monitor.audit.timefmt import iso, parse_time
from discern.monitor.client import Monitor
from discern.monitor.config import LogSettings, MonitorConfig, ZenohSettings, free_port
from discern.monitor.example_planner import highway_scene
from discern.monitor.log import McapLogWriter, RejectedInput, vehicle_topic
from discern.monitor.server import MonitorServer
from discern.monitor.status import StatusCounters, percentile
from discern.rules.scene import Proposal
from discern.sanity import window_reasoner
from tests.audit_logs import (
    CLEAR_FRAMES,
    FLEET_A_FRAMES,
    FRAMES,
    PEDESTRIAN_FRAMES,
    SHADOW_FRAMES,
    SLOW_FRAMES,
    audit,
    highway,
    monitor_logs,
    serve_log,
    write_log,
)
from tests.monitor_process import wait_until
from tests.scenes import scene


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    return monitor_logs(tmp_path_factory)


@pytest.fixture(scope="module")
def all_logs(logs):
    return [str(logs[k]) for k in ("fleet", "shadow", "slow")]


def export(capsys, tmp_path, *args: str) -> dict:
    out = tmp_path / "audit.json"
    code, _, err = audit(capsys, *args, "--json", str(out), "--workers", "1")
    assert code == 0, err
    return json.loads(out.read_text())


def test_lists_every_veto_override_and_failsafe_with_rules_and_justification(capsys, all_logs):
    code, out, err = audit(capsys, *all_logs, "--workers", "1")
    assert code == 0, err
    overrides = FLEET_A_FRAMES // 2 + PEDESTRIAN_FRAMES
    assert f"override {overrides}, veto {SHADOW_FRAMES}, fail-safe {1 + SLOW_FRAMES}" in out
    lines = [l for l in out.splitlines() if l.startswith("  20")]
    assert len(lines) == overrides + SHADOW_FRAMES + 1 + SLOW_FRAMES
    row = next(l for l in lines if " car_a  frame 1 " in l)
    assert "override  accelerate -> cruise" in row and "[acc.at_limit]" in row
    assert row.endswith("override accelerate with cruise: accelerate is forbidden by acc.at_limit")
    veto = next(l for l in lines if " car_s  frame 3 " in l)
    assert "veto      accelerate -> accelerate" in veto and "shadow mode, not enforced" in veto
    bad = next(l for l in lines if "monitor.bad_input" in l)
    assert " car_b  frame - " in bad and " failsafe " in bad and "malformed JSON" in bad
    # the columns line up, whatever the vehicles' names and the frame ids
    assert len({l.index(" frame ") for l in lines}) == 1
    kinds = {min(l.find(k, l.index(" frame ")) for k in ("override", "veto", "failsafe") if k in l) for l in lines}
    assert len(kinds) == 1
    assert sum("[monitor.deadline]" in l for l in lines) == SLOW_FRAMES
    assert "1 refused input (the monitor status's errors)" in out


def test_filters_by_vehicle_rule_verdict_and_time(capsys, tmp_path, all_logs):
    by_vehicle = export(capsys, tmp_path, *all_logs, "--vehicle", "car_b")
    assert {d["vehicle"] for d in by_vehicle["disagreements"]} == {"car_b"}
    assert len(by_vehicle["disagreements"]) == PEDESTRIAN_FRAMES + 1
    assert by_vehicle["frames"] == PEDESTRIAN_FRAMES + 1  # the vehicle filter applies to frames too

    by_rule = export(capsys, tmp_path, *all_logs, "--rule", "acc.*")
    assert len(by_rule["disagreements"]) == FLEET_A_FRAMES // 2 + SHADOW_FRAMES
    assert by_rule["frames"] == FRAMES  # rule and verdict filters only narrow the listing

    vetoes = export(capsys, tmp_path, *all_logs, "--verdict", "veto", "--verdict", "failsafe")
    assert {d["verdict"] for d in vetoes["disagreements"]} == {"veto", "failsafe"}
    assert len(vetoes["disagreements"]) == SHADOW_FRAMES + 1 + SLOW_FRAMES

    times = [d["log_time_ns"] for d in by_rule["disagreements"]]
    since = (times[2] + times[3]) / 2e9  # epoch seconds, between two disagreements
    until = datetime.fromtimestamp((times[7] + times[8]) / 2e9, tz=timezone.utc).isoformat()
    window = export(capsys, tmp_path, *all_logs, "--rule", "acc.*", "--since", f"{since:.6f}", "--until", until)
    assert [d["log_time_ns"] for d in window["disagreements"]] == times[3:8]


def test_aggregates_per_rule_action_pair_scenario_and_time(capsys, tmp_path, all_logs):
    doc = export(capsys, tmp_path, *all_logs)
    assert doc["per_rule"]["acc.at_limit"] == FLEET_A_FRAMES // 2 + SHADOW_FRAMES
    assert doc["per_rule"]["cruise.hazard"] == PEDESTRIAN_FRAMES
    pairs = doc["per_action_pair"]
    assert pairs["accelerate -> cruise"] == FLEET_A_FRAMES // 2 and pairs["accelerate -> accelerate"] == SHADOW_FRAMES
    # braking for the pedestrian, the malformed payload (no proposal: '?'), and the deadline fail-safes
    assert pairs.get("cruise -> brake", 0) + pairs.get("? -> brake", 0) == PEDESTRIAN_FRAMES + 1 + SLOW_FRAMES
    assert pairs["? -> brake"] >= 1 and set(pairs) == {
        "accelerate -> cruise",
        "accelerate -> accelerate",
        "cruise -> brake",
        "? -> brake",
    }
    scenarios = {s["scenario"]: (s["disagreements"], s["frames"]) for s in doc["per_scenario"]}
    assert scenarios["city/vulnerable_road_user"] == (PEDESTRIAN_FRAMES, PEDESTRIAN_FRAMES)
    assert scenarios["city/open_road"] == (0, CLEAR_FRAMES)
    assert sum(b["veto"] + b["override"] + b["failsafe"] for b in doc["over_time"]) == len(doc["disagreements"])
    assert doc["latency_ms"]["samples"] == doc["frames"] == FRAMES


def test_the_audit_calls_vulnerable_the_road_users_the_catalog_does(reasoner):
    from discern.monitor.audit.aggregate import VULNERABLE, scenario_kind
    from discern.rules.scene import ObjectClass, Scene

    solved = reasoner.solve(Scene.model_validate({"frame_id": 1, "timestamp": 0.0, "ego": {"speed": 5.0, "lane": 1},
                                                  "lanes": [{"kind": "current", "id": 1}]}), "cruise")
    assert VULNERABLE == {ObjectClass(a.arguments[0].name) for a in solved.answer.of("vulnerable", 1)}
    motorbike = Scene.model_validate({"frame_id": 1, "timestamp": 0.0, "ego": {"speed": 5.0, "lane": 1, "zone": "city"},
                                      "lanes": [{"kind": "current", "id": 1}],
                                      "objects": [{"id": 1, "class": "bike", "position": {"x": 3.5, "y": 10.0}}]})
    assert scenario_kind(motorbike) != "city/vulnerable_road_user"


def test_latency_percentiles_take_the_nearest_rank_so_few_samples_do_not_lean_high():
    two = latency_summary([3.0, 1.0])
    assert (two["samples"], two["p50_ms"], two["max_ms"]) == (2, 1.0, 3.0)
    ten = latency_summary([float(v) for v in range(10, 0, -1)])
    assert (ten["p50_ms"], ten["p90_ms"], ten["p99_ms"], ten["max_ms"]) == (5.0, 9.0, 10.0, 10.0)


def test_no_more_than_one_percent_of_latencies_lie_above_the_p99():
    """3 of 273 latencies once lay above the status key's p99, which then read 44 ms under a 50 ms budget."""
    for n in (100, 273, 1000, 8192):
        ordered = [float(v) for v in range(1, n + 1)]
        for q in ("50", "90", "99", "99.9"):
            value, share_above = percentile(ordered, float(q)), (100 - Fraction(q)) / 100 * n
            assert sum(v > value for v in ordered) <= share_above, (n, q)
            assert sum(v >= value for v in ordered) > share_above, (n, q)  # the least such value


def test_the_audit_the_status_key_and_the_benchmarks_report_the_same_percentiles():
    for n in range(1, 40):
        values = [float(v) for v in range(n, 0, -1)]
        status = StatusCounters("unit", "*", 50)
        for v in values:
            status.verdict_sent("approve", False, v, None)
        live = status.snapshot().latency_ms
        audit = latency_summary(values)
        assert (live.p50_ms, live.p90_ms, live.p99_ms, live.max_ms) == (
            audit["p50_ms"], audit["p90_ms"], audit["p99_ms"], audit["max_ms"]), n
        assert [pct(values, q) for q in (50, 90, 99)] == [audit["p50_ms"], audit["p90_ms"], audit["p99_ms"]], n


def test_json_export_counts_every_decision_kind_even_when_none_occurred(capsys, tmp_path, logs):
    doc = export(capsys, tmp_path, str(logs["shadow"]))
    assert doc["decisions"] == {"approve": 0, "veto": SHADOW_FRAMES, "override": 0, "failsafe": 0}


def test_the_terminal_shows_disagreements_per_scenario_and_per_vehicle_out_of_their_frames(capsys, all_logs):
    code, out, err = audit(capsys, *all_logs, "--workers", "1")
    assert code == 0, err
    per_scenario = out.split("Disagreements per scenario kind:\n")[1]
    assert f"  {PEDESTRIAN_FRAMES:>6}  city/vulnerable_road_user (of {PEDESTRIAN_FRAMES} frames)\n" in per_scenario
    per_vehicle = out.split("Disagreements per vehicle:\n")[1]
    assert f"  {FLEET_A_FRAMES // 2:>6}  car_a (of {FLEET_A_FRAMES} frames, 0.12 km)\n" in per_vehicle
    assert f"  {0:>6}  car_c (of {CLEAR_FRAMES} frames, 0.01 km)\n" in per_vehicle


def test_quiet_leaves_out_the_line_per_disagreement_and_keeps_the_tables(capsys, all_logs):
    _, full, _ = audit(capsys, *all_logs, "--workers", "1")
    code, quiet, err = audit(capsys, *all_logs, "--workers", "1", "-q")
    assert code == 0, err
    head, listing = full.split("\n\nDisagreements (", 1)
    tables = listing.split("\n\nDisagreements per rule:\n", 1)[1]
    assert quiet == f"{head}\n\nDisagreements per rule:\n{tables}"
    assert "acc.at_limit" in tables.split("\n\n")[0]


def test_odometry_integrates_scene_speed_over_scene_time(capsys, tmp_path, all_logs):
    doc = export(capsys, tmp_path, *all_logs)
    km = {v["vehicle"]: v["km"] for v in doc["per_vehicle"]}
    # 0.1 s between frames: car_a 39 steps at 31 m/s, car_s 29 at 32 m/s, car_b and car_c 9 each at 8 m/s
    assert km["car_a"] == pytest.approx(39 * 0.1 * 31 / 1000)
    assert km["car_s"] == pytest.approx(29 * 0.1 * 32 / 1000)
    assert km["car_b"] == km["car_c"] == pytest.approx(9 * 0.1 * 8 / 1000)
    total_km = sum(km.values())
    assert doc["odometry"]["km"] == pytest.approx(total_km)
    assert doc["odometry"]["per_km"] == pytest.approx(len(doc["disagreements"]) / total_km)
    late = 2 if km.get("car_l") else 0  # the deadline fail-safes' scenes, when the monitor logged them
    assert doc["odometry"]["driving_hours"] == pytest.approx((39 + 29 + 9 + 9 + late) * 0.1 / 3600)


def test_a_refused_out_of_order_frame_does_not_move_the_odometer(capsys, tmp_path):
    refused = []

    def drive(endpoint: str) -> None:
        with Monitor("car_o", connect=[endpoint], timeout=10.0) as car:
            for frame in [*range(1, 21), 5, *range(21, 31)]:  # frame 5 again after 20: refused
                verdict = car.check(scene(frame=frame, timestamp=frame * 0.1, speed=10.0), "cruise")
                if verdict.failsafe:
                    refused.append((frame, verdict.rules))

    serve_log(tmp_path / "log", "ooo", drive, budget_ms=1000.0)
    assert refused == [(5, ["monitor.bad_input"])]
    doc = export(capsys, tmp_path, str(tmp_path / "log"))
    assert doc["frames"] == 31 and [d["frame_id"] for d in doc["disagreements"]] == [5]
    # frames 1 to 30, 0.1 s apart at 10 m/s: 29 steps, as if the refused frame had not been sent
    assert doc["odometry"]["km"] == pytest.approx(29 * 0.1 * 10 / 1000)
    assert doc["odometry"]["driving_hours"] == pytest.approx(29 * 0.1 / 3600)


def test_an_episode_whose_clock_starts_again_at_0_is_a_new_stretch_of_the_odometer():
    odometer = Odometer()
    for episode in range(2):  # each 1 s at 10 m/s, scene time 0.0 to 1.0, proposals 0.1 s apart
        for step in range(11):
            odometer.add("car_e", round(0.1 * step, 1), 100.0 + episode * 5 + 0.1 * step, 10.0)
    assert (odometer.km, odometer.hours) == (0.02, 2.0 / 3600)


def test_the_odometer_sums_the_same_however_its_frames_are_split():
    frames = [(round(0.1 * i, 1), 1.0 + 0.1 * i, 0.3 + 0.7 * (i % 3)) for i in range(60)]
    whole, halves = Odometer(), Odometer()
    for f in frames:
        whole.add("v", *f)
    second = Odometer()
    for f in frames[:31]:
        halves.add("v", *f)
    second.warm("v", *frames[30])
    for f in frames[31:]:
        second.add("v", *f)
    merged = Odometer()
    merged.merge(second)
    merged.merge(halves)  # the other order
    assert (merged.km, merged.hours) == (whole.km, whole.hours)


def test_refusals_and_unanswered_proposals_are_counted_under_the_vehicle_and_time_filters(capsys, tmp_path):
    writer = McapLogWriter(LogSettings(directory=tmp_path / "log"), "filters")
    reasoner = window_reasoner()
    second = 1_800_000_000 * 10**9
    for f in range(3):
        p = Proposal(vehicle="car_a", action="cruise", scene=highway_scene(f, 2))
        writer.write(vehicle_topic("car_a", "proposal"), "proposal", p, log_time_ns=second * (f + 1))
        verdict = reasoner.decide(p.scene, p.action, vehicle="car_a")
        writer.write(vehicle_topic("car_a", "verdict"), "verdict", verdict, log_time_ns=second * (f + 1) + 1)
    lost = Proposal(vehicle="car_b", action="cruise", scene=highway_scene(0, 2))  # its verdict never logged
    writer.write(vehicle_topic("car_b", "proposal"), "proposal", lost, log_time_ns=second)
    refused = RejectedInput(vehicle="car_b", key="discern/car_b/check", size=3, error="malformed JSON", excerpt="{{{")
    writer.write(vehicle_topic("car_b", "rejected"), "rejected", refused, log_time_ns=second)
    writer.close()
    log = str(tmp_path / "log")
    car_b = "1 proposal without a logged verdict; 1 refused input"
    assert car_b in audit(capsys, log, "--workers", "1", "-q")[1]
    assert car_b in audit(capsys, log, "--vehicle", "car_b", "--workers", "1", "-q")[1]
    for args in (["--vehicle", "car_a"], ["--since", str(second * 2)], ["--until", str(second - 1)]):
        code, out, err = audit(capsys, log, *args, "--workers", "1", "-q")
        assert code == 0 and "without a logged verdict" not in out and "refused input" not in out, (args, out)
        _, out, _ = audit(capsys, "--replay", log, *args, "--workers", "1", "-q")
        assert "without a logged verdict" not in out, (args, out)


def test_since_and_until_take_epoch_nanoseconds_as_the_csv_gives_them(capsys, tmp_path, all_logs):
    times = [d["log_time_ns"] for d in export(capsys, tmp_path, *all_logs)["disagreements"]]
    since, until = (times[2] + times[3]) // 2, (times[7] + times[8]) // 2
    by_ns = export(capsys, tmp_path, *all_logs, "--since", str(since), "--until", str(until))
    by_s = export(capsys, tmp_path, *all_logs, "--since", f"{since / 1e9:.6f}", "--until", f"{until / 1e9:.6f}")
    assert [d["log_time_ns"] for d in by_ns["disagreements"]] == times[3:8]
    assert by_s["disagreements"] == by_ns["disagreements"]


def test_csv_text_a_spreadsheet_would_run_as_a_formula_stays_text(capsys, tmp_path, reasoner):
    """A verdict's error or summary that starts with '=' became a live formula when the CSV was opened."""
    class Formulas:
        def decide(self, *args, **kwargs):
            verdict = reasoner.decide(*args, **kwargs)
            return verdict.model_copy(update={"error": '=HYPERLINK("http://x","y")'})

    log = write_log(tmp_path / "log", [("car_a", highway(1), "accelerate", 10**18, 10**18 + 10**6)], Formulas())
    out = tmp_path / "audit.csv"
    code, _, err = audit(capsys, str(log), "--csv", str(out), "--workers", "1", "-q")
    assert code == 0, err
    [row] = csv.DictReader(out.open())
    assert row["error"] == '\'=HYPERLINK("http://x","y")' and row["log_time_ns"] == str(10**18 + 10**6)


def test_the_html_reports_per_rule_table_says_which_cited_rule_this_versions_catalog_no_longer_has(
    capsys, tmp_path, reasoner
):
    """A log an older catalog decided cites ids since renamed: an empty "says" cell left the reader guessing."""
    class OlderCatalog:
        def decide(self, *args, **kwargs):
            verdict = reasoner.decide(*args, **kwargs)
            return verdict.model_copy(update={"rules": ["acc.retired_rule"], "vetoed_by": ["acc.retired_rule"]})

    log = write_log(tmp_path / "log", [("car_a", highway(1), "accelerate", 10**18, 10**18 + 10**6)], OlderCatalog())
    page = tmp_path / "audit.html"
    code, _, err = audit(capsys, str(log), "--html", str(page), "--workers", "1", "-q")
    assert code == 0, err
    html = page.read_text()
    # forbade 1, also cited 0
    assert "<td>acc.retired_rule</td><td class=n>1</td><td class=n>0</td><td>(no rule of this version&#x27;s" in html


def test_a_shown_time_is_the_millisecond_its_record_falls_in_so_given_back_it_keeps_the_record(
    capsys, tmp_path, reasoner
):
    """Shown rounded up (a float's rounding), a time late in its millisecond pasted into --since left its record out."""
    late = 1_790_000_000_000_999_700
    assert iso(late) == "2026-09-21T14:13:20.000Z" and iso(1_790_000_000_999_999_600) == "2026-09-21T14:13:20.999Z"
    assert parse_time("2026-09-21T14:13:20.001Z") == 1_790_000_000_001_000_000  # exact, not 1_790_000_000_000_999_936
    assert parse_time("2026-09-21T15:13:20.000001+01:00") == 1_790_000_000_000_001_000
    assert parse_time("1790000000.001") == 1_790_000_000_001_000_000
    log = write_log(tmp_path / "log", [("car_a", highway(1), "accelerate", late - 10**6, late)], reasoner)
    out = tmp_path / "audit.csv"
    code, _, err = audit(capsys, str(log), "--csv", str(out), "--workers", "1", "-q")
    assert code == 0, err
    [row] = csv.DictReader(out.open())
    assert (row["time"], row["log_time_ns"], row["verdict"]) == ("2026-09-21T14:13:20.000Z", str(late), "override")
    since = export(capsys, tmp_path, str(log), "--since", row["time"])
    assert [d["log_time_ns"] for d in since["disagreements"]] == [late]
    until = export(capsys, tmp_path, str(log), "--since", row["time"], "--until", row["time"])  # to the end of its ms
    assert [d["log_time_ns"] for d in until["disagreements"]] == [late]
    assert parse_time("2026-09-21T14:13:20.000Z", through=True) == 1_790_000_000_000_999_999
    assert parse_time("2026-09-21", through=True) - parse_time("2026-09-21") == 86_400 * 10**9 - 1
    assert parse_time(str(late), through=True) == late  # epoch nanoseconds are exact


@pytest.mark.parametrize("until, last", [
    ("2026-11-27T17:12", "2026-11-27T17:12:59.999Z"),  # a minute: all of it
    ("2026-11-27T17", "2026-11-27T17:59:59.999Z"),
    ("20261127T1712Z", "2026-11-27T17:12:59.999Z"),  # the basic format
    ("2026-11-27 17:12-05:00", "2026-11-27T22:12:59.999Z"),
    ("2026-W48-5", "2026-11-27T23:59:59.999Z"),  # a week date: the day
    ("2026-W48", "2026-11-29T23:59:59.999Z"),  # ... without its day: the week
    ("2026-11-27T17:12:50,091Z", "2026-11-27T17:12:50.091Z"),  # a decimal comma
    ("1764263571.5", "2025-11-27T17:12:51.599Z"),
    ("2026-11-27T17:12:50.717z", "2026-11-27T17:12:50.717Z"),  # RFC 3339's lowercase z
    ("9999-12-31T23:59:59.999Z", "9999-12-31T23:59:59.999Z"),  # a time the audit shows for --until 9999-12-31T23:59:59Z
    ("253402300799.5", "9999-12-31T23:59:59.599Z"),
])
def test_until_runs_to_the_end_of_the_unit_the_time_is_written_to_however_iso_writes_it(until, last):
    assert iso(parse_time(until, through=True)) == last
    assert parse_time(until, through=True) % 10**6 == 999_999  # to the last nanosecond of that unit


def test_a_report_that_would_overwrite_a_log_is_refused_before_the_logs_are_read(capsys, tmp_path, logs):
    run = tmp_path / "run"
    run.mkdir()
    first, second = run / "a.mcap", run / "b.mcap"
    shutil.copy(logs["fleet"], first)
    shutil.copy(logs["shadow"], second)
    before = first.read_bytes(), second.read_bytes()
    for mode in ([], ["--replay"]):
        # the directory's first log named again as the report, spelt another way
        spelt = f"{tmp_path}/run/../run/a.mcap"
        code, out, err = audit(capsys, str(run), *mode, "--json", spelt, "--workers", "1")
        assert code == 2 and out == "", err
        assert err.strip() == f"discern audit: error: --json {spelt}: the report would overwrite the log {first}"
        # `discern audit --csv run/*.mcap`: the shell made the first log the CSV, the second one the log read
        code, out, err = audit(capsys, *mode, "--csv", str(first), str(second), "--workers", "1")
        assert code == 2 and out == "", err
        assert f"--csv {first}: a report named *.mcap could overwrite a log" in err
        assert len(err.strip().splitlines()) == 1
    assert (first.read_bytes(), second.read_bytes()) == before


def test_a_report_that_is_a_hard_link_to_a_log_is_refused_as_the_log_it_is(capsys, tmp_path, logs):
    """A hard link is the log's file under another name: writing the report through it would destroy the log."""
    run = tmp_path / "run"
    run.mkdir()
    log = run / "a.mcap"
    shutil.copy(logs["fleet"], log)
    report = tmp_path / "report.csv"
    os.link(log, report)
    before = log.read_bytes()
    for mode in ([], ["--replay"]):
        code, out, err = audit(capsys, str(run), *mode, "--csv", str(report), "--workers", "1")
        assert code == 2 and out == ""
        assert err == f"discern audit: error: --csv {report}: the report would overwrite the log {log}\n"
    assert log.read_bytes() == before


def test_csv_export_has_one_row_per_disagreement(capsys, tmp_path, all_logs):
    out = tmp_path / "audit.csv"
    code, _, err = audit(capsys, *all_logs, "--csv", str(out), "--workers", "1", "--quiet")
    assert code == 0 and f"wrote {out}" in err
    rows = list(csv.DictReader(out.open()))
    assert len(rows) == FLEET_A_FRAMES // 2 + PEDESTRIAN_FRAMES + SHADOW_FRAMES + 1 + SLOW_FRAMES
    first = next(r for r in rows if r["vehicle"] == "car_b" and r["frame_id"] == "0")
    assert (first["proposed"], first["executed"], first["verdict"]) == ("cruise", "brake", "override")
    assert first["rules"] == "cruise.closing_in;cruise.hazard;brake.obstacle_ahead"  # closing in on it, and a hazard
    assert first["time"].endswith("Z") and float(first["latency_ms"]) > 0


def test_worker_processes_give_the_same_audit_as_one_process(capsys, tmp_path, all_logs):
    one = export(capsys, tmp_path, *all_logs)
    out = tmp_path / "parallel.json"
    code, _, err = audit(capsys, *all_logs, "--json", str(out), "--workers", "2", "--quiet")
    assert code == 0, err
    two = json.loads(out.read_text())
    assert two == one


def test_a_report_that_cannot_be_written_is_refused_before_the_logs_are_read(capsys, tmp_path, logs):
    written = tmp_path / "audit.csv"
    nowhere = tmp_path / "no" / "r.html"
    for mode in ([], ["--replay"]):
        code, out, err = audit(capsys, str(logs["fleet"]), *mode, "--csv", str(written), "--html", str(nowhere))
        assert code == 2 and out == "" and not written.exists(), err
        assert err.strip() == f"discern audit: error: cannot write {nowhere}: No such file or directory"
    code, out, err = audit(capsys, str(logs["fleet"]), "--csv", str(written), "--json", str(written))
    assert code == 2 and out == "" and not written.exists()
    assert f"--csv and --json name the same file {written}" in err


@pytest.mark.parametrize(
    "args, message",
    [
        (["/nonexistent/run.mcap"], "/nonexistent/run.mcap: no such file or directory"),
        (["{log}", "--since", "yesterday"], "--since: time 'yesterday' is neither ISO 8601"),
        (["{log}", "--until", "inf"], "--until inf: not a finite time"),
        (["{log}", "--since", "nan", "--replay"], "--since nan: not a finite time"),
        (["{log}", "--since", "1e30"], "--since 1e30: out of range: epoch seconds go from 0 to"),
        (["{log}", "--replay", "--until", "-1"], "--until -1: out of range"),
        (["{log}", "--since", "1795317229313"], "--since 1795317229313: out of range"),  # milliseconds
        (["{log}", "--until", "1969-07-20T20:17:40Z"], "--until 1969-07-20T20:17:40Z: out of range"),
        (["{log}", "--since", "2026-01-02", "--until", "2026-01-01"], "--since 2026-01-02 is after --until 2026-01-01"),
        (["{log}", "--rules", "/tmp"], "--rules only applies with --replay"),
        (["{log}", "--replay", "--rules", "/nonexistent"], "rules catalog: rules directory /nonexistent does not exist"),
        (["{log}", "--replay", "--verdict", "veto"], "--rule and --verdict filter the audit listing"),
        (["{log}", "--workers", "0"], "--workers must be 1 to 64, got 0"),
        (["{log}", "--workers", "100000"], "--workers must be 1 to 64, got 100000"),
        (["{log}", "--since", ""], "--since: time '' is neither ISO 8601"),  # an unset shell variable
        (["{log}", "--replay", "--until", ""], "--until: time '' is neither ISO 8601"),
        (["{log}", "--vehicle", ""], "--vehicle is empty: it would match nothing"),
        (["{log}", "--rule", " "], "--rule is empty: it would match nothing"),
        (["{log}", "--replay", "--window", "inf"], "--window must be a finite number at least 1.5 s and at most 60 s, got inf"),
        (["{log}", "--replay", "--window", "0"], "--window must be a finite number at least 1.5 s and at most 60 s, got 0.0"),
        # as the monitor's --window-s: shorter, every flash is judged afresh, which no monitor decides with
        (["{log}", "--replay", "--window", "1"], "--window must be a finite number at least 1.5 s and at most 60 s, got 1.0"),
        (["{log}", "--html", "/nonexistent/dir/report.html"], "cannot write /nonexistent/dir/report.html"),
    ],
)
def test_a_users_mistake_is_named_in_one_line(capsys, logs, args, message):
    code, _, err = audit(capsys, *[a.format(log=logs["slow"]) for a in args])
    assert code == 2
    assert message in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


def test_a_deadline_failsafe_takes_its_scene_time_from_its_logged_proposal(capsys, tmp_path, logs):
    out = tmp_path / "slow.csv"
    code, _, err = audit(capsys, str(logs["slow"]), "--csv", str(out), "--workers", "1", "-q")
    assert code == 0, err
    rows = [r for r in csv.DictReader(out.open()) if "monitor.deadline" in r["rules"]]
    assert len(rows) == SLOW_FRAMES
    # the fail-safe answered before the scene was read: its verdict has no timestamp, its logged proposal has
    assert [float(r["scene_time"]) for r in rows] == [highway(int(r["frame_id"])).timestamp for r in rows]


def test_the_example_planners_scene_time_follows_its_frame_rate(tmp_path):
    import io

    from discern.monitor.example_planner import run
    from discern.monitor.log import read_log

    rate_hz = 10.0
    serve_log(tmp_path, "planner", lambda endpoint: run("ego", 4, rate_hz, [endpoint], out=io.StringIO()))
    stamps = [r.proposal.scene.timestamp for r in read_log(tmp_path) if r.kind == "proposal"]
    assert len(stamps) == 4
    # one frame period of scene time per frame, as the frames really came: the audit's rates per hour go by it
    assert [round(b - a, 6) for a, b in zip(stamps, stamps[1:])] == [1 / rate_hz] * 3


def test_with_no_log_named_it_reads_where_discern_serve_logs_by_default(capsys, tmp_path, monkeypatch, logs):
    monkeypatch.chdir(tmp_path)
    code, _, err = audit(capsys)
    assert code == 2 and err.strip() == ("discern audit: error: discern-log: no such file or directory "
                                         "(the log `discern serve` writes by default; name the logs to read)")
    (tmp_path / "discern-log").mkdir()
    shutil.copy(logs["slow"], tmp_path / "discern-log")
    code, out, _ = audit(capsys, "-q")
    assert code == 0 and out == audit(capsys, "discern-log", "-q")[1] and "frames: 3 (" in out


@pytest.mark.parametrize("until", ["1800000000", "1.8e9", "1.800000000e9", "+1800000000", "1_800_000_000"])
def test_until_in_epoch_seconds_however_written_runs_to_the_end_of_its_last_digits_unit(capsys, tmp_path, until):
    writer = McapLogWriter(LogSettings(directory=tmp_path / "log"), "until")
    reasoner = window_reasoner()
    second = 1_800_000_000 * 10**9
    for f, at in enumerate((second + 10**8, second + 2 * 10**9, second + 3600 * 10**9)):  # 0.1 s, 2 s, 1 h after
        p = Proposal(vehicle="car_a", action="cruise", scene=highway_scene(f, 2))
        writer.write(vehicle_topic("car_a", "proposal"), "proposal", p, log_time_ns=at)
        writer.write(vehicle_topic("car_a", "verdict"), "verdict", reasoner.decide(p.scene, p.action), log_time_ns=at)
    writer.close()
    frames = export(capsys, tmp_path, str(tmp_path / "log"), "--until", until)["frames"]
    assert frames == (3 if until == "1.8e9" else 1)  # 1.8e9 is written to 10^8 s, some three years


def test_disagreements_count_per_rule_for_the_rules_that_forbade_the_proposal_and_apart_for_those_also_cited(
    capsys, tmp_path, reasoner
):
    """Counted for every rule a verdict cited, a sanity note that forbade nothing (san.memory.red_light) led the
    table for vetoes other rules made. A verdict logged before vetoed_by was counts for every rule, and says so."""
    writer = McapLogWriter(LogSettings(directory=tmp_path / "log"), "per_rule")
    cited = (
        (["acc.at_limit", "san.limit.debounce"], ["acc.at_limit"]),
        (["acc.at_limit", "acc.lane_not_clear", "san.limit.debounce"], ["acc.at_limit", "acc.lane_not_clear"]),
        (["acc.hazard", "san.memory.red_light"], None),  # logged without vetoed_by
    )
    for f, (rules, vetoed_by) in enumerate(cited):
        p = Proposal(vehicle="car_a", action="accelerate", scene=highway(f))
        verdict = reasoner.decide(p.scene, p.action, vehicle="car_a").model_copy(
            update={"rules": rules, "vetoed_by": vetoed_by or []})
        logged = verdict.model_dump(mode="json", exclude={"vetoed_by"} if vetoed_by is None else set())
        writer.write(vehicle_topic("car_a", "proposal"), "proposal", p, log_time_ns=10**18 + f * 10**8)
        writer.write(vehicle_topic("car_a", "verdict"), "verdict", json.dumps(logged).encode(),
                     log_time_ns=10**18 + f * 10**8 + 1)
    writer.close()
    log = str(tmp_path / "log")
    doc = export(capsys, tmp_path, log)
    assert doc["per_rule"] == {"acc.at_limit": 2, "acc.lane_not_clear": 1, "acc.hazard": 1, "san.memory.red_light": 1}
    assert doc["per_rule_also_cited"] == {"san.limit.debounce": 2} and doc["per_rule_unattributed"] == 1
    assert [d["vetoed_by"] for d in doc["disagreements"]] == [["acc.at_limit"], ["acc.at_limit", "acc.lane_not_clear"],
                                                              None]
    code, out, err = audit(capsys, log, "--workers", "1", "-q")
    assert code == 0, err
    table = out.split("Disagreements per rule:\n")[1].split("\n\n")[0]
    assert "  forbade  also cited  rule\n        2           0  acc.at_limit\n" in table
    assert "\n        0           2  san.limit.debounce\n" in table
    assert "1 disagreement logged without vetoed_by (by a monitor before 2026-11-27) counted as forbidden" in table
    # --rule still matches any rule a verdict cites, a sanity note included
    assert len(export(capsys, tmp_path, log, "--rule", "san.*")["disagreements"]) == 3


def test_the_audit_counts_as_refused_every_input_the_monitors_status_counts_as_an_error_and_lists_invalid_keys(
    capsys, tmp_path
):
    """A duplicate frame id is refused as bad input but logged on .../proposal, not .../rejected: the audit said 0
    refused where the status said 1. A put on a wildcard key (logged under @invalid) went unlisted per vehicle."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    settings = MonitorConfig(monitor_id="refusals", zenoh=ZenohSettings(listen=[endpoint]), workers=1,
                             budget_ms=1000.0, shadow=True, log=LogSettings(directory=tmp_path / "log"))
    with MonitorServer(settings) as server:
        with Monitor("car_a", connect=[endpoint], timeout=10.0) as car_a:
            assert not car_a.check(highway(1), "cruise").failsafe
            duplicate = car_a.check(highway(1), "brake")
            assert duplicate.failsafe and "duplicate frame 1" in duplicate.error
            assert list(car_a.session.get("discern/car_b/check", payload=b'{"action": ', timeout=10.0))
            car_a.session.put("discern/*/proposal", Proposal(action="cruise", scene=highway(2)).model_dump_json())
            wait_until(lambda: server.status().errors == 3)
        errors = server.status().errors_by_kind
    assert errors == {"order": 1, "json": 1, "vehicle": 1}
    doc = export(capsys, tmp_path, str(tmp_path / "log"))
    assert doc["refused_inputs"] == 3
    refused = {v["vehicle"]: (v["frames"], v["refused_inputs"]) for v in doc["per_vehicle"]}
    assert refused == {"car_a": (2, 1), "car_b": (1, 1), "@invalid": (0, 1)}
    _, out, _ = audit(capsys, str(tmp_path / "log"), "--workers", "1", "-q")
    assert "3 refused inputs (the monitor status's errors)" in out
    assert "@invalid (of 0 frames, 0.00 km, 1 refused input)" in out.split("Disagreements per vehicle:\n")[1]


def test_the_latency_line_of_a_single_verdict_says_verdict(capsys, tmp_path, reasoner):
    log = write_log(tmp_path / "log", [("car_a", highway(1), "accelerate", 10**18, 10**18 + 10**6)], reasoner)
    _, out, _ = audit(capsys, str(log), "--workers", "1", "-q")
    assert " over 1 verdict\n" in out


def test_the_csv_shows_a_proposed_action_never_read_as_the_terminal_does(capsys, tmp_path, all_logs):
    out = tmp_path / "audit.csv"
    code, text, err = audit(capsys, *all_logs, "--csv", str(out), "--workers", "1")
    assert code == 0, err
    [row] = [r for r in csv.DictReader(out.open()) if "malformed JSON" in r["error"]]
    assert row["proposed"] == "?" and "  ? -> brake  " in next(l for l in text.splitlines() if "malformed JSON" in l)
