"""Nothing a user does breaks the env: each reproducer of the "hostile user" report, and a fuzz.

Every test here is a case that once hung, overflowed, leaked ground into a wall, or failed with a
message that named nothing.
"""

from __future__ import annotations

import copy
import math
import pickle
import re
import tracemalloc
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import anonloc_env
from anonloc_env.camera import detection_capacity
from anonloc_env.overlap import robot_overlaps, wall_overlaps
from tests.helpers import constant_actions

# -- physics: the arena is closed and robots are solid ---------------------------------------------


@pytest.mark.parametrize("v_max", [5.0, 0.5])
def test_column_pushed_into_a_wall_never_breaks_through(v_max: float) -> None:
    n = 80
    width = 0.3 * n + 0.5
    env = anonloc_env.parallel_env(
        n_robots=n, arena_size=(width, 0.3), robot={"v_max": v_max}, max_cycles=10**6
    )
    env.reset(seed=0, options={"poses": [[0.25 + 0.3 * i, 0.15, 0.0] for i in range(n)]})
    for _ in range(300 if v_max > 1 else 600):
        env.step(constant_actions(env, (1.0, 0.0)))
        x = env.world.poses[:, 0]
        assert np.all(np.diff(x) > 0.0), "two robots swapped order"
        assert x.max() < width
        assert x.min() > 0.0


@pytest.mark.parametrize("shape", ["square", "circle"])
def test_single_robot_into_a_wall_barely_overlaps_it(shape: str) -> None:
    env = anonloc_env.parallel_env(n_robots=1, robot={"shape": shape})
    env.reset(seed=0, options={"poses": [[2.0, 2.0, 0.0]]})
    robot = env.config.robot
    for _ in range(200):
        env.step(constant_actions(env, (1.0, 0.0)))
        assert wall_overlaps(robot, env.config.arena_size, env.world.poses)[0] <= 0.05 * robot.size
    assert env.world.poses[0, 0] > 3.85  # it reached the wall


def test_crowd_stays_inside_the_arena() -> None:
    """A short soak: 60 robots in the 4 m arena on persistent random actions."""
    env = anonloc_env.parallel_env(
        n_robots=60, arena_size=(4.0, 4.0), reward_fn=anonloc_env.EnergyCost(), max_cycles=300
    )
    env.reset(seed=1)
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (60, 2)).astype(np.float32)
    robot = env.config.robot
    while env.agents:
        redraw = rng.random(60) < 0.05
        actions[redraw] = rng.uniform(-1, 1, (int(redraw.sum()), 2))
        env.step(dict(zip(env.agents, actions, strict=True)))
        poses = env.world.poses
        assert wall_overlaps(robot, env.config.arena_size, poses).max() <= 0.0501 * robot.size
        _, _, depth = robot_overlaps(robot, poses)
        assert depth.max(initial=0.0) <= 0.10 * robot.size


def _steer_to_corner(poses: np.ndarray) -> np.ndarray:
    """Full speed, turning towards (0, 0) as fast as allowed (benchmarks/robustness.py corner)."""
    x, y, theta = poses.T
    error = (np.arctan2(-y, -x) - theta + np.pi) % (2 * np.pi) - np.pi
    return np.column_stack([np.ones(len(x)), np.clip(3.0 * error, -1.0, 1.0)]).astype(np.float32)


@pytest.mark.parametrize("shape", ["square", "circle"])
def test_crowd_driven_into_a_corner_overlaps_at_most_a_tenth(shape: str) -> None:
    """100 robots of the default size, all driven into one corner of the 4 m arena for 15 s:
    the pile is pressed against both walls and squares turn inside it (it reached 48 % of the
    size before the position correction)."""
    n = 100
    env = anonloc_env.parallel_env(
        n_robots=n,
        arena_size=(4.0, 4.0),
        robot={"shape": shape},
        reward_fn=anonloc_env.EnergyCost(),
    )
    env.reset(seed=0)
    robot = env.config.robot
    worst = 0.0
    for _ in range(300):
        env.step(dict(zip(env.agents, _steer_to_corner(env.world.poses), strict=True)))
        _, _, depth = robot_overlaps(robot, env.world.poses)
        worst = max(worst, float(depth.max(initial=0.0)))
        assert wall_overlaps(robot, env.config.arena_size, env.world.poses).max() <= (
            0.0501 * robot.size
        )
    assert worst <= 0.10 * robot.size
    # The pile did form: most robots ended within 2.5 m of the corner, pressed together.
    assert np.mean(np.hypot(*env.world.poses[:, :2].T) < 2.5) > 0.8
    assert len(robot_overlaps(robot, env.world.poses)[0]) > n // 2


# -- configs the validator accepts must work -------------------------------------------------------


