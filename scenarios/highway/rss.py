"""The RSS peer: Intel's ad-rss longitudinal safe distance as an alternative shield.

It judges the same scene Discern gets (fused objects, faults included) with the RSS
same-direction rule: the following car must keep

    d_min = v_r rho + a_max rho^2 / 2 + (v_r + rho a_max)^2 / (2 b_min) - v_f^2 / (2 b_max)

ad-rss accelerates the follower at `alpha_lon.accel_max` during the response time, capped at
`max_speed_on_acceleration`; leaving the cap out of reach (100 m/s) makes it the paper's formula
exactly (tests/test_highway_rss.py checks the two agree). A proposal whose resulting lane is unsafe
is overridden: a lane change into an unsafe gap becomes cruise (or brake when the own lane is unsafe
too), anything else becomes brake, RSS's proper response.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Sequence

from discern.rules.scene import Action, DetectedObject, Scene
from discern.rules.verdict import Decision, Justification, Verdict

with warnings.catch_warnings():
    warnings.simplefilter("ignore", RuntimeWarning)  # boost.python re-registers a vector converter
    import ad_rss

EGO_LENGTH = 5.0  # highway-env's Vehicle.LENGTH
RULE = "rss_longitudinal"


@dataclass(frozen=True)
class RssParameters:
    response_time: float = 1.0  # s: the shield acts once per policy step (1 Hz)
    accel_max: float = 3.0  # m/s^2 the follower may still accelerate during the response time
    brake_min: float = 4.0  # m/s^2 the follower is sure to brake with afterwards
    brake_max: float = 6.0  # m/s^2 the leader may brake with (highway-env IDM's ACC_MAX)


def _state(speed: float, p: RssParameters, ego: bool):
    phys, rss = ad_rss.physics, ad_rss.rss
    state = rss.core.RelativeObjectState()
    state.object_type = rss.world.ObjectType.EgoVehicle if ego else rss.world.ObjectType.OtherVehicle
    dyn = rss.world.RssDynamics()
    dyn.alpha_lon.accel_max = phys.Acceleration(p.accel_max)
    dyn.alpha_lon.brake_max = phys.Acceleration(-p.brake_max)
    dyn.alpha_lon.brake_min = phys.Acceleration(-p.brake_min)
    dyn.alpha_lon.brake_min_correct = phys.Acceleration(-p.brake_min)
    dyn.alpha_lat.accel_max = phys.Acceleration(0.2)
    dyn.alpha_lat.brake_min = phys.Acceleration(-0.8)
    dyn.response_time = phys.Duration(p.response_time)
    dyn.max_speed_on_acceleration = phys.Speed(100.0)
    dyn.lateral_fluctuation_margin = phys.Distance(0.0)
    dyn.min_longitudinal_safety_distance = phys.Distance(0.0)
    settings = dyn.unstructured_settings  # unused by the structured formula but validated by ad-rss
    settings.pedestrian_turning_radius = phys.Distance(2.0)
    settings.drive_away_max_angle = phys.Angle(2.4)
    settings.vehicle_yaw_rate_change = phys.AngularAcceleration(0.3)
    settings.vehicle_min_radius = phys.Distance(3.5)
    settings.vehicle_trajectory_calculation_step = phys.Duration(0.2)
    dyn.unstructured_settings = settings
    state.dynamics = dyn
    pose = state.unstructured_object_state
    pose.yaw, pose.yaw_rate, pose.steering_angle = phys.Angle(0.0), phys.AngularVelocity(0.0), phys.Angle(0.0)
    pose.dimension.length, pose.dimension.width = phys.Distance(EGO_LENGTH), phys.Distance(2.0)
    pose.center_point.x, pose.center_point.y = phys.Distance(0.0), phys.Distance(0.0)
    pose.speed_range.minimum, pose.speed_range.maximum = phys.Speed(speed), phys.Speed(speed)
    state.unstructured_object_state = pose
    structured = rss.core.StructuredObjectState()
    velocity = rss.world.Velocity()
    velocity.speed_lon_min = velocity.speed_lon_max = phys.Speed(speed)
    velocity.speed_lat_min = velocity.speed_lat_max = phys.Speed(0.0)
    structured.velocity = velocity
    structured.is_in_correct_lane = True
    structured.has_priority = False
    structured.distance_to_enter_intersection = phys.Distance(0.0)
    structured.distance_to_leave_intersection = phys.Distance(0.0)
    state.structured_object_state = structured
    return state


def safe_distance(v_rear: float, v_front: float, p: RssParameters, ego_is_rear: bool = True) -> float:
    """ad-rss's safe longitudinal distance for a follower at v_rear behind a leader at v_front."""
    distance = ad_rss.physics.Distance(0.0)
    ok = ad_rss.rss.structured.calculateSafeLongitudinalDistanceSameDirection(
        _state(max(v_front, 0.0), p, ego=not ego_is_rear), _state(max(v_rear, 0.0), p, ego=ego_is_rear), distance
    )
    if not ok:
        raise ValueError(f"ad-rss rejected the speeds rear={v_rear} front={v_front}")
    return float(distance.mDistance)


