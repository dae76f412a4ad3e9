"""Closed loop: real highway-env episodes, the real DQN planner, the real Discern reasoner."""

import re

import pytest

pytest.importorskip("highway_env")
pytest.importorskip("torch")

from discern.adapters.highway.actions import FASTER, from_catalog
from discern.scenarios.highway.cli import demo
from discern.monitor.cli import main as cli_main
from discern.adapters.highway.envs import make_env
from discern.scenarios.highway.evaluate import Setup, evaluate, summarise
from discern.adapters.highway.perception import Faults
from discern.scenarios.highway.wrapper import DiscernWrapper, ReasonerChecker
from discern.rules.verdict import Decision, Verdict


@pytest.fixture(scope="module")
def checker():
    return ReasonerChecker()


def test_wrapper_executes_the_override_and_records_the_verdict(checker):
    env = DiscernWrapper(make_env("highway-fast-v0", duration=12), checker=checker)
    env.reset(seed=10_001)
    decisions = []
    done = False
    while not done:
        _, _, terminated, truncated, info = env.step(FASTER)  # a reckless agent: always faster
        verdict = Verdict.model_validate(info["discern"])
        assert verdict.proposed.value == "accelerate" and info["proposed_action"] == FASTER
        if verdict.decision is Decision.override:
            assert info["executed_action"] == from_catalog(verdict.action) != FASTER
            assert verdict.rules and verdict.justification.summary
        else:
            assert info["executed_action"] == FASTER
        decisions.append(verdict.decision)
        done = terminated or truncated
    assert Decision.override in decisions, "flooring it on a 30 m/s highway must be stopped at the limit"
    assert not env.unwrapped.vehicle.crashed
    assert len(env.history) <= 3  # about 2 s of scenes at 1 Hz


def test_wrapper_passes_history_of_the_last_two_seconds(checker):
    seen = []

    class Recording:
        name = "recording"

        def check(self, scene, proposed, history):
            seen.append((scene.timestamp, [h.timestamp for h in history]))
            return checker.check(scene, proposed, history)

    env = DiscernWrapper(make_env("highway-fast-v0", duration=5), checker=Recording())
    env.reset(seed=10_002)
    for _ in range(4):
        env.step(1)
    assert seen[0][1] == [] and seen[3] == (3.0, [1.0, 2.0])


@pytest.mark.parametrize("shadow, decision, executed", [(False, Decision.override, "brake"), (True, Decision.veto, None)])
def test_a_checker_that_fails_gets_the_monitors_fail_safe_verdict_and_the_episode_goes_on(shadow, decision, executed):
    class Broken:
        name = "broken"

        def __init__(self):
            self.shadow = shadow

        def check(self, scene, proposed, history):
            raise RuntimeError("solver gone")

    env = DiscernWrapper(make_env("highway-fast-v0", duration=3), checker=Broken())
    env.reset(seed=10_002)
    _, _, _, _, info = env.step(FASTER)
    verdict = Verdict.model_validate(info["discern"])
    assert verdict.failsafe and verdict.rules == ["monitor.internal_error"] and verdict.decision is decision
    assert verdict.error == "RuntimeError: solver gone" and verdict.proposed.value == "accelerate"
    assert info["executed_action"] == (from_catalog(executed) if executed else FASTER)


def test_short_evaluation_compares_planner_and_discern_on_the_same_episodes():
    setup = Setup(duration=10)
    results = evaluate(
        2, [Faults(), Faults.preset("signs,missed", seed=0, sign_rate=1.0)], ["planner", "discern"], setup, progress=False
    )
    assert [(r.faults, r.variant, r.seed) for r in results] == [
        (faults, variant, seed)
        for faults in ("none", "signs@1,missed")
        for variant in ("planner", "discern")
        for seed in (10_000, 10_001)
    ]
    shielded = [r for r in results if r.variant == "discern"]
    assert all(len(r.decide_ms) == r.steps > 0 for r in shielded)
    rows = summarise(results)
    assert {row["variant"] for row in rows} == {"planner", "discern"} and all(row["km"] > 0 for row in rows)


