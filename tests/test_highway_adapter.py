"""The highway-env adapter: real episodes -> Discern scenes."""

import pytest

pytest.importorskip("highway_env")

from discern.adapters.highway.actions import FASTER, IDLE, LANE_LEFT, LANE_RIGHT, SLOWER, from_catalog, to_catalog
from discern.adapters.highway.envs import make_env
from discern.adapters.highway.perception import Perception
from discern.adapters.highway.scene import build_scene
from discern.adapters.highway.truth import VehicleIds, read_truth
from discern.rules.scene import Action, Intent, Scene, Zone


def _scene(env, seed):
    env.reset(seed=seed)
    perceived = Perception().reset(seed, read_truth(env, VehicleIds()))
    return perceived, build_scene(perceived)


def test_meta_actions_map_to_catalog_actions_and_back():
    expected = {
        LANE_LEFT: Action.change_lane_left,
        IDLE: Action.cruise,
        LANE_RIGHT: Action.change_lane_right,
        FASTER: Action.accelerate,
        SLOWER: Action.brake,
    }
    for index, action in expected.items():
        assert to_catalog(index) is action
        assert from_catalog(action) == index
    assert from_catalog(Action.pull_over) == SLOWER
    with pytest.raises(ValueError, match="not a DiscreteMetaAction"):
        to_catalog(7)


def test_lanes_are_numbered_from_the_left_starting_at_one():
    env = make_env("highway-fast-v0")
    for seed in range(4):
        _, scene = _scene(env, seed)
        ego = env.unwrapped.vehicle
        assert scene.ego.lane == ego.lane_index[2] + 1
        assert [l.id for l in scene.lanes if l.kind == "current"] == [1, 2, 3]
        assert scene.ego.zone is Zone.highway and scene.ego.intent is Intent.continue_in_lane
        assert scene.speed_limit == scene.map_speed_limit == 30.0


def test_objects_are_placed_in_the_ego_frame_with_their_lanes():
    env = make_env("highway-fast-v0")
    _, scene = _scene(env, 3)
    ego = env.unwrapped.vehicle
    assert scene.objects, "highway-fast-v0 always has traffic around the ego"
    by_id = {o.id: o for o in scene.objects}
    others = [v for v in env.unwrapped.road.vehicles if v is not ego]
    for obj in scene.objects:
        # x: metres to the right, y: metres ahead; a lane to the right is 4 m further right
        assert obj.lane is not None
        assert obj.position.x == pytest.approx((obj.lane.id - scene.ego.lane) * 4.0, abs=1.5)
    ahead = [v for v in others if v.position[0] - ego.position[0] > 10.0]
    nearest = min(ahead, key=lambda v: v.position[0])
    bumper_gap = nearest.position[0] - ego.position[0] - (nearest.LENGTH + ego.LENGTH) / 2
    match = [o for o in by_id.values() if o.position.y == pytest.approx(bumper_gap, abs=1e-2)]
    assert match and match[0].velocity.y == pytest.approx(nearest.speed, abs=1e-2)


def test_scene_round_trips_through_the_json_schema():
    env = make_env("highway-fast-v0")
    perceived, scene = _scene(env, 5)
    text = scene.model_dump_json(by_alias=True)
    assert Scene.model_validate_json(text) == scene
    assert {r.side.value for r in scene.sensors} <= {
        "front", "front_left", "left", "rear_left", "rear", "rear_right", "right", "front_right"
    }
    assert any(r.side.value == "front" for r in scene.sensors) == any(
        t.lane == scene.ego.lane and t.ahead > 0 for t in perceived.truth.tracks
    )


def test_merge_lane_reports_where_it_ends():
    env = make_env("merge-v0")
    env.reset(seed=0)
    ids = VehicleIds()
    perception = Perception()
    perception.reset(0, read_truth(env, ids))
    seen = None
    for _ in range(25):
        env.step(SLOWER)
        scene = build_scene(perception.step(read_truth(env, ids)))
        ends = [l for l in scene.lanes if l.ends_in is not None]
        if ends:
            seen = (scene, ends)
            break
    assert seen is not None, "the ego should reach the section beside the merge lane"
    scene, ends = seen
    assert [l.id for l in ends] == [3] and [l.id for l in scene.lanes if l.kind == "current"] == [1, 2, 3]
    assert 0 < ends[0].ends_in <= 80.0


def test_wrapper_refuses_an_env_without_the_five_meta_actions():
    import gymnasium as gym

    from discern.scenarios.highway.wrapper import DiscernWrapper

    env = gym.make("intersection-v2")  # longitudinal meta-actions only
    with pytest.raises(ValueError, match="all five meta-actions"):
        DiscernWrapper(env, passthrough=True)


def test_wrapper_refuses_a_speed_grid_its_vehicle_parameters_do_not_fit():
    """accel_step is half the grid's 5 m/s step: on a 10 m/s grid a FASTER at 26 m/s passed a 30 m/s limit, approved."""
    import gymnasium as gym

    from discern.scenarios.highway.wrapper import DiscernWrapper

    coarse = gym.make("highway-fast-v0", config={"action": {"type": "DiscreteMetaAction",
                                                            "target_speeds": [0, 10, 20, 30, 40]}})
    with pytest.raises(ValueError, match=r"target speeds .* this environment's are \[0.0, 10.0, 20.0, 30.0, 40.0\]"):
        DiscernWrapper(coarse)
    DiscernWrapper(coarse, passthrough=True)  # the unshielded baseline checks nothing
    DiscernWrapper(make_env("highway-fast-v0"))


@pytest.mark.parametrize("name", ["roundabout-v0", "two-way-v0", "u-turn-v0", "exit-v0"])
def test_wrapper_refuses_roads_the_scene_conversion_gets_wrong(name):
    import warnings

    import gymnasium as gym

    from discern.scenarios.highway.wrapper import DiscernWrapper

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        env = gym.make(name, config={"action": {"type": "DiscreteMetaAction"}})
    with pytest.raises(ValueError, match=f"{name}.*highway-fast-v0, highway-v0, merge-v0"):
        DiscernWrapper(env, passthrough=True)
