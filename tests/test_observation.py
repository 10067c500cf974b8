"""Observations: contents, history, immutability, and that they hold no ground truth."""

from __future__ import annotations

import numpy as np
import pytest

import anonloc_env
from anonloc_env.geometry import rotate
from tests.helpers import constant_actions

#: The observation keys in their documented order (without and with history).
KEY_ORDER = [
    "detections",
    "mask",
    "new_picture",
    "since_picture",
    "odometry",
    "bumper",
    "odometry_between",
    "interval",
]
HISTORY_ORDER = ["history_detections", "history_mask", "history_odometry", "history_interval"]
KEYS = set(KEY_ORDER)
HISTORY_KEYS = set(HISTORY_ORDER)
OWN = {"odometry", "bumper", "odometry_between", "history_odometry"}


def test_ground_truth_is_in_infos_and_never_in_observations() -> None:
    """What an agent observes is (a) arrays shared by every agent, the very same objects, and
    (b) its own odometry and bumper, which equal what its own commands and wheels produce. So no
    observation can single out one robot, and the row order of a picture is independent of
    identity (see test_camera.test_permutation_is_uniform). The identity, ``true_index``, and
    the true pose are in infos only."""
    env = anonloc_env.parallel_env(
        n_robots=4,
        arena_size=(30.0, 30.0),
        picture_interval=0.25,
        camera={"pixel_noise": 0.0, "orientation_noise_deg": 0.0},
        observation={"history": 2},
    )
    poses = np.array([[5.0, 5.0, 0.0], [15.0, 5.0, 1.0], [5.0, 15.0, 2.0], [15.0, 15.0, 3.0]])
    env.reset(seed=0, options={"poses": poses})
    start = env.world.poses.copy()  # poses at the newest picture
    rng = np.random.default_rng(0)
    for _ in range(40):
        actions = {a: rng.uniform(-1, 1, 2).astype(np.float32) for a in env.agents}
        obs, _, _, _, infos = env.step(actions)
        for agent in env.agents:
            assert set(obs[agent]) == KEYS | HISTORY_KEYS
            assert set(infos[agent]) == {"true_index", "pose", "picture", "camera_pose"}
        shared = (KEYS | HISTORY_KEYS) - OWN
        for key in shared:
            assert all(obs[a][key] is obs["robot_0"][key] for a in env.agents), key
        if obs["robot_0"]["new_picture"][0]:
            # The whole interval's own motion arrives with the picture.
            for i, agent in enumerate(env.agents):
                between = obs[agent]["odometry_between"].astype(float)
                moved = rotate(between[:2], start[i, 2])
                np.testing.assert_allclose(moved, env.world.poses[i, :2] - start[i, :2], atol=1e-5)
            start = env.world.poses.copy()
        else:
            # Own odometry is exactly the robot's own motion since the picture, nothing more.
            for i, agent in enumerate(env.agents):
                moved = rotate(obs[agent]["odometry"][:2].astype(float), start[i, 2])
                true = env.world.poses[i, :2] - start[i, :2]
                np.testing.assert_allclose(moved, true, atol=1e-5)
        # The identity lives in infos: the true row holds this robot's projected position.
        picture = env.picture
        for i, agent in enumerate(env.agents):
            row = infos[agent]["true_index"]
            assert picture.true_index[i] == row
            uv = env.camera.project(np.asarray(infos[agent]["pose"])[None, :2])[0]
            np.testing.assert_allclose(picture.detections[row, :2], uv, atol=1e-9)


def test_observation_arrays_are_read_only_and_stay_valid() -> None:
    env = anonloc_env.parallel_env(n_robots=2, picture_interval=0.05, dt=0.05)
    obs, _ = env.reset(seed=0)
    kept = obs["robot_0"]["detections"].copy()
    with pytest.raises(ValueError, match="read-only"):
        obs["robot_0"]["detections"][0, 0] = 1.0
    with pytest.raises(ValueError, match="read-only"):
        obs["robot_1"]["odometry"][0] = 1.0
    old = obs["robot_0"]["detections"]
    env.step(constant_actions(env, (1.0, 0.5)))
    np.testing.assert_array_equal(old, kept)  # a new picture never overwrites an old one


def test_padding_and_mask() -> None:
    env = anonloc_env.parallel_env(
        n_robots=3, camera={"false_positives": 0.5}, observation={"max_detections": 8}
    )
    obs, _ = env.reset(seed=4)
    o = obs["robot_0"]
    rows = env.picture.n_rows
    assert o["detections"].shape == (8, 3)
    np.testing.assert_array_equal(o["mask"], [1.0] * rows + [0.0] * (8 - rows))
    np.testing.assert_array_equal(o["detections"][rows:], 0.0)
    np.testing.assert_allclose(o["detections"][:rows], env.picture.detections, rtol=1e-6)


def test_history_shifts_pictures_and_odometry() -> None:
    env = anonloc_env.parallel_env(
        n_robots=2, dt=0.1, picture_interval=0.3, observation={"history": 2}
    )
    obs, _ = env.reset(seed=1)
    assert np.all(obs["robot_0"]["history_mask"] == 0.0)
    pictures = [obs["robot_0"]["detections"]]
    odometry_at_picture = []
    for _ in range(6):
        before = obs["robot_0"]["odometry"]
        obs, *_ = env.step(constant_actions(env, (1.0, 0.3)))
        if obs["robot_0"]["new_picture"][0]:
            pictures.append(obs["robot_0"]["detections"])
            odometry_at_picture.append(before)
    assert len(pictures) == 3
    o = obs["robot_0"]
    np.testing.assert_array_equal(o["history_detections"][0], pictures[1])
    np.testing.assert_array_equal(o["history_detections"][1], pictures[0])
    np.testing.assert_allclose(o["history_interval"], [0.3, 0.3], rtol=1e-6)
    # Odometry from the previous picture to the newest covers three steps: the last observed
    # value two steps in, plus one more step of the same motion.
    assert o["history_odometry"][0][0] > odometry_at_picture[-1][0]


def test_since_picture_and_new_picture_flag() -> None:
    env = anonloc_env.parallel_env(n_robots=1, dt=0.1, picture_interval=0.3)
    obs, _ = env.reset(seed=0)
    assert obs["robot_0"]["new_picture"][0] == 1.0
    seen = []
    for _ in range(6):
        obs, *_ = env.step(constant_actions(env, (0.0, 0.0)))
        seen.append(
            (obs["robot_0"]["new_picture"][0], round(float(obs["robot_0"]["since_picture"][0]), 6))
        )
    assert seen == [(0, 0.1), (0, 0.2), (1, 0.0), (0, 0.1), (0, 0.2), (1, 0.0)]


@pytest.mark.parametrize("history", [0, 2])
def test_keys_come_in_the_documented_order_and_flags_are_constants(history: int) -> None:
    env = anonloc_env.parallel_env(
        n_robots=3, arena_size=(1.5, 1.5), observation={"history": history}
    )
    order = KEY_ORDER + (HISTORY_ORDER if history else [])
    obs, _ = env.reset(seed=0)
    bumps = 0.0
    for _ in range(30):  # crowded: some bumpers fire
        for agent in env.agents:
            assert list(obs[agent]) == order
            for key in ("bumper", "new_picture"):
                assert not obs[agent][key].flags.writeable
                assert obs[agent][key].tolist() in ([0.0], [1.0])
            bumps += obs[agent]["bumper"][0]
        obs, *_ = env.step(constant_actions(env, (1.0, 0.2)))
    assert bumps > 0
