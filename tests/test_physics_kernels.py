"""The compiled physics sub-step (numba) gives the same floats as the numpy one, to the bit."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from anonloc_env import make_config, physics_kernels
from anonloc_env.config import RobotConfig
from anonloc_env.env import AnonLocEnv
from anonloc_env.rewards import EnergyCost
from anonloc_env.separation import Separator

pytest.importorskip("numba")
pytestmark = pytest.mark.skipif(
    physics_kernels.mode() is None, reason="kernels off (ANONLOC_JIT=0 or an unknown numpy)"
)


def _episode(compiled: bool, n: int, side: float, shape: str, steps: int, seed: int) -> list:
    """Every step's poses, wheel travel and bumpers of a crowded episode of random actions."""
    config = make_config(n_robots=n, arena_size=(side, side), robot={"shape": shape})
    env = AnonLocEnv(config, reward_fn=EnergyCost())
    env.reset(seed=seed)
    world = env.world
    assert world.compiled is not None
    if not compiled:
        world.compiled = None
    rng = np.random.default_rng(seed)
    record = []
    for _ in range(steps):
        v = rng.uniform(-1.0, 1.0, n) * config.robot.v_max
        w = rng.uniform(-1.0, 1.0, n) * config.robot.omega_max
        travel = world.step(v, w)
        record.append((world.poses.copy(), np.array(travel.forward), np.array(travel.turned)))
        record.append((travel.contact.copy(),))
    return record


@pytest.mark.parametrize(
    ("n", "side", "shape"), [(24, 2.2, "square"), (80, 4.0, "square"), (30, 2.6, "circle")]
)
def test_a_crowded_episode_is_the_same_to_the_bit(n: int, side: float, shape: str) -> None:
    """Robots packed at 5 per m^2 with random commands (contacts, pushes, rebuilds of the
    neighbour list, projections): poses, wheel travel and bumpers equal at every step."""
    compiled = _episode(True, n, side, shape, 150, seed=n)
    plain = _episode(False, n, side, shape, 150, seed=n)
    assert any(row[0].any() for row in compiled if len(row) == 1)  # some bumpers fired
    for a, b in zip(compiled, plain, strict=True):
        for x, y in zip(a, b, strict=True):
            np.testing.assert_array_equal(x, y)


def test_a_pile_is_separated_as_numpy_separates_it() -> None:
    """60 squares dropped at random on a 1.5 m square (deep overlaps, many projections, pushes
    into pairs left out): the compiled pass leaves every robot where numpy's does."""
    robot = RobotConfig()
    rng = np.random.default_rng(7)
    n = 60
    poses = np.column_stack([rng.uniform(0, 1.5, (n, 2)), rng.uniform(-np.pi, np.pi, n)])
    heading = np.exp(1j * poses[:, 2])
    low, high = np.full((n, 1), -1e9), np.full((n, 2), 1e9)
    state = np.zeros((n + 1, 7))
    state[:n, :2] = poses[:, :2]
    numpy_side, compiled_side = Separator(robot, n), Separator(robot, n)
    xy = np.ascontiguousarray(poses[:, :2])
    numpy_side.separate(xy, heading, lambda: None)
    compiled_side.separate_compiled(state, heading, low, high, bool(physics_kernels.mode()))
    assert np.abs(xy - poses[:, :2]).max() > 0.1 * robot.size  # robots were pushed
    np.testing.assert_array_equal(state[:n, :2], xy)
    assert compiled_side.rebuilds == numpy_side.rebuilds


def test_the_fused_products_match_numpy() -> None:
    """The kernels' complex product is numpy's on this machine (fused or not, as detected)."""
    assert physics_kernels.numpy_fuses() is not None


def test_anonloc_jit_0_switches_the_kernels_off() -> None:
    code = "from anonloc_env import physics_kernels as k; print(k.mode())"
    env = {**os.environ, "ANONLOC_JIT": "0"}
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == "None"
