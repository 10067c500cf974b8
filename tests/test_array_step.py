"""``AnonLocEnv.step_arrays``: the learning path's step, with no per-agent dict, is ``step``."""

from __future__ import annotations

import numpy as np
import pytest

import anonloc_env
from anonloc_env.robot_view import read_step

NOISY = {
    "n_robots": 7,
    "picture_interval": 0.3,
    "max_cycles": 120,
    "camera": {"pixel_noise": 1.0, "p_miss": 0.1, "false_positives": 1.5},
    "robot": {"odometry_noise": 0.02},
    "schedule": {"jitter": 0.1},
}


def test_step_arrays_is_step_to_the_bit() -> None:
    """Same seed and actions: what the robots observed (as ``read_step`` reads the dicts), the
    rewards, the truncation and the infos' ``true_index`` are equal to the bit, to the end."""
    by_dict = anonloc_env.AnonLocEnv(anonloc_env.make_config(**NOISY))
    by_array = anonloc_env.AnonLocEnv(anonloc_env.make_config(**NOISY))
    by_dict.reset(seed=11)
    by_array.reset(seed=11)
    actions = np.random.default_rng(0).uniform(-1.2, 1.2, (120, 7, 2)).astype(np.float32)
    pictures = 0
    for a in actions:
        obs, rewards, _, truncations, infos = by_dict.step(
            dict(zip(by_dict.agents, a, strict=True))
        )
        result = by_array.step_arrays(a)
        seen = read_step([obs[agent] for agent in by_dict.possible_agents])
        for field in ("rows", "odometry", "bumper", "between"):
            np.testing.assert_array_equal(getattr(result.seen, field), getattr(seen, field))
        assert (result.seen.new_picture, result.seen.interval) == (seen.new_picture, seen.interval)
        np.testing.assert_array_equal(result.rewards, list(rewards.values()))
        assert result.truncated == all(truncations.values())
        assert result.true_index.tolist() == [i["true_index"] for i in infos.values()]
        pictures += seen.new_picture
    assert pictures > 10
    assert result.truncated
    assert by_array.agents == []
    np.testing.assert_array_equal(by_array.state(), by_dict.state())


def test_infos_after_array_steps_are_those_of_dict_steps() -> None:
    """The per-agent infos, which ``step_arrays`` does not build, are those ``step`` hands out
    when a caller switches from arrays to dicts between pictures (the poses and picture count
    of the newest picture, not of the step that asks)."""
    by_dict = anonloc_env.AnonLocEnv(anonloc_env.make_config(**NOISY))
    by_array = anonloc_env.AnonLocEnv(anonloc_env.make_config(**NOISY))
    by_dict.reset(seed=5)
    by_array.reset(seed=5)
    actions = np.random.default_rng(1).uniform(-1, 1, (60, 7, 2)).astype(np.float32)
    for k, a in enumerate(actions):
        *_, infos = by_dict.step(dict(zip(by_dict.agents, a, strict=True)))
        if k % 7 < 5:  # arrays for a while, then dicts
            by_array.step_arrays(a)
            continue
        *_, got = by_array.step(dict(zip(by_array.agents, a, strict=True)))
        assert list(got) == list(infos)
        for agent, info in infos.items():
            assert got[agent].keys() == info.keys()
            np.testing.assert_array_equal(got[agent]["pose"], info["pose"])
            assert got[agent]["picture"] == info["picture"]
            assert got[agent]["true_index"] == info["true_index"]
            np.testing.assert_array_equal(got[agent]["camera_pose"], info["camera_pose"])


def test_step_arrays_checks_its_actions_before_any_change() -> None:
    env = anonloc_env.AnonLocEnv(anonloc_env.make_config(n_robots=3))
    env.reset(seed=0)
    before = env.state()
    with pytest.raises(ValueError, match=r"\(3, 2\) numeric array"):
        env.step_arrays(np.zeros((2, 2)))
    with pytest.raises(ValueError, match=r"\(3, 2\) numeric array"):
        env.step_arrays(np.array([["a", "b"]] * 3))
    with pytest.raises(ValueError, match="robot 1 is not finite"):
        env.step_arrays(np.array([[0.0, 0.0], [np.nan, 0.0], [0.0, 0.0]]))
    np.testing.assert_array_equal(env.state(), before)
    assert env.steps == 0
    actions = np.full((3, 2), 3.0)
    env.step_arrays(actions)
    assert (actions == 3.0).all()  # clipped in a copy, not in the caller's array


def test_energy_rewards_may_be_left_to_the_caller() -> None:
    """``rewards=False`` skips an ``EnergyCost`` (zeros, the same episode) and refuses a reward
    that keeps state between steps."""
    config = anonloc_env.make_config(**NOISY)
    runs = []
    for rewards in (True, False):
        env = anonloc_env.AnonLocEnv(config, reward_fn=anonloc_env.EnergyCost())
        env.reset(seed=4)
        rng = np.random.default_rng(4)
        steps = [env.step_arrays(rng.uniform(-1, 1, (7, 2)), rewards=rewards) for _ in range(40)]
        runs.append((steps, env.state()))
    (kept, kept_state), (skipped, skipped_state) = runs
    np.testing.assert_array_equal(kept_state, skipped_state)
    for a, b in zip(kept, skipped, strict=True):
        np.testing.assert_array_equal(a.seen.odometry, b.seen.odometry)
        assert (b.rewards == 0.0).all()
    assert all((a.rewards < 0.0).any() for a in kept)
    env = anonloc_env.AnonLocEnv(config)  # InformationGain
    env.reset(seed=4)
    with pytest.raises(ValueError, match=r"only EnergyCost.*InformationGain"):
        env.step_arrays(np.zeros((7, 2)), rewards=False)
    assert env.steps == 0


def test_the_crews_energy_rewards_are_the_envs() -> None:
    """The crew adds up an ``EnergyCost`` reward itself, once per decision: the same bits as
    the env's step by step (a subclass of ``EnergyCost`` keeps the env's path)."""
    pytest.importorskip("stable_baselines3")
    from agents.vec import AnonLocVecEnv

    class EnvEnergyCost(anonloc_env.EnergyCost):
        """Computed by the env: the crew only takes over an ``EnergyCost`` itself."""

    config = anonloc_env.make_config(**{**NOISY, "reward": {"energy_weight": 0.7}})
    rewards = []
    for reward_fn in (anonloc_env.EnergyCost, EnvEnergyCost):
        vec = AnonLocVecEnv(
            config,
            n_envs=2,
            make_env=lambda cfg, r=reward_fn: anonloc_env.AnonLocEnv(cfg, reward_fn=r()),
        )
        assert vec.crews[0]._energy_reward == (reward_fn is anonloc_env.EnergyCost)
        vec.seed(2)
        vec.reset()
        rng = np.random.default_rng(2)
        got = []
        for _ in range(25):
            vec.step_async(rng.integers(0, 8, vec.num_envs))
            got.append(vec.step_wait()[1])
        rewards.append(np.array(got))
    np.testing.assert_array_equal(rewards[0], rewards[1])
    assert (rewards[0] != 0.0).any()
