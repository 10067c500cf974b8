"""The env's default reward and a ``bayes`` team share one identifier where they run the same one.

The reward feeds its identifier what the robots observed (``StepContext.seen``), so a team of
all the env's robots reads that identifier's beliefs instead of computing them again: the
beliefs must be the same to the bit as a team with an identifier of its own, on recorded
episodes and on fuzzed scenarios.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import anonloc_env
import baselines
from anonloc_env.identify import Identifier
from anonloc_env.rewards import StepContext
from anonloc_env.robot_view import read_step

#: Scenarios that exercise every input of the identifier: misses, false positives, detected
#: headings, contacts in a crowded arena, blackouts and jittered pictures, a tilted camera.
HARD = {
    "default": {"n_robots": 5},
    "clutter": {"n_robots": 12, "camera": {"p_miss": 0.1, "false_positives": 2.0}},
    "headings": {"n_robots": 8, "camera": {"orientation": True}},
    "crowd": {
        "n_robots": 20,
        "arena_size": (2.0, 2.0),
        "schedule": {"jitter": 0.2, "blackouts": ((0.0, 1.5), (5.0, 8.0))},
    },
    "tilted": {"n_robots": 6, "camera": {"tilt_deg": 10.0}},
    # A windy drone whose landmarks rectify its pictures: the footprint the robots observe.
    "landmarks": {
        "n_robots": 12,
        "camera": {
            "drift": 0.25,
            "yaw_wobble_deg": 2.0,
            "height_wobble": 0.1,
            "landmarks": ((0.6, 0.6), (2.0, 0.6), (3.4, 0.6), (0.6, 3.4), (2.0, 3.4), (3.4, 3.4)),
        },
    },
}


def play(env: Any, share: bool, seed: int, steps: int) -> tuple[Any, list[np.ndarray]]:
    """A bayes team of all the env's robots for ``steps`` steps; its beliefs at each picture."""
    team = baselines.make_team("bayes", env, share=share)
    observations, _ = env.reset(seed=seed)
    team.reset(np.random.SeedSequence(seed).spawn(env.config.n_robots))
    beliefs = []
    for _ in range(steps):
        actions = team.act([observations[a] for a in env.possible_agents])
        if observations[env.possible_agents[0]]["new_picture"][0] > 0.5:
            beliefs.append(team.beliefs().copy())
        observations, *_ = env.step(dict(zip(env.possible_agents, actions, strict=True)))
    return team, beliefs


@pytest.mark.parametrize("name", sorted(HARD))
def test_a_shared_identifier_gives_the_team_the_same_beliefs_to_the_bit(name: str) -> None:
    env = anonloc_env.parallel_env(**HARD[name], max_cycles=10**6)
    for seed in (0, 1):
        shared, with_share = play(env, True, seed, 400)
        own, without = play(env, False, seed, 400)
        assert shared.localizer.shared
        assert not own.localizer.shared
        assert len(with_share) == len(without) >= 5
        for a, b in zip(with_share, without, strict=True):
            np.testing.assert_array_equal(a, b)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    n=st.integers(1, 15),
    p_miss=st.sampled_from([0.0, 0.2]),
    false_positives=st.sampled_from([0.0, 1.5]),
    interval=st.sampled_from([0.3, 1.0]),
    side=st.sampled_from([1.5, 4.0]),
    seed=st.integers(0, 2**31),
)
def test_shared_and_own_beliefs_agree_on_fuzzed_scenarios(
    n: int, p_miss: float, false_positives: float, interval: float, side: float, seed: int
) -> None:
    env = anonloc_env.parallel_env(
        n_robots=n,
        arena_size=(side, side),
        picture_interval=interval,
        camera={"p_miss": p_miss, "false_positives": false_positives},
        max_cycles=10**6,
    )
    _, with_share = play(env, True, seed, 60)
    _, without = play(env, False, seed, 60)
    assert len(with_share) == len(without)
    for a, b in zip(with_share, without, strict=True):
        np.testing.assert_array_equal(a, b)


