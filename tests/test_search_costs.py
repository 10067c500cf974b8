"""A search's costs (issue 24): the same bits in a pool of processes as in one, the baseline
it is measured against, the energy cap, the size terms and a start from a saved agent."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

from agents.conditions import ConditionRanges, draw_scenario
from agents.linear_agent import LINEAR_SPEC, linear_weights, save_linear_agent
from agents.linear_terms import (
    DENSE_TERMS,
    LINEAR_TERMS,
    MISSING_TERMS,
    SIZE_TERMS,
    linear_terms,
)
from agents.search import (
    SIZE_ROBOTS,
    SearchConfig,
    costing,
    first_mu,
    search,
    search_ranges,
    search_spec,
    validate,
)
from agents.search_costs import costs, member_costs, play_weights, pool
from agents.spec import saved_spec
from tests.test_search import TINY

#: Two small scenarios of a search (3 and 6 robots, one swarm, one with clutter), two seeds each.
SMALL = SearchConfig(pictures=4, ranges=ConditionRanges(robots=(3, 6), pictures=4, p_swarm=0.5))


def _scenarios(config: SearchConfig) -> list:
    rng = np.random.default_rng(11)
    return [(draw_scenario(rng, config.ranges), [5, 6]) for _ in range(2)]


def test_costs_are_the_same_bits_in_a_pool_of_processes() -> None:
    members = np.random.default_rng(3).normal(0.0, 1.0, (3, len(LINEAR_TERMS)))
    scenarios = _scenarios(SMALL)
    here = costs(members, scenarios, costing(SMALL), LINEAR_SPEC)
    executor = pool(2)
    assert executor is not None
    with executor:
        there = costs(members, scenarios, costing(SMALL), LINEAR_SPEC, executor)
    for a, b in zip(here, there, strict=True):
        np.testing.assert_array_equal(a, b)
    assert pool(1) is None


def test_the_validation_is_the_same_in_a_pool_of_processes() -> None:
    """Free, swarm and crowd validations of some weights at rest: every ratio, interval and
    mean equal to the bit, whether one process plays the episodes or a pool."""
    weights = np.random.default_rng(5).normal(0.0, 1.0, len(LINEAR_TERMS))
    here = validate(weights, 4, 4, 0.9999, LINEAR_SPEC, crowd=True)
    executor = pool(2)
    assert executor is not None
    with executor:
        there = validate(weights, 4, 4, 0.9999, LINEAR_SPEC, True, executor)
    assert there == here
    assert {k.split("_")[0] for k in here} == {"free", "swarm", "crowd"}


def test_the_baseline_is_the_ablation_or_plain_uniform() -> None:
    """Zero weights at rest cost exactly nothing against their ablation; against ``uniform``
    their ratios are ``uniform-rest``'s over ``uniform``'s, episode for episode."""
    rest = dataclasses.replace(SMALL, rest=0.9999)
    spec = search_spec(rest)
    zeros = np.zeros((1, len(spec.terms)))
    scenarios = _scenarios(rest)
    cost, ratios, _ = costs(zeros, scenarios, costing(rest), spec)
    assert cost[0] == 0.0
    np.testing.assert_array_equal(ratios, [[1.0, 1.0]])
    plain = dataclasses.replace(rest, against="uniform")
    cost, ratios, _ = costs(zeros, scenarios, costing(plain), spec)
    expected = []
    for scenario, seeds in scenarios:
        at_rest = play_weights(scenario, zeros[0], seeds, 4, 0.9999, spec)[0].mean(axis=0)
        moving = play_weights(scenario, zeros[0], seeds, 4, None, spec)[0].mean(axis=0)
        expected.append(np.log(at_rest / moving))
    np.testing.assert_allclose(ratios[0], np.exp(np.mean(expected, axis=0)), rtol=1e-12)
    assert ratios[0, 1] < 1.0  # resting robots spend less than moving ones


def test_energy_under_the_cap_costs_nothing() -> None:
    ratios = np.array([[[1.1, 0.7], [0.9, 0.75]], [[1.1, 0.9], [0.9, 0.75]]])
    capped = member_costs(ratios, 2.0, 0.8)
    assert capped[0] == pytest.approx((math.log(1.1) + math.log(0.9)) / 2, abs=1e-15)
    assert capped[1] == pytest.approx(capped[0] + 2.0 * math.log(0.9 / 0.8) / 2, abs=1e-15)
    uncapped = member_costs(ratios, 2.0, None)
    assert uncapped[0] == pytest.approx(capped[0] + (math.log(0.7) + math.log(0.75)), abs=1e-15)


def test_a_size_search_has_the_size_terms_and_draws_larger_teams() -> None:
    config = SearchConfig(size=True)
    assert search_spec(config).terms == LINEAR_TERMS + SIZE_TERMS
    assert set(SIZE_ROBOTS) <= set(search_ranges(config).robots)
    assert search_ranges(SearchConfig()).robots == ConditionRanges().robots
    # each size term is its base times ``rows`` in free motion, 0 on duty
    spec = search_spec(config)
    columns = spec.columns()
    rng = np.random.default_rng(0)
    cands = rng.random((4, 8, len(spec.candidate_features)))
    context = rng.random((4, len(spec.context_features)))
    context[:, columns[1]["on_duty"]] = [0.0, 1.0, 0.0, 1.0]
    terms = linear_terms(cands, context, np.stack, spec.terms, columns)
    energy_rows = [t.name for t in spec.terms].index("energy*rows_free")
    rows = context[:, None, columns[1]["rows"]] * np.array([1.0, 0.0, 1.0, 0.0])[:, None]
    expected = cands[..., columns[0]["energy"]] * rows
    np.testing.assert_array_equal(terms[..., energy_rows], expected)
    assert np.all(terms[[1, 3]][..., len(LINEAR_TERMS) :] == 0.0)  # nothing on duty


def test_a_search_starts_from_a_saved_agents_weights_by_term_name(tmp_path: Path) -> None:
    weights = np.linspace(-1.0, 1.0, len(LINEAR_TERMS))
    path = save_linear_agent(weights, tmp_path / "agent.zip")
    saved = linear_weights(path)
    assert list(saved) == [t.name for t in LINEAR_TERMS]
    np.testing.assert_allclose(list(saved.values()), weights, atol=1e-7)  # float32 in the zip
    mu = first_mu(SearchConfig(start=str(path), size=True))
    np.testing.assert_allclose(mu[: len(LINEAR_TERMS)], weights, atol=1e-7)
    assert mu[len(LINEAR_TERMS) :] == [0.0] * len(SIZE_TERMS)
    assert first_mu(SearchConfig()) == [0.0] * len(LINEAR_TERMS)
    bundled = LINEAR_TERMS + SIZE_TERMS + DENSE_TERMS + MISSING_TERMS  # ninth round
    assert list(linear_weights("bundled")) == [t.name for t in bundled]
    # a search of the size terms from the bundled agent starts from its weights of those terms
    mu = first_mu(SearchConfig(start="bundled", size=True))
    assert mu == [linear_weights("bundled")[t.name] for t in LINEAR_TERMS + SIZE_TERMS]


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("workers", 0, "workers"),
        ("workers", 1000, "workers"),
        ("energy_cap", 0.0, "energy_cap"),
        ("energy_cap", 11.0, "energy_cap"),
        ("against", "random", "against must be"),
        ("start", "no/such/agent.zip", "start must be"),
    ],
)
def test_the_new_fields_are_checked_when_built(field: str, value: object, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        dataclasses.replace(SearchConfig(), **{field: value})


def test_a_search_resumed_with_more_workers_finds_the_same_weights(tmp_path: Path) -> None:
    tiny = dataclasses.replace(TINY, scenarios=2, validate_every=5)
    whole = search(tiny, tmp_path / "whole", log=lambda _: None)
    cut = dataclasses.replace(tiny, generations=1)
    search(cut, tmp_path / "cut", log=lambda _: None)
    data = json.loads((tmp_path / "cut" / "search.json").read_text())
    data["config"]["generations"] = 2  # as if the first run had been killed after generation 0
    (tmp_path / "cut" / "search.json").write_text(json.dumps(data))
    resumed = search(
        dataclasses.replace(tiny, workers=2), tmp_path / "cut", log=lambda _: None, resume=True
    )
    np.testing.assert_array_equal(resumed, whole)


def test_anonloc_search_from_the_bundled_agent_with_size_terms_as_users_run_it(
    tmp_path: Path,
) -> None:
    """The real console script with the new options: two workers, the size terms, a start from
    the bundled agent, plain ``uniform`` as the baseline and an energy cap; bad values of the
    new options are refused with the option named, before any work."""
    from tests.cli_helpers import run_script

    out = tmp_path / "size"
    small = ["--pairs", "1", "--scenarios", "1", "--seeds", "1", "--pictures", "3"]
    small += ["--validation-episodes", "2", "--generations", "1", "--rest", "0.9999"]
    new = ["--size", "--start", "bundled", "--against", "uniform", "--energy-cap", "0.8"]
    done = run_script("search", out, *small, *new, "--workers", "2", timeout=300)
    assert done.returncode == 0, done.stderr
    spec = saved_spec(out / "agent.zip")
    assert spec is not None
    assert spec.terms == LINEAR_TERMS + SIZE_TERMS
    config = json.loads((out / "search.json").read_text())["config"]
    assert (config["start"], config["against"], config["energy_cap"]) == ("bundled", "uniform", 0.8)
    for option, value, message in (
        ("--energy-cap", "0", "energy_cap"),
        ("--against", "chance", "against must be"),
        ("--workers", "0", "workers"),
    ):
        bad = run_script("search", tmp_path / "bad", option, value)
        assert bad.returncode != 0
        assert message in bad.stderr
        assert not (tmp_path / "bad" / "search.json").exists()