def test_demo_prints_the_comparison_table_with_and_without_faults(tmp_path, capsys):
    code = demo(tmp_path, episodes=1, duration=6)
    out = capsys.readouterr().out
    assert code == 0
    assert "coll/km" in out and "discern" in out and "rss" in out and "signs,missed" in out
    header = next(line for line in out.splitlines() if line.startswith("faults"))
    planner_row = next(line for line in out.splitlines() if line.split()[1:2] == ["planner"])
    # the planner alone decides nothing: no vetoes, decision times or fail-safes
    for column in ("introduced", "veto/km", "interv %", "false/km", "p50 ms", "p99 ms", "over budget", "failsafe"):
        assert planner_row[header.index(column):].split()[0] == "–", column
    assert "nan" not in out
    assert (tmp_path / "summary.csv").is_file() and (tmp_path / "evaluation.png").stat().st_size > 10_000


def test_cli_rejects_bad_options_with_a_clear_error(capsys):
    code = cli_main(
        ["eval", "highway", "--faults", "gremlins", "--variants", "planner,magic", "--episodes", "0",
         "--param", "warp=9", "--param", "decel=fast"]
    )
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err
    for problem in ("gremlins", "magic", "--episodes", "'warp'", "--param decel needs a number from"):
        assert problem in err


@pytest.mark.parametrize(
    "argv,problem",
    [
        (["--param", "decel=0"], "--param decel needs a number from 0.01 to 100, got '0'"),
        (["--param", "reaction_s=nan"], "--param reaction_s needs a number from 0.01 to 60"),
        (["--param", "min_gap=-1"], "--param min_gap needs a number from 0.01 to 10000"),
        (["--faults", "signs", "--sign-rate", "1.5"], "--sign-rate is a chance and must lie in [0, 1], got 1.5"),
        (["--miss-rate", "nan"], "--miss-rate is a chance"),
        (["--sign-value", "-5"], "--sign-value must lie in [0, 150] m/s"),
        (["--sign-value", "151"], "--sign-value must lie in [0, 150] m/s"),
        (["--noise", "inf"], "--noise must lie in [0, 100] metres, got inf"),
        (["--faults", "noise", "--noise", "2000"], "--noise must lie in [0, 100] metres, got 2000"),  # once a traceback
        (["--faults", ""], "fault set '' names no fault kind: give 'none' for a run without faults"),
        (["--faults", ","], "fault set ',' names no fault kind"),
        (["--faults", "signs,", "missed"], "fault set 'signs,' has an empty kind: write a set without spaces"),
        (["--variants", "planner", "--record", "rec"], "--record logs Discern's verdicts: add discern to --variants"),
        (["--variants", "planner,rss", "--monitor"], "--monitor serves the discern variant: add discern to --variants"),
        (["--variants", "planner,planner"], "--variants names 'planner' twice: its episodes would count twice"),
        (["--monitor", "--param", "decel=4"], "--param has no effect with --monitor: the monitor decides with its own"),
        (["--monitor", "--record", "rec"], "--record has nothing to add with --monitor: the monitor logs every proposal"),
        (["--variants", ","], "--variants names no variant"),
        (["--duration", "nan"], "--duration must be a number of seconds above 0 and at most 3600, got nan"),
        (["--duration", "inf"], "--duration must be a number of seconds above 0 and at most 3600, got inf"),
        (["--duration", "1e300"], "--duration must be a number of seconds above 0 and at most 3600, got 1e+300"),
        (["--faults", "none", "missed", "--miss-rate", "0"], "--faults gives more than one set that comes out as 'none'"),
        (["--faults", "signs,missed", "missed,signs"], "--faults gives more than one set that comes out as 'signs,missed'"),
        (["--seed", "-1"], "--seed must be at least 0 (the environment's seeds are), got -1"),
        (["--faults", "none", "--miss-rate", "0.9"], "--miss-rate 0.9 sets the 'missed' fault, which no --faults set injects"),
        (["--faults", "signs", "--sign-rate", "0"], "--sign-rate 0 turns the 'signs' fault off, but a --faults set names it"),
        (["--faults", "missed", "--sign-value", "30"], "--sign-value 30 sets the 'signs' fault, which no --faults set"),
        (["--jobs", "0"], "--jobs must be at least 1, got 0"),
        (["--budget-ms", "0"], "--budget-ms must be a number of milliseconds above 0, got 0"),
        (["--planner", "user_policy"], "--planner 'user_policy': give it as MODULE:FACTORY"),
        (["--planner", "no_such_module_here:make"], "--planner 'no_such_module_here:make': cannot import"),
        (["--planner", "json:no_such_factory"], "--planner 'json:no_such_factory': json has no callable"),
        (["--planner", "json:loads", "--weights", "w.pt"], "--weights are the shipped planner's: --planner brings"),
    ],
)
def test_cli_rejects_odd_option_values_in_one_line_without_a_traceback(argv, problem, capsys):
    code = cli_main(["eval", "highway", "--episodes", "1", *argv])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err
    assert err.startswith("discern eval: error: ") and problem in err


