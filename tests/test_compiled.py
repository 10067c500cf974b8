"""The compiled kernels (numba) give the same floats as the numpy code they replace, to the bit:
the physics sub-step, odometry, the neighbour search, and a whole belief-env episode."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable

import numpy as np
import pytest

from anonloc_env import compiled, make_config
from anonloc_env.config import RobotConfig
from anonloc_env.env import AnonLocEnv
from anonloc_env.neighbours import pairs_within, pairs_within_each
from anonloc_env.odometry import IntervalStatistics, Odometry
from anonloc_env.rewards import EnergyCost
from anonloc_env.separation import Separator, pairs_within_self
from anonloc_env.world import WheelTravel

pytest.importorskip("numba")
pytestmark = pytest.mark.skipif(
    compiled.mode() is None, reason="kernels off (ANONLOC_JIT=0 or an unknown numpy)"
)


def _episode(use_kernels: bool, n: int, side: float, shape: str, steps: int, seed: int) -> list:
    """Every step's poses, wheel travel and bumpers of a crowded episode of random actions."""
    config = make_config(n_robots=n, arena_size=(side, side), robot={"shape": shape})
    env = AnonLocEnv(config, reward_fn=EnergyCost())
    env.reset(seed=seed)
    world = env.world
    assert world.compiled is not None
    if not use_kernels:
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
def test_a_crowded_episode_is_the_same_to_the_bit(
    n: int, side: float, shape: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Robots packed at 5 per m^2 with random commands (contacts, pushes, rebuilds of the
    neighbour list, projections): poses, wheel travel and bumpers equal at every step. Squares
    take the turns of the one-call sub-step (``compiled.substep``): done and a stale list, and
    in the larger crowd projections for the caller to go on with."""
    answers: list[int] = []
    substep = compiled.substep

    def counted(*args: object) -> int:
        answers.append(substep(*args))
        return answers[-1]

    monkeypatch.setattr(compiled, "substep", counted)
    fast = _episode(True, n, side, shape, 150, seed=n)
    if shape == "square":
        assert {0, -1} <= set(answers)
        assert max(answers) > 0 or n < 80
    else:
        assert not answers  # circles: the numpy correction
    plain = _episode(False, n, side, shape, 150, seed=n)
    assert any(row[0].any() for row in fast if len(row) == 1)  # some bumpers fired
    for a, b in zip(fast, plain, strict=True):
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
    compiled_side.separate_compiled(state, heading, low, high, bool(compiled.mode()))
    assert np.abs(xy - poses[:, :2]).max() > 0.1 * robot.size  # robots were pushed
    np.testing.assert_array_equal(state[:n, :2], xy)
    assert compiled_side.rebuilds == numpy_side.rebuilds


def test_the_fused_products_match_numpy() -> None:
    """The kernels' complex product is numpy's on this machine (fused or not, as detected)."""
    assert compiled.numpy_fuses() is not None


def test_anonloc_jit_0_switches_the_kernels_off() -> None:
    code = "from anonloc_env import compiled as k; print(k.mode())"
    env = {**os.environ, "ANONLOC_JIT": "0"}
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == "None"


@pytest.fixture
def numpy_only(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every kernel off, as without numba (worlds built afterwards run numpy too)."""
    monkeypatch.setattr(compiled, "_MODE", [None])


@pytest.mark.parametrize("seed", range(6))
def test_the_neighbour_search_finds_the_same_pairs(
    seed: int, request: pytest.FixtureRequest
) -> None:
    """Random point sets (on a grid for seeds 0 and 1: distances of exactly the radius, points on
    cell borders, duplicates) and radii: the same pairs, order and distances as the grid search."""
    rng = np.random.default_rng(seed)
    n, m = int(rng.integers(1, 60)), int(rng.integers(1, 60))
    if seed < 2:
        a, b = rng.integers(0, 6, (n, 2)).astype(float), rng.integers(0, 6, (m, 2)).astype(float)
        radius = 1.0
    else:
        a, b = rng.uniform(0, 10, (n, 2)), rng.uniform(0, 10, (m, 2))
        radius = float(rng.uniform(0.1, 3.0))
    _same_pairs(pairs_within, a, b, radius, request)


def _same_pairs(
    search: Callable[..., tuple[np.ndarray, ...]],
    a: np.ndarray,
    b: np.ndarray,
    radius: float | np.ndarray,
    request: pytest.FixtureRequest,
) -> None:
    """``search(a, b, radius)`` by its kernel, then by numpy: the same pairs (at least one), in
    the same order, with the same distances and dtypes."""
    assert compiled.mode() is not None
    fast = search(a, b, radius)
    request.getfixturevalue("numpy_only")
    plain = search(a, b, radius)
    assert len(plain[0]) > 0
    for x, y in zip(fast, plain, strict=True):
        assert x.dtype == y.dtype
        np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize("seed", range(8))
def test_the_search_by_each_points_radius_finds_the_same_pairs(
    seed: int, request: pytest.FixtureRequest
) -> None:
    """``pairs_within_each`` by its kernel and by numpy's grouped grid search: the same pairs,
    order and distances. Radii over three levels (seeds 0 to 2 on a grid: distances of exactly a
    radius, points on cell borders, duplicates; seed 3 with radii of 0 and below, which find
    nothing), up to 59 x 59 points: within the kernel's reach."""
    rng = np.random.default_rng(seed)
    n, m = int(rng.integers(1, 60)), int(rng.integers(1, 60))
    if seed < 3:
        a, b = rng.integers(0, 8, (n, 2)).astype(float), rng.integers(0, 8, (m, 2)).astype(float)
        radius = rng.choice([0.5, 1.0, 2.0, 3.0], n)
    else:
        a, b = rng.uniform(0, 10, (n, 2)), rng.uniform(0, 10, (m, 2))
        radius = rng.uniform(0.2, 3.0, n) * rng.choice([1.0, 2.0, 4.0], n)
    if seed == 3:
        radius[: n // 2] = rng.choice([0.0, -1.0], n // 2)
    _same_pairs(pairs_within_each, a, b, radius, request)


@pytest.mark.parametrize("seed", range(6))
def test_the_neighbour_list_is_the_grid_searchs(seed: int, request: pytest.FixtureRequest) -> None:
    """The position correction's neighbour list (``pairs_within_self``) by its kernel and by
    numpy: the same pairs in the same order, on random crowds and on grids (distances of exactly
    the radius and a hair within or beyond it, duplicates, points on cell borders)."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 400))
    if seed < 3:
        xy = rng.integers(0, 12, (n, 2)).astype(float) * 0.125
        xy[: n // 3] += rng.choice([-1e-17, 0.0, 1e-17], (n // 3, 2))
        radius = 0.125 * float(rng.integers(1, 3))
    else:
        xy = rng.uniform(0, float(rng.uniform(1.0, 20.0)), (n, 2))
        radius = float(rng.uniform(0.05, 1.5))
    z = xy.view(np.complex128)[:, 0]
    fast = pairs_within_self(z, radius)
    request.getfixturevalue("numpy_only")
    plain = pairs_within_self(z, radius)
    assert len(plain) > 0
    assert fast.dtype == plain.dtype
    np.testing.assert_array_equal(fast, plain)


def _interval(rng: np.random.Generator) -> tuple[np.ndarray, ...]:
    """A robot log's statistics over 30 random steps (pushes on a third of them), and the
    interval they close."""
    stats = IntervalStatistics(25, 0.3, 0.05)
    before = np.zeros((25, 3))
    for _ in range(30):
        now = before + rng.normal(0.0, 0.01, (25, 3))
        bumper = rng.random(25) < 0.3
        stats.add_motion(before, now, bumper, rng.uniform(-0.3, 0.3, 25))
        before = now
    interval = stats.interval(before[:, :2], before[:, 2])
    assert interval.push is not None
    assert interval.push_sum is not None
    return (interval.path, interval.sum_ds2, interval.sum_dth2, interval.push, interval.push_sum)


def test_the_robots_interval_statistics_are_numpys(request: pytest.FixtureRequest) -> None:
    """A robot log's path, squared increments and contact bounds (``add_motion``): the kernel's
    floats are numpy's."""
    fast = _interval(np.random.default_rng(3))
    request.getfixturevalue("numpy_only")
    plain = _interval(np.random.default_rng(3))
    for x, y in zip(fast, plain, strict=True):
        np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize("statistics", [True, False])
@pytest.mark.parametrize("noise", [0.0, 0.05])
def test_odometry_integrates_the_same(
    noise: float, statistics: bool, request: pytest.FixtureRequest
) -> None:
    """Dead reckoning of 20 steps of wheel travel (3 sub-steps, with and without noise, with
    and without the interval's statistics, which the kernel adds up in the same call)."""
    rng = np.random.default_rng(3)
    steps = [
        WheelTravel(rng.uniform(0, 0.01, (3, 9)), rng.normal(0, 0.05, (3, 9)), rng.random(9) < 0.3)
        for _ in range(20)
    ]
    results = []
    for use_kernels in (True, False):
        if not use_kernels:
            request.getfixturevalue("numpy_only")
        odometry = Odometry(9, noise, v_max=0.5, dt=0.1, statistics=statistics)
        draws = np.random.default_rng(4)
        for motion in steps:
            odometry.integrate(motion, draws, np.full(9, 0.3))
        interval = odometry.mark_picture()
        results.append(
            (interval.d, interval.dphi, interval.path, interval.sum_ds2, interval.sum_dth2)
            + ((interval.push, interval.push_sum) if statistics else ())
        )
    if not statistics:  # the straight distance, nothing summed
        np.testing.assert_array_equal(results[0][2], np.hypot(*results[0][0].T))
        assert not results[0][3].any()
    else:
        assert results[0][3].all()  # every robot moved
        assert results[0][4].all()  # and turned
    for x, y in zip(*results, strict=True):
        np.testing.assert_array_equal(x, y)


def _belief_episode() -> list[np.ndarray]:
    """The belief env (N = 12, 8 % misses and 2 false positives, 2 copies, random candidate
    choices): every decision's observations, rewards and beliefs."""
    from agents.vec import AnonLocVecEnv

    config = make_config(n_robots=12, camera={"p_miss": 0.08, "false_positives": 2.0})
    vec = AnonLocVecEnv(config, n_envs=2)
    vec.seed(5)
    first = vec.reset()
    out = [first[key] for key in sorted(first)]
    rng = np.random.default_rng(5)
    for _ in range(12):
        vec.step_async(rng.integers(0, 8, vec.num_envs))
        obs, rewards, _, _ = vec.step_wait()
        out.extend([*(obs[key] for key in sorted(obs)), rewards])
        out.extend(crew.localizer.belief for crew in vec.crews)
    return out


def test_a_belief_env_episode_is_the_same_to_the_bit(request: pytest.FixtureRequest) -> None:
    """What ``anonloc train`` learns on, kernels on and off: every observation, reward and
    belief equal."""
    pytest.importorskip("stable_baselines3")
    fast = _belief_episode()
    request.getfixturevalue("numpy_only")
    plain = _belief_episode()
    for x, y in zip(fast, plain, strict=True):
        np.testing.assert_array_equal(x, y)


def test_the_leave_out_sums_are_numpys(request: pytest.FixtureRequest) -> None:
    """``identify.others._leave_out_sums`` (the others' matchings, every row and column left
    out in turn) on 120 random components of 1 to 5 copies, up to 8 rows and 8 columns (256
    column sets: numpy's pairwise sum splits them), weights over six orders of magnitude with
    missing edges."""
    from anonloc_env.identify.others import _leave_out_sums

    rng = np.random.default_rng(11)
    cases = []
    for _ in range(120):
        n_c, n_a, n_b = (int(x) for x in rng.integers(1, [6, 9, 9]))
        n_a = min(n_a, max(1, 24 // n_b))
        edges = rng.uniform(0.0, 3.0, (n_c, n_a, n_b)) * (rng.random((n_c, n_a, n_b)) < 0.6)
        w = edges * 10 ** rng.uniform(-3.0, 3.0)
        cases.append((w, float(rng.uniform(0.01, 1.0)), float(rng.uniform(1e-4, 2.0))))
    assert any(w.shape[2] == 8 for w, _, _ in cases)
    fast = [_leave_out_sums(*case) for case in cases]
    request.getfixturevalue("numpy_only")
    for case, got in zip(cases, fast, strict=True):
        np.testing.assert_array_equal(got, _leave_out_sums(*case))


def _actions_both_ways(seed: int) -> list[object]:
    """``to_actions``, ``to_actions_and_speed`` (with the speed sent) and ``check_action_array``
    of commands and actions with NaN, infinities, signed zeros, subnormals and values past the
    limits: every array's bytes, every error."""
    from anonloc_env.actions import (
        check_action_array,
        stack_actions,
        to_actions,
        to_actions_and_speed,
    )

    robot = RobotConfig()
    special = [np.nan, np.inf, -np.inf, 0.0, -0.0, 5e-324, 1e308, -1e308, 1.0, -1.0]
    special += [robot.v_max, -robot.omega_max, np.nextafter(1.0, 2.0)]
    rng = np.random.default_rng(seed)
    out: list[object] = []
    for case in range(300):
        n = int(rng.integers(0, 12))
        v, w = rng.normal(scale=float(rng.choice([0.05, 1.0, 1e3])), size=(2, n))
        actions = rng.normal(scale=float(rng.choice([0.3, 3.0])), size=(n, 2))
        if n and case % 2:
            v[rng.integers(0, n)], w[rng.integers(0, n)] = rng.choice(special, 2)
            actions[rng.integers(0, n), rng.integers(0, 2)] = rng.choice(special)
        out.append(to_actions(v, w, robot).tobytes())
        sent, speed = to_actions_and_speed(v, w, robot)
        out.extend([sent.tobytes(), speed.tobytes(), speed.dtype.str])
        for given in (actions, actions.astype(np.float32), np.asfortranarray(actions)):
            try:
                out.append(check_action_array(given, n).tobytes())
            except ValueError as error:
                out.append(str(error))
            agents = [f"robot_{i}" for i in range(n)]  # the env's dicts: rows joined as bytes
            try:
                out.append(stack_actions(dict(zip(agents, given, strict=True)), agents).tobytes())
            except ValueError as error:
                out.append(str(error))
    return out


def test_energy_rewards_are_numpys(request: pytest.FixtureRequest) -> None:
    """``EnergyCost``'s rewards in one compiled call: numpy's bytes, for commands with signed
    zeros, subnormals, huge values and the column views the env passes."""
    config = make_config(n_robots=3, reward={"turn_cost": 0.037})
    rng = np.random.default_rng(5)
    special = np.array([0.0, -0.0, 5e-324, -5e-324, 1e300, -1e300, 0.3, -2.0])
    cases = []
    for case in range(200):
        commands = rng.normal(scale=float(rng.choice([0.01, 1.0, 50.0])), size=(int(case % 13), 2))
        if len(commands):
            commands.flat[rng.integers(0, commands.size, 3)] = rng.choice(special, 3)
        cases.append(commands)
    fast = [EnergyCost.of(config, c[:, 0], c[:, 1]).tobytes() for c in cases]
    request.getfixturevalue("numpy_only")
    for commands, got in zip(cases, fast, strict=True):
        assert got == EnergyCost.of(config, commands[:, 0], commands[:, 1]).tobytes()


def test_actions_are_converted_and_checked_as_numpy_does(request: pytest.FixtureRequest) -> None:
    """The commands' actions (``to_actions``, and with the speed they send) and the env's check
    of an action array, one compiled call each: numpy's bytes and errors."""
    with np.errstate(over="ignore", invalid="ignore"):
        fast = _actions_both_ways(7)
        request.getfixturevalue("numpy_only")
        plain = _actions_both_ways(7)
    assert fast == plain
    assert any(isinstance(x, str) for x in plain)  # some were refused
