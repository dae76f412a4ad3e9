"""The deployment recipe of docs/protocol.md: mutual TLS plus zenoh access control, per vehicle."""

from __future__ import annotations

import shutil
import subprocess

import pytest

from discern.monitor.client import Monitor
from discern.monitor.example_planner import highway_scene
from tests.monitor_process import DiscernProcess, free_port

pytestmark = pytest.mark.skipif(shutil.which("openssl") is None, reason="openssl is needed to make test certificates")


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


MONITOR_CONFIG = """{
  mode: "peer",
  listen: { endpoints: ["tls/127.0.0.1:%(port)d"] },
  scouting: { multicast: { enabled: false }, gossip: { enabled: false } },
  transport: { link: { tls: {
    root_ca_certificate: "%(dir)s/ca.pem",
    listen_private_key: "%(dir)s/monitor.key",
    listen_certificate: "%(dir)s/monitor.pem",
    enable_mtls: true,
  } } },
  access_control: {
    enabled: true,
    default_permission: "deny",
    rules: [
      { id: "car_1_asks", messages: ["query", "put", "declare_subscriber"], flows: ["ingress"],
        permission: "allow", key_exprs: ["discern/car_1/check", "discern/car_1/proposal", "discern/car_1/verdict"] },
      { id: "monitor_answers", messages: ["reply", "put", "declare_queryable", "declare_subscriber"], flows: ["egress"],
        permission: "allow", key_exprs: ["discern/car_1/**", "discern/*/check", "discern/*/proposal"] },
    ],
    subjects: [{ id: "car_1", cert_common_names: ["car_1"] }],
    policies: [{ rules: ["car_1_asks", "monitor_answers"], subjects: ["car_1"] }],
  },
}
"""

PLANNER_CONFIG = """{
  mode: "peer",
  connect: { endpoints: ["tls/localhost:%(port)d"] },
  listen: { endpoints: [] },
  scouting: { multicast: { enabled: false }, gossip: { enabled: false } },
  transport: { link: { tls: {
    root_ca_certificate: "%(dir)s/ca.pem",
    connect_private_key: "%(dir)s/%(name)s.key",
    connect_certificate: "%(dir)s/%(name)s.pem",
    enable_mtls: true,
  } } },
}
"""


@pytest.fixture(scope="module")
def secured(tmp_path_factory):
    directory = tmp_path_factory.mktemp("tls")
    make_certificates(directory, ["monitor", "car_1", "intruder"])
    port = free_port()
    values = {"port": port, "dir": directory}
    (directory / "monitor.json5").write_text(MONITOR_CONFIG % values)
    for name in ("car_1", "intruder"):
        (directory / f"{name}.json5").write_text(PLANNER_CONFIG % dict(values, name=name))
    proc = DiscernProcess("serve", "--zenoh-config", str(directory / "monitor.json5"), "--id", "secure", "--budget-ms", "5000").wait_ready()
    assert f"tls/127.0.0.1:{port}" in proc.output
    yield directory
    proc.stop()


def check(config, vehicle):
    with Monitor(vehicle, config_file=config, timeout=1.0) as monitor:
        return monitor.check(highway_scene(0, 4), "cruise")


def test_a_planner_with_its_certificate_is_judged(secured):
    verdict = check(secured / "car_1.json5", "car_1")
    assert not verdict.failsafe and verdict.decision.value == "approve"


def test_access_control_keeps_a_planner_to_its_own_vehicle(secured):
    verdict = check(secured / "car_1.json5", "car_2")
    assert verdict.failsafe and verdict.rules == ["monitor.no_answer"]


def test_a_certificate_with_no_policy_gets_nothing(secured):
    verdict = check(secured / "intruder.json5", "car_1")
    assert verdict.failsafe and verdict.rules == ["monitor.no_answer"]
