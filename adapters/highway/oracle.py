"""Ground-truth judge of a vetoed proposal: was it actually safe?

A veto is *false* when the proposal, executed on a copy of the true simulator state, neither collides
nor exceeds the true speed limit within the horizon: the proposal for one policy step, then
`horizon - 1` steps of SLOWER (the most defensive continuation the planner could still pick). A
collision that braking cannot avoid counts against the proposal, so an unavoidable crash never makes
a veto false. The checker never sees this judge: it has only the (possibly faulty) perception.
"""

from __future__ import annotations

import copy

from .actions import FASTER, SLOWER

SPEED_TOLERANCE = 0.5  # m/s above the true limit before a target speed counts as speeding


def proposal_was_safe(env, action: int, true_limit: float | None, horizon: int = 3) -> bool:
    sim = copy.deepcopy(env.unwrapped)
    sim.step(int(action))
    if sim.vehicle.crashed:
        return False
    if int(action) == FASTER and true_limit is not None and sim.vehicle.target_speed > true_limit + SPEED_TOLERANCE:
        return False
    for _ in range(horizon - 1):
        sim.step(SLOWER)
        if sim.vehicle.crashed:
            return False
    return True
