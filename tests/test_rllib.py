"""The PettingZoo view of a crew (agents.pettingzoo), the RLlib module of the candidate scorer
(agents.rllib_module) and RLlib PPO training on it (agents.rllib)."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from gymnasium import spaces
from pettingzoo.test import parallel_api_test

import anonloc_env
import baselines
from agents.candidate_features import CANDIDATE_FEATURES, CANDIDATES, CONTEXT_FEATURES
from agents.pettingzoo import BeliefParallelEnv, flat_size, flatten, unflatten
from agents.vec import AnonLocVecEnv
from anonloc_env import make_config

CONFIG = make_config(n_robots=3, max_cycles=20)
#: Three decisions per episode (a decision is one picture interval of 20 control steps).
LONG = make_config(n_robots=3, max_cycles=60)


@pytest.mark.parametrize("observation", ["dict", "flat"])
def test_passes_the_pettingzoo_parallel_api_test(observation: str) -> None:
    parallel_api_test(BeliefParallelEnv(CONFIG, observation=observation), num_cycles=30)


def test_every_agent_chooses_one_of_c_candidates() -> None:
    """Per-agent spaces: the layout's dict or its flat form, and Discrete(C); one object per
    agent, the same on every call."""
    as_dict = BeliefParallelEnv(CONFIG)
    as_flat = BeliefParallelEnv(CONFIG, observation="flat")
    assert flat_size() == CANDIDATES * CANDIDATE_FEATURES + CONTEXT_FEATURES == 66
    for agent in as_dict.possible_agents:
        space = as_dict.observation_space(agent)
        assert isinstance(space, spaces.Dict)
        assert space["candidates"].shape == (CANDIDATES, CANDIDATE_FEATURES)
        assert space["context"].shape == (CONTEXT_FEATURES,)
        assert as_flat.observation_space(agent).shape == (flat_size(),)
        assert as_dict.action_space(agent) == spaces.Discrete(CANDIDATES)
        assert as_dict.action_space(agent) is as_dict.action_space(agent)
    first, second = as_dict.possible_agents[:2]
    assert as_dict.observation_space(first) is not as_dict.observation_space(second)


def test_robots_see_and_earn_what_the_sb3_slots_do() -> None:
    """Same seed and candidate choices: every agent's view is its row of the VecEnv's batched
    observation, and every reward the VecEnv's, across two episode boundaries (both continue
    their env's generator after the first reset)."""
    vec = AnonLocVecEnv(LONG)
    seed = vec.seed(5)[0]  # the seed the VecEnv gives its one copy
    vec_obs: Any = vec.reset()
    env = BeliefParallelEnv(LONG)
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(0)
    scored = 0
    for t in range(8):
        for key, batched in vec_obs.items():
            mine = np.stack([obs[agent][key] for agent in env.possible_agents])
            np.testing.assert_array_equal(mine, batched, err_msg=f"step {t}, key {key}")
        scored += int(vec_obs["context"][:, -1].sum())
        actions = rng.integers(0, CANDIDATES, LONG.n_robots)
        vec.step_async(actions)
        vec_obs, vec_rewards, dones, _ = vec.step_wait()
        obs, rewards, terminations, truncations, _ = env.step(
            dict(zip(env.possible_agents, actions, strict=True))
        )
        np.testing.assert_allclose(
            [rewards[a] for a in env.possible_agents], vec_rewards, rtol=1e-6, atol=1e-7
        )
        assert not any(terminations.values())
        assert all(truncations.values()) == bool(dones[0]) == (t % 3 == 2)
        if dones[0]:
            assert env.agents == []
            obs, _ = env.reset()
    assert scored > 0  # some observations held scored candidates, not only zeros