@pytest.mark.parametrize("mean", [700.0, 720.0, 745.0, 800.0, 1000.0])
def test_false_positive_capacity_is_the_poisson_quantile(mean: float) -> None:
    extra = detection_capacity(anonloc_env.make_config(camera={"false_positives": mean})) - 4
    # Normal approximation of the Poisson 1 - 1e-6 quantile (z = 4.75), within a few counts.
    expected = mean + 4.75 * math.sqrt(mean)
    assert abs(extra - expected) < 0.05 * math.sqrt(mean) + 12


def test_false_positives_800_builds_and_steps() -> None:
    env = anonloc_env.parallel_env(camera={"false_positives": 800})
    obs, _ = env.reset(seed=0)
    assert obs["robot_0"]["mask"].sum() > 600


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"robot": {"size": 1e-9}}, "robot.size must be in [0.001, 1000]"),
        ({"robot": {"v_max": 1e6}}, "sub-steps"),
        ({"robot": {"omega_max": 1e9}}, "robot.omega_max must be in (0, 1e+06]"),
        ({"robot": {"v_max": 1e308}}, "robot.v_max must be in (0, 1e+06]"),
        ({"arena_size": (1e308, 1e308)}, "arena_size[0] must be in (0, 1e+06]"),
        ({"arena_size": (1e5, 1e5), "camera": {"scale": 1e5}}, "camera.scale * the larger"),
        ({"camera": {"principal_point": (1e39, 0)}}, "camera.principal_point[0] must be in"),
        ({"camera": {"pixel_noise": 1e308}}, "camera.pixel_noise must be in [0, 1e+06]"),
    ],
)
def test_values_the_simulation_cannot_honour_are_refused(
    overrides: dict[str, Any], message: str
) -> None:
    with pytest.raises(ValueError, match=re.escape(message)):
        anonloc_env.parallel_env(**overrides)


@pytest.mark.parametrize(
    ("call", "error", "message"),
    [
        (lambda: anonloc_env.parallel_env(schedule={"blackouts": None}), TypeError, "blackouts"),
        (lambda: anonloc_env.parallel_env(schedule={"blackouts": 5}), TypeError, "blackouts"),
        (lambda: anonloc_env.parallel_env(5), TypeError, "n_robots="),
        (lambda: anonloc_env.parallel_env(detector=object()), TypeError, "detector"),
    ],
)
def test_bad_arguments_name_the_parameter(call: Any, error: type, message: str) -> None:
    with pytest.raises(error, match=message):
        call()


def test_numpy_scalars_are_numbers() -> None:
    env = anonloc_env.parallel_env(n_robots=np.int64(4), dt=np.float32(0.05))
    env.reset(seed=0)
    env.step(constant_actions(env, (0.5, 0.5)))
    assert env.config.n_robots == 4
    assert type(env.config.n_robots) is int


def test_n_robots_alone_grows_the_arena_but_a_given_size_is_kept() -> None:
    env = anonloc_env.parallel_env(n_robots=1000)
    assert env.config.arena_size == pytest.approx((4.0 * math.sqrt(250), 4.0 * math.sqrt(250)))
    env.reset(seed=0)
    assert anonloc_env.make_config(n_robots=2).arena_size == (4.0, 4.0)
    with pytest.raises(ValueError, match="holds at most 169"):
        anonloc_env.parallel_env(n_robots=1000, arena_size=(4.0, 4.0))


def test_construction_memory_is_linear_in_n() -> None:
    held = []
    for n in (250, 1000):
        tracemalloc.start()
        env = anonloc_env.parallel_env(n_robots=n)
        held.append(tracemalloc.get_traced_memory()[0])
        tracemalloc.stop()
        del env
    assert held[1] < 6 * held[0]  # 4 x N; quadratic would be 16 x


# -- start poses: the shapes, not the centres -----------------------------------------------------


def test_rotated_squares_that_overlap_are_refused() -> None:
    env = anonloc_env.parallel_env(n_robots=2)
    quarter = math.pi / 4
    with pytest.raises(ValueError, match=r"\[0\] and \[1\] overlap"):
        env.reset(options={"poses": [[1.0, 1.0, quarter], [1.25, 1.0, quarter]]})
    env.reset(options={"poses": [[1.0, 1.0, 0.0], [1.25, 1.0, 0.0]]})  # apart when aligned


def test_corner_in_the_wall_is_refused() -> None:
    env = anonloc_env.parallel_env(n_robots=1)
    with pytest.raises(ValueError, match="outside the arena"):
        env.reset(options={"poses": [[0.1, 1.0, math.pi / 4]]})  # a corner 0.041 m in the wall


