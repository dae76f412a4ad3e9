"""The sanity layer: perception plausibility, range sensors over vision, reasoning over a frame window.

Rules live in sanity/catalog/*.lp (loaded with the driving catalog); the
window facts come from `WindowProvider`, which the Reasoner picks up through
`default_providers()`.
"""

from __future__ import annotations

from .window import WindowConfig, WindowProvider


def default_providers(config: WindowConfig = WindowConfig()) -> list[WindowProvider]:
    return [WindowProvider(config)]


__all__ = ["WindowConfig", "WindowProvider", "default_providers"]
