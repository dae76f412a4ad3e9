"""The sanity layer: perception plausibility, range sensors over vision, reasoning over a frame window.

Rules live in sanity/catalog/*.lp (loaded with the driving catalog); the
window facts come from `WindowProvider`, which a Reasoner is given through
`default_providers()` (as `window_reasoner` and `reasoner_for` do): rules
never import this layer.
"""

from __future__ import annotations

from .reasoner import default_providers, reasoner_for, window_reasoner
from .window import WindowConfig, WindowProvider

__all__ = ["WindowConfig", "WindowProvider", "default_providers", "reasoner_for", "window_reasoner"]
