"""Where verdicts come from: the core's Reasoner, one instance per worker thread.

The server depends only on the `Decide` call shape, so the decision engine is
loaded in one place.
"""

from __future__ import annotations

import time
from typing import Callable, Protocol, Sequence

from discern.rules.scene import Action, Scene
from discern.rules.verdict import Verdict


class Decide(Protocol):
    def __call__(
        self, scene: Scene, action: Action, *, history: Sequence[Scene], explain: bool, shadow: bool, vehicle: str
    ) -> Verdict: ...


DecideFactory = Callable[[], Decide]


def reasoner_factory() -> Decide:
    """A fresh Reasoner (rule catalogs loaded once) for one worker thread."""
    from discern.rules.engine import Reasoner

    return Reasoner().decide


def with_delay(factory: DecideFactory, delay_s: float) -> DecideFactory:
    """Test-only: make every decision slow, to exercise the deadline and fail-safe path."""

    def make() -> Decide:
        decide = factory()

        def slow(scene: Scene, action: Action, **kwargs) -> Verdict:
            time.sleep(delay_s)
            return decide(scene, action, **kwargs)

        return slow

    return make
