"""agents: the candidate observation, the vectorized env, the scorer, saved agents as policies."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

import torch

import anonloc_env
import baselines
from agents.candidate_features import (
    CANDIDATE_FEATURES,
    CANDIDATES,
    CONTEXT_COLUMN,
    CONTEXT_FEATURES,
)
from agents.candidates import CandidateChooser
from agents.features import CandidatePolicy, CandidateScorer
from agents.policy import LearnedExcitation, draw, load_model
from agents.spec import AgentSpec
from agents.vec import AnonLocVecEnv
from baselines.active import GreedyIdentification
from baselines.excitations import SwarmDuty
from baselines.registry import make_excitation
from baselines.runner import run_episode

SMALL = {
    "n_robots": 3,
    "arena_size": (2.0, 2.0),
    "max_cycles": 32,
    "picture_interval": 0.25,
    "camera": {"pixel_noise": 1.0, "orientation": False},
}


def small_config(**changes: object) -> anonloc_env.EnvConfig:
    return anonloc_env.make_config(**{**SMALL, **changes})


def _rollout(venv: AnonLocVecEnv, steps: int, seed: int) -> list[tuple]:
    rng = np.random.default_rng(seed)
    out = []
    obs = venv.reset()
    out.append(({k: v.copy() for k, v in obs.items()},))
    for _ in range(steps):
        actions = rng.integers(0, CANDIDATES, venv.num_envs)
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


def _seeded(venv: AnonLocVecEnv, seed: int) -> AnonLocVecEnv:
    venv.seed(seed)
    return venv


def untrained_agent(tmp_path: Path, seed: int = 0) -> Path:
    """An untrained layout-2 agent, saved as ``anonloc train`` saves one."""
    from stable_baselines3 import PPO

    model = PPO(CandidatePolicy, AnonLocVecEnv(small_config()), n_steps=8, batch_size=8, seed=seed)
    path = tmp_path / "agent.zip"
    model.save(path)
    return path


def test_every_robot_is_a_slot_with_the_documented_observation() -> None:
    venv = AnonLocVecEnv(small_config(), n_envs=2)
    assert venv.num_envs == 6
    venv.seed(0)
    obs = venv.reset()
    assert obs["candidates"].shape == (6, CANDIDATES, CANDIDATE_FEATURES)
    assert obs["context"].shape == (6, CONTEXT_FEATURES)
    assert all(o.dtype == np.float32 for o in obs.values())
    assert venv.observation_space == AgentSpec().observation_space()
    assert venv.action_space == AgentSpec().action_space()
    assert venv.observation_space.contains({k: v[0] for k, v in obs.items()})
    # At the first picture every robot is equally likely to be each of the 3 rows.
    context = obs["context"]
    col = CONTEXT_COLUMN
    np.testing.assert_allclose(context[:, col["entropy_now"]], np.log(3.0), rtol=1e-6)  # nats
    np.testing.assert_allclose(context[:, col["largest_belief"]], 1.0 / 3.0, rtol=1e-6)
    np.testing.assert_array_equal(context[:, col["scored"]], 1.0)
    cand = obs["candidates"]
    assert (np.abs(cand[..., :2]) <= 1.0).all()  # commands within the robot's limits
    # The best candidate's gap to the best is 0; information = entropy now - expected entropy.
    np.testing.assert_array_equal(cand[..., 4].min(axis=1), 0.0)
    np.testing.assert_allclose(cand[..., 3], context[:, :1] - cand[..., 2], atol=1e-6)


class _Reshuffled:
    """The built-in camera, with the rows of every picture shuffled once more by a generator of
    its own (the robots' identities in the rows change; nothing a robot can see does)."""

    def __init__(self, config: anonloc_env.EnvConfig, seed: int) -> None:
        from anonloc_env.camera import Camera

        self.camera = Camera(config)
        self.capacity = self.camera.capacity
        self.rng = np.random.default_rng(seed)

    def take(self, poses: np.ndarray, rng: np.random.Generator, time: float, index: int) -> Any:
        from anonloc_env.camera import Picture

        picture = self.camera.take(poses, rng, time, index)
        order = self.rng.permutation(picture.n_rows)
        where = np.argsort(order)
        true = np.where(picture.true_index >= 0, where[picture.true_index], -1)
        return Picture(picture.detections[order], true, time, index, picture.has_orientation)


def test_shuffled_rows_give_the_same_observation_to_1e_6() -> None:
    """The observation is a function of the picture as a set: the same episode with the rows
    of every picture in another order gives the same candidates' features (to 1e-6, float
    summation order) and so the same choices."""
    config = small_config(n_robots=6, arena_size=(2.5, 2.5))
    seen = []
    for seed in (0, 1):
        env = anonloc_env.parallel_env(
            **{**SMALL, "n_robots": 6, "arena_size": (2.5, 2.5)}, detector=_Reshuffled(config, seed)
        )
        chooser = _Teacher()
        team = baselines.make_team("bayes", env, excitation=chooser)
        observations, _ = env.reset(seed=7)
        team.reset(np.random.SeedSequence(2).spawn(6))
        frames = []
        for _ in range(20):
            actions = team.act([observations[a] for a in env.possible_agents])
            if chooser.cset is not None and not any(f is chooser.observation for f in frames):
                frames.append(chooser.observation)
            observations, *_ = env.step(dict(zip(env.possible_agents, actions, strict=True)))
        seen.append(frames)
    assert len(seen[0]) == len(seen[1]) >= 4
    for a, b in zip(*seen, strict=True):
        for key in a:
            np.testing.assert_allclose(a[key], b[key], atol=1e-6, rtol=0.0)


def test_time_limit_ends_are_truncations_with_the_terminal_observation() -> None:
    venv = AnonLocVecEnv(small_config(), n_envs=2)
    venv.seed(1)
    venv.reset()
    actions = np.zeros(venv.num_envs, np.int64)
    # One decision per picture (every 5 steps): 32 steps are 6 whole intervals and 2 steps.
    for step in range(1, 8):
        _, _, dones, infos = venv.step(actions)
        if step < 7:
            assert not dones.any()
            assert not any("terminal_observation" in info for info in infos)
    assert dones.all()
    for info in infos:
        assert info["TimeLimit.truncated"] is True
        assert set(info["terminal_observation"]) == {"candidates", "context"}
        assert info["episode"]["l"] == 7
        assert 0 <= info["teacher"] < CANDIDATES


def test_actions_are_checked_at_step() -> None:
    venv = _seeded(AnonLocVecEnv(small_config()), 0)
    venv.reset()
    with pytest.raises(ValueError, match=r"in \[0, 8\); slot 1 got 8"):
        venv.step(np.array([0, 8, 0]))
    with pytest.raises(ValueError, match="3 integers"):
        venv.step(np.array([0.0, 1.0, 2.0]))
    with pytest.raises(ValueError, match="3 integers"):
        venv.step(np.array([0, 1]))


def test_seeding_goes_through_reset_and_copies_share_no_random_state() -> None:
    a = _rollout(_seeded(AnonLocVecEnv(small_config(), n_envs=2), 7), 30, seed=3)
    b = _rollout(_seeded(AnonLocVecEnv(small_config(), n_envs=2), 7), 30, seed=3)
    c = _rollout(_seeded(AnonLocVecEnv(small_config(), n_envs=2), 8), 30, seed=3)
    assert _same(a, b)  # same seed: bit-identical, across automatic resets
    assert not _same(a, c)
    venv = _seeded(AnonLocVecEnv(small_config(), n_envs=2), 7)
    obs = venv.reset()
    first, second = venv.crews
    assert first.env.rng is not second.env.rng
    assert not np.array_equal(obs["candidates"][:3], obs["candidates"][3:])


def test_copies_may_hold_different_scenarios() -> None:
    from agents.conditions import training_scenarios

    scenarios = training_scenarios(3, seed=2)
    venv = _seeded(AnonLocVecEnv(scenarios[0].config, scenarios=scenarios), 0)
    assert venv.num_envs == sum(s.config.n_robots for s in scenarios)
    obs = venv.reset()
    assert obs["context"].shape == (venv.num_envs, CONTEXT_FEATURES)
    _, _, _, infos = venv.step(np.zeros(venv.num_envs, np.int64))
    assert len(infos) == venv.num_envs
    assert venv.get_attr("config", [venv.num_envs - 1])[0] == scenarios[-1].config


class _Teacher(CandidateChooser):
    """Drives greedy's choice among its candidates (what imitation learns)."""

    def on_scored(self) -> None:
        if self.cset is not None:
            self.decide(self.teacher())


def test_the_teacher_is_greedys_choice() -> None:
    """The imitation label is the candidate greedy would drive: same candidates, same rule."""
    config = small_config(n_robots=5, arena_size=(2.5, 2.5))
    env = anonloc_env.AnonLocEnv(config)
    chooser, greedy = _Teacher(), GreedyIdentification()
    teams = [baselines.make_team("bayes", env, excitation=e) for e in (chooser, greedy)]
    runs = []
    for team in teams:
        runs.append([])
        observations, _ = env.reset(seed=3)
        team.reset(np.random.SeedSequence(5).spawn(5))
        for _ in range(12):
            actions = team.act([observations[a] for a in env.possible_agents])
            runs[-1].append(actions.copy())
            observations, *_ = env.step(dict(zip(env.possible_agents, actions, strict=True)))
    np.testing.assert_array_equal(np.array(runs[0]), np.array(runs[1]))


class _CoinFlip(CandidateChooser):
    """The agent with zero logits: a fair draw among its candidates (``agents.policy.draw``)."""

    def on_scored(self) -> None:
        if self.cset is not None:
            self.decide(draw(np.zeros((self.n, self.candidates)), self.rngs))


@pytest.mark.parametrize("swarm", [False, True])
def test_uniform_is_the_agent_with_zero_logits(swarm: bool) -> None:
    """``uniform`` (no torch, in ``baselines``) gives bit for bit the episode of the agent's
    chooser driven by zero logits: same candidates, same coin, same back-off."""
    config = small_config(n_robots=6, arena_size=(2.5, 2.5))
    env = anonloc_env.AnonLocEnv(config, reward_fn=anonloc_env.EnergyCost())
    rows = []
    for own in (_CoinFlip(), make_excitation("uniform")):
        excitation = SwarmDuty(own, 0.2, common_seed=4) if swarm else own
        team = baselines.make_team("bayes", env, excitation=excitation)
        rows.append(run_episode(env, team, 4, max_pictures=10).rows())
    assert rows[0] == rows[1]


def test_swarm_duty_tells_the_chooser_it_deviates_from_the_first_picture() -> None:
    config = small_config()
    env = anonloc_env.AnonLocEnv(config)
    chooser = CandidateChooser()
    team = baselines.make_team("bayes", env, excitation=SwarmDuty(chooser, budget=0.3))
    observations, _ = env.reset(seed=0)
    team.reset(np.random.SeedSequence(1).spawn(3))
    team.act([observations[a] for a in env.possible_agents])
    context = chooser.observation["context"]
    np.testing.assert_array_equal(context[:, CONTEXT_COLUMN["on_duty"]], 1.0)
    np.testing.assert_allclose(context[:, CONTEXT_COLUMN["budget"]], 0.3)
    assert (chooser.observation["candidates"][..., 0] < 0).any()  # deviations go backwards too


def test_the_scorer_is_equivariant_to_the_candidates_order() -> None:
    torch.manual_seed(0)
    net = CandidateScorer()
    gen = torch.Generator().manual_seed(1)
    cand = torch.randn(5, CANDIDATES, CANDIDATE_FEATURES, generator=gen)
    ctx = torch.randn(5, CONTEXT_FEATURES, generator=gen)
    logits, value = net(cand, ctx)
    perm = torch.randperm(CANDIDATES, generator=gen)
    shuffled, again = net(cand[:, perm], ctx)
    torch.testing.assert_close(shuffled, logits[:, perm], atol=1e-6, rtol=0.0)
    torch.testing.assert_close(again, value, atol=1e-6, rtol=0.0)
    # Any number of candidates: the weights do not depend on it.
    assert net(cand[:, :3], ctx)[0].shape == (5, 3)


def test_draw_follows_the_softmax_with_each_robots_own_generator() -> None:
    logits = np.log(np.array([[0.7, 0.2, 0.1]] * 4000))
    picks = draw(logits, [np.random.default_rng(i) for i in range(4000)])
    share = np.bincount(picks, minlength=3) / 4000
    # 4000 draws: the standard error of a share near 0.7 is 0.0072; 4 of them is the tolerance.
    np.testing.assert_allclose(share, [0.7, 0.2, 0.1], atol=0.03)
    again = draw(logits, [np.random.default_rng(i) for i in range(4000)])
    np.testing.assert_array_equal(picks, again)
    assert draw(np.array([[0.0, -np.inf, 5.0]]), [np.random.default_rng(0)])[0] == 2


def test_a_saved_agent_is_a_policy_that_replays_from_its_seed(tmp_path: Path) -> None:
    path = untrained_agent(tmp_path)
    env = anonloc_env.parallel_env(**SMALL)
    team = baselines.make_team("agent", env, path=str(path))
    assert isinstance(team.excitation, LearnedExcitation)
    first = run_episode(env, team, seed=11)
    again = run_episode(env, baselines.make_team("agent", env, path=str(tmp_path)), seed=11)
    assert first.records == again.records
    other = run_episode(env, baselines.make_team("agent", env, path=str(path)), 11, policy_seed=3)
    assert [r.energy for r in other.records] != [r.energy for r in first.records]
    policy = baselines.make("agent", env, path=str(path))
    observations, _ = env.reset(seed=0)
    action, _ = policy.predict(observations["robot_0"])
    assert action.shape == (2,)
    assert env.action_space("robot_0").contains(action.astype(np.float32))


def test_one_agent_runs_at_any_n_camera_and_clutter(tmp_path: Path) -> None:
    path = untrained_agent(tmp_path)
    for changes in (
        {"n_robots": 2},
        {"n_robots": 12, "arena_size": (4.0, 4.0), "camera": {"orientation": True}},
        {"n_robots": 8, "camera": {"p_miss": 0.2, "false_positives": 3.0}},
    ):
        env = anonloc_env.parallel_env(**{**SMALL, **changes})
        outcome = run_episode(env, baselines.make_team("agent", env, path=str(path)), seed=1)
        assert outcome.records


def test_an_agent_of_the_older_layout_is_refused_by_name(tmp_path: Path) -> None:
    """An agent saved before layout 2 (its observations were the picture's rows) is refused
    before anything in it is unpickled."""
    import json
    import zipfile

    from gymnasium import spaces
    from stable_baselines3.common.save_util import data_to_json

    old = spaces.Dict(
        {
            "rows": spaces.Box(-np.inf, np.inf, (4, 6), np.float32),
            "mask": spaces.Box(0.0, 1.0, (4,), np.float32),
            "own": spaces.Box(-np.inf, np.inf, (12,), np.float32),
        }
    )
    path = tmp_path / "old.zip"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("data", data_to_json({"observation_space": old}))
    with pytest.raises(ValueError, match="older observation layout"):
        load_model(path)
    (tmp_path / "junk.zip").write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="not a saved agent"):
        load_model(tmp_path / "junk.zip")
    assert json.loads(data_to_json({"a": 1}))["a"] == 1