@pytest.mark.parametrize("flag", ["--out", "--record"])
def test_cli_refuses_an_output_folder_that_is_a_file_before_any_episode_runs(flag, tmp_path, capsys):
    taken = tmp_path / "scene.json"
    taken.write_text("{}")
    code = cli_main(["eval", "highway", "--episodes", "1", "--variants", "discern", flag, str(taken)])
    err = capsys.readouterr().err
    assert code == 2 and f"{flag} {taken}: not a directory" in err and "Traceback" not in err
    assert taken.read_text() == "{}"


def test_cli_refuses_an_output_folder_inside_a_file_before_any_episode_runs(tmp_path, capsys):
    """Once found only when the table was written, after every episode had run."""
    (tmp_path / "scene.json").write_text("{}")
    inside = tmp_path / "scene.json" / "out"
    code = cli_main(["eval", "highway", "--episodes", "1", "--variants", "planner", "--out", str(inside)])
    err = capsys.readouterr().err
    assert code == 2 and err == f"discern eval: error: --out {inside}: cannot make the folder: Not a directory\n"


def test_planner_weights_that_are_not_finite_are_refused(tmp_path, capsys):
    import torch

    from discern.scenarios.highway.planner import default_weights

    state = torch.load(default_weights(), map_location="cpu", weights_only=True)
    diverged = tmp_path / "nan.pt"
    torch.save({name: torch.full_like(tensor, float("nan")) for name, tensor in state.items()}, diverged)
    code = cli_main(["eval", "highway", "--episodes", "1", "--variants", "planner", "--faults", "none", "--quiet",
                     "--weights", str(diverged), "--duration", "1", "--out", str(tmp_path / "out")])
    assert code == 2 and capsys.readouterr().err == (
        f"discern eval: error: {diverged} holds NaN or infinite weights: a diverged training run, not a planner\n")


def test_one_episode_of_a_run_is_run_again_alone_with_the_runs_fault_seed(tmp_path):
    """--seed shifts the faults' seed with the episodes': an episode a table cites could not be run again alone."""
    import csv

    def rows(out, *argv):
        assert cli_main(["eval", "highway", "--variants", "planner", "--faults", "signs,missed", "--quiet",
                         "--duration", "8", "--out", str(tmp_path / out), *argv]) == 0
        return {row["seed"]: row for row in csv.DictReader((tmp_path / out / "episodes.csv").open())}

    run = rows("run", "--episodes", "3")
    again = rows("again", "--episodes", "1", "--seed", "2", "--fault-seed", "0")
    shifted = rows("shifted", "--episodes", "1", "--seed", "2")
    assert list(again) == list(shifted) == ["10002"] and again["10002"] == run["10002"]
    assert (shifted["10002"]["distance_m"], shifted["10002"]["misread_s"]) != (run["10002"]["distance_m"],
                                                                               run["10002"]["misread_s"])


