"""PettingZoo's own checkers, on both API forms, plus the registry and space identity."""

from __future__ import annotations

import sys
import warnings

import numpy as np
import pettingzoo
import pytest
from pettingzoo.test import (
    api_test,
    max_cycles_test,
    parallel_api_test,
    render_test,
    seed_test,
    state_test,
)

import anonloc_env


def small(**kwargs):
    return anonloc_env.parallel_env(n_robots=3, max_cycles=60, **kwargs)


def test_parallel_api() -> None:
    with warnings.catch_warnings():
        # parallel_api_test passes options={"options": 1}; we warn about unknown options.
        warnings.filterwarnings("ignore", message="reset options")
        parallel_api_test(small(), num_cycles=200)


def test_aec_api() -> None:
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="reset options")
        api_test(anonloc_env.env(n_robots=3, max_cycles=60), num_cycles=200)


def test_aec_seed() -> None:
    seed_test(lambda: anonloc_env.env(n_robots=3, max_cycles=100), num_cycles=100)


def test_render_modes() -> None:
    pytest.importorskip("pygame")
    render_test(lambda render_mode=None: anonloc_env.env(n_robots=3, render_mode=render_mode))


def test_max_cycles() -> None:
    max_cycles_test(sys.modules["anonloc_env"])


def test_state() -> None:
    state_test(anonloc_env.env(n_robots=3, max_cycles=60), small(), num_cycles=50)


@pytest.mark.parametrize("kind", ["parallel", "aec"])
def test_registered(kind: str) -> None:
    env = pettingzoo.make(kind, anonloc_env.ENV_ID, n_robots=2)
    assert env.possible_agents == ["robot_0", "robot_1"]


def test_spaces_built_once() -> None:
    env = small()
    first = env.observation_space("robot_0")
    assert env.observation_space("robot_0") is first
    assert env.action_space("robot_1") is env.action_space("robot_1")
    assert env.action_space("robot_0") is not env.action_space("robot_1")
    obs, _ = env.reset(seed=1)
    for agent in env.agents:
        assert env.observation_space(agent).contains(obs[agent])


def test_sb3_multiinput_compatible_observation() -> None:
    env = small(observation={"history": 3})
    obs, _ = env.reset(seed=0)
    space = env.observation_space("robot_0")
    for key, box in space.spaces.items():
        assert box.dtype == np.float32, key
        assert obs["robot_0"][key].shape == box.shape, key
    assert set(obs["robot_0"]) == set(space.spaces)
