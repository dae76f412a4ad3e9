"""The deployment recipes of docs/protocol.md: mutual TLS plus zenoh access control, per vehicle, with the monitor
as the TLS peer and behind a TLS router. The configs are read from the docs, so that the docs' are the ones that work."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys

import pytest

from discern.monitor.client import Monitor
from discern.monitor.example_planner import highway_scene
from discern.monitor.config import free_port
from tests.monitor_process import REPO, DiscernProcess

pytestmark = [pytest.mark.wall_clock,  # run alone: see the marker in pyproject.toml
              pytest.mark.skipif(shutil.which("openssl") is None, reason="openssl is needed to make test certificates")]

PARTIES = ["monitor", "router", "car_1", "operator", "intruder"]


def make_certificates(directory, names):
    def run(*args):
        subprocess.run(["openssl", *args], cwd=directory, check=True, capture_output=True)

    run("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", "ca.key", "-out", "ca.pem", "-days", "2",
        "-subj", "/CN=discern-test-ca")
    for name in names:
        (directory / f"{name}.ext").write_text("subjectAltName=DNS:localhost,IP:127.0.0.1\n")
        run("req", "-newkey", "rsa:2048", "-nodes", "-keyout", f"{name}.key", "-out", f"{name}.csr", "-subj", f"/CN={name}")
        run("x509", "-req", "-in", f"{name}.csr", "-CA", "ca.pem", "-CAkey", "ca.key", "-CAcreateserial",
            "-out", f"{name}.pem", "-days", "2", "-extfile", f"{name}.ext")


def docs_configs() -> dict[str, str]:
    """The json5 blocks of docs/protocol.md's TLS section, by the file name on their first line."""
    doc = (REPO / "docs" / "protocol.md").read_text()
    return dict(re.findall(r"```json5\n// (\S+\.json5)\n(.*?)```", doc, re.DOTALL))


def write_config(directory, text: str, name: str, port: int, party: str = "") -> None:
    """A docs config on this machine: the test's certificates, loopback and a free port (and `party`'s certificate
    for the planner's config, as the docs tell an operator to use it)."""
    text = (text.replace("/etc/discern/", f"{directory}/").replace("0.0.0.0:7447", f"127.0.0.1:{port}")
            .replace(".vehicle.local:7447", f".vehicle.local:{port}").replace("monitor.vehicle.local", "localhost")
            .replace("router.vehicle.local", "localhost"))
    if party:
        text = text.replace("car_1.key", f"{party}.key").replace("car_1.pem", f"{party}.pem")
    (directory / name).write_text(text)


@pytest.fixture(scope="module")
def certificates(tmp_path_factory):
    directory = tmp_path_factory.mktemp("tls")
    make_certificates(directory, PARTIES)
    return directory


@pytest.fixture(scope="module", params=["peer", "router"])
def secured(request, certificates, tmp_path_factory):
    """The docs' setup: a monitor its planners reach directly, or one behind a router holding TLS and the rules."""
    directory = tmp_path_factory.mktemp(request.param)
    for name in PARTIES:
        for suffix in ("key", "pem"):
            shutil.copy(certificates / f"{name}.{suffix}", directory)
    shutil.copy(certificates / "ca.pem", directory)
    configs, port = docs_configs(), free_port()
    for party in ("car_1", "operator", "intruder"):
        write_config(directory, configs["car_1.json5"], f"{party}.json5", port, party)
    started = []
    try:
        if request.param == "peer":
            write_config(directory, configs["monitor.json5"], "monitor.json5", port)
            monitor_args = ["--zenoh-config", str(directory / "monitor.json5")]
        else:
            write_config(directory, configs["router.json5"], "router.json5", port)
            write_config(directory, configs["monitor_client.json5"], "monitor_client.json5", port)
            started.append(DiscernProcess("router", "--zenoh-config", str(directory / "router.json5")).wait_ready())
            monitor_args = ["--zenoh-config", str(directory / "monitor_client.json5")]
        started.append(DiscernProcess("serve", *monitor_args, "--id", "secure", "--budget-ms", "5000").wait_ready())
        assert f"tls/127.0.0.1:{port}" in started[0].output
        with Monitor("car_1", config_file=directory / "car_1.json5") as planner:
            assert planner.wait_for_monitor(timeout=15), "\n".join(p.output for p in started)
        yield directory
    finally:
        for proc in reversed(started):
            proc.stop()


def check(config, vehicle):
    with Monitor(vehicle, config_file=config, timeout=1.0) as monitor:
        return monitor.check(highway_scene(0, 4), "cruise")


def status(config):
    return subprocess.run([sys.executable, "-m", "discern.monitor.commands", "status", "--zenoh-config", str(config),
                           "--json"], cwd=REPO, capture_output=True, text=True, timeout=60)


def test_a_planner_with_its_certificate_is_judged(secured):
    verdict = check(secured / "car_1.json5", "car_1")
    assert not verdict.failsafe and verdict.decision.value == "approve"


def test_access_control_keeps_a_planner_to_its_own_vehicle(secured):
    verdict = check(secured / "car_1.json5", "car_2")
    assert verdict.failsafe and verdict.rules == ["monitor.no_answer"]
    assert "the certificate or the access rules may be refusing" in verdict.error


def test_a_certificate_with_no_policy_gets_nothing(secured):
    verdict = check(secured / "intruder.json5", "car_1")
    assert verdict.failsafe and verdict.rules == ["monitor.no_answer"]
    assert "TLS or access control" in verdict.error


def test_waiting_for_a_monitor_the_access_rules_keep_from_the_vehicle_says_so(secured):
    """The monitor declares discern/*/check to car_1: a known route said True for car_2, whose every check then failed."""
    with Monitor("car_2", config_file=secured / "car_1.json5") as planner:
        assert planner.wait_for_monitor(timeout=1.5) is False


def test_an_operator_certificate_reads_the_status_and_a_planners_does_not(secured):
    done = status(secured / "operator.json5")
    assert done.returncode == 0 and '"monitor_id":"secure"' in done.stdout, done.stderr
    assert status(secured / "car_1.json5").returncode == 2