def _speed(obj: DetectedObject) -> float:
    return max(obj.velocity.y, 0.0) if obj.velocity is not None else 0.0


def _gap(obj: DetectedObject) -> float:
    """Free road between bumpers: the scene's `y` already is that gap (scene.py), so no lengths come off."""
    return abs(obj.position.y)


class RssChecker:
    name = "rss"

    def __init__(self, parameters: RssParameters | None = None):
        self.p = parameters or RssParameters()

    def lane_conflicts(self, scene: Scene, lane: int, check_rear: bool) -> list[str]:
        """Why `lane` is unsafe for the ego now (empty when it is safe)."""
        ego_speed = scene.ego.speed
        in_lane = [o for o in scene.objects if o.lane is not None and o.lane.id == lane]
        reasons = []
        ahead = [o for o in in_lane if o.position.y > 0]
        if ahead:
            lead = min(ahead, key=lambda o: o.position.y)
            need = safe_distance(ego_speed, _speed(lead), self.p, ego_is_rear=True)
            if _gap(lead) < need:
                reasons.append(f"object {lead.id} ahead in lane {lane}: gap {_gap(lead):.1f} m < RSS {need:.1f} m")
        behind = [o for o in in_lane if o.position.y <= 0]
        if check_rear and behind:
            rear = max(behind, key=lambda o: o.position.y)
            need = safe_distance(_speed(rear), ego_speed, self.p, ego_is_rear=False)
            if _gap(rear) < need:
                reasons.append(f"object {rear.id} behind in lane {lane}: gap {_gap(rear):.1f} m < RSS {need:.1f} m")
        return reasons

    def check(self, scene: Scene, proposed: Action, history: Sequence[Scene] = ()) -> Verdict:
        lane = scene.ego.lane
        target = {Action.change_lane_left: lane - 1, Action.change_lane_right: lane + 1}.get(proposed, lane)
        own = self.lane_conflicts(scene, lane, check_rear=False)
        reasons = self.lane_conflicts(scene, target, check_rear=True) if target != lane else own
        if not reasons or proposed is Action.brake:
            return self._verdict(scene, proposed, Decision.approve, proposed, "RSS longitudinal distances safe")
        action = Action.cruise if target != lane and not own else Action.brake
        return self._verdict(scene, proposed, Decision.override, action, "; ".join(reasons))

    def _verdict(self, scene: Scene, proposed: Action, decision: Decision, action: Action, why: str) -> Verdict:
        return Verdict(
            frame_id=scene.frame_id,
            timestamp=scene.timestamp,
            decision=decision,
            proposed=proposed,
            action=action,
            rules=[RULE] if decision is not Decision.approve else [],
            vetoed_by=[RULE] if decision is not Decision.approve else [],
            justification=Justification(summary=why),
        )
