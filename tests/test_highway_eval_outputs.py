"""What `discern eval highway` leaves in its --out folder: real highway-env episodes, the real planner and reasoner."""

import csv
import math

import pytest

pytest.importorskip("highway_env")
pytest.importorskip("torch")

from discern.adapters.highway.perception import Faults
from discern.monitor.cli import main as cli_main
from discern.scenarios.highway.evaluate import Setup, evaluate, evaluation_figure, report


def test_without_the_judge_false_vetoes_read_not_measured_rather_than_zero(tmp_path):
    """--no-judge once reported 0 false vetoes (and drew 0-high bars): a figure never measured read as a perfect one."""
    results = evaluate(1, [Faults()], ["discern"], Setup(duration=3, judge_vetoes=False), progress=False)
    assert results[0].vetoes > 0, "a veto to judge, or the test shows nothing"
    rows, text, _ = report(results, tmp_path)
    summary = next(csv.DictReader((tmp_path / "summary.csv").open()))
    assert [summary[key] for key in ("false_vetoes", "false_vetoes_per_km", "false_veto_share")] == ["nan"] * 3
    assert next(csv.DictReader((tmp_path / "episodes.csv").open()))["false_vetoes"] == ""
    header, _, row = text.splitlines()[:3]
    assert row[header.index("false/km"):].split()[0] == "–"
    false_vetoes = evaluation_figure(rows).axes[3]
    assert false_vetoes.get_title() == "false vetoes per km" and not false_vetoes.patches
    assert [t.get_text() for t in false_vetoes.texts] == ["not measured"]
    assert math.isfinite(rows[0]["vetoes_per_km"]) and evaluation_figure(rows).axes[2].patches


def test_a_rerun_into_the_same_folder_lists_only_what_it_wrote_and_leaves_no_earlier_run_s_plots(tmp_path, capsys):
    """A planner-only rerun once left the earlier run's vetoing_rules.png beside its own table, and said it wrote it."""
    def run(variants):
        assert cli_main(["eval", "highway", "--episodes", "1", "--faults", "none", "--variants", variants, "--quiet",
                         "--duration", "2", "--out", str(tmp_path)]) == 0
        return capsys.readouterr().out.splitlines()[-1]

    assert run("planner,discern").endswith(": summary.csv, episodes.csv, summary.txt, evaluation.png, vetoing_rules.png, "
                                           "run.json")
    assert (tmp_path / "vetoing_rules.png").is_file()
    assert run("planner") == f"wrote {tmp_path}/: summary.csv, episodes.csv, summary.txt, evaluation.png, run.json"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["episodes.csv", "evaluation.png", "run.json", "summary.csv",
                                                          "summary.txt"]


def test_recorded_verdicts_name_the_episodes_vehicle_as_their_topic_and_proposal_do(tmp_path):
    """They said "vehicle": "ego" under /discern/discern_missed-signs_10000/verdict: the audit could not tell whose."""
    from discern.monitor.log.reader import read_log

    faults = Faults.preset("signs,missed", miss_rate=0.9)  # signs,missed@0.9: a vehicle id has no '@' or '.'
    evaluate(1, [faults], ["discern"], Setup(duration=2, record=str(tmp_path)), progress=False)
    records = list(read_log(sorted(tmp_path.glob("*.mcap"))))
    verdicts = [r for r in records if r.kind == "verdict"]
    vehicle = "discern_signs-missed-0p9_10000"
    assert verdicts and {r.vehicle for r in records if r.kind in ("proposal", "verdict")} == {vehicle}
    assert {r.verdict.vehicle for r in verdicts} == {r.proposal.vehicle for r in records if r.kind == "proposal"} == {
        vehicle}


def test_a_wrapper_refuses_a_checker_that_decides_for_another_vehicle():
    from discern.adapters.highway.envs import make_env
    from discern.scenarios.highway.wrapper import DiscernWrapper, ReasonerChecker

    with pytest.raises(ValueError, match="^the checker decides for vehicle 'ego', the wrapper's vehicle is 'car7'"):
        DiscernWrapper(make_env("highway-fast-v0", duration=1), checker=ReasonerChecker(), vehicle="car7")


