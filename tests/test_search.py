"""The linear agent and its search (issue 24): zero weights are ``uniform``, torch and numpy agree,
the agent saves and loads with its spec, and a search killed mid-run resumes and loses nothing."""

from __future__ import annotations

import dataclasses
import json
import zipfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

import torch

import anonloc_env
import baselines
from agents.conditions import ConditionRanges
from agents.features import LinearScorer
from agents.linear_agent import LINEAR_SPEC, linear_spec, save_linear_agent
from agents.linear_terms import CROWD_TERMS, DENSE, LINEAR_TERMS, SIZE_TERMS, linear_terms
from agents.policy import BUNDLED_NAME, agent_file, load_agent, load_model
from agents.search import (
    LinearChooser,
    SearchConfig,
    chooser,
    search,
    search_ranges,
    search_spec,
)
from agents.spec import AgentSpec, saved_spec
from baselines.excitations import SwarmDuty
from baselines.excitations.rest import RestWhenSure
from baselines.registry import make_excitation
from baselines.runner import run_episode

#: A search small enough for a test: 3 robots, 4 pictures, one scenario of one seed.
TINY = SearchConfig(
    generations=2,
    pairs=1,
    scenarios=1,
    seeds=1,
    pictures=4,
    validate_every=1,
    validation_episodes=2,
    ranges=ConditionRanges(robots=(3,), pictures=4),
)


def _episode(own: object, swarm: bool, seed: int = 4) -> list[tuple]:
    config = anonloc_env.make_config(n_robots=6, arena_size=(2.5, 2.5))
    env = anonloc_env.AnonLocEnv(config, reward_fn=anonloc_env.EnergyCost())
    excitation = SwarmDuty(own, 0.2, common_seed=seed) if swarm else own
    team = baselines.make_team("bayes", env, excitation=excitation)
    return run_episode(env, team, seed, max_pictures=8).rows()


@pytest.mark.parametrize("swarm", [False, True])
def test_zero_weights_are_uniform_bit_for_bit(swarm: bool) -> None:
    zero = _episode(LinearChooser(np.zeros(len(LINEAR_TERMS))), swarm)
    assert zero == _episode(make_excitation("uniform"), swarm)


def test_weights_change_the_choices() -> None:
    """A strong preference for slow candidates moves the robots less than chance does."""
    weights = np.zeros(len(LINEAR_TERMS))
    weights[[t.name for t in LINEAR_TERMS].index("speed*always")] = -30.0
    slow = _episode(LinearChooser(weights), swarm=False)
    assert slow != _episode(make_excitation("uniform"), swarm=False)


def test_torch_and_numpy_terms_agree_to_1e_5() -> None:
    """The SB3 policy's logits (float32, torch) equal the search's (float64, numpy)."""
    rng = np.random.default_rng(0)
    candidates = rng.normal(size=(5, 8, 7))
    context = rng.uniform(size=(5, 10))
    weights = rng.normal(size=len(LINEAR_TERMS))
    scorer = LinearScorer()
    with torch.no_grad():
        scorer.weights.copy_(torch.as_tensor(weights))
        logits, value = scorer(
            torch.as_tensor(candidates).float(), torch.as_tensor(context).float()
        )
    expected = linear_terms(candidates, context, np.stack) @ weights
    np.testing.assert_allclose(logits.numpy(), expected, rtol=1e-5, atol=1e-5)
    assert value.shape == (5,)


def test_weights_are_checked() -> None:
    with pytest.raises(ValueError, match="weights must be 18 finite numbers"):
        LinearChooser(np.zeros(3))
    with pytest.raises(ValueError, match="weights must be 18 finite numbers"):
        LinearChooser(np.full(len(LINEAR_TERMS), np.nan))


def test_a_linear_agent_round_trips_with_its_spec(tmp_path: Path) -> None:
    weights = np.linspace(-1, 1, len(LINEAR_TERMS))
    path = save_linear_agent(weights, tmp_path / "agent.zip")
    model = load_model(path)
    np.testing.assert_allclose(model.policy.scorer.weights.detach().numpy(), weights, rtol=1e-6)
    env = anonloc_env.parallel_env(n_robots=5)
    team = baselines.make_team("agent", env, path=str(path))
    observations, _ = env.reset(seed=1)
    team.reset(np.random.SeedSequence(1).spawn(5))
    actions = team.act([observations[a] for a in env.possible_agents])
    assert actions.shape == (5, 2)
    assert np.all(np.isfinite(actions))


