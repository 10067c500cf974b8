"""One definition of the agent (agents.spec): saved with the model, checked when it is loaded."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

import anonloc_env
from agents.candidate_features import CANDIDATE_SPEC, CONTEXT_SPEC, Feature
from agents.features import CandidatePolicy
from agents.policy import LearnedExcitation, load_agent, load_model
from agents.spec import AgentSpec, Reward, saved_spec
from agents.train import TrainConfig
from agents.vec import AnonLocVecEnv
from baselines.excitations import SwarmDuty
from baselines.excitations.rest import RestWhenSure

CONFIG = anonloc_env.make_config(n_robots=3, arena_size=(2.0, 2.0), max_cycles=60)


def _saved(tmp_path: Path, spec: AgentSpec, name: str = "agent.zip") -> Path:
    """A tiny untrained agent whose zip records ``spec`` (as ``anonloc train`` saves one)."""
    from stable_baselines3 import PPO

    # The env gives the spaces only (this anonloc's features, as many); the zip records `spec`,
    # which may name another anonloc's features.
    spaces = dataclasses.replace(
        spec.in_scenario("free", spec.budget),
        candidate_features=CANDIDATE_SPEC[: len(spec.candidate_features)],
        context_features=CONTEXT_SPEC[: len(spec.context_features)],
    )
    venv = AnonLocVecEnv(CONFIG, spec=spaces)
    kwargs = {"hidden": 8, "spec": spec.to_json()}
    model = PPO(CandidatePolicy, venv, n_steps=8, batch_size=8, policy_kwargs=kwargs)
    path = tmp_path / name
    model.save(path)
    return path


def test_json_round_trip_and_bad_json() -> None:
    spec = AgentSpec(condition="swarm", budget=0.35, reward=Reward("team", 2.0, 0.3))
    assert AgentSpec.from_json(spec.to_json()) == spec
    with pytest.raises(ValueError, match="not an agent spec"):
        AgentSpec.from_json({"candidates": 0})
    with pytest.raises(ValueError, match="condition"):
        AgentSpec(condition="crowd")
    with pytest.raises(ValueError, match="distinct names"):
        AgentSpec(context_features=(CONTEXT_SPEC[0], CONTEXT_SPEC[0]))


def test_the_train_config_builds_the_spec_once() -> None:
    config = TrainConfig(condition="swarm", budget=0.3, reward="team", energy_weight=0.5)
    assert config.spec() == AgentSpec(
        reward=Reward("team", 1.0, 0.5), condition="swarm", budget=0.3
    )
    assert TrainConfig(rest=0.999).spec().rest == 0.999


@pytest.mark.parametrize("rest", [0.5, 1.01, float("nan"), -1.0])
def test_a_bad_rest_is_refused_naming_it(rest: float) -> None:
    with pytest.raises(ValueError, match="rest must be"):
        AgentSpec(rest=rest)
    with pytest.raises(ValueError, match="rest must be"):
        TrainConfig(rest=rest)


def test_an_agent_that_rests_is_run_at_rest(tmp_path: Path) -> None:
    """``rest`` is saved with the agent and read back: the loaded agent is the policy inside
    ``RestWhenSure`` (inside ``SwarmDuty`` on swarm duty), and an agent saved without it is
    not wrapped."""
    spec = AgentSpec(condition="swarm", budget=0.3, rest=0.9995)
    path = _saved(tmp_path, spec)
    assert saved_spec(path) == spec
    loaded = load_agent(path)
    assert isinstance(loaded, SwarmDuty)
    assert isinstance(loaded.deviation, RestWhenSure)
    assert loaded.deviation.sure == 0.9995
    assert isinstance(loaded.deviation.inner, LearnedExcitation)
    plain = load_agent(_saved(tmp_path, AgentSpec(), "plain.zip"))
    assert isinstance(plain, LearnedExcitation)
    built = spec.excitation(LearnedExcitation(load_model(path)))
    assert isinstance(built, SwarmDuty)
    assert isinstance(built.deviation, RestWhenSure)


def test_the_spec_round_trips_through_a_saved_agent(tmp_path: Path) -> None:
    spec = AgentSpec(condition="swarm", budget=0.3, reward=Reward("team", 1.0, 0.3))
    path = _saved(tmp_path, spec)
    assert saved_spec(path) == spec
    model = load_model(path)
    assert model.policy.spec == spec.to_json()
    # The saved agent runs in its own condition and budget, with no run folder beside it.
    excitation = load_agent(path)
    assert isinstance(excitation, SwarmDuty)
    assert excitation.budget == 0.3
    assert isinstance(excitation.deviation, LearnedExcitation)
    assert isinstance(load_agent(path, condition="free"), LearnedExcitation)


@pytest.mark.parametrize(
    ("change", "said"),
    [
        (
            {"context_features": (*CONTEXT_SPEC[:-1], Feature("seen", CONTEXT_SPEC[-1].meaning))},
            "context_features[9] is 'seen' in the saved agent, 'scored' here",
        ),
        (
            {
                "candidate_features": (
                    Feature("speed", "forward speed in m/s"),
                    *CANDIDATE_SPEC[1:],
                )
            },
            "candidate_features[0] 'speed' means 'forward speed in m/s' in the saved agent",
        ),
        ({"layout": 3}, "observation layout 3"),
    ],
)
def test_an_agent_whose_features_differ_is_refused(
    tmp_path: Path, change: dict[str, object], said: str
) -> None:
    path = _saved(tmp_path, dataclasses.replace(AgentSpec(), **change))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="trained on other observations") as refused:
        load_model(path)
    assert said in str(refused.value)
    assert str(path) in str(refused.value)


def test_an_agent_saved_before_specs_loads_as_layout_two(tmp_path: Path) -> None:
    from stable_baselines3 import PPO

    model = PPO(CandidatePolicy, AnonLocVecEnv(CONFIG), n_steps=8, batch_size=8)
    path = tmp_path / "old.zip"
    model.save(path)
    assert saved_spec(path) is None
    assert isinstance(load_agent(path), LearnedExcitation)


def test_the_reward_object() -> None:
    before, after = np.array([0.5, 0.25, 1e-6]), np.array([1.0, 0.5, 1e-6])
    own = np.log([1.0, 0.5, 1e-3])  # floored at LOG_BELIEF_FLOOR
    np.testing.assert_allclose(Reward("log_belief", 2.0).term(before, after), 2.0 * own)
    np.testing.assert_allclose(Reward("team").term(before, after), np.full(3, own.mean()))
    gained = np.log(2.0) * np.array([1.0, 1.0, 0.0])
    np.testing.assert_allclose(Reward("information").term(before, after), gained, atol=1e-12)
    with pytest.raises(ValueError, match="identity"):
        Reward("selfish")


def test_every_adapter_acts_with_the_spec_it_is_given() -> None:
    from agents.pettingzoo import BeliefParallelEnv

    spec = AgentSpec(reward=Reward("team"), condition="swarm", budget=0.3)
    for crew in (BeliefParallelEnv(CONFIG, spec).crew, AnonLocVecEnv(CONFIG, spec=spec).crews[0]):
        assert crew.spec == spec
        assert isinstance(crew.team.excitation, SwarmDuty)
        assert crew.team.excitation.budget == 0.3
    with pytest.raises(ValueError, match="mixed"):
        AnonLocVecEnv(CONFIG, spec=AgentSpec(condition="mixed"))