def test_weights_of_another_network_are_refused_naming_the_missing_unexpected_and_mis_shaped_keys(tmp_path, capsys):
    """The error ended at "Error(s) in loading state_dict for QNetwork:", the keys it meant on lines never shown."""
    import torch

    from discern.scenarios.highway.planner import default_weights

    state = torch.load(default_weights(), map_location="cpu", weights_only=True)
    del state["layers.4.bias"]
    state["layers.0.weight"] = torch.zeros(128, 35)
    state["head.weight"] = torch.zeros(5, 128)
    other = tmp_path / "other.pt"
    torch.save(state, other)
    code = cli_main(["eval", "highway", "--episodes", "1", "--variants", "planner", "--faults", "none", "--quiet",
                     "--weights", str(other), "--duration", "1", "--out", str(tmp_path / "out")])
    assert code == 2 and capsys.readouterr().err == (
        f"discern eval: error: {other} does not hold this planner's weights: missing layers.4.bias; unexpected "
        "head.weight; mis-shaped layers.0.weight (128x35 in the file, 256x35 here)\n")


def test_the_output_folder_records_what_produced_it_and_each_episode_its_fault_seed(tmp_path, capsys):
    """Nothing in --out said which command, weights, rules, code, rates or seeds made its figures; a rate other than
    the default read as the default's ('missed'), and no episode row said which fault seed to replay it with."""
    import hashlib
    import json
    from importlib import metadata

    from discern.rules.catalog import catalog_digest
    from discern.rules.code_digest import reasoning_code_digest
    from discern.rules.engine import jurisdiction_pack
    from discern.scenarios.highway.planner import default_weights

    argv = ["eval", "highway", "--episodes", "1", "--faults", "missed", "--miss-rate", "0.9", "--variants",
            "planner,discern", "--param", "headway_s=2", "--seed", "3", "--fault-seed", "0", "--duration", "2", "--quiet",
            "--out", str(tmp_path)]
    assert cli_main(argv) == 0
    assert "missed@0.9  discern" in capsys.readouterr().out
    episodes = list(csv.DictReader((tmp_path / "episodes.csv").open()))
    assert [(e["faults"], e["seed"], e["fault_seed"]) for e in episodes] == [("missed@0.9", "10003", "0")] * 2
    run = json.loads((tmp_path / "run.json").read_text())
    assert run["command"] == ["discern", *argv]
    assert run["arguments"]["miss_rate"] == 0.9 and run["arguments"]["episodes"] == 1 and run["arguments"]["jobs"] == 1
    assert run["environment"]["id"] == "highway-fast-v0" and run["environment"]["duration_s"] == 2.0
    assert run["episode_seeds"] == [10003] and run["fault_seed"] == 0
    [faults] = run["faults"]
    assert (faults["label"], faults["kinds"], faults["miss_rate"], faults["seed"]) == ("missed@0.9", {"missed": 0.9}, 0.9, 0)
    weights = default_weights()
    assert run["planner"]["weights"] == str(weights.resolve())
    assert run["planner"]["sha256"] == hashlib.sha256(weights.read_bytes()).hexdigest()
    discern = run["discern"]
    assert discern["jurisdiction"] == "us" and discern["param_overrides"] == {"accel_step": 2.5, "decel": 4.0,
                                                                             "headway_s": 2.0}
    assert discern["params"]["headway_s"] == 2.0 and discern["params"]["reaction_s"] == 1.0  # a default used
    assert discern["catalog"] == catalog_digest(extra_files=[jurisdiction_pack("us")])
    assert discern["reasoning_code"] == reasoning_code_digest()
    assert {name: run["versions"][name] for name in ("highway-env", "torch", "clingo")} == {
        name: metadata.version(name) for name in ("highway-env", "torch", "clingo")}


def _train(*argv, cwd):
    import subprocess
    import sys

    return subprocess.run([sys.executable, "-m", "discern.scenarios.highway.train", *map(str, argv)],
                          capture_output=True, text=True, timeout=300, cwd=cwd)


