"""Monitor settings and the zenoh session configuration built from them.

Defaults are safe for a single machine: peer mode, listening on loopback
only, multicast and gossip scouting off. Deployments across machines pass a
zenoh JSON5 config file (TLS, access control, routers) and/or --connect endpoints.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import socket
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

import zenoh

from discern.rules.engine import JURISDICTIONS
from discern.rules.facts import Params
from discern.rules.scene import ID_RULE, valid_id

from .config_syntax import json5_fault

DEFAULT_PORT = 7447
DEFAULT_ENDPOINT = f"tcp/127.0.0.1:{DEFAULT_PORT}"


def free_port() -> int:
    """A loopback port nothing holds now, for a monitor beside another (the demo's, a test's, a benchmark's)."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]
MODES = ("peer", "client", "router")
DEFAULT_LOG_DIR = Path("discern-log")  # `discern serve` records everything unless told not to

# Bounds of the settings that pace the monitor's threads: zero or tiny periods busy-loop (a status
# record or a log file per loop), and a wait past threading.TIMEOUT_MAX (about 9.2e9 s) raises
# OverflowError in the thread that waits, which then stops for good.
BUDGET_MAX_MS = 60_000.0
STATUS_PERIOD_MIN_S, STATUS_PERIOD_MAX_S = 0.1, 3600.0
# A vehicle's state lives a window past its last proposal: a window of hours would keep every vehicle ever seen.
# A minute is 3,000 frames at 50 Hz, far past what any sanity rule reads (a flashing light: a few seconds).
WINDOW_MAX_S = 60.0
# A flashing light is seen on, off and on again (its slowest cycle lasts 1.2 s, MUTCD 4D.19); a shorter window judges
# every flash, glint and one-frame sign reading afresh.
WINDOW_MIN_S = 1.5
LOG_FLUSH_MIN_S, LOG_FLUSH_MAX_S = 0.05, 60.0
LOG_ROTATE_MIN_S = 1.0
LOG_ROTATE_MIN_BYTES = 64 * 1024
MIB = 1024 * 1024
TEST_DELAY_MAX_MS = 10 * BUDGET_MAX_MS  # past any budget; time.sleep overflows on far more


def default_monitor_id() -> str:
    host = re.sub(r"[^A-Za-z0-9_\-]", "-", socket.gethostname())[:48] or "host"
    return f"{host}-{os.getpid()}"


@dataclass
class ZenohSettings:
    """How to join the zenoh network; `None` leaves the value of the config file (or zenoh's default)."""

    mode: Optional[str] = None
    listen: Optional[list[str]] = None
    connect: Optional[list[str]] = None
    config_file: Optional[Path] = None
    multicast_scouting: Optional[bool] = None

    def to_zenoh(self, *, default_mode: str = "peer", default_listen: Optional[list[str]] = None) -> zenoh.Config:
        """The zenoh Config: the file if given, then the explicit settings on top.

        Without a file, unset values take Discern's safe defaults (loopback only,
        no multicast or gossip scouting) rather than zenoh's (all interfaces, both on).
        Scouting stays off also where a file leaves it unset (a minimal client file naming
        only its router): only a file or flag that turns it on does.
        Gossip would let any session connected to two monitors introduce them to each
        other: they would stay linked and answer each other's vehicles.
        """
        if self.config_file is not None:
            try:
                config = zenoh.Config.from_file(str(self.config_file))
            except zenoh.ZError as exc:
                raise ValueError(f"zenoh config {self.config_file}: "
                                 f"{config_file_problem(str(exc), _read_text(self.config_file))}") from None
            from_file = True
        else:
            config = zenoh.Config()
            from_file = False
        mode = self.mode or (None if from_file else default_mode)
        if mode is not None:
            if mode not in MODES:
                raise ValueError(f"zenoh mode {mode!r} is not one of {', '.join(MODES)}")
            config.insert_json5("mode", json.dumps(mode))
        if self.listen is not None:
            listen = self.listen
        elif from_file:
            listen = None
        else:  # a client does not listen: it connects
            listen = [] if mode == "client" else (default_listen or [])
        if listen is not None:
            _insert(config, "listen/endpoints", listen)
        if self.connect is not None:
            _insert(config, "connect/endpoints", self.connect)
            check_connect_ports(self.connect)
        if self.multicast_scouting is not None:
            config.insert_json5("scouting/multicast/enabled", json.dumps(self.multicast_scouting))
        for key in SCOUTING_KEYS:  # what the file leaves unset takes Discern's default, not zenoh's
            if _config_value(config, key) is None:
                config.insert_json5(key, "false")
        return config


SCOUTING_KEYS = ("scouting/multicast/enabled", "scouting/gossip/enabled")
ZENOH_DEFAULT_MODE = "peer"  # what zenoh runs as when a configuration names no mode


def listen_endpoints(config: zenoh.Config) -> list[str]:
    """The endpoints a session opened with `config` listens on: those of the mode it runs in.

    Zenoh takes a list for every mode, or a list per mode ({"peer": [...], "router": [...]}), and then opens only
    the running mode's: zenoh's own default is such a dict with nothing for a client, which listens only when told
    to. Counting every mode's refused a client configured by file for the peer default's port 0, and named endpoints
    that were never opened.
    """
    return _mode_endpoints(config, "listen")


def _mode_endpoints(config: zenoh.Config, kind: str) -> list[str]:
    """The `kind` ("listen", "connect") endpoints of the mode the configuration runs in."""
    value = _config_value(config, f"{kind}/endpoints")
    if isinstance(value, dict):
        value = value.get(_config_value(config, "mode") or ZENOH_DEFAULT_MODE)
    return list(value or [])


def uses_tls(config: zenoh.Config) -> bool:
    """Whether a session opened with `config` links by TLS (or QUIC, TLS's too): a certificate may be refused."""
    endpoints = _mode_endpoints(config, "connect") + listen_endpoints(config)
    return (any(str(e).startswith(("tls/", "quic/")) for e in endpoints)
            or _config_value(config, "transport/link/tls/root_ca_certificate") is not None)


def _config_value(config: zenoh.Config, key: str):
    value = config.get_json(key)
    return json.loads(value) if isinstance(value, str) else value


_IP_PROTOCOLS = ("tcp", "udp", "tls", "quic", "ws")


def listens_by_default(config: zenoh.Config) -> bool:
    """Whether the configuration leaves listen.endpoints as zenoh's own default (port 0 for a peer)."""
    return _config_value(config, "listen/endpoints") == _config_value(zenoh.Config(), "listen/endpoints")


def check_listen_ports(endpoints: list[str], defaulted: bool = False) -> None:
    """Refuse port 0: zenoh would take some free port without telling which, so no one could be told to connect.

    `defaulted`: the endpoints are zenoh's default, which the error then says, as the configuration named none.
    """
    for endpoint in endpoints:
        protocol, address = _protocol_address(endpoint)
        if protocol in _IP_PROTOCOLS and address.rpartition(":")[2] == "0":
            default = " (zenoh's own default, as the configuration names no listen.endpoints)" if defaulted else ""
            raise ValueError(f"listen endpoint {endpoint!r}{default}: port 0 is not supported, as zenoh does not "
                             "say which free port it takes: name a port (--listen, or listen.endpoints)")


def check_connect_ports(endpoints: list[str]) -> None:
    """Refuse an IP endpoint without a port a socket can have: zenoh takes it, and then tries to connect to it in vain,
    saying nothing (it refuses it only to listen on)."""
    for endpoint in endpoints:
        protocol, address = _protocol_address(endpoint)
        if protocol not in _IP_PROTOCOLS:
            continue
        host, colon, port = address.rpartition(":")
        if not colon or address.endswith("]"):  # [::1]: an IPv6 address, with no port
            problem = "no port"
        elif not host:
            problem = "no host"
        elif not (re.fullmatch("[0-9]{1,5}", port) and 0 < int(port) < 65536):
            problem = f"invalid port {port!r}"
        else:
            continue
        raise ValueError(f"cannot connect to {endpoint}: {problem}: give <host>:<port>, a port from 1 to 65535")


def _protocol_address(endpoint: str) -> tuple[str, str]:
    """An endpoint's protocol and address, without zenoh's ?metadata and #config."""
    protocol, _, address = re.split(r"[?#]", endpoint, maxsplit=1)[0].partition("/")
    return protocol, address


_RUST_LOCATION = re.compile(r" at /\S+?\.rs:\d+\.?")
_JSON5_MESSAGE = re.compile(r'msg: "((?:[^"\\]|\\.)*)"')
_JSON5_LOCATION = re.compile(r"Location \{ line: (\d+), column: (\d+) \}")
_PARSER_POSITION = re.compile(r"-->\s*(\d+):(\d+)")
_PARSER_EXPECTED = re.compile(r"^\s*= (.+)$", re.MULTILINE)


def config_file_problem(text: str, source: Optional[str]) -> str:
    """One line from zenoh's error on a config file: its position and reason, not the parser's diagram of them.

    A value zenoh cannot take is named at its exact position. A syntax error is named where zenoh's JSON5 parser
    gave up, the start of the value it could not finish, often lines before the fault: the file's `source` is read
    again (config_syntax) for the fault's own position and kind, and zenoh's position is only given, as near the
    fault, when that finds none.
    """
    text = without_rust_locations(text)
    message, position = _JSON5_MESSAGE.search(text), _JSON5_LOCATION.search(text)
    near = ""
    if message is None:
        message, position = _PARSER_EXPECTED.search(text), _PARSER_POSITION.search(text)
        fault = json5_fault(source) if message is not None and source is not None else None
        if fault is not None:
            return fault
        near = "near "
    if message is None:
        return " ".join(text.split())
    reason = message.group(1).replace('\\"', '"')  # a value quoted inside the debug form's own quotes
    return f"{near}line {position.group(1)} column {position.group(2)}: {reason}" if position else reason


def _read_text(path: Path) -> Optional[str]:
    try:
        return path.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return None


def without_rust_locations(text: str) -> str:
    """Zenoh's error text without the Rust source locations that mean nothing to a user."""
    return _RUST_LOCATION.sub("", text)


def _insert(config: zenoh.Config, key: str, endpoints: list[str]) -> None:
    for endpoint in endpoints:  # one at a time, to name the bad one
        try:
            zenoh.Config().insert_json5(key, json.dumps([endpoint]))
        except zenoh.ZError as exc:
            inner = _JSON5_MESSAGE.search(str(exc))  # zenoh wraps the reason in its JSON5 error's debug form
            reason = without_rust_locations(inner.group(1) if inner else str(exc))
            raise ValueError(f"bad zenoh endpoint {endpoint!r}: {reason}") from None
    config.insert_json5(key, json.dumps(list(endpoints)))


def path_text(text: str) -> str:
    """A path argument as given. An empty one (an unset shell variable) is refused: as a Path it is the current
    directory, where `discern scenarios run ""` read every file below and `serve --log-dir ""` logged."""
    if not text:
        raise argparse.ArgumentTypeError("empty path: give a file or directory name")
    return text


def path_arg(text: str) -> Path:
    return Path(path_text(text))


def check_number(flag: str, value, low: float, high: float = math.inf, *, unit: str = "", above: bool = False) -> None:
    """Refuse NaN, infinities and values out of range, naming the flag that sets the value."""
    if (
        isinstance(value, (int, float))
        and not isinstance(value, bool)  # True is 1 to Python, not a number anyone meant
        and math.isfinite(value)
        and (value > low if above else value >= low)
        and value <= high
    ):
        return
    bounds = f"{'above' if above else 'at least'} {low:g}{unit}" + (f" and at most {high:g}{unit}" if high < math.inf else "")
    if isinstance(value, bool) or not isinstance(value, (int, float)):  # "got 0.1" did not say it was the string '0.1'
        value = f"{value!r} ({type(value).__name__})"
    raise ValueError(f"{flag} must be a finite number {bounds}, got {value}")


def check_window(flag: str, seconds) -> None:
    """A history window the monitor can run with: serve's --window-s, and a replay's --window, which decides as such
    a monitor would."""
    check_number(flag, seconds, WINDOW_MIN_S, WINDOW_MAX_S, unit=" s")


def check_max_payload_bytes(value) -> None:
    """A payload limit the monitor can run with: serve's, and `discern check`'s, which refuses what the monitor would."""
    if not (isinstance(value, int) and not isinstance(value, bool) and value >= MIN_PAYLOAD_BYTES):
        raise ValueError(f"--max-payload-bytes must be at least {MIN_PAYLOAD_BYTES}, got {value}")


@dataclass
class LogSettings:
    """Where the MCAP log goes and how it is cut."""

    directory: Path
    rotate_bytes: int = 256 * 1024 * 1024
    rotate_seconds: float = 3600.0
    flush_seconds: float = 0.5  # a kill -9 loses at most about this much
    compression: str = "zstd"  # or "none"
    keep_bytes: Optional[int] = None  # the monitor's files beyond this, oldest first, are deleted; None: all kept

    def validate(self) -> "LogSettings":
        """Refuse settings that would make the writer spin: a file or a chunk per loop."""
        check_number("--log-rotate-mb", self.rotate_bytes / MIB, LOG_ROTATE_MIN_BYTES / MIB, unit=" MiB")
        check_number("--log-rotate-s", self.rotate_seconds, LOG_ROTATE_MIN_S, unit=" s")
        check_number("--log-flush-s", self.flush_seconds, LOG_FLUSH_MIN_S, LOG_FLUSH_MAX_S, unit=" s")
        if self.compression not in ("zstd", "none"):
            raise ValueError(f"--log-compression must be zstd or none, got {self.compression!r}")
        if self.keep_bytes is not None and not self.keep_bytes >= self.rotate_bytes:
            raise ValueError(f"--log-keep-mb must be at least --log-rotate-mb ({self.rotate_bytes / MIB:g} MiB), "
                             f"room for the file being written, got {self.keep_bytes / MIB:g}")
        return self


MAX_PAYLOAD_BYTES = 1024 * 1024  # --max-payload-bytes by default, for the monitor and for `discern check`
MIN_PAYLOAD_BYTES = 1024  # less holds no scene with a few objects


@dataclass
class MonitorConfig:
    monitor_id: str = field(default_factory=default_monitor_id)
    zenoh: ZenohSettings = field(default_factory=ZenohSettings)
    vehicles: str = "*"  # key-chunk filter: shard the fleet across monitors
    budget_ms: float = 50.0
    window_s: float = 2.0
    max_payload_bytes: int = MAX_PAYLOAD_BYTES
    workers: int = 1  # decision processes; each vehicle sticks to one
    shadow: bool = False
    jurisdiction: str = "us"
    # reasoning parameters (rules.facts.Params) as `--param NAME=VALUE` gives them: a fleet that brakes less firmly
    params: tuple[str, ...] = ()
    log: Optional[LogSettings] = None
    status_period_s: float = 1.0
    # Test-only: every decision sleeps this long first, to exercise the deadline.
    test_decision_delay_ms: float = 0.0

    def param_values(self) -> dict[str, float]:
        """The `params` as numbers, for the workers' reasoners and the log's metadata (checked by `validate`)."""
        return Params.overrides(list(self.params))[0]

    def validate(self) -> "MonitorConfig":
        """Refuse, by flag, what the monitor cannot run with, before anything starts."""
        if not self.monitor_id:
            raise ValueError("monitor id is empty: give one with --id, or leave --id out for host-pid")
        if not valid_id(self.monitor_id):
            raise ValueError(f"monitor id {self.monitor_id!r} must match {ID_RULE}")
        check_number("--budget-ms", self.budget_ms, 0, BUDGET_MAX_MS, unit=" ms", above=True)
        check_window("--window-s", self.window_s)
        check_number("--status-period-s", self.status_period_s, STATUS_PERIOD_MIN_S, STATUS_PERIOD_MAX_S, unit=" s")
        if self.log is not None:
            self.log.validate()
        check_max_payload_bytes(self.max_payload_bytes)
        if self.jurisdiction not in JURISDICTIONS:
            raise ValueError(f"unknown jurisdiction {self.jurisdiction!r}: choose from {', '.join(JURISDICTIONS)}")
        problems = Params.overrides(list(self.params))[1]
        if problems:
            raise ValueError("; ".join(problems))
        if not 1 <= self.workers <= 64:
            raise ValueError(f"--workers must be between 1 and 64, got {self.workers}")
        # A negative sleep would crash every decision worker at its first batch.
        check_number("--test-only-decision-delay-ms", self.test_decision_delay_ms, 0, TEST_DELAY_MAX_MS, unit=" ms")
        return self