@pytest.mark.parametrize(
    ("options", "error"),
    [
        ("poses", TypeError),
        ({"poses": "abc"}, TypeError),
        ({"poses": [[1.0, 1.0, 0.0], [2.0]]}, TypeError),
        ({"poses": [[1.0, 1.0, 0.0]]}, ValueError),
    ],
)
def test_bad_reset_options_leave_the_episode_alone(options: Any, error: type) -> None:
    env = anonloc_env.parallel_env(n_robots=2)
    env.reset(seed=0)
    env.step(constant_actions(env, (1.0, 0.0)))
    state, draw = env.state(), copy.deepcopy(env.rng.bit_generator.state)
    with pytest.raises(error, match="options"):
        env.reset(seed=1, options=options)
    np.testing.assert_array_equal(env.state(), state)
    assert env.rng.bit_generator.state == draw
    env.step(constant_actions(env, (1.0, 0.0)))  # still running


@pytest.mark.parametrize("seed", [-1, 1.5, "1", True])
def test_bad_seed_is_refused(seed: Any) -> None:
    with pytest.raises(ValueError, match="seed must be None or an integer >= 0"):
        anonloc_env.parallel_env().reset(seed=seed)


def test_aec_nan_action_is_refused_at_its_turn_and_the_env_goes_on() -> None:
    env = anonloc_env.env(n_robots=3)
    env.reset(seed=0)
    env.step(np.zeros(2, np.float32))
    with pytest.raises(ValueError, match="robot_1"):
        env.step(np.array([np.nan, 0.0], np.float32))
    assert env.agent_selection == "robot_1"
    env.step(np.zeros(2, np.float32))
    env.step(np.zeros(2, np.float32))
    assert env.agent_selection == "robot_0"  # a whole cycle went through


@pytest.mark.parametrize("make_copy", [pickle.dumps, copy.deepcopy])
def test_copy_mid_episode_asks_for_reset(make_copy: Any) -> None:
    env = anonloc_env.parallel_env()
    env.reset(seed=0)
    env.step(constant_actions(env, (1.0, 0.0)))
    copied = make_copy(env)
    clone = pickle.loads(copied) if isinstance(copied, bytes) else copied
    with pytest.raises(RuntimeError, match=r"reset\(\) first"):
        clone.step(constant_actions(env, (1.0, 0.0)))
    clone.reset(seed=0)
    clone.step(constant_actions(clone, (1.0, 0.0)))


# -- fuzz: a clean error, or an env that steps with finite observations ---------------------------

_numbers = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-(10**6), 10**6),
    st.sampled_from([0, 1, -1, 0.5, 1e-9, 1e6, 1e308, 800, 1000.5]),
    st.none(),
    st.text(max_size=3),
)


def _large_int(value: Any) -> bool:
    return isinstance(value, int) and value > 200


_fields = {
    # Small N: the fuzz is about values; large N is measured in benchmarks/robustness.py.
    "n_robots": st.one_of(st.integers(-2, 6), _numbers.filter(lambda x: not _large_int(x))),
    "dt": _numbers,
    "arena_size": st.one_of(st.tuples(_numbers, _numbers), _numbers),
    "robot": st.fixed_dictionaries(
        {},
        optional={
            "size": _numbers,
            "v_max": _numbers,
            "omega_max": _numbers,
            "shape": st.sampled_from(["square", "circle", "hex"]),
        },
    ),
    "camera": st.fixed_dictionaries(
        {},
        optional={
            "false_positives": _numbers,
            "pixel_noise": _numbers,
            "scale": _numbers,
            "tilt_deg": _numbers,
            "principal_point": st.one_of(st.tuples(_numbers, _numbers), _numbers),
            "p_miss": _numbers,
        },
    ),
    "schedule": st.fixed_dictionaries(
        {}, optional={"blackouts": st.one_of(_numbers, st.lists(st.tuples(_numbers, _numbers)))}
    ),
}


@settings(
    max_examples=300,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
)
@given(
    overrides=st.fixed_dictionaries({}, optional=_fields),
    actions=st.lists(st.tuples(_numbers, _numbers), min_size=1, max_size=3),
)
def test_fuzzed_configs_and_actions_fail_cleanly_or_run(
    overrides: dict[str, Any], actions: list[tuple[Any, Any]]
) -> None:
    try:
        env = anonloc_env.parallel_env(max_cycles=50, **overrides)
    except (ValueError, TypeError):
        return
    obs, _ = env.reset(seed=0)
    for action in actions:
        try:
            obs, *_ = env.step({agent: np.array(action) for agent in env.agents})
        except (ValueError, TypeError):
            continue
        for agent_obs in obs.values():
            for value in agent_obs.values():
                assert np.all(np.isfinite(value))
        assert np.all(np.isfinite(env.state()))