def test_a_fault_set_is_labelled_in_the_order_the_command_line_named_its_kinds(tmp_path, capsys):
    """`--faults signs,missed` was shown as missed,signs in the table, summary.txt and summary.csv."""
    assert cli_main(["eval", "highway", "--episodes", "1", "--faults", "signs,missed", "--variants", "planner",
                     "--quiet", "--duration", "1", "--out", str(tmp_path)]) == 0
    assert "signs,missed  planner" in capsys.readouterr().out
    assert "signs,missed  planner" in (tmp_path / "summary.txt").read_text()
    assert [row["faults"] for row in csv.DictReader((tmp_path / "summary.csv").open())] == ["signs,missed"]


def test_a_merge_run_at_its_default_length_records_that_its_episodes_end_past_the_merge(tmp_path):
    """merge-v0 has no duration: writing run.json failed with KeyError 'duration' after the episodes had run."""
    import json

    assert cli_main(["eval", "highway", "--episodes", "1", "--env", "merge-v0", "--faults", "none", "--variants",
                     "planner", "--no-judge", "--quiet", "--out", str(tmp_path)]) == 0
    environment = json.loads((tmp_path / "run.json").read_text())["environment"]
    assert (environment["id"], environment["duration_s"], environment["past_x_m"]) == ("merge-v0", None, 370.0)


def test_a_duration_ends_merge_episodes_as_it_ends_highway_ones():
    """merge-v0 never truncates: --duration was recorded in run.json but the episodes ran to the merge all the same."""
    from discern.adapters.highway.envs import make_env

    env = make_env("merge-v0", duration=2)
    env.reset(seed=0)
    try:
        assert [env.step(1)[2:4] for _ in range(2)] == [(False, False), (False, True)]  # IDLE: not terminated, cut at 2 s
    finally:
        env.close()


def test_training_needs_an_out_path_and_replaces_the_shipped_weights_only_with_force(tmp_path):
    """--out defaulted to a path relative to the working directory, which its help called the packaged weights."""
    from discern.scenarios.highway.planner import default_weights

    shipped = default_weights()
    before = shipped.read_bytes()
    try:
        done = _train("--steps", "1", cwd=tmp_path)
        assert done.returncode == 2 and done.stderr.splitlines()[-1] == (
            "train.py: error: the following arguments are required: --out")
        done = _train("--steps", "1", "--out", shipped, cwd=tmp_path)
        assert done.returncode == 2 and done.stderr.splitlines()[-1] == (
            f"train.py: error: --out {shipped} is the shipped planner's weights: give --force to replace them")
        assert list(tmp_path.iterdir()) == []
    finally:
        if shipped.read_bytes() != before:  # the refusal failed: put the shipped weights back before failing
            shipped.write_bytes(before)
            pytest.fail("the trainer overwrote the shipped weights without --force")