def test_a_linear_agent_whose_term_means_otherwise_is_refused(tmp_path: Path) -> None:
    path = save_linear_agent(np.zeros(len(LINEAR_TERMS)), tmp_path / "agent.zip")
    with zipfile.ZipFile(path) as archive:
        members = {name: archive.read(name) for name in archive.namelist()}
    data = json.loads(members["data"])
    spec = data["policy_kwargs"]["spec"]
    spec["terms"][3]["meaning"] = "something else"
    members["data"] = json.dumps(data).encode()
    changed = tmp_path / "changed.zip"
    with zipfile.ZipFile(changed, "w") as archive:
        for name, content in members.items():
            archive.writestr(name, content)
    with pytest.raises(ValueError, match=r"terms\[3\] 'speed_sq\*always' means 'something else'"):
        load_model(changed)


def test_the_spec_records_the_scorer_and_its_terms() -> None:
    spec = linear_spec()
    assert AgentSpec.from_json(spec.to_json()) == spec
    assert spec.differences(AgentSpec()) == ["scorer 'deep_sets', this spec has 'linear'"] + [
        f"terms[{i}] {t.name!r} is only in this anonloc" for i, t in enumerate(LINEAR_TERMS)
    ]
    with pytest.raises(ValueError, match="terms must be given for the linear scorer"):
        AgentSpec(scorer="linear")
    with pytest.raises(ValueError, match="scorer"):
        AgentSpec(scorer="transformer")


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("pairs", 0, "pairs"),
        ("pictures", 1, "pictures"),
        ("std", 0.0, "std"),
        ("step_size", -1.0, "step_size"),
        ("energy_weight", -1.0, "energy_weight"),
        ("rest", 0.5, "rest must be"),
        ("rest", 1.5, "rest"),
    ],
)
def test_search_config_is_checked_when_built(field: str, value: object, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        dataclasses.replace(SearchConfig(), **{field: value})


class _KilledError(Exception):
    pass


def test_a_search_killed_after_a_generation_resumes_and_loses_nothing(tmp_path: Path) -> None:
    whole = search(TINY, tmp_path / "whole", log=lambda _: None)
    seen: list[str] = []

    def kill_after_first(line: str) -> None:
        seen.append(line)
        if line.startswith("generation 0"):
            raise _KilledError

    with pytest.raises(_KilledError):
        search(TINY, tmp_path / "cut", log=kill_after_first)
    assert not (tmp_path / "cut" / "agent.zip").exists()
    with pytest.raises(FileExistsError, match="holds a search"):
        search(TINY, tmp_path / "cut", log=lambda _: None)
    with pytest.raises(ValueError, match="another config"):
        search(dataclasses.replace(TINY, seed=1), tmp_path / "cut", resume=True)
    resumed = search(TINY, tmp_path / "cut", log=lambda _: None, resume=True)
    np.testing.assert_array_equal(resumed, whole)
    saved = [json.loads((tmp_path / d / "search.json").read_text()) for d in ("whole", "cut")]
    timeless = [
        [{k: v for k, v in r.items() if k != "seconds"} for r in s["history"]] for s in saved
    ]
    assert timeless[0] == timeless[1]
    assert [row["generation"] for row in saved[1]["history"]] == [0, 1, 2]
    # the start is uniform itself: its validation ratios are exactly 1
    assert saved[1]["history"][0]["free_pictures"] == 1.0
    assert (tmp_path / "cut" / "progress.csv").read_text().startswith("generation,")
    assert load_model(tmp_path / "cut" / "agent.zip").policy.scorer_kind == "linear"


def test_anonloc_search_runs_as_users_run_it(tmp_path: Path) -> None:
    """The real console script: a one-generation search writes a loadable agent; a second run
    into the same folder, and bad settings, are refused with the parameter named."""
    from tests.cli_helpers import run_script

    out = tmp_path / "search"
    small = ["--pairs", "1", "--scenarios", "1", "--seeds", "1"]
    small += ["--pictures", "3", "--validation-episodes", "2", "--generations", "1"]
    done = run_script("search", out, *small, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "generation 0" in done.stdout
    assert (out / "agent.zip").is_file()
    again = run_script("search", out, *small)
    assert again.returncode != 0
    assert "holds a search" in again.stderr
    # --resume alone continues with the search's own settings (the options given replace
    # them, and one that changes what it finds is refused, naming the saved ones)
    saved = json.loads((out / "search.json").read_text())
    resumed = run_script("search", out, "--resume", "--workers", "1")
    assert resumed.returncode == 0, resumed.stderr
    assert json.loads((out / "search.json").read_text())["history"] == saved["history"]
    changed = run_script("search", out, "--resume", "--pairs", "2")
    assert changed.returncode != 0
    assert "another config" in changed.stderr
    bad = run_script("search", tmp_path / "other", "--pairs", "0")
    assert bad.returncode != 0
    assert "pairs" in bad.stderr
    assert not (tmp_path / "other" / "search.json").exists()


def test_anonloc_search_with_the_crowd_features_as_users_run_it(tmp_path: Path) -> None:
    """The real console script with ``--crowd --crowd-only``: the saved agent names the crowd
    features and terms, only the crowding-gated weights moved, the validation has a crowd, and
    ``--crowd-only`` without ``--crowd`` is refused before any work."""
    from tests.cli_helpers import run_script

    out = tmp_path / "crowd"
    small = ["--pairs", "1", "--scenarios", "1", "--seeds", "1", "--pictures", "3"]
    small += ["--validation-episodes", "2", "--generations", "1", "--rest", "0.9999"]
    done = run_script("search", out, "--crowd", "--crowd-only", *small, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "crowd " in done.stdout  # the crowd validation in the summary line
    spec = saved_spec(out / "agent.zip")
    assert spec is not None
    assert spec.terms == CROWD_TERMS
    assert [f.name for f in spec.context_features][-3:] == ["free_space", "crowding", "density"]
    assert spec.rest == 0.9999
    weights = load_model(out / "agent.zip").policy.scorer.weights.detach().numpy()
    gated = np.array([t.name.endswith("*crowding") for t in CROWD_TERMS])
    assert np.all(weights[~gated] == 0.0)
    bad = run_script("search", tmp_path / "other", "--crowd-only")
    assert bad.returncode != 0
    assert "crowd_only needs crowd" in bad.stderr
    assert not (tmp_path / "other" / "search.json").exists()


@pytest.mark.parametrize("swarm", [False, True])
def test_zero_weights_at_rest_are_uniform_rest_bit_for_bit(swarm: bool) -> None:
    """The search's ablation with ``rest`` is ``uniform-rest`` itself, and resting changes the
    episode (robots that are sure stand still)."""
    zero = _episode(chooser(np.zeros(len(LINEAR_TERMS)), 0.999)(), swarm)
    assert zero == _episode(make_excitation("uniform-rest"), swarm)
    assert zero != _episode(make_excitation("uniform"), swarm)


def test_a_search_at_rest_saves_an_agent_that_rests(tmp_path: Path) -> None:
    """``SearchConfig.rest`` reaches the saved spec, and the loaded agent rests as it was
    searched: its episode equals the searched weights wrapped in ``RestWhenSure``."""
    config = dataclasses.replace(TINY, generations=1, rest=0.999)
    mu = search(config, tmp_path / "s", log=lambda _: None)
    history = json.loads((tmp_path / "s" / "search.json").read_text())["history"]
    assert history[0]["free_pictures"] == 1.0  # the start is uniform-rest itself
    path = tmp_path / "s" / "agent.zip"
    assert saved_spec(path) == dataclasses.replace(linear_spec(), rest=0.999)
    loaded = load_agent(path, condition="free")
    assert isinstance(loaded, RestWhenSure)
    assert loaded.sure == 0.999
    assert _episode(loaded, False) == _episode(chooser(mu, 0.999)(), False)


def test_a_crowd_only_search_moves_only_the_crowding_terms(tmp_path: Path) -> None:
    config = dataclasses.replace(TINY, crowd=True, crowd_only=True)
    mu = search(config, tmp_path / "run", log=lambda _: None)
    gated = np.array([t.name.endswith("*crowding") for t in CROWD_TERMS])
    assert np.all(mu[~gated] == 0.0)
    assert np.any(mu[gated] != 0.0)
    progress = (tmp_path / "run" / "progress.csv").read_text()
    assert "crowd_pictures" in progress  # validated in a crowd too
    with pytest.raises(ValueError, match="crowd_only needs crowd"):
        SearchConfig(crowd_only=True)


def test_a_dense_search_moves_only_the_dense_terms_from_its_start(tmp_path: Path) -> None:
    """``dense`` gives the search the bundled agent's spec (with ``size``); ``moves="dense"``
    keeps every other weight at the start's, draws only dense arenas and validates only in the
    crowd, against the start."""
    start = np.linspace(-1.0, 1.0, len(LINEAR_TERMS + SIZE_TERMS))
    base = dataclasses.replace(LINEAR_SPEC, terms=LINEAR_TERMS + SIZE_TERMS)
    save_linear_agent(start, tmp_path / "start.zip", base)
    config = dataclasses.replace(
        TINY,
        size=True,
        dense=True,
        moves="dense",
        start=str(tmp_path / "start.zip"),
        ranges=ConditionRanges(robots=(3,), pictures=4, density=(0.5, 6.0)),
    )
    bundled = saved_spec(agent_file(BUNDLED_NAME))
    assert bundled is not None
    assert search_spec(config).terms == bundled.terms
    assert search_spec(config).context_features == bundled.context_features
    assert search_ranges(config).density == (DENSE, 6.0)
    mu = search(config, tmp_path / "run", log=lambda _: None)
    names = [t.name for t in bundled.terms]
    moved = np.array([n.endswith("*dense") for n in names])
    saved = start.astype(np.float32).astype(np.float64)  # the agent's file holds float32
    assert np.array_equal(mu[~moved], np.r_[saved, np.zeros(6)])  # the start's, missing at 0
    assert np.any(mu[moved] != 0.0)
    header = (tmp_path / "run" / "progress.csv").read_text().splitlines()[0]
    assert "crowd_pictures" in header
    assert "crowd_start" in header
    assert "free_pictures" not in header


def test_moves_must_name_a_gate_of_the_searched_terms() -> None:
    with pytest.raises(ValueError, match="moves must be a gate"):
        SearchConfig(moves="dense")  # no dense terms without dense
    with pytest.raises(ValueError, match="moves must be a gate"):
        SearchConfig(crowd=True, crowd_only=True, moves="crowding")
    assert SearchConfig(dense=True, moves="missing").moves == "missing"


def test_the_starts_validation_is_played_once_and_reused() -> None:
    """A search validates ``mu`` against its unchanging start many times: with a cache the
    start's episodes are played on the first validation only, and every ratio is the same as
    when they are played again."""
    from agents.conditions import Scenario
    from agents.evaluation import validate_against_uniform
    from agents.search_costs import play_weights

    spec = search_spec(dataclasses.replace(TINY, crowd=True))
    weights, start = np.full(len(spec.terms), 0.3), np.zeros(len(spec.terms))
    played: list[int] = []

    def player(scenario: Scenario, which: int, seeds: Sequence[int], pictures: int) -> np.ndarray:
        played.append(which)
        return play_weights(scenario, (weights, start)[which], seeds, pictures, None, spec)[0]

    make, ablation = chooser(weights, None, spec), chooser(start, None, spec)
    cache: dict[str, np.ndarray] = {}
    fresh = validate_against_uniform(make, 2, 4, ablation, True, player)
    assert played.count(1) == 3  # free, swarm and crowd: the start played each time
    played.clear()
    first = validate_against_uniform(make, 2, 4, ablation, True, player, None, cache)
    second = validate_against_uniform(make, 2, 4, ablation, True, player, None, cache)
    assert played == [0, 1, 0, 1, 0, 1, 0, 0, 0]  # the start's episodes played once
    assert first == fresh
    assert second == fresh


def test_a_saved_search_config_is_read_back_with_changes(tmp_path: Path) -> None:
    """``saved_config`` gives the config a search saved (its ranges' tuples included), with the
    changes asked for; what is not a field is refused."""
    from agents.search import saved_config

    config = dataclasses.replace(TINY, generations=1, seed=3, rest=0.99)
    search(config, tmp_path / "run", log=lambda _: None)
    assert saved_config(tmp_path / "run") == config
    assert saved_config(tmp_path / "run", workers=2) == dataclasses.replace(config, workers=2)
    with pytest.raises(ValueError, match="not fields of SearchConfig"):
        saved_config(tmp_path / "run", colour="red")
    with pytest.raises(FileNotFoundError, match="no search to resume"):
        saved_config(tmp_path / "none")