def test_one_identifier_is_built_where_two_were(monkeypatch: pytest.MonkeyPatch) -> None:
    built = []
    original = Identifier.__init__

    def counting(self: Identifier, *args: Any, **kwargs: Any) -> None:
        built.append(1)
        original(self, *args, **kwargs)

    monkeypatch.setattr(Identifier, "__init__", counting)
    for share, expected in ((True, 1), (False, 2)):
        built.clear()
        env = anonloc_env.parallel_env(n_robots=4, max_cycles=10**6)
        play(env, share, 0, 30)
        assert len(built) == expected


@pytest.mark.parametrize(
    "build",
    [
        lambda env: baselines.make_team("bayes", env, n=2),  # not all the env's robots
        lambda env: baselines.make_team("bayes", env, scale_known=False),  # another model
        lambda env: baselines.make_team("bayes", env.config),  # built for a config, not the env
        lambda env: baselines.make_team(
            "bayes", anonloc_env.parallel_env(n_robots=3, reward_fn=anonloc_env.EnergyCost())
        ),  # no identifier in the reward
    ],
)
def test_a_team_shares_only_the_same_identifier(build: Any) -> None:
    env = anonloc_env.parallel_env(n_robots=3)
    assert not build(env).localizer.shared


def test_a_team_out_of_step_with_its_env_says_so() -> None:
    """Fed the pictures of another env than the one it shares with, the team refuses (rather
    than reading beliefs about pictures it was not shown)."""
    env = anonloc_env.parallel_env(n_robots=3)
    other = anonloc_env.parallel_env(n_robots=3)
    team = baselines.make_team("bayes", env)
    env.reset(seed=0)
    observations, _ = other.reset(seed=1)
    team.reset([0, 1, 2])
    with pytest.raises(RuntimeError, match="share=False"):
        team.act([observations[a] for a in other.possible_agents])


def test_the_reward_reads_what_the_robots_observed() -> None:
    """``StepContext.seen`` is, to the bit, what ``read_step`` reads from the observations."""
    seen: list[Any] = []

    class Recorder:
        needs_statistics = False

        def reset(self, config: Any, rng: Any, picture: Any = None) -> None:
            pass

        def __call__(self, context: StepContext) -> np.ndarray:
            seen.append(context.seen)
            return np.zeros(context.config.n_robots)

    env = anonloc_env.parallel_env(
        n_robots=6, arena_size=(1.5, 1.5), picture_interval=0.3, reward_fn=Recorder()
    )
    env.reset(seed=4)
    rng = np.random.default_rng(4)
    for _ in range(40):
        observations, *_ = env.step({a: rng.uniform(-1, 1, 2) for a in env.agents})
        expected = read_step([observations[a] for a in env.possible_agents])
        got = seen[-1]
        assert got.new_picture == expected.new_picture
        assert got.interval == expected.interval
        for field in ("rows", "odometry", "bumper", "between"):
            np.testing.assert_array_equal(getattr(got, field), getattr(expected, field))
    with pytest.raises(ValueError, match="without the robots' observations"):
        _ = StepContext(
            env.config, 0.0, np.zeros(6), np.zeros(6), np.zeros(6, bool), None, None
        ).seen


def test_a_one_robot_policy_never_shares_and_serves_a_batch_of_envs() -> None:
    """``baselines.make`` (SB3-style, one robot) may run in any env of its scenario, a VecEnv's
    batch included, so even in a one-robot env it keeps an identifier of its own."""
    envs = [anonloc_env.parallel_env(n_robots=1) for _ in range(2)]
    policy = baselines.make("bayes", envs[0])
    observations = [env.reset(seed=i)[0]["robot_0"] for i, env in enumerate(envs)]
    batch = {key: np.stack([o[key] for o in observations]) for key in observations[0]}
    actions, _ = policy.predict(batch)
    assert actions.shape == (2, 2)
