"""A zenoh router in Python, for when zenohd is not installed.

Monitors and planners on several machines connect to it (`--connect
tcp/<router>:7447`) instead of to each other; it forwards proposals to the
monitor whose key expressions match, which is how a fleet is sharded.
"""

from __future__ import annotations

from dataclasses import replace

import zenoh

from .config import DEFAULT_ENDPOINT, ZenohSettings


def router_config(settings: ZenohSettings) -> zenoh.Config:
    """Router mode, whatever mode `settings` name (left as they are); by default on Discern's loopback endpoint, no
    multicast."""
    return replace(settings, mode="router").to_zenoh(default_listen=[DEFAULT_ENDPOINT])