def test_a_monitor_that_gives_no_verdict_gets_the_clients_fail_safe_executed_and_counted():
    """The first step without a verdict once aborted the whole run, and nothing was written: a vehicle brakes and
    drives on, and the row says how often (here every step: no monitor ever answered)."""
    from discern.monitor.config import free_port
    from tests.monitor_process import endpoint

    gone = endpoint(free_port())
    [result] = evaluate(1, [Faults()], ["discern"], Setup(duration=2, monitor=(gone,)), progress=False)
    assert result.steps == 2 and result.failsafes == 2 and result.failsafe_rules == {"monitor.no_answer": 2}
    assert result.vetoes == 0 and not result.rules  # the client's brakes are no veto of the rules


def test_a_monitor_past_its_budget_gets_its_fail_safe_executed_and_counted_apart_from_the_rules_vetoes():
    """A deadline verdict once aborted the run (RuntimeError), so a machine too busy for the budget left no figures."""
    from tests.monitor_process import serve

    proc, endpoint = serve("--id", "slow-eval", "--test-only-decision-delay-ms", "100")
    try:
        [result] = evaluate(1, [Faults()], ["discern"], Setup(duration=3, monitor=(endpoint,)), progress=False)
    finally:
        assert proc.stop() == 0, proc.output
    # a machine busier still may leave a verdict past the client's own timeout too (monitor.no_answer)
    assert result.steps == result.failsafes == sum(result.failsafe_rules.values()) == 3
    assert "monitor.deadline" in result.failsafe_rules
    assert result.over_budget == 3 and result.vetoes == 0 and not result.rules
    [row] = summarise([result])
    assert (row["failsafes"], row["over_budget"]) == (3, 3) and row["decide_ms_p99"] > 50


def test_a_recorded_evaluation_logs_discerns_verdicts_not_rsss(tmp_path):
    """RSS's overrides in the log read, to the audit and its replay, as Discern decisions that would change."""
    from discern.monitor.log.reader import read_log

    evaluate(1, [Faults()], ["discern", "rss"], Setup(duration=2, record=str(tmp_path)), progress=False)
    assert {r.vehicle for r in read_log(sorted(tmp_path.glob("*.mcap"))) if r.kind == "verdict"} == {"discern_none_10000"}


