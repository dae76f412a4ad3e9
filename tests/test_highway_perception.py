"""Perception faults between highway-env's truth and the facts Discern and the planner get."""

from dataclasses import replace

import pytest

pytest.importorskip("highway_env")

from discern.adapters.highway.actions import FASTER, IDLE, SLOWER
from discern.adapters.highway.envs import make_env
from discern.adapters.highway.perception import Faults, Perception
from discern.scenarios.highway.planner import follow_sign
from discern.adapters.highway.scene import build_scene
from discern.adapters.highway.signs import SignLayer
from discern.adapters.highway.truth import VehicleIds, read_truth
from discern.rules.scene import SignKind, Source


def _frames(faults, seed=7, steps=8):
    env = make_env("highway-fast-v0")
    env.reset(seed=seed)
    ids = VehicleIds()
    perception = Perception(faults)
    frames = [perception.reset(seed, read_truth(env, ids))]
    for _ in range(steps):
        env.step(SLOWER)
        frames.append(perception.step(read_truth(env, ids)))
    return frames


def test_missed_camera_detection_keeps_the_radar_track():
    frames = _frames(Faults(miss_rate=0.3, miss_frames=2, seed=1))
    missed = [(f, i) for f in frames for i in f.missed]
    assert missed, "a 30 % miss rate must lose some vehicles in 8 frames"
    for frame, track_id in missed:
        detection = next(d for d in frame.detections if d.track.id == track_id)
        assert detection.sources == (Source.radar,)
        assert track_id not in {t.id for t in frame.camera_tracks()}
        scene = build_scene(frame)
        assert next(o for o in scene.objects if o.id == track_id).sources == [Source.radar]


def test_dropped_track_still_shows_in_the_range_readings():
    faults = Faults(miss_rate=1.0, miss_frames=1, miss_drop_track=True, seed=1)
    frame = _frames(faults, steps=1)[-1]
    assert not frame.detections and frame.truth.tracks
    assert build_scene(frame).sensors, "the range sensor still sees what the camera lost"


def test_phantoms_are_camera_only_without_range_echo():
    clean = _frames(Faults(seed=2))
    haunted = _frames(Faults(phantom_rate=1.0, phantom_frames=1, seed=2))
    for before, after in zip(clean[1:], haunted[1:]):
        phantoms = [d for d in after.detections if d.phantom]
        assert len(phantoms) == 1 and phantoms[0].sources == (Source.camera,)
        assert phantoms[0].track in after.camera_tracks()
        assert after.ranges == before.ranges


def test_faults_repeat_for_the_same_seed_and_differ_for_another():
    faults = Faults(miss_rate=0.2, phantom_rate=0.3, noise=1.0, seed=4)
    first = [(f.missed, [d.track for d in f.detections]) for f in _frames(faults)]
    again = [(f.missed, [d.track for d in f.detections]) for f in _frames(faults)]
    other = [(f.missed, [d.track for d in f.detections]) for f in _frames(Faults(miss_rate=0.2, phantom_rate=0.3, noise=1.0, seed=5))]
    assert first == again and first != other


def test_misread_sign_reaches_the_scene_and_the_planner_speeds_up():
    layer = SignLayer(spacing=200.0, misread_rate=1.0, misread_value=80.0, seed=0)
    layer.reset(episode_seed=3, limit=30.0)
    assert layer.read(100.0, 30.0).limit == 30.0  # the sign at 200 m is not in view yet
    reading = layer.read(150.0, 30.0)
    assert reading.misread and reading.limit == 80.0
    assert reading.visible.kind is SignKind.speed_limit and reading.visible.source is Source.camera
    assert layer.read(250.0, 30.0).limit == 80.0  # remembered until the next sign
    # The sign-following cruise control turns IDLE into FASTER below the read limit...
    assert follow_sign(IDLE, 30.0, 80.0) == FASTER
    # ...where the true sign would have held the speed
    assert follow_sign(IDLE, 30.0, 30.0) == IDLE and follow_sign(FASTER, 30.0, 30.0) == IDLE


def test_misread_limit_is_the_perceived_limit_and_the_map_keeps_the_true_one():
    frames = _frames(Faults.preset("signs", seed=0, sign_rate=1.0), steps=12)
    misread = [f for f in frames if f.sign.misread]
    assert misread, "the ego passes a sign within 12 s at highway speed"
    scene = build_scene(misread[0])
    assert scene.speed_limit == 80.0 and scene.map_speed_limit == 30.0


@pytest.mark.parametrize("kinds", ["none,all", "signs,none", "all,missed"])
def test_none_and_all_are_refused_in_a_list_of_kinds_as_standing_alone(kinds):
    with pytest.raises(ValueError, match=f"^fault set '{kinds}': 'none' and 'all' stand alone, not with other kinds$"):
        Faults.preset(kinds)


