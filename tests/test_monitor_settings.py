"""Settings the monitor cannot run with are refused by flag before anything starts."""

from __future__ import annotations

import json
import math

import pytest

from discern.monitor import keys
from discern.monitor.config import LogSettings, MonitorConfig, ZenohSettings, free_port
from discern.monitor.config_syntax import json5_fault
from tests.monitor_process import START_TIMEOUT_S, DiscernProcess, endpoint

pytestmark = pytest.mark.wall_clock  # run alone: see the marker in pyproject.toml


def config(tmp_path, **settings) -> MonitorConfig:
    log = {k: settings.pop(k) for k in ("rotate_bytes", "rotate_seconds", "flush_seconds") if k in settings}
    return MonitorConfig(monitor_id="settings", log=LogSettings(directory=tmp_path, **log), **settings)


@pytest.mark.parametrize(
    "settings, flag",
    [
        (dict(budget_ms=math.inf), "--budget-ms"),
        (dict(budget_ms=1e13), "--budget-ms"),  # past threading.TIMEOUT_MAX: the watchdog's wait would overflow
        (dict(budget_ms=60_001), "--budget-ms"),
        (dict(budget_ms=math.nan), "--budget-ms"),
        (dict(budget_ms=0), "--budget-ms"),
        (dict(window_s=math.inf), "--window-s"),
        (dict(window_s=61), "--window-s"),  # a vehicle's state lives a window: one of hours keeps every vehicle seen
        (dict(window_s=0.05), "--window-s"),  # shorter than a flash cycle: each frame judged afresh
        (dict(status_period_s=0), "--status-period-s"),
        (dict(status_period_s=-1), "--status-period-s"),
        (dict(status_period_s=math.nan), "--status-period-s"),
        (dict(status_period_s=math.inf), "--status-period-s"),
        (dict(flush_seconds=0), "--log-flush-s"),
        (dict(flush_seconds=math.nan), "--log-flush-s"),
        (dict(flush_seconds=1e12), "--log-flush-s"),
        (dict(rotate_seconds=0), "--log-rotate-s"),
        (dict(rotate_seconds=-5), "--log-rotate-s"),
        (dict(rotate_seconds=math.nan), "--log-rotate-s"),
        (dict(rotate_bytes=1024), "--log-rotate-mb"),
    ],
)
def test_nonsensical_settings_are_refused_naming_the_flag(tmp_path, settings, flag):
    with pytest.raises(ValueError, match=f"^{flag} must be a finite number"):
        config(tmp_path, **settings).validate()


def test_the_documented_bounds_are_accepted(tmp_path):
    config(tmp_path).validate()
    config(
        tmp_path, budget_ms=60_000, status_period_s=0.1, flush_seconds=0.05, rotate_seconds=1, rotate_bytes=64 * 1024
    ).validate()


@pytest.mark.parametrize(
    "flags, message",
    [
        (["--budget-ms", "inf"], "--budget-ms must be a finite number above 0 ms and at most 60000 ms, got inf"),
        (["--status-period-s", "0"], "--status-period-s must be a finite number at least 0.1 s"),
        (["--log-flush-s", "0", "--log-rotate-s", "0"], "--log-rotate-s must be a finite number at least 1 s"),
        (["--log-rotate-mb", "nan"], "--log-rotate-mb must be a finite number at least 0.0625 MiB, got nan"),
        (["--log-keep-mb", "nan"], "--log-keep-mb must be a finite number at least 0.0625 MiB, got nan"),
        (["--log-keep-mb", "10"],
         "--log-keep-mb must be at least --log-rotate-mb (256 MiB), room for the file being written, got 10"),
        (["--connect", "nonsense"], "bad zenoh endpoint 'nonsense': Endpoints must be of the form"),
        (["--vehicles", "car_[12]"], "vehicle filter 'car_[12]' may hold only letters, digits, '_', '-' and the wildcard '*'"),
        (["--vehicles", "**"], "vehicle filter '**' must be one key chunk: '**' matches several, use '*'"),
        (["--vehicles", ""], "vehicle filter is empty: give one key chunk, or '*' for all"),
        (["--id", ""], "monitor id is empty: give one with --id, or leave --id out for host-pid"),
        (["--test-only-decision-delay-ms", "-1"], "--test-only-decision-delay-ms must be a finite number at least 0 ms"),
        (["--listen", "tcp/127.0.0.1:0"], "listen endpoint 'tcp/127.0.0.1:0': port 0 is not supported"),
        (["--param", "decel=0"], "--param decel needs a number from 0.01 to 100, got '0'"),
        (["--param", "brakes=4"], "unknown --param 'brakes' (known: "),
        (["--param", "decel=4", "--param", "decel=5"], "--param decel given twice (4 and 5)"),
    ],
)
def test_serve_refuses_bad_settings_in_one_line_with_status_2(tmp_path, flags, message):
    proc = DiscernProcess("serve", "--listen", endpoint(free_port()), "--log-dir", str(tmp_path), *flags)
    try:
        code = proc.proc.wait(START_TIMEOUT_S)
    finally:
        proc.stop()
    assert code == 2 and len(proc.lines) == 1, proc.output
    assert proc.lines[0].startswith(f"discern serve: error: {message}"), proc.output


