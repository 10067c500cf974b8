"""PettingZoo's checkers that ``test_pettingzoo_api.py`` does not run: the parallel seed test on
both envs, and the AEC checkers (API, seed, state, render) on the belief env.

Which of ``pettingzoo.test`` runs where, and why the rest do not: ``docs/design.md``, "Where
PettingZoo's checkers decided".
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from gymnasium.utils.env_checker import data_equivalence
from pettingzoo.test import api_test, parallel_seed_test, render_test, seed_test, state_test
from pettingzoo.utils.conversions import parallel_to_aec

import anonloc_env
from agents.pettingzoo import BeliefParallelEnv
from anonloc_env import make_config

ENVS: dict[str, Callable[[], Any]] = {
    "env": lambda: anonloc_env.parallel_env(n_robots=3, max_cycles=60),
    "clutter": lambda: anonloc_env.parallel_env(
        n_robots=5, max_cycles=200, camera={"p_miss": 0.2, "false_positives": 1.0}
    ),
    "belief": lambda: belief(),
}


def belief(render_mode: str | None = None) -> BeliefParallelEnv:
    """A small belief env: N = 3 robots, 6 decisions of one picture interval (20 steps)."""
    return BeliefParallelEnv(make_config(n_robots=3, max_cycles=120), render_mode=render_mode)


class Leaky(BeliefParallelEnv):
    """A belief env whose observations draw from a generator that ``reset(seed)`` never seeds."""

    unseeded = np.random.default_rng()

    def step(self, actions: dict[str, Any]) -> Any:
        observations, *rest = super().step(actions)
        for observation in observations.values():
            observation["context"][0] = self.unseeded.random()
        return (observations, *rest)


@pytest.mark.parametrize("name", list(ENVS))
def test_parallel_seed_test(name: str) -> None:
    parallel_seed_test(ENVS[name], num_cycles=50)


def test_parallel_seed_test_fails_an_env_that_draws_outside_the_seed() -> None:
    """The checker is not vacuous on this env: a leak in the observations fails it."""
    with pytest.raises(AssertionError, match="Incorrect observations"):
        parallel_seed_test(lambda: Leaky(make_config(n_robots=2, max_cycles=40)), num_cycles=5)


@pytest.mark.parametrize("name", ["belief", "clutter"])
def test_whole_episode_is_bit_identical(name: str) -> None:
    """``parallel_seed_test`` stops after its first step (it tests ``any(terminations)`` on the
    dict's keys); this runs its check to the episode's end: same seed, same seeded action
    stream, the same observations, rewards, ends and infos at every step."""
    first, second = ENVS[name](), ENVS[name]()
    for env in (first, second):
        env.reset(seed=42)
        for i, agent in enumerate(env.agents):
            env.action_space(agent).seed(42 + i)
    steps = 0
    while first.agents:
        actions = {agent: first.action_space(agent).sample() for agent in first.agents}
        again = {agent: second.action_space(agent).sample() for agent in second.agents}
        assert data_equivalence(actions, again)
        assert data_equivalence(first.step(actions), second.step(again)), f"step {steps}"
        steps += 1
    assert not second.agents
    assert steps == (6 if name == "belief" else first.max_cycles)


def test_belief_aec_api() -> None:
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="reset options")
        api_test(parallel_to_aec(belief()), num_cycles=20)


def test_belief_aec_seed() -> None:
    seed_test(lambda: parallel_to_aec(belief()), num_cycles=20)


def test_belief_state() -> None:
    state_test(parallel_to_aec(belief()), belief(), num_cycles=20)


def test_belief_render_modes() -> None:
    pytest.importorskip("pygame")
    render_test(lambda render_mode=None: parallel_to_aec(belief(render_mode)))