def test_dropped_detections_are_a_fault_of_their_own_that_all_leaves_out():
    """'missed' keeps the radar track in Discern's list (only the planner loses it); 'dropped' takes it from both."""
    dropped = Faults.preset("signs,dropped", miss_rate=0.2)
    assert dropped.miss_drop_track and dropped.miss_rate == 0.2 and dropped.label() == "signs,dropped@0.2"
    assert not Faults.preset("missed").miss_drop_track and Faults.preset("missed").label() == "missed"
    assert not Faults.preset("all").miss_drop_track and Faults.preset("all").label() == "noise,missed,phantoms,signs"
    with pytest.raises(ValueError, match="'dropped' is 'missed' with the object gone"):
        Faults.preset("missed,dropped")


@pytest.mark.parametrize("kinds, rates, label", [
    ("missed", {"miss_rate": 0.05}, "missed"),  # the default rate, given
    ("missed", {"miss_rate": 0.9}, "missed@0.9"),
    ("all", {"noise": 2.0, "phantom_rate": 0.3}, "noise@2,missed,phantoms@0.3,signs"),
    ("signs", {"sign_value": 60.0}, "signs@0.5:60"),
    ("signs", {"sign_rate": 1.0}, "signs@1"),
])
def test_a_fault_sets_label_carries_each_rate_other_than_the_default(kinds, rates, label):
    """A row of missed detections at 0.9 read 'missed', as one at the default 0.05 does."""
    assert Faults.preset(kinds, **rates).label() == label


def test_unknown_fault_kind_is_named_in_the_error():
    with pytest.raises(ValueError, match="unknown fault kind.*gremlins"):
        Faults.preset("signs,gremlins")


def test_a_visible_signs_position_is_a_gap_from_the_bumper_and_stands_right_of_the_road():
    """It was measured from the ego's centre, and stood 8 m right of the ego's lane: inside the road from lane 1."""
    env = make_env("highway-fast-v0")
    env.reset(seed=7)
    perception = Perception(Faults(seed=0))
    truth = read_truth(env, VehicleIds())
    perception.reset(7, truth)
    lanes = max(l.id for l in truth.lanes)
    for lane, position in ((1, 150.0), (lanes, 170.0)):  # the sign at 200 m is 50 and 30 m ahead of the ego's centre
        ego = replace(truth.ego, lane=lane, road_position=position)
        sign = perception.step(replace(truth, ego=ego)).sign.visible
        assert sign.position.y == pytest.approx(200.0 - position - ego.length / 2)
        right_edge = (lanes - lane + 0.5) * ego.lane_width - ego.lateral
        assert right_edge < sign.position.x < right_edge + 5.0


def _misses_by_vehicle(policy, seed: int) -> list[dict[int, bool]]:
    """Per frame, each vehicle in range, named by its place on the simulator's road (found by its exact offset from
    the ego, as read_truth computes it), and whether the camera missed it."""
    from discern.scenarios.highway.wrapper import DiscernWrapper

    env = DiscernWrapper(make_env("highway-fast-v0"), faults=Faults.preset("missed"), passthrough=True)
    env.reset(seed=seed)
    frames, done = [], False
    while not done:
        road, ego = env.unwrapped.road, env.unwrapped.vehicle
        lane = road.network.get_lane(ego.lane_index)
        s_ego, l_ego = lane.local_coordinates(ego.position)
        place = {}
        for index, vehicle in enumerate(road.vehicles):
            s, l = lane.local_coordinates(vehicle.position)
            place[(float(s - s_ego), float(l - l_ego))] = index
        perceived = env.perceived
        frames.append({place[(t.ahead, t.right)]: t.id in perceived.missed for t in perceived.truth.tracks})
        *_, terminated, truncated, _ = env.step(policy(perceived))
        done = terminated or truncated
    env.close()
    return frames


def test_every_variant_of_an_episode_misses_the_same_vehicles_wherever_both_have_them_in_range():
    """Track ids were handed out in the order vehicles came into range, which the ego's trajectory decides: in episode
    10007 the planner and a car that keeps lane and speed gave two cars each other's ids, and the camera missed one
    car in one run and the other in the other. Ids are now the simulator's own, and so are the draws."""
    from discern.scenarios.highway.planner import Planner

    dqn = Planner.load()
    planner = _misses_by_vehicle(lambda p: dqn.act(p.truth.ego, len(p.truth.lanes), p.camera_tracks(), p.sign.limit),
                                 10_007)
    idle = _misses_by_vehicle(lambda perceived: IDLE, 10_007)
    both = [(frame, vehicle, a[vehicle], b[vehicle]) for frame, (a, b) in enumerate(zip(planner, idle))
            for vehicle in a.keys() & b.keys()]
    assert len(both) > 100 and any(a for _, _, a, _ in both), "too few shared sightings or misses to compare"
    assert [d for d in both if d[2] != d[3]] == []