def test_a_router_refuses_to_listen_on_port_0_which_it_could_not_name(tmp_path):
    proc = DiscernProcess("router", "--listen", "tcp/127.0.0.1:0")
    try:
        code = proc.proc.wait(START_TIMEOUT_S)
    finally:
        proc.stop()
    assert code == 2 and proc.lines == [
        "discern router: error: listen endpoint 'tcp/127.0.0.1:0': port 0 is not supported, "
        "as zenoh does not say which free port it takes: name a port (--listen, or listen.endpoints)"
    ], proc.output


def refused_at_start(*args: str) -> str:
    """The one error line of a `discern` process that must exit with status 2 before it serves."""
    proc = DiscernProcess(*args)
    try:
        code = proc.proc.wait(START_TIMEOUT_S)
    finally:
        proc.stop()
    assert code == 2 and len(proc.lines) == 1, proc.output
    return proc.lines[0]


def test_a_zenoh_config_naming_no_listen_endpoint_is_told_that_zenohs_default_is_port_0(tmp_path):
    config = tmp_path / "plain.json5"
    config.write_text('{ mode: "peer" }\n')
    said = refused_at_start("serve", "--zenoh-config", str(config), "--log-dir", str(tmp_path))
    assert "(zenoh's own default, as the configuration names no listen.endpoints): port 0 is not supported" in said


def test_a_client_monitor_with_nowhere_to_connect_is_told_to_name_its_router():
    assert "--connect ENDPOINT" in refused_at_start("serve", "--mode", "client", "--no-log")


def test_a_zenoh_config_naming_port_0_is_refused_without_blaming_zenohs_default(tmp_path):
    config = tmp_path / "port0.json5"
    config.write_text('{ listen: { endpoints: ["tcp/127.0.0.1:0"] } }\n')
    said = refused_at_start("serve", "--zenoh-config", str(config), "--log-dir", str(tmp_path))
    assert "listen endpoint 'tcp/127.0.0.1:0': port 0 is not supported" in said


def ready_line(proc: DiscernProcess) -> str:
    return next(line for line in proc.lines if " ready; " in line)


def test_a_client_monitor_configured_by_file_listens_on_nothing_and_serves_through_its_router(tmp_path):
    """A client names no listen endpoint: zenoh's default for peers (port 0) is not its own, and was refused."""
    from discern.monitor.client import Monitor
    from discern.monitor.example_planner import highway_scene

    router_ep = endpoint(free_port())
    config = tmp_path / "client.json5"
    config.write_text(f'{{ mode: "client", connect: {{ endpoints: ["{router_ep}"] }}, '
                      'scouting: { multicast: { enabled: false }, gossip: { enabled: false } } }\n')
    router = DiscernProcess("router", "--listen", router_ep).wait_ready()
    try:
        proc = DiscernProcess("serve", "--zenoh-config", str(config), "--id", "by_file", "--budget-ms", "5000").wait_ready()
        try:
            assert "; listening on nothing; " in ready_line(proc), proc.output
            with Monitor("car_1", connect=[router_ep], mode="client", timeout=5) as planner:
                assert planner.wait_for_monitor(timeout=10)
                verdict = planner.check(highway_scene(0, 4), "cruise")
            assert not verdict.failsafe and verdict.vehicle == "car_1", verdict.error
        finally:
            assert proc.stop() == 0, proc.output
    finally:
        router.stop()


def test_a_monitor_names_only_the_listen_endpoints_of_its_mode(tmp_path):
    """Per-mode endpoints: a peer opens the peer's only, and says so (it named the router's as well)."""
    from discern.monitor.client import Monitor
    from discern.monitor.example_planner import highway_scene

    peer_ep, router_ep = endpoint(free_port()), endpoint(free_port())
    config = tmp_path / "per_mode.json5"
    config.write_text(f'{{ mode: "peer", listen: {{ endpoints: {{ peer: ["{peer_ep}"], router: ["{router_ep}"] }} }}, '
                      'scouting: { multicast: { enabled: false }, gossip: { enabled: false } } }\n')
    proc = DiscernProcess("serve", "--zenoh-config", str(config), "--budget-ms", "5000").wait_ready()
    try:
        assert f"; listening on {peer_ep}; " in ready_line(proc), proc.output
        with Monitor("car_1", connect=[peer_ep], timeout=5) as planner:
            assert not planner.check(highway_scene(0, 4), "cruise").failsafe
    finally:
        assert proc.stop() == 0, proc.output


