"""Monitor settings and the zenoh session configuration built from them.

Defaults are safe for a single machine: peer mode, listening on loopback
only, multicast scouting off. Deployments across machines pass a zenoh JSON5
config file (TLS, access control, routers) and/or --connect endpoints.
"""

from __future__ import annotations

import json
import os
import re
import socket
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

import zenoh

from discern.rules.engine import JURISDICTIONS

DEFAULT_PORT = 7447
DEFAULT_ENDPOINT = f"tcp/127.0.0.1:{DEFAULT_PORT}"
MODES = ("peer", "client", "router")


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
        no multicast scouting) rather than zenoh's (all interfaces, multicast on).
        """
        if self.config_file is not None:
            try:
                config = zenoh.Config.from_file(str(self.config_file))
            except zenoh.ZError as exc:
                raise ValueError(f"zenoh config {self.config_file}: {exc}") from None
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
        multicast = self.multicast_scouting
        if multicast is None and not from_file:
            multicast = False
        if multicast is not None:
            config.insert_json5("scouting/multicast/enabled", json.dumps(multicast))
        return config


def listen_endpoints(config: zenoh.Config) -> list[str]:
    """The endpoints a config listens on; zenoh may give them per mode ({"peer": [...], ...})."""
    value = config.get_json("listen/endpoints")
    value = json.loads(value) if isinstance(value, str) else value
    if isinstance(value, dict):
        value = [e for eps in value.values() for e in eps]
    return list(value or [])


def _insert(config: zenoh.Config, key: str, endpoints: list[str]) -> None:
    try:
        config.insert_json5(key, json.dumps(list(endpoints)))
    except zenoh.ZError as exc:
        raise ValueError(f"bad zenoh endpoint in {endpoints}: {exc}") from None


@dataclass
class LogSettings:
    """Where the MCAP log goes and how it is cut."""

    directory: Path
    rotate_bytes: int = 256 * 1024 * 1024
    rotate_seconds: float = 3600.0
    flush_seconds: float = 0.5  # a kill -9 loses at most about this much
    compression: str = "zstd"  # or "none"


@dataclass
class MonitorConfig:
    monitor_id: str = field(default_factory=default_monitor_id)
    zenoh: ZenohSettings = field(default_factory=ZenohSettings)
    vehicles: str = "*"  # key-chunk filter: shard the fleet across monitors
    budget_ms: float = 50.0
    window_s: float = 2.0
    max_payload_bytes: int = 1024 * 1024
    workers: int = 1  # decision processes; each vehicle sticks to one
    shadow: bool = False
    jurisdiction: str = "us"
    log: Optional[LogSettings] = None
    status_period_s: float = 1.0
    # Test-only: every decision sleeps this long first, to exercise the deadline.
    test_decision_delay_ms: float = 0.0

    def validate(self) -> "MonitorConfig":
        if not re.fullmatch(r"[A-Za-z0-9_\-]{1,128}", self.monitor_id):
            raise ValueError(f"monitor id {self.monitor_id!r} must match [A-Za-z0-9_-]{{1,128}}")
        for name, value in (("budget_ms", self.budget_ms), ("window_s", self.window_s)):
            if not value > 0:
                raise ValueError(f"{name} must be > 0, got {value}")
        if self.max_payload_bytes < 1024:
            raise ValueError(f"max_payload_bytes must be >= 1024, got {self.max_payload_bytes}")
        if self.jurisdiction not in JURISDICTIONS:
            raise ValueError(f"unknown jurisdiction {self.jurisdiction!r}: choose from {', '.join(JURISDICTIONS)}")
        if not 1 <= self.workers <= 64:
            raise ValueError(f"workers must be between 1 and 64, got {self.workers}")
        return self
