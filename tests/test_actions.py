"""Actions: validation at step, clipping, conversion to physical commands and back."""

from __future__ import annotations

import re

import numpy as np
import pytest

import anonloc_env
from anonloc_env import RobotConfig, to_actions, to_commands
from anonloc_env.actions import stack_actions


@pytest.fixture
def env() -> anonloc_env.AnonLocEnv:
    env = anonloc_env.parallel_env(n_robots=2)
    env.reset(seed=0)
    return env


@pytest.mark.parametrize(
    ("actions", "message"),
    [
        ({"robot_0": [0.1, 0.2]}, "no entry for live agent 'robot_1'"),
        ({"robot_0": [0, 0], "robot_1": [0, 0], "robot_9": [0, 0]}, "not live: ['robot_9']"),
        ({"robot_0": [0, 0], "robot_1": [0, 0, 0]}, "action of 'robot_1' must be 2 numbers"),
        ({"robot_0": 0.5, "robot_1": [0, 0]}, "action of 'robot_0' must be 2 numbers"),
        ({"robot_0": [0, 0], "robot_1": "go"}, "action of 'robot_1' must be 2 numbers"),
        ({"robot_0": ["1", "2"], "robot_1": [0, 0]}, "action of 'robot_0' must be 2 numbers"),
        ({"robot_0": [None, 1], "robot_1": [0, 0]}, "action of 'robot_0' must be 2 numbers"),
        ({"robot_0": [np.nan, 0], "robot_1": [0, 0]}, "action of 'robot_0' is not finite"),
        ({"robot_0": [0, 0], "robot_1": [0, np.inf]}, "action of 'robot_1' is not finite"),
    ],
)
def test_bad_actions_raise_naming_the_agent(env, actions, message) -> None:
    with pytest.raises(ValueError, match=re.escape(message)):
        env.step(actions)


def test_bad_action_corrupts_nothing(env) -> None:
    before = env.world.poses.copy()
    steps = env.steps
    with pytest.raises(ValueError, match="not finite"):
        env.step({"robot_0": [np.nan, 0], "robot_1": [0, 0]})
    assert env.steps == steps
    np.testing.assert_array_equal(env.world.poses, before)


def test_actions_must_be_a_dict(env) -> None:
    with pytest.raises(TypeError, match="actions must be a dict"):
        env.step([[0, 0], [0, 0]])


def test_out_of_range_actions_are_clipped(env) -> None:
    env.reset(seed=0, options={"poses": [[1.0, 1.0, 0.0], [3.0, 3.0, 0.0]]})
    env.step({"robot_0": [5.0, 0.0], "robot_1": [-7.0, 0.0]})
    v_max, dt = env.config.robot.v_max, env.config.dt
    np.testing.assert_allclose(env.world.poses[:, 0], [1.0 + v_max * dt, 3.0 - v_max * dt])


def test_commands_and_actions_convert_both_ways() -> None:
    robot = RobotConfig(v_max=0.4, omega_max=2.0)
    actions = to_actions([0.2, -0.4, 1.0], [1.0, 0.0, -9.0], robot)
    assert actions.dtype == np.float32
    np.testing.assert_allclose(actions, [[0.5, 0.5], [-1.0, 0.0], [1.0, -1.0]])
    v, w = to_commands(actions, robot)
    np.testing.assert_allclose(v, [0.2, -0.4, 0.4], rtol=1e-6)
    np.testing.assert_allclose(w, [1.0, 0.0, -2.0], rtol=1e-6)


def test_step_after_the_end_is_an_error() -> None:
    env = anonloc_env.parallel_env(n_robots=1, max_cycles=2)
    env.reset(seed=0)
    for _ in range(2):
        env.step({"robot_0": [0.0, 0.0]})
    assert env.agents == []
    with pytest.raises(RuntimeError, match="finished episode"):
        env.step({"robot_0": [0.0, 0.0]})


@pytest.mark.parametrize(
    "rows",
    [
        list(np.linspace(-1.5, 1.5, 10, dtype=np.float32).reshape(5, 2)),  # row views, float32
        list(np.linspace(-1.5, 1.5, 10).reshape(5, 2)),  # float64
        list(np.linspace(-1, 1, 20, dtype=np.float32).reshape(5, 4)[:, ::2]),  # not contiguous
        list(np.linspace(-1, 1, 10).reshape(5, 2).astype(">f8")),  # big-endian
        [np.array([0.1, -0.2], np.float32)] * 2 + [np.array([0.3, 0.4])] * 3,  # mixed dtypes
        [np.array([1, -2], np.int32)] * 5,  # integers: 4 bytes an item, read as numbers
        [[0.1, 0.2], (0.3, -0.4), np.array([0.5, 0.6], np.float32), [1, 2], [0.0, -0.0]],
    ],
)
def test_stacked_actions_are_the_rows_values(rows) -> None:
    """However the rows are held (views of one array, several dtypes, strides, byte orders,
    lists), the env takes the values of the rows, as ``np.array`` reads them, clipped."""
    env = anonloc_env.parallel_env(n_robots=5)
    env.reset(seed=0)
    stacked = stack_actions(dict(zip(env.agents, rows, strict=True)), env.agents)
    expected = np.clip(np.array([np.asarray(r, dtype=np.float64) for r in rows]), -1.0, 1.0)
    assert stacked.dtype == np.float64
    assert stacked.flags.writeable
    np.testing.assert_array_equal(stacked, expected)
    assert (np.signbit(stacked) == np.signbit(expected)).all()


def test_rows_of_other_shapes_are_refused_whatever_their_bytes() -> None:
    """Rows whose bytes add up to two numbers a row are still refused when a row is not 2."""
    env = anonloc_env.parallel_env(n_robots=2)
    env.reset(seed=0)
    rows = {"robot_0": np.zeros(1, np.float32), "robot_1": np.zeros(3, np.float32)}
    with pytest.raises(ValueError, match="must be 2 numbers"):
        env.step(rows)
    square = {"robot_0": np.zeros((2, 2), np.float32), "robot_1": np.zeros((2, 2), np.float32)}
    with pytest.raises(ValueError, match="must be 2 numbers"):
        env.step(square)
