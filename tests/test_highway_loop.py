"""Closed loop: real highway-env episodes, the real DQN planner, the real Discern reasoner."""

import pytest

pytest.importorskip("highway_env")
pytest.importorskip("torch")

from discern.adapters.highway.actions import FASTER, from_catalog
from discern.adapters.highway.cli import demo
from discern.monitor.cli import main as cli_main
from discern.adapters.highway.envs import make_env
from discern.adapters.highway.evaluate import Setup, evaluate, summarise
from discern.adapters.highway.perception import Faults
from discern.adapters.highway.wrapper import DiscernWrapper, ReasonerChecker
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


def test_short_evaluation_compares_planner_and_discern_on_the_same_episodes():
    setup = Setup(duration=10)
    results = evaluate(
        2, [Faults(), Faults.preset("signs,missed", seed=0, sign_rate=1.0)], ["planner", "discern"], setup, progress=False
    )
    assert [(r.faults, r.variant, r.seed) for r in results] == [
        (faults, variant, seed)
        for faults in ("none", "missed,signs")
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
    assert "coll/km" in out and "discern" in out and "rss" in out and "missed,signs" in out
    assert (tmp_path / "summary.csv").is_file() and (tmp_path / "evaluation.png").stat().st_size > 10_000


def test_cli_rejects_bad_options_with_a_clear_error(capsys):
    code = cli_main(
        ["eval", "highway", "--faults", "gremlins", "--variants", "planner,magic", "--episodes", "0",
         "--param", "warp=9", "--param", "decel=fast"]
    )
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err
    for problem in ("gremlins", "magic", "--episodes", "'warp'", "decel needs a non-negative number"):
        assert problem in err


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
