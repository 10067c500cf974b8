"""agents: the vectorized adapter, the features extractors, training, saved agents as policies."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

import torch

import anonloc_env
import baselines
from agents.features import AttentionExtractor, DeepSetsExtractor, FlatExtractor
from agents.observation import OWN_FEATURES, ROW_FEATURES, policy_observation_space
from agents.train import TrainConfig, build_model, make_vec_env, resume, train
from agents.vec import AnonLocVecEnv
from baselines.runner import run_episode

SMALL = {
    "n_robots": 3,
    "arena_size": (2.0, 2.0),
    "max_cycles": 32,
    "picture_interval": 0.25,
    "camera": {"pixel_noise": 1.0, "orientation": False},
}


def small_config() -> anonloc_env.EnvConfig:
    return anonloc_env.make_config(**SMALL)


def _rollout(venv: AnonLocVecEnv, steps: int, seed: int) -> list[tuple]:
    rng = np.random.default_rng(seed)
    out = []
    obs = venv.reset()
    out.append(({k: v.copy() for k, v in obs.items()},))
    for _ in range(steps):
        actions = rng.uniform(-1, 1, (venv.num_envs, 2)).astype(np.float32)
        obs, rewards, dones, _ = venv.step(actions)
        out.append(({k: v.copy() for k, v in obs.items()}, rewards.copy(), dones.copy()))
    return out


def _same(a: list[tuple], b: list[tuple]) -> bool:
    for x, y in zip(a, b, strict=True):
        for u, v in zip(x, y, strict=True):
            if isinstance(u, dict):
                if any(not np.array_equal(u[k], v[k]) for k in u):
                    return False
            elif not np.array_equal(u, v):
                return False
    return True


def test_every_robot_is_a_slot_with_the_documented_observation() -> None:
    venv = AnonLocVecEnv(small_config(), n_envs=2)
    assert venv.num_envs == 6
    venv.seed(0)
    obs = venv.reset()
    capacity = venv.crews[0].capacity
    assert obs["rows"].shape == (6, capacity, ROW_FEATURES)
    assert obs["mask"].shape == (6, capacity)
    assert obs["own"].shape == (6, OWN_FEATURES)
    assert all(o.dtype == np.float32 for o in obs.values())
    assert venv.observation_space == policy_observation_space(capacity)
    assert venv.observation_space.contains({k: v[0] for k, v in obs.items()})
    # At the first picture every row is equally likely: belief 1/3 on each of the 3 rows.
    np.testing.assert_allclose(obs["rows"][:, :3, 4], 1.0 / 3.0, rtol=1e-6)
    np.testing.assert_array_equal(obs["mask"][:, :3], 1.0)


def test_time_limit_ends_are_truncations_with_the_terminal_observation() -> None:
    venv = AnonLocVecEnv(small_config(), n_envs=2)
    venv.seed(1)
    venv.reset()
    actions = np.zeros((venv.num_envs, 2), np.float32)
    # One decision per picture (every 5 steps): 32 steps are 6 whole intervals and 2 steps.
    for step in range(1, 8):
        obs, _, dones, infos = venv.step(actions)
        if step < 7:
            assert not dones.any()
            assert not any("terminal_observation" in info for info in infos)
    assert dones.all()
    for info in infos:
        assert info["TimeLimit.truncated"] is True
        terminal = info["terminal_observation"]
        assert set(terminal) == {"rows", "mask", "own"}
        assert terminal["own"][3] > 0.0  # cut between two pictures
        assert info["episode"]["l"] == 7
    # The returned observation is the new episode's first: its picture was just taken.
    np.testing.assert_array_equal(obs["own"][:, 3], 0.0)
    np.testing.assert_array_equal(obs["own"][:, 8:10], 0.0)  # no command sent yet


def test_seeding_goes_through_reset_and_copies_share_no_random_state() -> None:
    a = _rollout(_seeded(AnonLocVecEnv(small_config(), n_envs=2), 7), 70, seed=3)
    b = _rollout(_seeded(AnonLocVecEnv(small_config(), n_envs=2), 7), 70, seed=3)
    c = _rollout(_seeded(AnonLocVecEnv(small_config(), n_envs=2), 8), 70, seed=3)
    assert _same(a, b)  # same seed: bit-identical, across automatic resets
    assert not _same(a, c)
    venv = _seeded(AnonLocVecEnv(small_config(), n_envs=2), 7)
    venv.reset()
    first, second = venv.crews
    assert first.env.rng is not second.env.rng
    assert not np.array_equal(first.env.state(), second.env.state())
    assert not np.array_equal(first.observer.dice, second.observer.dice)


def _seeded(venv: AnonLocVecEnv, seed: int) -> AnonLocVecEnv:
    venv.seed(seed)
    return venv


def test_swarm_duty_adds_the_policy_as_a_bounded_deviation_of_the_shared_stream() -> None:
    from agents.crew import HeldCommands
    from baselines.excitations import Still, SwarmDuty
    from baselines.observations import Step

    n, v_max, omega_max = 4, 0.5, 1.0
    step = Step(np.zeros((0, 3)), False, np.zeros((n, 3)), np.zeros(n, bool), np.zeros((n, 3)), 0.0)
    own = HeldCommands()
    duty = SwarmDuty(own, budget=0.2, common_seed=9)
    alone = SwarmDuty(Still(), budget=0.2, common_seed=9)
    for excitation in (duty, alone):
        excitation.reset([np.random.default_rng(i) for i in range(n)])
    for t in range(50):
        own.set(np.full(n, v_max), np.full(n, -omega_max) * (1 if t % 2 else -1))
        v, w = duty.commands(step, 0.05)
        v0, w0 = alone.commands(step, 0.05)
        assert np.ptp(v0) == 0.0  # jitter 0: one shared command
        np.testing.assert_allclose(v - v0, 0.2 * v_max)
        np.testing.assert_allclose(np.abs(w - w0), 0.2 * omega_max)


@pytest.mark.parametrize("extractor", [DeepSetsExtractor, AttentionExtractor])
def test_set_extractors_are_permutation_invariant_and_ignore_masked_rows(extractor: type) -> None:
    torch.manual_seed(0)
    space = policy_observation_space(7)
    net = extractor(space)
    gen = torch.Generator().manual_seed(1)
    rows = torch.randn(5, 7, ROW_FEATURES, generator=gen)
    mask = torch.ones(5, 7)
    mask[:, 5:] = 0.0
    mask[4] = 0.0  # a picture with no row at all
    own = torch.randn(5, OWN_FEATURES, generator=gen)
    out = net({"rows": rows, "mask": mask, "own": own})
    assert torch.isfinite(out).all()
    perm = torch.randperm(7, generator=gen)
    shuffled = net({"rows": rows[:, perm], "mask": mask[:, perm], "own": own})
    torch.testing.assert_close(shuffled, out, atol=1e-6, rtol=0.0)
    garbage = rows.clone()
    garbage[:, 5:] = 1e3 * torch.randn(5, 2, ROW_FEATURES, generator=gen)
    garbage[4] = -7.0
    masked = net({"rows": garbage, "mask": mask, "own": own})
    torch.testing.assert_close(masked, out, atol=1e-6, rtol=0.0)


def test_the_flat_extractor_depends_on_row_order() -> None:
    torch.manual_seed(0)
    net = FlatExtractor(policy_observation_space(4))
    rows = torch.randn(1, 4, ROW_FEATURES)
    inputs = {"rows": rows, "mask": torch.ones(1, 4), "own": torch.zeros(1, OWN_FEATURES)}
    swapped = dict(inputs, rows=rows[:, [1, 0, 2, 3]])
    assert not torch.allclose(net(inputs), net(swapped))


def _config(tmp_path: Path, **changes: object) -> TrainConfig:
    fields = {
        "overrides": SMALL,
        "timesteps": 192,
        "n_envs": 2,
        "n_steps": 16,
        "batch_size": 48,
        "n_epochs": 2,
        "checkpoint_every": 96,
        "out": str(tmp_path),
        "name": "run",
    }
    fields.update(changes)
    return TrainConfig(**fields)  # type: ignore[arg-type]  # test fixture


def test_two_trainings_with_one_seed_give_the_same_weights(tmp_path: Path) -> None:
    weights = []
    for name in ("a", "b"):
        config = _config(tmp_path, name=name, extractor="attention", seed=3)
        model = build_model(config, make_vec_env(config))
        model.learn(96)
        weights.append([p.detach().clone() for p in model.policy.parameters()])
    for x, y in zip(*weights, strict=True):
        assert torch.equal(x, y)


def test_a_training_run_saves_an_agent_that_reloads_and_acts_the_same(tmp_path: Path) -> None:
    from stable_baselines3 import PPO

    result = train(_config(tmp_path))
    assert result.timesteps >= 192
    run = result.directory
    assert (run / "config.json").is_file()
    assert sorted(p.name for p in (run / "checkpoints").iterdir())
    progress = (run / "tb" / "progress.csv").read_text().splitlines()
    header = progress[0].split(",")
    losses = [line.split(",")[header.index("train/loss")] for line in progress[1:]]
    assert losses
    assert all(np.isfinite(float(x)) for x in losses if x)
    model = PPO.load(result.agent, device="cpu")
    again = PPO.load(result.agent, device="cpu")
    venv = _seeded(AnonLocVecEnv(small_config(), n_envs=1), 5)
    obs = venv.reset()
    for _ in range(5):
        first, _ = model.predict(obs, deterministic=True)
        second, _ = again.predict(obs, deterministic=True)
        np.testing.assert_array_equal(first, second)
        obs, *_ = venv.step(first)
    # Resuming continues from the newest checkpoint up to a larger total.
    assert resume(run, timesteps=288).timesteps >= 288


def test_a_saved_agent_is_a_policy(tmp_path: Path) -> None:
    result = train(_config(tmp_path))
    env = anonloc_env.parallel_env(**SMALL)
    team = baselines.make_team("agent", env, path=str(result.directory))
    outcome = run_episode(env, team, seed=11)
    assert outcome.records
    again = run_episode(env, baselines.make_team("agent", env, path=str(result.agent)), seed=11)
    assert [r.estimate for r in outcome.records] == [r.estimate for r in again.records]
    policy = baselines.make("agent", env, path=str(result.agent))
    observations, _ = env.reset(seed=0)
    action, _ = policy.predict(observations["robot_0"])
    assert action.shape == (2,)
    with pytest.raises(ValueError, match="needs path="):
        baselines.make_team("agent", env)
    other = anonloc_env.parallel_env(**{**SMALL, "n_robots": 5, "arena_size": (3.0, 3.0)})
    with pytest.raises(ValueError, match="trained on pictures of 3 rows"):
        baselines.make_team("agent", other, path=str(result.agent))


def test_a_sampling_agent_draws_from_each_robots_own_generator(tmp_path: Path) -> None:
    """deterministic=False samples with the team's per-robot generators: reproducible by seed."""
    from agents.policy import LearnedExcitation, load_model

    result = train(_config(tmp_path))
    env = anonloc_env.parallel_env(**SMALL)
    model = load_model(result.agent)

    def play(seed: int) -> list[int]:
        from baselines.localizers import BayesLocalizer
        from baselines.policies import Team

        excitation = LearnedExcitation(model, env.config, deterministic=False)
        team = Team(env.config, BayesLocalizer(env.config, 3), excitation)
        outcome = run_episode(env, team, seed=0, policy_seed=seed)
        return [r.estimate for r in outcome.records] + [round(float(env.state().sum()), 9)]

    assert play(1) == play(1)
    assert play(1) != play(2)
