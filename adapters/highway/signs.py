"""A speed-limit sign layer for highway-env, which has no signs.

A sign stands every `spacing` metres and posts its lane's limit. The camera reads it when it comes
into view; a sign-reading stack keeps the last value read until the next sign. A perturbed sign is
read as `misread_value` (30 m/s read as 80 m/s), the fault a sticker or a bad classifier causes.
Which signs are misread depends only on the seed and the sign's index, so every variant of an
episode meets the same signs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from discern.rules.scene import SignKind, Source, TrafficSign, Vec2

SIGN_VIEW = 60.0  # m: the camera reads a sign from this far
SIGN_MARGIN = 2.0  # m beyond the right edge of the road: where the sign post stands


@dataclass
class SignReading:
    limit: float | None  # the limit the stack believes is in force
    visible: TrafficSign | None  # the sign in view this frame, if any
    misread: bool  # the believed limit comes from a perturbed sign


class SignLayer:
    def __init__(self, spacing: float = 200.0, misread_rate: float = 0.0, misread_value: float = 80.0, seed: int = 0):
        if spacing <= SIGN_VIEW:
            raise ValueError(f"sign spacing must exceed the {SIGN_VIEW:.0f} m view distance, got {spacing}")
        if not 0.0 <= misread_rate <= 1.0:
            raise ValueError(f"sign misread rate must lie in [0, 1], got {misread_rate}")
        self.spacing = spacing
        self.misread_rate = misread_rate
        self.misread_value = misread_value
        self.seed = seed
        self.episode_seed = 0
        self._believed: float | None = None
        self._misread = False

    def reset(self, episode_seed: int, limit: float | None) -> None:
        """A new episode begins with the limit of the sign just passed, read correctly."""
        self.episode_seed = episode_seed
        self._believed = limit
        self._misread = False

    def _misread_sign(self, index: int) -> bool:
        if self.misread_rate <= 0.0:
            return False
        return bool(np.random.default_rng([self.seed, self.episode_seed, 7, index]).random() < self.misread_rate)

    def read(self, position: float, limit: float | None, right_edge: float = 0.0, front: float = 0.0) -> SignReading:
        """`position`: the ego's centre's distance along the road; `limit`: the true limit of its lane;
        `right_edge`: m from the ego's centre to the road's right edge; `front`: from its centre to its front
        bumper. The sign's position is then the scene's: a gap from the bumper, right of the ego's centre."""
        index = int(np.floor(position / self.spacing)) + 1
        ahead = index * self.spacing - position
        visible = None
        if limit is not None and ahead <= SIGN_VIEW:
            misread = self._misread_sign(index)
            value = self.misread_value if misread else limit
            visible = TrafficSign(
                kind=SignKind.speed_limit,
                value=value,
                source=Source.camera,
                position=Vec2(x=round(right_edge + SIGN_MARGIN, 3), y=round(max(ahead - front, 0.0), 3)),
                confidence=0.9,
            )
            self._believed, self._misread = value, misread
        return SignReading(limit=self._believed, visible=visible, misread=self._misread)