def test_flat_observation_is_the_dict_concatenated_and_unflatten_undoes_it() -> None:
    import torch

    as_dict = BeliefParallelEnv(LONG)
    as_flat = BeliefParallelEnv(LONG, observation="flat")
    dict_obs, _ = as_dict.reset(seed=3)
    flat_obs, _ = as_flat.reset(seed=3)
    actions = dict.fromkeys(as_dict.possible_agents, 2)
    dict_obs, *_ = as_dict.step(actions)  # past the first picture: candidates scored
    flat_obs, *_ = as_flat.step(actions)
    agents = as_dict.possible_agents
    batched = {k: np.stack([dict_obs[a][k] for a in agents]) for k in ("candidates", "context")}
    assert np.abs(batched["candidates"]).sum() > 0
    expected = flatten(batched)
    assert expected.shape == (LONG.n_robots, flat_size())
    for i, agent in enumerate(agents):
        np.testing.assert_array_equal(flat_obs[agent], expected[i])
        assert as_flat.observation_space(agent).contains(flat_obs[agent])
    # Candidates row-major first, then the context.
    np.testing.assert_array_equal(expected[1, :CANDIDATE_FEATURES], batched["candidates"][1, 0])
    np.testing.assert_array_equal(expected[1, -CONTEXT_FEATURES:], batched["context"][1])
    tensor = torch.from_numpy(expected)
    # unflatten only slices and reshapes: it takes tensors as it takes arrays.
    for back in (unflatten(expected), unflatten(tensor)):  # type: ignore[arg-type]
        for key in batched:
            np.testing.assert_array_equal(np.asarray(back[key]), batched[key])


def test_bad_arguments_are_named() -> None:
    with pytest.raises(ValueError, match="observation must be one of"):
        BeliefParallelEnv(CONFIG, observation="box")
    env = BeliefParallelEnv(CONFIG)
    with pytest.raises(RuntimeError, match="reset"):
        env.step({})
    env.reset(seed=0)
    with pytest.raises(ValueError, match="robot_2"):
        env.step({"robot_0": 0, "robot_1": 0})
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


# -- The RLlib module -----------------------------------------------------------------------------


def _module(hidden: int = 16, seed: int = 0) -> Any:
    pytest.importorskip("ray.rllib", reason="needs ray[rllib] (the ray extra)")
    import torch

    from agents.rllib_module import CandidateRLModule

    torch.manual_seed(seed)
    return CandidateRLModule(
        observation_space=spaces.Box(-np.inf, np.inf, (flat_size(),), np.float32),
        action_space=spaces.Discrete(CANDIDATES),
        model_config={"hidden": hidden},
    )


def _scored_observations() -> dict[str, np.ndarray]:
    """Three robots' observations after their first picture (candidates scored)."""
    vec = AnonLocVecEnv(LONG)
    vec.seed(1)
    vec.reset()
    vec.step_async(np.array([0, 3, 7]))
    observation = vec.step_wait()[0]
    assert isinstance(observation, dict)
    assert observation["context"][:, -1].tolist() == [1.0, 1.0, 1.0]
    return observation


def _sb3_logits(model: Any, observation: dict[str, np.ndarray]) -> np.ndarray:
    import torch

    with torch.no_grad():
        tensors, _ = model.policy.obs_to_tensor(observation)
        return model.policy.logits(tensors).numpy()


def test_the_module_scores_as_the_sb3_policy_with_the_same_weights(tmp_path: Path) -> None:
    """Same weights, same observation: the RLlib module (flat) and CandidatePolicy (dict) give
    the same logits and values; export_agent carries the weights into a zip load_model reads."""
    import torch
    from stable_baselines3 import PPO

    from agents.features import CandidatePolicy
    from agents.policy import load_model
    from agents.rllib import export_agent

    module = _module()
    observation = _scored_observations()
    flat = torch.from_numpy(flatten(observation))
    with torch.no_grad():
        logits = module.forward_inference({"obs": flat})["action_dist_inputs"].numpy()
        values = module.compute_values({"obs": flat}).numpy()
    model = PPO(CandidatePolicy, AnonLocVecEnv(LONG), policy_kwargs={"hidden": 16}, device="cpu")
    fresh = _sb3_logits(model, observation)
    assert np.abs(fresh - logits).max() > 1e-3  # different weights score differently
    assert isinstance(model.policy, CandidatePolicy)
    model.policy.scorer.load_state_dict(module.scorer.state_dict())
    np.testing.assert_allclose(_sb3_logits(model, observation), logits, rtol=0, atol=1e-6)
    with torch.no_grad():
        tensors, _ = model.policy.obs_to_tensor(observation)
        sb3_values = model.policy.predict_values(tensors).squeeze(-1).numpy()
    np.testing.assert_allclose(sb3_values, values, rtol=0, atol=1e-6)
    exported = load_model(export_agent(module, tmp_path / "agent.zip"))
    np.testing.assert_allclose(_sb3_logits(exported, observation), logits, rtol=0, atol=1e-6)
    assert exported.policy.hidden == 16


