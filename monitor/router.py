"""A zenoh router in Python, for when zenohd is not installed.

Monitors and planners on several machines connect to it (`--connect
tcp/<router>:7447`) instead of to each other; it forwards proposals to the
monitor whose key expressions match, which is how a fleet is sharded.
"""

from __future__ import annotations

import zenoh

from .config import DEFAULT_ENDPOINT, ZenohSettings


def open_router(settings: ZenohSettings) -> zenoh.Session:
    """A session in router mode; by default on Discern's loopback endpoint, no multicast."""
    settings.mode = "router"
    return zenoh.open(settings.to_zenoh(default_mode="router", default_listen=[DEFAULT_ENDPOINT]))