def test_cli_says_a_weights_file_that_holds_no_weights_is_not_the_planners(tmp_path, capsys):
    wrong = tmp_path / "scene.json"
    wrong.write_text("{}")
    code = cli_main(["eval", "highway", "--episodes", "1", "--variants", "planner", "--faults", "none", "--quiet",
                     "--weights", str(wrong), "--duration", "1", "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and f"{wrong} is not a planner weights file" in err and "Traceback" not in err


@pytest.mark.parametrize("weights, message", [
    ("{tmp}", "planner weights {tmp}: a directory, not a weights file"),
    ("{tmp}/scene.json", "{tmp}/scene.json is not a planner weights file (a torch state dict from the trainer)"),
    ("{tmp}/hi.pt", "{tmp}/hi.pt is not a planner weights file (a torch state dict from the trainer)"),  # a pickle opcode
    ("{tmp}/log.csv", "{tmp}/log.csv is not a planner weights file (a torch state dict from the trainer)"),  # IndexError
])
def test_cli_says_a_weights_path_that_is_no_weights_file_is_not_one(tmp_path, capsys, weights, message):
    (tmp_path / "scene.json").write_text('{"frame_id": 1}')
    (tmp_path / "hi.pt").write_text("hi\n")
    (tmp_path / "log.csv").write_text("step,loss\n1,0.5\n")
    weights, message = weights.format(tmp=tmp_path), message.format(tmp=tmp_path)
    code = cli_main(["eval", "highway", "--episodes", "1", "--variants", "planner", "--faults", "none", "--quiet",
                     "--weights", weights, "--duration", "1", "--out", str(tmp_path / "out")])
    assert code == 2 and capsys.readouterr().err == f"discern eval: error: {message}\n"


@pytest.mark.parametrize("argv, message", [
    (["--steps", "0", "--out", "{tmp}/x.pt"], "argument --steps: must be at least 1, got 0"),
    (["--steps", "1", "--out", "{tmp}/scene.json/x.pt"], "--out {tmp}/scene.json/x.pt: {tmp}/scene.json is not a directory"),
    (["--steps", "1", "--out", "{tmp}"], "--out {tmp}: a directory, not a weights file"),
])
def test_training_refuses_what_it_could_not_train_or_save_before_it_starts(tmp_path, argv, message):
    import subprocess
    import sys

    (tmp_path / "scene.json").write_text("{}")
    done = subprocess.run([sys.executable, "-m", "discern.scenarios.highway.train", *[a.format(tmp=tmp_path) for a in argv]],
                          capture_output=True, text=True, timeout=120, cwd=tmp_path)  # never near the packaged weights
    assert done.returncode == 2 and done.stdout == "", done.stdout
    assert done.stderr.splitlines()[-1] == f"train.py: error: {message.format(tmp=tmp_path)}", done.stderr


def test_cli_refuses_a_monitor_that_does_not_answer(capsys):
    from discern.monitor.config import free_port
    from tests.monitor_process import endpoint

    nowhere = endpoint(free_port())
    code = cli_main(["eval", "highway", "--episodes", "1", "--variants", "discern", "--monitor", nowhere])
    err = capsys.readouterr().err
    assert code == 2 and f"no monitor answered on {nowhere}" in err and "Traceback" not in err


def test_evaluation_loads_the_weights_each_setup_names(tmp_path):
    evaluate(1, [Faults()], ["planner"], Setup(duration=2), progress=False)
    with pytest.raises(FileNotFoundError, match="missing.pt"):
        evaluate(1, [Faults()], ["planner"], Setup(duration=2, weights=str(tmp_path / "missing.pt")), progress=False)


def test_wrapper_asks_a_running_monitor_over_zenoh():
    from tests.monitor_process import serve

    proc, endpoint = serve("--id", "highway", "--budget-ms", "5000")
    try:
        env = DiscernWrapper(
            make_env("highway-fast-v0", duration=6), monitor=True, monitor_options={"connect": [endpoint]}, timeout=5.0
        )
        env.reset(seed=10_001)
        verdicts = []
        for _ in range(6):
            _, _, terminated, truncated, info = env.step(FASTER)
            verdicts.append(Verdict.model_validate(info["discern"]))
            if terminated or truncated:
                break
        env.close()
    finally:
        assert proc.stop() == 0, proc.output
    assert all(not v.failsafe and v.error is None for v in verdicts), [v.error for v in verdicts]
    assert Decision.override in {v.decision for v in verdicts}


def test_monitor_keeps_judging_after_the_wrapper_resets():
    from tests.monitor_process import serve

    proc, endpoint = serve("--id", "highway-resets", "--budget-ms", "5000")
    try:
        env = DiscernWrapper(
            make_env("highway-fast-v0", duration=3), monitor=True, monitor_options={"connect": [endpoint]}, timeout=5.0
        )
        episodes = []
        for seed in (10_001, 10_002, 10_003):  # two resets after the first episode
            env.reset(seed=seed)
            episodes.append([Verdict.model_validate(env.step(FASTER)[4]["discern"]) for _ in range(2)])
        env.close()
    finally:
        assert proc.stop() == 0, proc.output
    frames = [v.frame_id for verdicts in episodes for v in verdicts]
    assert frames == sorted(set(frames)), "frame ids must keep rising across resets"
    assert all(not v.failsafe and v.error is None for verdicts in episodes for v in verdicts), [
        v.error for verdicts in episodes for v in verdicts
    ]


def test_evaluation_through_a_monitor_judges_every_episode():
    from tests.monitor_process import serve

    proc, endpoint = serve("--id", "highway-eval", "--budget-ms", "5000")
    try:
        results = evaluate(2, [Faults()], ["discern"], Setup(duration=3, monitor=(endpoint,)), progress=False)
    finally:
        assert proc.stop() == 0, proc.output
    assert [r.seed for r in results] == [10_000, 10_001]
    assert all(r.steps > 0 and len(r.decide_ms) == r.steps for r in results)
    assert not any(rule.startswith("monitor.") or rule == "failsafe" for r in results for rule in r.rules), [
        r.rules for r in results
    ]


def test_evaluation_records_every_proposal_and_verdict_to_mcap(tmp_path):
    from discern.monitor.log.reader import read_log

    results = evaluate(1, [Faults()], ["planner", "discern"], Setup(duration=5, record=str(tmp_path)), progress=False)
    records = list(read_log(sorted(tmp_path.glob("*.mcap"))))
    shielded = next(r for r in results if r.variant == "discern")
    proposals = [r for r in records if r.kind == "proposal"]
    verdicts = [r for r in records if r.kind == "verdict"]
    assert len(proposals) == len(verdicts) == shielded.steps  # the unshielded run has no verdicts to log
    assert {r.vehicle for r in verdicts} == {"discern_none_10000"}
    assert [v.verdict.frame_id for v in verdicts] == [p.proposal.scene.frame_id for p in proposals]


def test_a_replay_of_a_recorded_evaluation_decides_with_the_parameters_it_recorded(tmp_path, capsys):
    """The closed loop decides with decel=4, and the replay with it: on the defaults (decel=6) it reported decisions
    no rule edit changed. A parameter that matters, given on the command line, changes decisions."""
    evaluate(1, [Faults()], ["discern"], Setup(record=str(tmp_path)), progress=False)
    assert cli_main(["audit", "--replay", str(tmp_path), "-q", "--workers", "1"]) == 0
    assert "(us rules, accel_step=2.5, decel=4)" in capsys.readouterr().out
    assert cli_main(["audit", "--replay", str(tmp_path), "-q", "--workers", "1", "--param", "headway_s=3"]) == 1
    assert re.search(r"\b[1-9]\d* decisions? would change", capsys.readouterr().out)


def test_logs_decided_with_different_parameters_are_not_replayed_as_one(tmp_path, capsys):
    from discern.monitor.config import LogSettings
    from discern.monitor.log.writer import McapLogWriter

    for name, params in (("a", {"decel": 4.0}), ("b", {})):
        McapLogWriter(LogSettings(directory=tmp_path / name), "m", params).close()
    assert cli_main(["audit", "--replay", str(tmp_path / "a"), str(tmp_path / "b"), "-q"]) == 2
    err = capsys.readouterr().err
    assert "the logs were decided with different settings" in err and '{"decel": 4.0}' in err


def test_the_judge_counts_holding_a_speed_above_the_limit_as_speeding_and_slowing_down_as_not():
    """A veto of keeping 35 m/s on a 30 m/s road is no false veto; one of slowing down from it would be."""
    from discern.adapters.highway.actions import IDLE, SLOWER
    from discern.scenarios.highway.oracle import proposal_was_safe

    env = make_env("highway-fast-v0", duration=10)
    env.reset(seed=10_001)
    ego = env.unwrapped.vehicle
    ego.target_speed = 35.0
    for _ in range(2):
        env.step(IDLE)
    assert not ego.crashed and ego.speed > 31.0
    assert not proposal_was_safe(env, IDLE, 30.0)
    assert proposal_was_safe(env, SLOWER, 30.0)
    assert proposal_was_safe(env, IDLE, 40.0)  # below a higher limit, holding the speed is fine


def test_the_fault_rates_help_gives_the_defaults_a_fault_set_runs_at(capsys):
    """The help gave no defaults; it names perception.DEFAULT_RATES without importing highway-env, so it could drift."""
    from discern.adapters.highway.perception import DEFAULT_RATES

    with pytest.raises(SystemExit):
        cli_main(["eval", "highway", "--help"])
    help_text = " ".join(capsys.readouterr().out.split())
    for flag, key in (("--miss-rate", "miss_rate"), ("--phantom-rate", "phantom_rate"), ("--sign-rate", "sign_rate"),
                      ("--sign-value", "sign_value"), ("--noise", "noise")):
        described = help_text.rsplit(f"{flag} {flag.lstrip('-').replace('-', '_').upper()}", 1)[1].split(" --", 1)[0]
        assert f"(default: {DEFAULT_RATES[key]:g}" in described, (flag, described)