def test_the_module_is_equivariant_to_the_candidates_order() -> None:
    """Shuffled candidates: the logits shuffle with them and the value stays, to 1e-6."""
    import torch

    module = _module()
    observation = _scored_observations()
    order = np.random.default_rng(4).permutation(CANDIDATES)
    shuffled = {
        "candidates": observation["candidates"][:, order],
        "context": observation["context"],
    }
    with torch.no_grad():
        out = module.forward_train({"obs": torch.from_numpy(flatten(observation))})
        out_shuffled = module.forward_train({"obs": torch.from_numpy(flatten(shuffled))})
    np.testing.assert_allclose(
        out_shuffled["action_dist_inputs"].numpy(),
        out["action_dist_inputs"].numpy()[:, order],
        rtol=0,
        atol=1e-6,
    )
    np.testing.assert_allclose(
        out_shuffled["embeddings"].numpy(), out["embeddings"].numpy(), rtol=0, atol=1e-6
    )


def test_the_module_refuses_other_spaces_by_name() -> None:
    pytest.importorskip("ray.rllib", reason="needs ray[rllib] (the ray extra)")
    from agents.rllib_module import CandidateRLModule

    flat = spaces.Box(-np.inf, np.inf, (flat_size(),), np.float32)
    with pytest.raises(ValueError, match="action_space must be Discrete"):
        CandidateRLModule(observation_space=flat, action_space=spaces.Box(-1, 1, (2,)))
    with pytest.raises(ValueError, match=r"observation_space must be a flat Box of shape \(38,\)"):
        CandidateRLModule(observation_space=flat, action_space=spaces.Discrete(4))
    with pytest.raises(ValueError, match=r"model_config\['hidden'\] must be an integer >= 1"):
        CandidateRLModule(
            observation_space=flat,
            action_space=spaces.Discrete(CANDIDATES),
            model_config={"hidden": 0},
        )


# -- RLlib ----------------------------------------------------------------------------------------


def test_ppo_settings_are_validated() -> None:
    from agents.rllib import PPOSettings

    with pytest.raises(ValueError, match=r"minibatch_size must be in \[1, 8\], got 16"):
        PPOSettings(train_batch_size=8, minibatch_size=16)
    with pytest.raises(ValueError, match="gamma must be in"):
        PPOSettings(gamma=1.5)
    with pytest.raises(ValueError, match=r"hidden must be in \[1, 4096\]"):
        PPOSettings(hidden=0)
    with pytest.raises(ValueError, match=r"num_env_runners must be in \[0, 1024\]"):
        PPOSettings(num_env_runners=-1)
    with pytest.raises(ValueError, match=r"learning_rate must be in \(0, 1\]"):
        PPOSettings(learning_rate=0.0)


def test_export_refuses_what_it_cannot_convert(tmp_path: Path) -> None:
    pytest.importorskip("ray.rllib", reason="needs ray[rllib] (the ray extra)")
    from agents.rllib import export_agent

    with pytest.raises(ValueError, match=r"path must name a \.zip file"):
        export_agent(_module(), tmp_path / "agent")
    with pytest.raises(FileNotFoundError, match="no RLlib module 'shared' saved under"):
        export_agent(tmp_path, tmp_path / "agent.zip")
    with pytest.raises(TypeError, match="source must be an RLlib Algorithm"):
        export_agent(object(), tmp_path / "agent.zip")
    assert not (tmp_path / "agent.zip").exists()


@pytest.fixture(scope="module")
def local_ray() -> Iterator[None]:
    pytest.importorskip("ray.rllib", reason="needs ray[rllib] (the ray extra)")
    import ray

    ray.init(num_cpus=1, include_dashboard=False)
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


