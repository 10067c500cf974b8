"""The PettingZoo view of a crew (agents.pettingzoo) and RLlib PPO training on it (agents.rllib)."""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test

from agents.pettingzoo import BeliefParallelEnv, flat_size, flatten
from agents.vec import AnonLocVecEnv
from anonloc_env import make_config

CONFIG = make_config(n_robots=3, max_cycles=20)


@pytest.mark.parametrize("observation", ["dict", "flat"])
def test_passes_the_pettingzoo_parallel_api_test(observation: str) -> None:
    parallel_api_test(BeliefParallelEnv(CONFIG, observation=observation), num_cycles=30)


def test_robots_see_and_earn_what_the_sb3_slots_do() -> None:
    """Same seed and actions: every observation and reward equals the VecEnv's, across an
    episode boundary (both continue their env's generator after the first reset)."""
    vec = AnonLocVecEnv(CONFIG)
    seed = vec.seed(5)[0]  # the seed the VecEnv gives its one copy
    vec_obs: Any = vec.reset()
    env = BeliefParallelEnv(CONFIG)
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(0)
    for t in range(2 * CONFIG.max_cycles + 3):
        for key, batched in vec_obs.items():
            mine = np.stack([obs[agent][key] for agent in env.possible_agents])
            np.testing.assert_array_equal(mine, batched, err_msg=f"step {t}, key {key}")
        actions = rng.uniform(-1.0, 1.0, (CONFIG.n_robots, 2)).astype(np.float32)
        vec.step_async(actions)
        vec_obs, vec_rewards, dones, _ = vec.step_wait()
        obs, rewards, terminations, truncations, _ = env.step(
            dict(zip(env.possible_agents, actions, strict=True))
        )
        np.testing.assert_allclose(
            [rewards[a] for a in env.possible_agents], vec_rewards, rtol=1e-6, atol=1e-7
        )
        assert not any(terminations.values())
        assert all(truncations.values()) == bool(dones[0])
        if dones[0]:
            assert env.agents == []
            obs, _ = env.reset()


def test_flat_observation_is_the_dict_concatenated() -> None:
    config = make_config(n_robots=3)  # long episodes: past the second picture
    as_dict = BeliefParallelEnv(config)
    as_flat = BeliefParallelEnv(config, observation="flat")
    dict_obs, _ = as_dict.reset(seed=3)
    flat_obs, _ = as_flat.reset(seed=3)
    actions = {a: np.array([0.5, -0.3], np.float32) for a in as_dict.possible_agents}
    for _ in range(25):  # past the next picture, so the rows are not all zero
        dict_obs, *_ = as_dict.step(actions)
        flat_obs, *_ = as_flat.step(actions)
    agents = as_dict.possible_agents
    batched = {k: np.stack([dict_obs[a][k] for a in agents]) for k in dict_obs["robot_0"]}
    capacity = as_dict.crew.capacity
    assert as_flat.observation_space("robot_0").shape == (flat_size(capacity),)
    assert np.abs(batched["rows"]).sum() > 0
    expected = flatten(batched)
    for i, agent in enumerate(as_flat.possible_agents):
        np.testing.assert_array_equal(flat_obs[agent], expected[i])
        assert as_flat.observation_space(agent).contains(flat_obs[agent])
    np.testing.assert_array_equal(expected[0, : capacity * 6], batched["rows"][0].ravel())


def test_bad_arguments_are_named() -> None:
    with pytest.raises(ValueError, match="observation must be one of"):
        BeliefParallelEnv(CONFIG, observation="box")
    env = BeliefParallelEnv(CONFIG)
    with pytest.raises(RuntimeError, match="reset"):
        env.step({})
    env.reset(seed=0)
    with pytest.raises(ValueError, match="robot_2"):
        env.step({"robot_0": [0.0, 0.0], "robot_1": [0.0, 0.0]})
    with pytest.raises(ValueError, match="render mode 'human' differs"):
        env.render("human")


def test_render_takes_the_mode_rllib_passes() -> None:
    env = BeliefParallelEnv(CONFIG, render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render("rgb_array")  # what ray's ParallelPettingZooEnv.render() calls
    assert isinstance(frame, np.ndarray)
    assert frame.ndim == 3
    assert frame.shape[2] == 3
    env.close()


# -- RLlib ----------------------------------------------------------------------------------------


def test_ppo_settings_are_validated() -> None:
    from agents.rllib import PPOSettings

    with pytest.raises(ValueError, match=r"minibatch_size must be in \[1, train_batch_size=8\]"):
        PPOSettings(train_batch_size=8, minibatch_size=16)
    with pytest.raises(ValueError, match="gamma must be in"):
        PPOSettings(gamma=1.5)
    with pytest.raises(ValueError, match="hidden must be"):
        PPOSettings(hidden=())
    with pytest.raises(ValueError, match="num_env_runners must be an integer >= 0"):
        PPOSettings(num_env_runners=-1)


@pytest.fixture(scope="module")
def local_ray() -> Iterator[None]:
    pytest.importorskip("ray.rllib", reason="needs ray[rllib] (the ray extra)")
    import ray

    ray.init(num_cpus=2, include_dashboard=False)
    yield
    ray.shutdown()


def test_rllib_wrapper_renders_through_the_mode_argument(local_ray: None) -> None:
    from ray.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv

    wrapped = ParallelPettingZooEnv(BeliefParallelEnv(CONFIG, render_mode="rgb_array"))
    frame = wrapped.render()  # calls BeliefParallelEnv.render(wrapped.render_mode)
    assert isinstance(frame, np.ndarray)
    assert frame.ndim == 3
    assert sorted(map(str, wrapped.possible_agents)) == [
        f"robot_{i}" for i in range(CONFIG.n_robots)
    ]
    wrapped.close()


def test_two_rllib_iterations_train_the_shared_module(local_ray: None) -> None:
    from agents.rllib import MODULE_ID, PPOSettings, make_ppo_config, train_iterations

    settings = PPOSettings(train_batch_size=40, minibatch_size=30, num_epochs=2)
    algorithm = make_ppo_config(CONFIG, settings, seed=0).build_algo()
    try:
        module = algorithm.get_module(MODULE_ID)
        before = {k: v.detach().clone() for k, v in module.state_dict().items()}
        metrics = train_iterations(algorithm, 2, CONFIG.n_robots)
        after = algorithm.get_module(MODULE_ID).state_dict()
        assert list(algorithm.config.policies) == [MODULE_ID]
    finally:
        algorithm.stop()
    assert [m.iteration for m in metrics] == [1, 2]
    assert metrics[-1].env_steps >= 2 * settings.train_batch_size
    # Every robot's step is a step of the one shared module.
    assert metrics[-1].agent_steps == CONFIG.n_robots * metrics[-1].env_steps
    for m in metrics:
        # Episodes of 20 steps end within each 40-step batch.
        for value in (m.episode_return_mean, m.policy_loss, m.vf_loss, m.entropy, m.seconds):
            assert math.isfinite(value), m
    changed = max(float((after[k] - before[k]).abs().max()) for k in before)
    assert changed > 0.0