@pytest.mark.parametrize(
    "text, message",
    [
        ("{ mode: \n", "line 2 column 1: expected a value, found the end of the file"),
        # zenoh's parser named line 1 column 39, the '[', "expected boolean or null"
        ('{ mode: "peer", listen: { endpoints: ["tcp/127.0.0.1:17449"] }\n  scouting: {} }\n',
         "line 2 column 3: expected ',' or '}', found 'scouting': likely a comma missing after the value that ends at "
         "line 1 column 62"),
        ('{ mode: "pear" }\n', "line 1 column 9: unknown variant `pear`, expected one of `router`, `peer`, `client`"),
        ('{ listen: { endpoints: "tcp/127.0.0.1:7447" } }\n',  # a quoted value, not \"tcp/...\"
         'line 1 column 24: invalid type: string "tcp/127.0.0.1:7447", expected list of endpoints or mode dependent'
         ' list of endpoints'),
    ],
)
def test_a_malformed_zenoh_config_is_one_line_naming_its_position(tmp_path, text, message):
    path = tmp_path / "bad.json5"
    path.write_text(text)
    proc = DiscernProcess("serve", "--zenoh-config", str(path))
    try:
        code = proc.proc.wait(START_TIMEOUT_S)
    finally:
        proc.stop()
    assert code == 2 and proc.lines == [f"discern serve: error: zenoh config {path}: {message}"], proc.output


@pytest.mark.parametrize(
    "text, message",
    [
        ('{ mode: "peer" listen: {} }', "line 1 column 16: expected ',' or '}', found 'listen': likely a comma missing "
                                        "after the value that ends at line 1 column 14"),
        ('{ listen: { endpoints: ["tcp/127.0.0.1:1"\n "tcp/127.0.0.1:2"] } }',
         "line 2 column 2: expected ',' or ']', found '\"tcp/127.0.0.1:2\"': likely a comma missing after the value "
         "that ends at line 1 column 41"),
        ('{ mode: "peer }', "line 1 column 9: a string starts here that is not closed on its line"),
        ('{ mode: "peer"\n', "line 2 column 1: expected ',' or '}' (the '{' at line 1 column 1 is open), found the end "
                            "of the file"),
        ('{ mode "peer" }', "line 1 column 8: expected ':' after the key 'mode', found '\"peer\"'"),
        ('{ mode: peer }', "line 1 column 9: 'peer' is no JSON5 value: quote a string (a number, true, false and null "
                           "are not quoted)"),
        ('{ mode: "peer" } /* done', "line 1 column 18: a comment starts here that is never closed with '*/'"),
        # what this reading passes and zenoh's parser does not: zenoh's position, said to be near the fault
        ('{ mode: "\\u00" }', "near line 1 column 12: expected unicode_escape_sequence"),
    ],
)
def test_a_zenoh_config_syntax_error_is_named_where_it_is(tmp_path, text, message):
    path = tmp_path / "bad.json5"
    path.write_text(text)
    with pytest.raises(ValueError) as refused:
        ZenohSettings(config_file=path).to_zenoh()
    assert str(refused.value) == f"zenoh config {path}: {message}"


def test_a_config_zenoh_takes_has_no_syntax_fault():
    """The reading that names a fault agrees with zenoh's parser on what is valid JSON5, comments and all."""
    assert json5_fault("// the monitor\n{ mode: 'peer', listen: { endpoints: [\"tcp/127.0.0.1:7447\",], },\n"
                       "  /* off */ scouting: { multicast: { enabled: false } }, $x: [+.5, 0x1F, -Infinity, 5.] }\n") is None


@pytest.mark.parametrize("pattern", ["**", "fleet_**", "**_a", "a**b"])
def test_a_vehicle_filter_that_spans_key_chunks_is_refused(pattern):
    with pytest.raises(ValueError, match="must be one key chunk: '\\*\\*' matches several"):
        keys.vehicle_selector(pattern)


@pytest.mark.parametrize("pattern, chunk", [("*", "*"), ("fleet_a_*", "fleet_a_$*"), ("$*", "*"), ("car_1", "car_1")])
def test_a_one_chunk_vehicle_filter_is_taken(pattern, chunk):
    assert keys.vehicle_selector(pattern) == chunk


@pytest.mark.parametrize(
    "key, vehicle",
    [
        ("discern/car_1/check", "car_1"),
        ("discern/car_1/proposal", "car_1"),
        ("discern/car_1/extra/check", None),
        ("discern/car_1/a/b/proposal", None),
        ("discern/check", None),
        ("discern/proposal", None),
        ("discern/car_1/verdict", None),
        ("other/car_1/check", None),
    ],
)
def test_only_a_three_chunk_proposal_or_check_key_names_a_vehicle(key, vehicle):
    assert keys.vehicle_of(key) == vehicle


