"""pymunk world: nothing passes through walls or robots; odometry matches the true motion."""

from __future__ import annotations

import math

import numpy as np
import pytest

import anonloc_env
from anonloc_env.geometry import rotate
from anonloc_env.world import BodyBatch
from tests.helpers import constant_actions


@pytest.mark.parametrize("shape", ["square", "circle"])
@pytest.mark.parametrize("dt", [0.01, 0.1, 0.5])
def test_full_speed_into_wall_never_passes(shape: str, dt: float) -> None:
    env = anonloc_env.parallel_env(
        n_robots=1,
        arena_size=(2.0, 2.0),
        dt=dt,
        max_cycles=10**6,
        robot={"shape": shape, "size": 0.2, "v_max": 5.0},
    )
    env.reset(seed=0, options={"poses": [[1.0, 1.0, 0.0]]})
    worst = 0.0
    for _ in range(round(10.0 / dt)):  # 10 s at 5 m/s into the wall at x = 2
        env.step(constant_actions(env, (1.0, 0.0)))
        worst = max(worst, env.world.poses[0, 0])
    # The robot's centre never goes past the wall's inner face minus a fraction of its half size.
    assert worst < 2.0 - 0.5 * env.config.robot.size / 2.0
    assert env.world.poses[0, 0] > 1.7  # it did reach the wall


def test_head_on_robots_never_pass_through_each_other() -> None:
    env = anonloc_env.parallel_env(
        n_robots=2, arena_size=(6.0, 2.0), dt=0.05, max_cycles=10**6, robot={"v_max": 3.0}
    )
    env.reset(seed=0, options={"poses": [[1.0, 1.0, 0.0], [5.0, 1.0, math.pi]]})
    size = env.config.robot.size
    closest = math.inf
    for _ in range(200):  # 10 s
        env.step(constant_actions(env, (1.0, 0.0)))
        gap = env.world.poses[1, 0] - env.world.poses[0, 0]
        closest = min(closest, gap)
    assert closest > 0.9 * size  # never swapped, overlap at most 10 % of a size


def test_noise_free_odometry_matches_true_displacement() -> None:
    env = anonloc_env.parallel_env(
        n_robots=1, arena_size=(40.0, 40.0), dt=0.05, picture_interval=5.0, max_cycles=10**6
    )
    env.reset(seed=3, options={"poses": [[20.0, 20.0, 0.3]]})
    start = env.world.poses[0].copy()
    rng = np.random.default_rng(0)
    for _ in range(99):  # stay inside one picture interval (100 steps)
        env.step({"robot_0": rng.uniform(-1, 1, 2).astype(np.float32)})
        true = env.world.poses[0]
        d = env.odometry.since_picture[0]
        world_displacement = rotate(d[:2], start[2])
        np.testing.assert_allclose(world_displacement, true[:2] - start[:2], rtol=0, atol=1e-9)
        assert abs(d[2] - (true[2] - start[2])) < 1e-9
        assert not env.world.poses[0, 0] < 1.0  # free motion: far from the walls


def test_bumper_fires_on_contact_only() -> None:
    env = anonloc_env.parallel_env(n_robots=1, arena_size=(2.0, 2.0), dt=0.05, max_cycles=1000)
    obs, _ = env.reset(seed=0, options={"poses": [[1.0, 1.0, 0.0]]})
    bumps = []
    for _ in range(60):
        obs, *_ = env.step(constant_actions(env, (1.0, 0.0)))
        bumps.append(obs["robot_0"]["bumper"][0])
    bumps_arr = np.array(bumps)
    # 0.8 m to go at 0.5 m/s, 0.025 m per step: free for the first ~30 steps, then pressed.
    assert bumps_arr[:25].sum() == 0
    assert bumps_arr[-10:].min() == 1.0


def test_physics_steps_once_per_step_whatever_the_agent_count() -> None:
    for n in (1, 5):
        env = anonloc_env.parallel_env(n_robots=n, arena_size=(8.0, 8.0), dt=0.05)
        env.reset(seed=0)
        before = env.world.poses.copy()
        env.step(constant_actions(env, (1.0, 0.0)))
        moved = np.hypot(*(env.world.poses[:, :2] - before[:, :2]).T)
        np.testing.assert_allclose(moved, 0.5 * 0.05, rtol=1e-9)


def test_direct_batch_calls_match_pymunk_batch() -> None:
    """``BodyBatch`` calls pymunk's batch C iterators and its C step directly; the public
    ``pymunk.batch`` functions and ``Space.step`` must give the very same motion, bit for
    bit."""
    worlds = []
    for fast in (True, False):
        env = anonloc_env.parallel_env(n_robots=30, arena_size=(2.0, 2.0), dt=0.05)
        env.reset(seed=3)
        world = env.world
        world.batch = BodyBatch(world.space, world._state, world.n, fast=fast)
        assert world.batch.fast is fast
        worlds.append(world)
    rng = np.random.default_rng(0)
    for _ in range(50):  # crowded: many contacts
        v, w = rng.uniform(-0.5, 0.5, 30), rng.uniform(-1.0, 1.0, 30)
        motions = [world.step(v, w) for world in worlds]
        np.testing.assert_array_equal(worlds[0].poses, worlds[1].poses)
        np.testing.assert_array_equal(motions[0].contact, motions[1].contact)
    assert motions[0].contact.any()
