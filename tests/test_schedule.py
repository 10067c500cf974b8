"""Picture schedule: interval, jitter, blackouts."""

from __future__ import annotations

import numpy as np

import anonloc_env
from tests.helpers import constant_actions


def picture_times(**overrides) -> list[float]:
    env = anonloc_env.parallel_env(n_robots=1, **overrides)
    env.reset(seed=0)
    times = [env.picture.time] if env.picture is not None else []
    while env.agents:
        count = env.pictures_taken
        env.step(constant_actions(env, (0.0, 0.0)))
        if env.pictures_taken > count:
            times.append(env.picture.time)
    return times


def test_regular_interval() -> None:
    times = picture_times(dt=0.01, picture_interval=0.25, max_cycles=100)
    np.testing.assert_allclose(times, [0.0, 0.25, 0.5, 0.75, 1.0], atol=1e-12)


def test_interval_not_a_multiple_of_dt_rounds_up_to_the_next_step() -> None:
    times = picture_times(dt=0.1, picture_interval=0.25, max_cycles=10)
    np.testing.assert_allclose(times, [0.0, 0.3, 0.5, 0.8, 1.0], atol=1e-12)


def test_jitter_stays_within_bounds() -> None:
    times = np.array(
        picture_times(dt=0.01, picture_interval=1.0, max_cycles=5000, schedule={"jitter": 0.2})
    )
    offsets = times - np.round(times)
    assert np.all(np.abs(offsets) <= 0.2 + 0.01)
    assert offsets.std() > 0.05  # the jitter is really there


def test_blackout_windows_have_no_pictures() -> None:
    times = picture_times(
        dt=0.1, picture_interval=0.5, max_cycles=60, schedule={"blackouts": [(1.2, 3.1)]}
    )
    np.testing.assert_allclose(times, [0.0, 0.5, 1.0, 3.5, 4.0, 4.5, 5.0, 5.5, 6.0], atol=1e-12)


def test_blackout_at_reset_means_no_first_picture() -> None:
    env = anonloc_env.parallel_env(n_robots=2, schedule={"blackouts": [(0.0, 0.5)]})
    obs, infos = env.reset(seed=0)
    assert env.picture is None
    assert np.all(obs["robot_0"]["mask"] == 0.0)
    assert infos["robot_0"]["true_index"] == -1
    assert infos["robot_0"]["picture"] == 0
