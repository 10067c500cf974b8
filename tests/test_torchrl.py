"""TorchRL (and so BenchMARL) users: TorchRL's ``PettingZooWrapper`` runs the environment and the
belief env, and steps them exactly as PettingZoo does. Skipped where torchrl is not installed."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import anonloc_env
from agents.candidate_features import CANDIDATE_FEATURES, CANDIDATES, CONTEXT_FEATURES
from agents.pettingzoo import BeliefParallelEnv
from anonloc_env import make_config

pytest.importorskip("torchrl", reason="needs torchrl (pip install torchrl)")

STEPS = 4


def _replayed(make: Any, actions: np.ndarray, seed: int) -> tuple[list[Any], np.ndarray]:
    """The observations and rewards of a fresh PettingZoo env reset with ``seed`` and stepped
    with ``actions`` ``(T, N, ...)`` (robot i's action in row i)."""
    env = make()
    observation, _ = env.reset(seed=seed)
    observations, rewards = [], []
    for step in actions:
        observation, reward, *_ = env.step(dict(zip(env.possible_agents, step, strict=True)))
        observations.append(observation)
        rewards.append([reward[a] for a in env.possible_agents])
    return observations, np.asarray(rewards, np.float32)


@pytest.mark.parametrize("which", ["env", "belief"])
def test_torchrl_pettingzoo_wrapper_steps_as_pettingzoo(which: str) -> None:
    """A 4-step TorchRL rollout (random actions from its specs) of N = 3 robots, grouped as one
    ``robot`` group, gives the observations and rewards that PettingZoo itself gives for the
    same seed and actions."""
    import torch
    from torchrl.envs.libs.pettingzoo import PettingZooWrapper

    def make() -> Any:
        if which == "env":
            return anonloc_env.parallel_env(n_robots=3, max_cycles=20)
        # Five decisions per episode (one decision is one picture interval of 20 steps).
        return BeliefParallelEnv(make_config(n_robots=3, max_cycles=100))

    torch.manual_seed(0)
    env = PettingZooWrapper(env=make(), seed=7)
    assert env.group_map == {"robot": ["robot_0", "robot_1", "robot_2"]}
    # TorchRL's reset passes its keyword arguments to the PettingZoo env's reset.
    start = env.reset(seed=11)
    rollout = env.rollout(STEPS, auto_reset=False, tensordict=start)
    assert rollout.batch_size == torch.Size([STEPS])  # no episode ended early
    assert not rollout["next", "done"].any()
    actions = rollout["robot", "action"].numpy()
    if which == "belief":
        assert actions.shape == (STEPS, 3)
        assert actions.dtype == np.int64
        assert ((actions >= 0) & (actions < CANDIDATES)).all()
    else:
        assert actions.shape == (STEPS, 3, 2)
    observations, rewards = _replayed(make, actions, seed=11)
    np.testing.assert_array_equal(rollout["next", "robot", "reward"].numpy()[..., 0], rewards)
    seen = rollout["next", "robot", "observation"]
    keys = ["candidates", "context"] if which == "belief" else ["detections", "odometry"]
    for t, observation in enumerate(observations):
        for i, agent in enumerate(observation):
            for key in keys:
                np.testing.assert_array_equal(seen[key][t, i].numpy(), observation[agent][key])
    if which == "belief":
        assert seen["candidates"].shape == (STEPS, 3, CANDIDATES, CANDIDATE_FEATURES)
        assert seen["context"].shape == (STEPS, 3, CONTEXT_FEATURES)
        assert seen["context"][..., -1].eq(1.0).all()  # every decision after a picture is scored