def test_a_trained_checkpoint_carries_how_it_was_trained_into_the_evaluations_run_json(tmp_path):
    """Nothing recorded which steps, seed, torch or environment made a set of weights; the shipped ones, saved before
    checkpoints carried it, still load, their training 'unknown'."""
    import json
    from importlib import metadata

    import torch

    from discern.adapters.highway.envs import config_digest, make_env
    from discern.scenarios.highway.planner import Planner

    weights = tmp_path / "dqn.pt"
    done = _train("--steps", "1", "--seed", "3", "--out", weights, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    training = {"steps": 1, "episodes": 0, "env": "highway-fast-v0", "env_config_sha256": config_digest(make_env()),
                "seed": 3, "torch": str(torch.__version__), "highway_env": metadata.version("highway-env")}
    assert Planner.load(weights).training == training and Planner.load().training is None
    for name, argv in (("trained", ["--weights", str(weights)]), ("shipped", [])):
        assert cli_main(["eval", "highway", "--episodes", "1", "--faults", "none", "--variants", "planner", "--quiet",
                         "--out", str(tmp_path / name), *argv]) == 0
    trained, shipped = (json.loads((tmp_path / name / "run.json").read_text()) for name in ("trained", "shipped"))
    assert trained["planner"]["training"] == training and shipped["planner"]["training"] == "unknown"
    # the evaluation ran the environment the weights were trained on (the default duration)
    assert trained["environment"]["config_sha256"] == training["env_config_sha256"]


def test_decisions_over_the_monitors_budget_are_counted_in_process_and_the_table_shows_p99(tmp_path, capsys):
    """In process nothing counted a decision past the sidecar's 50 ms budget, where it would get the fail-safe brake,
    and the table showed only the median. A budget below any decision counts every one, and changes no verdict."""
    out = {}
    for budget in ("0.001", "1000000"):
        assert cli_main(["eval", "highway", "--episodes", "1", "--faults", "none", "--variants", "discern", "--quiet",
                         "--duration", "3", "--budget-ms", budget, "--out", str(tmp_path / budget)]) == 0
        table = capsys.readouterr().out
        assert "p99 ms" in table and "over budget" in table and f"slower than {float(budget):g} ms" in table
        out[budget] = next(csv.DictReader((tmp_path / budget / "summary.csv").open()))
    fast, slow = out["1000000"], out["0.001"]
    assert (slow["over_budget"], fast["over_budget"], slow["failsafes"]) == ("3", "0", "0")
    assert float(slow["decide_ms_p99"]) >= float(slow["decide_ms_p50"]) > 0
    same = ("collisions", "km", "vetoes_per_km", "intervened_share", "false_vetoes")
    assert [slow[k] for k in same] == [fast[k] for k in same]  # counted, not enforced: the same episode


def test_the_share_of_steps_the_shield_changed_replaces_overrides_per_km_which_repeated_the_vetoes(tmp_path):
    """Without shadow mode every veto is an override: 'overrides/km' always equalled 'vetoes/km'."""
    [result] = evaluate(1, [Faults()], ["discern"], Setup(duration=4, judge_vetoes=False), progress=False)
    assert 0 < result.intervened <= result.steps
    [row] = report([result], tmp_path)[0]
    assert "overrides_per_km" not in row and row["intervened_share"] == result.intervened / result.steps


def test_collisions_a_shield_introduced_are_those_of_episodes_the_planner_alone_survived(tmp_path):
    """Episode 10032: the planner alone survives, with Discern the ego crashed after lane changes Discern made or
    approved; the totals netted such crashes against those prevented, and nothing showed them."""
    results = evaluate(1, [Faults()], ["planner", "discern"], Setup(duration=8, judge_vetoes=False), seed=32,
                       progress=False)
    alone, shielded = results
    rows, text, _ = report(results, tmp_path)
    row = next(r for r in rows if r["variant"] == "discern")
    assert row["collisions_introduced"] == int(shielded.collided and not alone.collided)
    assert math.isnan(next(r for r in rows if r["variant"] == "planner")["collisions_introduced"])
    assert ("came in episodes the planner alone survived" in text) == bool(row["collisions_introduced"])
    # without the planner alone's episodes in the run there is nothing to pair with: not measured, not 0
    assert math.isnan(report([shielded], None)[0][0]["collisions_introduced"])


USER_PLANNER = '''
from discern.adapters.highway.actions import FASTER, IDLE
from discern.adapters.highway.perception import Perceived

SEEN = []  # (seed, vehicles the camera missed) per step: what the policy was handed


class Cautious:
    """Speeds up while the camera sees nothing within 60 m ahead in its lane."""

    def __init__(self, seed):
        self.seed = seed

    def __call__(self, perceived):
        assert isinstance(perceived, Perceived)
        SEEN.append((self.seed, len(perceived.missed)))
        ego = perceived.truth.ego
        near = [t for t in perceived.camera_tracks() if t.lane == ego.lane and 0 < t.ahead < 60]
        return IDLE if near else FASTER


def wrong(seed):
    return lambda perceived: 7
'''


def test_a_users_planner_is_evaluated_through_the_planner_option_on_the_perceived_frames(tmp_path, monkeypatch, capsys):
    """The evaluation hard-wired the shipped DQN: no policy of one's own could be measured with the same metrics."""
    import hashlib
    import json
    import sys

    (tmp_path / "user_policy.py").write_text(USER_PLANNER)
    monkeypatch.chdir(tmp_path)  # found in the working directory, as the option's help says
    monkeypatch.setattr(sys, "path", list(sys.path))
    monkeypatch.delitem(sys.modules, "user_policy", raising=False)
    assert cli_main(["eval", "highway", "--planner", "user_policy:Cautious", "--episodes", "1", "--faults", "missed",
                     "--miss-rate", "0.5", "--variants", "planner,discern", "--duration", "3", "--quiet", "--no-judge",
                     "--out", "out"]) == 0
    assert "missed@0.5  discern" in capsys.readouterr().out
    import user_policy

    assert len(user_policy.SEEN) == 6 and {seed for seed, _ in user_policy.SEEN} == {10_000}
    assert any(missed for _, missed in user_policy.SEEN)  # handed the faulty perception, not the simulator's truth
    run = json.loads((tmp_path / "out" / "run.json").read_text())
    source = tmp_path / "user_policy.py"
    assert run["planner"] == {"factory": "user_policy:Cautious", "module_file": str(source.resolve()),
                              "sha256": hashlib.sha256(source.read_bytes()).hexdigest()}
    assert cli_main(["eval", "highway", "--planner", "user_policy:wrong", "--episodes", "1", "--faults", "none",
                     "--variants", "planner", "--duration", "1", "--quiet", "--out", "out"]) == 2
    assert capsys.readouterr().err == ("discern eval: error: planner episode 10000 (none), step 0: the planner "
                                       "returned 7, not a DiscreteMetaAction index (0..4)\n")


def test_run_json_records_the_commit_and_a_digest_of_the_loops_code_as_well_as_the_reasonings(tmp_path):
    """run.json's code digest covered rules/ and sanity/ only, and no commit: a figure could not be tied to the
    adapter, the planner or the evaluation that produced it."""
    import hashlib
    import json
    import subprocess
    from importlib import resources

    from discern.scenarios.highway.manifest import CODE_PACKAGES, ROOT

    assert cli_main(["eval", "highway", "--episodes", "1", "--faults", "none", "--variants", "planner", "--quiet",
                     "--duration", "1", "--out", str(tmp_path)]) == 0
    code = json.loads((tmp_path / "run.json").read_text())["code"]
    assert {"discern.adapters.highway", "discern.scenarios.highway"} <= set(CODE_PACKAGES)
    digest = hashlib.sha256()
    for package in CODE_PACKAGES:
        for source in sorted((p for p in resources.files(package).iterdir() if p.name.endswith(".py")),
                             key=lambda p: p.name):
            digest.update(f"{package}.{source.name}\0".encode() + source.read_bytes() + b"\0")
    assert code["sha256"] == digest.hexdigest()
    git = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True)
    if git.returncode:  # not a checkout: nothing to record, and nothing made up
        assert code["git_commit"] is None and code["git_dirty"] is None
    else:
        status = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--untracked-files=no"],
                                capture_output=True, text=True).stdout
        assert code["git_commit"] == git.stdout.strip() and code["git_dirty"] is bool(status.strip())


def test_the_closed_loops_package_names_only_commands_that_exist(capsys):
    """It named a `discern train` command that never existed (the trainer is `python -m ...highway.train`)."""
    import re

    import discern.scenarios.highway as package

    commands = re.findall(r"`discern ([a-z-]+)", package.__doc__)
    assert commands
    for command in commands:
        with pytest.raises(SystemExit) as done:
            cli_main([command, "--help"])
        assert done.value.code == 0, command
    assert "python -m discern.scenarios.highway.train" in package.__doc__


def test_the_wrappers_own_example_runs():
    """Its one line, DiscernWrapper(gym.make("highway-fast-v0")), raised ValueError: highway-env's own target speeds."""
    import textwrap

    from discern.adapters.highway.actions import IDLE
    from discern.scenarios.highway import wrapper

    example = textwrap.dedent("\n".join(line for line in wrapper.__doc__.splitlines() if line.startswith("    ")))
    scope = {"DiscernWrapper": wrapper.DiscernWrapper, "policy": lambda perceived: IDLE}
    exec(example, scope)
    assert "discern" in scope["info"] and scope["env"].perceived.sign.limit is not None
    scope["env"].close()