def test_a_monitor_decides_with_the_reasoning_parameters_it_is_given_and_logs_them(tmp_path):
    """A fleet that brakes at 4 m/s² once had no way to tell its monitor: every monitor decided on the defaults."""
    from discern.monitor.client import Monitor
    from discern.monitor.log.reader import log_metadata
    from discern.rules.facts import Params
    from discern.sanity import window_reasoner
    from tests.monitor_process import serve
    from tests.scenes import obj, scene

    # closing in at 15 m/s from 80 m: the ego covers 40 m in its headway (two seconds at 20 m/s) and needs
    # (20² - 5²) / (2 * 6) = 31.25 m more than the car to stop braking at the default 6 m/s² (71.25 m in all), but
    # 46.9 m more at 4 (86.9 m)
    ahead = scene(speed=20, limit=30, zone="highway", objects=[obj("car", 0, 80, lane=1, vy=5)])
    assert window_reasoner().decide(ahead, "cruise").action.value == "cruise"
    proc, ep = serve("--id", "trucks", "--budget-ms", "5000", "--param", "decel=4", "--log-dir", str(tmp_path))
    try:
        with Monitor("truck_1", connect=[ep], timeout=5.0) as client:
            verdict = client.check(ahead, "cruise")
    finally:
        assert proc.stop() == 0, proc.output
    expected = window_reasoner(params=Params(decel=4)).decide(ahead, "cruise")
    assert verdict.action.value == "brake" and not verdict.failsafe
    assert (verdict.decision, verdict.action, verdict.rules) == (expected.decision, expected.action, expected.rules)
    [log] = sorted(tmp_path.glob("*.mcap"))
    assert log_metadata(log)["params"] == '{"decel": 4.0}'


def test_a_monitor_logs_into_its_working_directory_unless_told_not_to(tmp_path):
    """A safety monitor's record is not opt-in: `discern serve` with no log flag logs to ./discern-log."""
    from discern.monitor.client import Monitor
    from discern.monitor.log import read_log
    from tests.scenes import scene

    logged, unlogged = tmp_path / "logged", tmp_path / "unlogged"
    for cwd, flags in ((logged, ()), (unlogged, ("--no-log",))):
        cwd.mkdir()
        ep = endpoint(free_port())
        proc = DiscernProcess("serve", "--listen", ep, "--budget-ms", "5000", *flags, cwd=cwd).wait_ready()
        try:
            with Monitor("car_1", connect=[ep], timeout=5.0) as client:
                assert not client.check(scene(), "cruise").failsafe
        finally:
            assert proc.stop() == 0, proc.output
        said = proc.lines[0]
        assert said.endswith("; logging to discern-log" if not flags else "; not logging (--no-log)"), said
    assert [r.kind for r in read_log(logged / "discern-log") if r.kind != "status"] == ["proposal", "verdict"]
    assert list(unlogged.iterdir()) == []


@pytest.mark.parametrize("flags, message", [
    (["--log-dir", "somewhere"], "argument --log-dir: not allowed with argument --no-log"),
    (["--log-keep-mb", "300", "--log-compression", "none"],
     "--no-log leaves nothing for --log-keep-mb, --log-compression to set: give a log or leave them out"),
])
def test_log_settings_with_no_log_are_refused(flags, message):
    proc = DiscernProcess("serve", "--listen", endpoint(free_port()), "--no-log", *flags)
    try:
        code = proc.proc.wait(START_TIMEOUT_S)
    finally:
        proc.stop()
    assert code == 2 and proc.lines[-1] == f"discern serve: error: {message}", proc.output


SCOUTING = ("scouting/multicast/enabled", "scouting/gossip/enabled")


@pytest.mark.parametrize("text, multicast_flag, expected", [
    ('{ mode: "client", connect: { endpoints: ["tcp/127.0.0.1:7447"] } }', None, (False, False)),  # the docs' minimal file
    ('{ mode: "client", scouting: { multicast: { enabled: true }, gossip: { enabled: true } } }', None, (True, True)),
    ('{ mode: "client", scouting: { gossip: { enabled: true } } }', None, (False, True)),
    ('{ mode: "client" }', True, (True, False)),  # --multicast-scouting
])
def test_a_config_file_leaving_scouting_unset_gets_discerns_default_off(tmp_path, text, multicast_flag, expected):
    """A file left scouting to zenoh's defaults, both on: a minimal client file scouted by multicast and gossip."""
    path = tmp_path / "zenoh.json5"
    path.write_text(text)
    zenoh_config = ZenohSettings(config_file=path, multicast_scouting=multicast_flag).to_zenoh()
    assert tuple(json.loads(zenoh_config.get_json(key)) for key in SCOUTING) == expected
