"""`discern audit --replay`: every logged frame decided again, with the shipped rules or an edited copy."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from discern.rules.catalog import catalog_dirs
from tests.audit_logs import FLEET_A_FRAMES, FLEET_B_FRAMES, SHADOW_FRAMES, audit, monitor_logs

AT_LIMIT = "forbidden(accelerate) :- ego_speed(V), speed_limit(S), V >= S."


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    return monitor_logs(tmp_path_factory)


@pytest.fixture(scope="module")
def tolerant_rules(tmp_path_factory) -> Path:
    """The shipped driving rules with acc.at_limit edited to tolerate 5 m/s over the limit."""
    rules = tmp_path_factory.mktemp("rules") / "catalog"
    shutil.copytree(catalog_dirs()[0], rules)
    speed = rules / "30_speed.lp"
    text = speed.read_text()
    assert AT_LIMIT in text
    speed.write_text(text.replace(AT_LIMIT, AT_LIMIT.replace("V >= S.", "V >= S + 500.")))
    return rules


def replay(capsys, tmp_path, *args: str) -> tuple[int, dict, str]:
    out = tmp_path / "replay.json"
    code, text, err = audit(capsys, "--replay", *args, "--json", str(out))
    assert "Traceback" not in err
    return code, json.loads(out.read_text()), text


def test_replay_with_the_shipped_rules_changes_no_decision(capsys, tmp_path, logs):
    code, doc, text = replay(capsys, tmp_path, str(logs["fleet"]), str(logs["shadow"]), str(logs["slow"]), "--workers", "1")
    assert code == 0
    assert "no decision would change" in text
    assert doc["frames"] == FLEET_A_FRAMES + FLEET_B_FRAMES + SHADOW_FRAMES
    assert doc["changes"] == [] and doc["rules_only_changes"] == 0
    # not decided by the rules: the deadline fail-safe with a scene, and the verdicts with no proposal logged
    assert doc["skipped_failsafe"] == 1 and doc["skipped_refused"] == 3
    assert doc["decided"] + doc["reused"] == doc["frames"]


def test_replay_with_an_edited_rule_reports_each_changed_decision_side_by_side(capsys, tmp_path, logs, tolerant_rules):
    code, doc, text = replay(
        capsys, tmp_path, str(logs["fleet"]), str(logs["shadow"]), "--rules", str(tolerant_rules), "--workers", "1"
    )
    assert code == 1  # like diff: decisions changed
    changes = doc["changes"]
    assert len(changes) == FLEET_A_FRAMES // 2 + SHADOW_FRAMES
    assert {(c["vehicle"], c["recorded_decision"], c["replayed_decision"]) for c in changes} == {
        ("car_a", "override", "approve"),
        ("car_s", "veto", "approve"),
    }
    first = changes[0]
    assert first["proposed"] == "accelerate" and first["recorded_rules"] == "acc.at_limit"
    assert first["recorded_justification"] == "override accelerate with cruise: accelerate is forbidden by acc.at_limit"
    assert first["replayed_justification"].startswith("approve accelerate: permitted")
    assert first["replayed_verdict"]["justification"]["tree"], "a changed decision carries its full justification tree"
    assert first["recorded_verdict"]["justification"]["tree"]
    assert doc["transitions"] == {
        "accelerate: override cruise -> approve accelerate": FLEET_A_FRAMES // 2,
        "accelerate: veto accelerate -> approve accelerate": SHADOW_FRAMES,
    }
    assert f"{len(changes)} decisions would change" in text
    assert "    recorded: override cruise [acc.at_limit]  override accelerate with cruise" in text
    assert "    replayed: approve accelerate [dec.permitted]  approve accelerate: permitted" in text


def test_identical_frames_are_decided_once(capsys, tmp_path, logs):
    _, doc, text = replay(capsys, tmp_path, str(logs["shadow"]), "--workers", "1")
    # car_s proposes the same acceleration in the same scene every frame: only frame and time differ
    assert doc["frames"] == SHADOW_FRAMES and doc["decided"] == 1 and doc["reused"] == SHADOW_FRAMES - 1
    assert f"1 decided, {SHADOW_FRAMES - 1} identical to a frame decided before" in text


def test_worker_processes_find_the_same_changes(capsys, tmp_path, logs, tolerant_rules):
    args = [str(logs["fleet"]), "--rules", str(tolerant_rules)]
    _, one, _ = replay(capsys, tmp_path, *args, "--workers", "1")
    _, two, _ = replay(capsys, tmp_path, *args, "--workers", "2")
    assert two["workers"] == 2
    assert two["changes"] == one["changes"] and two["frames"] == one["frames"]


def test_a_broken_rules_directory_is_named(capsys, tmp_path, logs):
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "10_bad.lp").write_text("%! rule x.bad\n%! says Nothing.\n%! source none\nforbidden(A) :- action(A\n")
    code, out, err = audit(capsys, "--replay", str(logs["fleet"]), "--rules", str(broken), "--workers", "1")
    assert code == 2 and out == ""
    assert err.startswith(f"discern audit: rules catalog: {broken / '10_bad.lp'}:5:1") and "syntax error" in err
    assert "Traceback" not in err
