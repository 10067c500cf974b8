"""The crowd features in the learned agent's observation, by name (issues 23 and 24): a spec that
names them gets them after the layout's own, its linear terms score them in numpy and torch
alike, and the agent saves, loads and runs with them."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

import torch

import anonloc_env
import baselines
from agents.candidate_features import CANDIDATE_SPEC, CONTEXT_SPEC, Feature
from agents.candidates import CandidateChooser
from agents.features import LinearScorer
from agents.linear_agent import linear_spec, save_linear_agent
from agents.linear_terms import (
    CROWD_TERMS,
    CROWDED,
    CROWDED_TERMS,
    DENSE,
    DENSE_TERMS,
    KNOWN_TERMS,
    LINEAR_TERMS,
    MISSING_TERMS,
    TERM_BASES,
    linear_terms,
)
from agents.policy import load_model
from agents.search import LinearChooser
from agents.spec import AgentSpec, check_features, check_saved
from baselines.runner import run_episode

CROWD = linear_spec("free").with_crowd_features()


class _Recorder(LinearChooser):
    """A linear chooser that keeps every observation it acted on."""

    def __init__(self, weights: np.ndarray, spec: AgentSpec) -> None:
        super().__init__(weights, spec)
        self.seen: list[dict[str, np.ndarray]] = []

    def on_scored(self) -> None:
        if self.cset is not None:
            self.seen.append({k: v.copy() for k, v in self.observation.items()})
        super().on_scored()


def _crowded(own: object, seed: int = 3, density: float = 4.0) -> list[tuple]:
    """An episode of 12 robots at ``density`` per m^2 (8 pictures)."""
    side = float(np.sqrt(12 / density))
    config = anonloc_env.make_config(n_robots=12, arena_size=(side, side))
    env = anonloc_env.AnonLocEnv(config, reward_fn=anonloc_env.EnergyCost())
    team = baselines.make_team("bayes", env, excitation=own)
    return run_episode(env, team, seed, max_pictures=8).rows()


def test_the_crowd_features_follow_the_layouts_and_leave_the_episode_unchanged() -> None:
    """Zero weights: the crowd spec plays the same episode as the plain one, bit for bit, and its
    observations are the plain ones with the crowd columns appended."""
    plain = _Recorder(np.zeros(len(LINEAR_TERMS)), linear_spec("free"))
    crowd = _Recorder(np.zeros(len(CROWD_TERMS)), CROWD)
    assert _crowded(plain) == _crowded(crowd)
    assert len(plain.seen) == len(crowd.seen) >= 7
    for a, b in zip(plain.seen, crowd.seen, strict=True):
        assert b["candidates"].shape[-1] == len(CANDIDATE_SPEC) + 1
        assert b["context"].shape[-1] == len(CONTEXT_SPEC) + 3
        np.testing.assert_array_equal(b["candidates"][..., : len(CANDIDATE_SPEC)], a["candidates"])
        np.testing.assert_array_equal(b["context"][:, : len(CONTEXT_SPEC)], a["context"])
    risk = np.concatenate([o["candidates"][..., -1].ravel() for o in crowd.seen])
    free = np.concatenate([o["context"][:, -3] for o in crowd.seen])
    crowding = np.concatenate([o["context"][:, -2] for o in crowd.seen])
    density = np.concatenate([o["context"][:, -1] for o in crowd.seen])
    assert 0.0 <= risk.min() < risk.max() <= 1.0  # a crowd has contacts
    assert 0.0 <= free.min() < free.max() <= 1.0
    assert 0.0 <= crowding.min() < crowding.max()
    # every robot is in every picture of the arena, which the view covers: 12 rows in 3 m^2
    np.testing.assert_allclose(density, 4.0, rtol=1e-4)


def test_a_chooser_that_meets_a_new_arena_sees_its_field_of_view() -> None:
    """A training copy redraws its scenario with the same excitation: the crowd features of the
    new arena are those of a fresh chooser there."""
    reused = _Recorder(np.zeros(len(CROWD_TERMS)), CROWD)
    _crowded(reused, density=4.0)
    reused.seen.clear()
    fresh = _Recorder(np.zeros(len(CROWD_TERMS)), CROWD)
    assert _crowded(reused, density=1.0) == _crowded(fresh, density=1.0)
    for a, b in zip(reused.seen, fresh.seen, strict=True):
        np.testing.assert_array_equal(a["candidates"], b["candidates"])


def test_a_contact_averse_weight_changes_the_choices() -> None:
    weights = np.zeros(len(CROWD_TERMS))
    weights[[t.name for t in CROWD_TERMS].index("contact_risk*always")] = -30.0
    assert _crowded(LinearChooser(weights, CROWD)) != _crowded(
        LinearChooser(np.zeros(len(CROWD_TERMS)), CROWD)
    )


def test_crowd_terms_agree_in_torch_and_numpy_to_1e_5() -> None:
    rng = np.random.default_rng(1)
    candidates = rng.normal(size=(5, 8, len(CROWD.candidate_features)))
    context = rng.uniform(size=(5, len(CROWD.context_features)))
    weights = rng.normal(size=len(CROWD_TERMS))
    scorer = LinearScorer(8, len(CROWD.context_features), CROWD.terms, CROWD.columns())
    with torch.no_grad():
        scorer.weights.copy_(torch.as_tensor(weights))
        logits, _ = scorer(torch.as_tensor(candidates).float(), torch.as_tensor(context).float())
    expected = linear_terms(candidates, context, np.stack, CROWD.terms, CROWD.columns()) @ weights
    np.testing.assert_allclose(logits.numpy(), expected, rtol=1e-5, atol=1e-5)


def test_a_crowd_agent_round_trips_and_runs(tmp_path: Path) -> None:
    weights = np.linspace(-1, 1, len(CROWD_TERMS))
    path = save_linear_agent(weights, tmp_path / "agent.zip", CROWD)
    model = load_model(path)
    assert model.observation_space["candidates"].shape == (8, len(CANDIDATE_SPEC) + 1)
    np.testing.assert_allclose(model.policy.scorer.weights.detach().numpy(), weights, rtol=1e-6)
    env = anonloc_env.parallel_env(n_robots=6, arena_size=(1.5, 1.5))
    team = baselines.make_team("agent", env, path=str(path))
    observations, _ = env.reset(seed=2)
    team.reset(np.random.SeedSequence(2).spawn(6))
    for _ in range(45):  # past two pictures, so the candidates are scored
        actions = team.act([observations[a] for a in env.possible_agents])
        assert np.all(np.isfinite(actions))
        observations, *_ = env.step(dict(zip(env.possible_agents, actions, strict=True)))


def test_features_this_anonloc_cannot_compute_are_refused() -> None:
    elbow = (*CONTEXT_SPEC, Feature("elbow_room", "metres to the nearest robot"))
    with pytest.raises(ValueError, match="context_features must be the layout's"):
        check_features(CANDIDATE_SPEC, elbow)
    with pytest.raises(ValueError, match="candidate_features must be the layout's"):
        CandidateChooser(features=(CANDIDATE_SPEC[1:], CONTEXT_SPEC))
    saved = dataclasses.replace(CROWD, context_features=elbow)
    with pytest.raises(ValueError, match="context_features\\[10\\] 'elbow_room' is only in the "):
        check_saved(Path("agent.zip"), saved)
    check_saved(Path("agent.zip"), CROWD)  # every crowd feature and term is known here


def test_the_flat_observation_refuses_the_crowd_features() -> None:
    from agents.pettingzoo import BeliefParallelEnv

    config = anonloc_env.make_config(n_robots=3)
    with pytest.raises(ValueError, match="observation='flat'"):
        BeliefParallelEnv(config, CROWD.in_scenario("free", 0.2), observation="flat")
    env = BeliefParallelEnv(config, CROWD.in_scenario("free", 0.2))  # the dict form takes them
    observations, _ = env.reset(seed=0)
    assert observations[env.possible_agents[0]]["context"].shape == (len(CONTEXT_SPEC) + 3,)


@pytest.mark.parametrize(
    ("gate", "feature", "threshold", "family"),
    [("crowded", "crowding", CROWDED, CROWDED_TERMS), ("dense", "density", DENSE, DENSE_TERMS)],
)
def test_a_crowd_gate_opens_only_at_its_threshold_in_numpy_and_torch(
    gate: str, feature: str, threshold: float, family: tuple[Feature, ...]
) -> None:
    """``base*crowded`` (``base*dense``) is the base where the crowding (the arena's density)
    reaches its threshold and 0 below it, the same in numpy and torch (what lets an agent act
    only in a crowd)."""
    terms = tuple(KNOWN_TERMS[f"{b.name}*{gate}"] for b in TERM_BASES)
    assert terms == family
    candidates = np.random.default_rng(2).normal(size=(3, 8, len(CROWD.candidate_features)))
    context = np.zeros((3, len(CROWD.context_features)))
    context[:, CROWD.columns()[1][feature]] = [threshold - 0.01, threshold, 3 * threshold]
    out = linear_terms(candidates, context, np.stack, terms, CROWD.columns())
    entropy = candidates[..., CROWD.columns()[0]["entropy_after"]]
    column = [t.name for t in terms].index(f"entropy_after*{gate}")
    np.testing.assert_array_equal(out[0, :, column], 0.0)
    np.testing.assert_array_equal(out[1:, :, column], entropy[1:])
    scorer = LinearScorer(8, len(CROWD.context_features), terms, CROWD.columns())
    weights = np.arange(1.0, len(terms) + 1)
    with torch.no_grad():
        scorer.weights.copy_(torch.as_tensor(weights))
        logits, _ = scorer(torch.as_tensor(candidates).float(), torch.as_tensor(context).float())
    np.testing.assert_allclose(logits.numpy(), out @ weights, rtol=1e-5, atol=1e-4)


def test_the_missing_gate_is_the_share_of_robots_a_picture_misses() -> None:
    """``base*missing`` is the base times ``1 - p_detect``: 0 on a clean camera, so that an agent
    with these terms plays its base there (the bundled agent, ninth round)."""
    terms = tuple(KNOWN_TERMS[f"{b.name}*missing"] for b in TERM_BASES)
    assert terms == MISSING_TERMS
    candidates = np.random.default_rng(3).normal(size=(3, 8, len(CROWD.candidate_features)))
    context = np.zeros((3, len(CROWD.context_features)))
    context[:, CROWD.columns()[1]["p_detect"]] = [1.0, 0.9, 0.75]
    out = linear_terms(candidates, context, np.stack, terms, CROWD.columns())
    energy = candidates[..., CROWD.columns()[0]["energy"]]
    column = [t.name for t in terms].index("energy*missing")
    np.testing.assert_array_equal(out[0, :, column], 0.0)
    np.testing.assert_allclose(out[1:, :, column], energy[1:] * np.array([[0.1], [0.25]]))