def test_the_rllib_module_trains_two_iterations_and_acts_through_baselines_make(
    local_ray: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Two PPO iterations change the shared CandidateRLModule; its checkpoint, saved to a
    relative folder, converts with one call into an agent that ``baselines.make`` loads and that
    drives the robot with its trained scores."""
    import torch

    from agents.policy import load_model
    from agents.rllib import (
        MODULE_ID,
        PPOSettings,
        export_agent,
        make_ppo_config,
        train_iterations,
        trained_module,
    )
    from agents.rllib_module import CandidateRLModule

    settings = PPOSettings(train_batch_size=12, minibatch_size=12, n_epochs=2, hidden=16)
    algorithm = make_ppo_config(LONG, settings, seed=0).build_algo()
    monkeypatch.chdir(tmp_path)
    try:
        module = algorithm.get_module(MODULE_ID)
        assert isinstance(module, CandidateRLModule)
        before = {k: v.detach().clone() for k, v in module.scorer.state_dict().items()}
        metrics = train_iterations(algorithm, 2, LONG.n_robots)
        assert list(algorithm.config.policies) == [MODULE_ID]
        algorithm.save_to_path(str(Path("checkpoint").resolve()))
    finally:
        algorithm.stop()
    assert [m.iteration for m in metrics] == [1, 2]
    assert metrics[-1].env_steps >= 2 * settings.train_batch_size
    # Every robot's decision is a step of the one shared module.
    assert metrics[-1].agent_steps == LONG.n_robots * metrics[-1].env_steps
    for m in metrics:
        # Episodes of 3 decisions end within each 12-decision batch.
        for value in (m.episode_return_mean, m.policy_loss, m.vf_loss, m.entropy, m.seconds):
            assert math.isfinite(value), m
    trained = trained_module("checkpoint")  # a relative path
    after = trained.scorer.state_dict()
    assert max(float((after[k] - before[k]).abs().max()) for k in before) > 0.0

    path = export_agent("checkpoint", "agent.zip")
    observation = _scored_observations()
    with torch.no_grad():
        flat = torch.from_numpy(flatten(observation))
        logits = trained.forward_inference({"obs": flat})["action_dist_inputs"].numpy()
    np.testing.assert_allclose(
        _sb3_logits(load_model(path), observation), logits, rtol=0, atol=1e-6
    )

    env = anonloc_env.parallel_env(n_robots=3, max_cycles=60)
    policy = baselines.make("agent", env, path=str(path))
    observations, _ = env.reset(seed=0)
    policy.reset(seed=0)
    moves = []
    for _ in range(45):  # past two pictures
        action, _ = policy.predict(observations["robot_0"])
        assert env.action_space("robot_0").contains(action)
        moves.append(action)
        actions = {a: np.zeros(2, np.float32) for a in env.agents}
        observations, *_ = env.step({**actions, "robot_0": action})
    assert np.abs(np.array(moves[20:])).max() > 0.0  # it drives a candidate after a picture


def test_train_rllib_saves_to_a_relative_folder(
    local_ray: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``checkpoint_dir="runs/rllib"`` (relative, as the docs write it) is saved under the
    working directory and converts with export_agent (Ray alone fails on a relative path)."""
    from agents.policy import load_model
    from agents.rllib import (
        PPOSettings,
        export_agent,
        make_ppo_config,
        train_rllib,
        trained_module,
    )
    from agents.rllib_module import CandidateRLModule

    monkeypatch.chdir(tmp_path)
    settings = PPOSettings(train_batch_size=6, minibatch_size=6, n_epochs=1, hidden=8)
    metrics = train_rllib(make_ppo_config(LONG, settings, seed=1), 1, "runs/rllib")
    assert [m.iteration for m in metrics] == [1]
    assert (tmp_path / "runs" / "rllib" / "learner_group" / "learner" / "rl_module").is_dir()
    assert isinstance(trained_module("runs/rllib"), CandidateRLModule)
    agent = export_agent("runs/rllib", "runs/rllib/agent.zip")
    assert (tmp_path / agent).is_file()
    assert load_model(tmp_path / agent).policy.hidden == 8
