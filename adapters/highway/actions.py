"""highway-env's DiscreteMetaAction <-> the catalog's actions."""

from __future__ import annotations

from discern.rules.scene import Action

LANE_LEFT, IDLE, LANE_RIGHT, FASTER, SLOWER = range(5)

_TO_CATALOG = {
    LANE_LEFT: Action.change_lane_left,
    IDLE: Action.cruise,
    LANE_RIGHT: Action.change_lane_right,
    FASTER: Action.accelerate,
    SLOWER: Action.brake,
}
_FROM_CATALOG = {action: index for index, action in _TO_CATALOG.items()}
# Catalog actions with no meta-action of their own: the nearest thing highway-env can do.
_FROM_CATALOG[Action.pull_over] = SLOWER
_FROM_CATALOG[Action.turn_left] = LANE_LEFT
_FROM_CATALOG[Action.turn_right] = LANE_RIGHT


def to_catalog(action: int) -> Action:
    try:
        return _TO_CATALOG[int(action)]
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"not a DiscreteMetaAction index: {action!r} (expected 0..4)") from None


def from_catalog(action: Action | str) -> int:
    return _FROM_CATALOG[Action(action)]