def test_redrawn_scenarios_keep_each_copys_robots_and_replay_from_the_seed() -> None:
    from agents.conditions import ConditionRanges, training_scenarios

    ranges = ConditionRanges(pictures=2)
    runs = []
    for _ in range(2):
        scenarios = training_scenarios(2, seed=5, ranges=ranges)
        venv = _seeded(AnonLocVecEnv(scenarios[0].config, scenarios=scenarios, redraw=ranges), 1)
        runs.append((_rollout(venv, 9, seed=0), [c.config for c in venv.crews]))
        assert [c.n for c in venv.crews] == [s.config.n_robots for s in scenarios]
        assert [c.config for c in venv.crews] != [s.config for s in scenarios]  # redrawn
    assert _same(runs[0][0], runs[1][0])
    assert runs[0][1] == runs[1][1]


def test_a_run_imitates_greedy_then_trains_and_ends_against_random(tmp_path: Path) -> None:
    from agents.train import TrainConfig, train

    config = TrainConfig(
        overrides=SMALL,
        n_envs=1,
        n_steps=8,
        batch_size=24,
        timesteps=48,
        imitation=60,
        imitation_epochs=2,
        eval_episodes=2,
        checkpoint_every=24,
        out=str(tmp_path),
        name="run",
    )
    result = train(config)
    assert result.comparison is not None
    mine, random = result.comparison
    # Censored at the episode's 6 pictures.
    assert 0.0 <= mine <= 6.0
    assert 0.0 <= random <= 6.0
    log = (result.directory / "tb" / "progress.csv").read_text().splitlines()
    header = log[0].split(",")
    assert "eval/pictures_to_99" in header
    assert "eval/identified_at_end" in header
    model = load_model(result.agent)
    assert model.action_space.n == CANDIDATES


def test_a_mixed_run_draws_its_scenarios_and_refuses_overrides() -> None:
    from agents.conditions import TRAINING_ROBOTS
    from agents.train import TrainConfig, make_vec_env

    venv = make_vec_env(TrainConfig(condition="mixed", n_envs=3, seed=4))
    assert len(venv.crews) == 3
    assert all(crew.n in TRAINING_ROBOTS for crew in venv.crews)
    with pytest.raises(ValueError, match="mixed"):
        TrainConfig(condition="mixed", overrides={"n_robots": 5})


def test_an_interrupt_inside_a_compiled_function_still_stops_and_saves() -> None:
    """numba's dispatcher turns a signal handler's ``KeyboardInterrupt`` into a ``SystemError``
    with the interrupt as its cause: training treats it as Ctrl-C (it saves), and any other
    ``SystemError`` as the bug it is."""
    from agents.train import _is_interrupt

    chained = SystemError("returned a result with an exception set")
    chained.__cause__ = KeyboardInterrupt()
    assert _is_interrupt(chained)
    assert not _is_interrupt(SystemError("returned NULL without setting an exception"))
