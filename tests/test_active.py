"""The distinct and greedy excitations, and the identification score."""

from __future__ import annotations

import math

import numpy as np
import pytest

import anonloc_env
import baselines
from baselines import active
from baselines.active import (
    GreedyIdentification,
    GreedySettings,
    Hypotheses,
    PredictionGeometry,
    expected_entropy,
    unicycle,
)
from baselines.excitations import DistinctMotion, SwarmDuty
from baselines.registry import EXCITATIONS
from baselines.runner import EpisodeResult, PictureRecord, run_episode
from baselines.scoring import pictures_to_identify, summarize
from baselines.statistics import bootstrap_mean


def _config(n: int = 10) -> anonloc_env.EnvConfig:
    side = math.sqrt(n)
    return anonloc_env.make_config(
        n_robots=n,
        arena_size=(side, side),
        camera={"pixel_noise": 1.0, "orientation": False},
        max_cycles=400,
    )


def _record(robot: int, picture: int, correct: bool, energy: float, true: int = 0) -> PictureRecord:
    return PictureRecord("", robot, picture, float(picture), 0, true, correct, 0.5, energy)


def test_pictures_to_identify_hand_built() -> None:
    records = [
        _record(0, 0, False, 0.0),
        _record(1, 0, False, 0.0),
        _record(0, 1, True, 1.0),
        _record(1, 1, False, 3.0),
        _record(0, 2, True, 2.0),
        _record(1, 2, True, 4.0, true=-1),  # not in the picture: does not count
        _record(0, 3, True, 5.0),
        _record(1, 3, True, 7.0),
    ]
    result = EpisodeResult(seed=0, n_robots=2, records=records)
    # Picture 2: the only robot present is right; energy is over all robots.
    assert pictures_to_identify(result) == (2, 3.0)
    assert pictures_to_identify(result, fraction=0.5) == (1, 2.0)
    never = EpisodeResult(seed=0, n_robots=2, records=records[:4])
    picture, energy = pictures_to_identify(never)
    assert picture is None
    assert math.isnan(energy)
    with pytest.raises(ValueError, match="fraction"):
        pictures_to_identify(result, fraction=0.0)


def test_ninety_nine_of_a_hundred_reach_99_percent() -> None:
    records = [_record(i, 0, i > 0, 1.0, true=i) for i in range(100)]
    assert pictures_to_identify(EpisodeResult(0, 100, records)) == (0, 1.0)


def test_summary_counts_and_interval() -> None:
    results = [
        EpisodeResult(0, 1, [_record(0, 0, False, 0.0), _record(0, p, True, float(p))])
        for p in (1, 2, 3)
    ]
    results.append(EpisodeResult(0, 1, [_record(0, 0, False, 0.0)]))
    s = summarize(results)
    assert (s.episodes, s.identified) == (4, 3)
    assert s.pictures.mean == 2.0
    assert 1.0 <= s.pictures.low <= s.pictures.high <= 3.0
    assert s.energy.mean == 2.0
    # Every episode: the one that never got there counts at one past its last picture (1).
    assert s.pictures_all.mean == (1 + 2 + 3 + 1) / 4
    # Kaplan-Meier: events at 1, 2, 3, one censored at 0 (its last picture): S(2) = 1/3.
    assert (s.median.median, s.median.reached, s.median.episodes) == (2.0, 3, 4)
    assert bootstrap_mean([4.0, 4.0]).low == 4.0


def test_unicycle_displacement() -> None:
    d = unicycle(np.array([1.0, 1.0]), np.array([0.0, math.pi / 2]), 1.0)
    np.testing.assert_allclose(d[0], [1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(d[1], [2 / math.pi, 2 / math.pi], atol=1e-12)
    w = np.array([[0.0, 1e-8, 0.7], [-2.0, 0.3, 1.0]])
    v = np.array([0.2, -0.1, 0.3])
    together = unicycle(v, w, 0.8)  # shapes broadcast: each pair as on its own
    assert together.shape == (2, 3, 2)
    for i, j in np.ndindex(w.shape):
        np.testing.assert_array_equal(together[i, j], unicycle(v[j], w[i, j], 0.8))


def _two_hypotheses(known: bool) -> Hypotheses:
    return Hypotheses(
        weight=np.array([[0.5, 0.5]]),
        pos=np.array([[[0.0, 0.0], [300.0, 0.0]]]),
        theta=np.zeros((1, 2)),
        theta_var=np.full((1, 2), 1e-4),
        known=np.full((1, 2), known),
    )


GEO = PredictionGeometry(
    scale=100.0, pixel_var=1.0, scale_spread=0.0, clutter=1e-5, p_detect=1.0, duration=1.0
)


@pytest.mark.parametrize("known", [True, False])
def test_separating_command_wins(known: bool) -> None:
    """The other robot surely drives straight at 0.3 m/s: copying it leaves both hypotheses
    alive, anything else separates them."""
    others = unicycle(np.array([[0.3]]), np.array([[0.0]]), 1.0)
    own = unicycle(np.array([[0.3, 0.1]]), np.array([[0.0, 0.0]]), 1.0)
    entropy = expected_entropy(_two_hypotheses(known), own, others, GEO)
    assert entropy[0, 0] > 0.5  # near log 2: nothing learnt
    assert entropy[0, 1] < 0.05
    if known:  # with headings, a turn separates as well as a change of speed
        turn = unicycle(np.array([[0.3]]), np.array([[1.0]]), 1.0)
        assert expected_entropy(_two_hypotheses(True), turn, others, GEO)[0, 0] < 0.05


def test_greedy_picks_the_separating_command() -> None:
    """End to end through choose(): of the candidates, the robot drives one unlike the others'."""
    settings = GreedySettings(candidates=16, others=((0.3, 0.0),), energy_weight=0.0)
    greedy = GreedyIdentification(settings)
    greedy.reset([np.random.default_rng(1)])
    greedy._pending = (_two_hypotheses(False), GEO, 0.1)
    greedy.choose()
    assert abs(greedy.v[0] - 0.3) > 0.03


def _episode(excitation: object, seed: int, n: int = 10, pictures: int = 12) -> EpisodeResult:
    env = anonloc_env.AnonLocEnv(_config(n), reward_fn=anonloc_env.EnergyCost())
    team = baselines.make_team("bayes", env, excitation=excitation)  # type: ignore[arg-type]
    return run_episode(env, team, seed, max_pictures=pictures)


def test_greedy_is_deterministic_given_the_seed() -> None:
    a = _episode("greedy", seed=3, pictures=6)
    b = _episode("greedy", seed=3, pictures=6)
    assert a.rows() == b.rows()
    c = _episode("greedy", seed=4, pictures=6)
    assert a.rows() != c.rows()


def test_registered_names_build() -> None:
    assert isinstance(EXCITATIONS["greedy"](), GreedyIdentification)
    assert isinstance(EXCITATIONS["distinct"](), DistinctMotion)


@pytest.mark.parametrize("name", ["distinct", "greedy"])
def test_beats_random_motion_on_ten_robots(name: str) -> None:
    """Mean pictures until all 10 robots are identified, over 8 seeded episodes: no more than
    random motion's (measured: random 6.3, distinct 3.5, greedy 3.6 over 10 to 20 episodes)."""
    seeds = range(8)

    def mean_pictures(spec: str) -> float:
        scores = [pictures_to_identify(_episode(spec, s)) for s in seeds]
        return float(np.mean([12 if p is None else p for p, _ in scores]))

    assert mean_pictures(name) <= mean_pictures("random")


@pytest.mark.parametrize("name", ["distinct", "greedy"])
def test_works_as_swarm_deviation(name: str) -> None:
    own = EXCITATIONS[name]()
    duty = SwarmDuty(own, budget=0.2, common_seed=5)
    result = _episode(duty, seed=5, pictures=10)
    assert any(r.correct for r in result.records)
    if isinstance(own, GreedyIdentification):
        assert own.following
        assert np.all(np.abs(own.v) <= own.settings.speed[1] + 1e-12)


@pytest.mark.parametrize("ring_samples", [8, 5])
def test_known_headings_fast_path_equals_the_general_path(ring_samples: int) -> None:
    """Where every heading is known, ``expected_entropy`` computes each density once instead of
    on every ring point: the densities are the general path's to the bit."""
    rng = np.random.default_rng(7)
    r, k, c, s = 5, 6, 8, 15
    weight = rng.random((r, k))
    hyp = Hypotheses(
        weight=weight / weight.sum(axis=1, keepdims=True),
        pos=rng.uniform(0.0, 200.0, (r, k, 2)),
        theta=rng.uniform(-math.pi, math.pi, (r, k)),
        theta_var=rng.uniform(1e-4, 1e-2, (r, k)),
        known=np.ones((r, k), bool),
    )
    own = unicycle(rng.uniform(0.1, 0.5, (r, c)), rng.uniform(-1, 1, (r, c)), 0.5)
    others = unicycle(rng.uniform(0.1, 0.5, (1, s)), rng.uniform(-1, 1, (1, s)), 0.5)
    rho = GEO.scale * np.hypot(own[..., 0], own[..., 1])
    var = rng.uniform(1.0, 4.0, (r, k, c))
    mu = hyp.pos[:, :, None, :] + rng.normal(0.0, 10.0, (r, k, c, 2))
    geometry = (rho, var, mu, GEO.scale)
    general = active._densities(hyp, own, others, geometry, ring_samples)
    fast = active._densities_known(hyp, own, others, geometry, ring_samples)
    for a, b in zip(general, fast, strict=True):
        np.testing.assert_array_equal(np.broadcast_to(b, a.shape), a)


def _random_hypotheses(rng: np.random.Generator, r: int, k: int) -> Hypotheses:
    weight = rng.random((r, k)) * (rng.random((r, k)) < 0.7)
    weight = -np.sort(-weight, axis=1)  # as GreedyIdentification sorts them: zeros last
    return Hypotheses(
        weight=weight / np.maximum(weight.sum(axis=1, keepdims=True), 1e-300),
        pos=rng.uniform(0.0, 200.0, (r, k, 2)),
        theta=rng.uniform(-math.pi, math.pi, (r, k)),
        theta_var=rng.uniform(1e-4, 1e-1, (r, k)),
        known=rng.random((r, k)) < 0.4,
    )


def test_collide_equals_every_point_computed() -> None:
    """The general path computes a known h* once and skips the ring points of h* of weight 0:
    where the weight counts, the values are those of every landing point computed and
    averaged."""
    rng = np.random.default_rng(3)
    r, k, c, m = 6, 5, 7, 8
    hyp = _random_hypotheses(rng, r, k)
    rho = rng.uniform(1.0, 60.0, (r, c))
    var = rng.uniform(1.0, 9.0, (r, k, c))
    mu = hyp.pos[:, :, None, :] + rng.normal(0.0, 20.0, (r, k, c, 2))
    phi = 2.0 * math.pi * (np.arange(m) + 0.5) / m
    circle = np.stack([np.cos(phi), np.sin(phi)], axis=-1)
    ring_points = hyp.pos[:, :, None, None, :] + rho[:, None, :, None, None] * circle
    known = hyp.known[:, :, None, None, None]
    land = np.where(known, mu[:, :, :, None, :], ring_points)
    every = active._density_at(  # axes (robot, h*, h', candidate, point): all computed
        land[:, :, None],
        mu[:, None, :, :, None, :],
        var[:, None, :, :, None],
        hyp.pos[:, None, :, None, None, :],
        rho[:, None, None, :, None],
        hyp.known[:, None, :, None, None],
    ).mean(axis=-1)
    fast = active._collide(hyp, land, mu, var, rho)
    counts = (hyp.weight > 0)[:, :, None, None] | hyp.known[:, :, None, None]
    np.testing.assert_array_equal(np.where(counts, fast, 0.0), np.where(counts, every, 0.0))


def test_hypotheses_of_weight_zero_change_nothing() -> None:
    """Padding hypotheses (weight 0) may sit anywhere, headings known or not: the expected
    entropy is the same to the bit."""
    rng = np.random.default_rng(5)
    hyp = _random_hypotheses(rng, 8, 6)
    zero = hyp.weight == 0
    assert zero.any()
    moved = Hypotheses(
        hyp.weight,
        np.where(zero[..., None], rng.uniform(0.0, 200.0, hyp.pos.shape), hyp.pos),
        hyp.theta,
        hyp.theta_var,
        np.where(zero, ~hyp.known, hyp.known),
    )
    own = unicycle(rng.uniform(0.1, 0.5, (8, 8)), rng.uniform(-1, 1, (8, 8)), 0.5)
    others = unicycle(rng.uniform(0.1, 0.5, (8, 15)), rng.uniform(-1, 1, (8, 15)), 0.5)
    np.testing.assert_array_equal(
        expected_entropy(moved, own, others, GEO), expected_entropy(hyp, own, others, GEO)
    )


def test_the_others_commands_follow_the_settings_and_deviation() -> None:
    """The others' commands are built once per settings and duty, read-only, and follow a
    change of settings (they equal ``GreedySettings.other_commands`` each time)."""
    excitation = GreedyIdentification(GreedySettings())
    for deviation in (False, True, False):
        got = excitation._other_commands(deviation)
        np.testing.assert_array_equal(got, excitation.settings.other_commands(deviation))
        assert not got.flags.writeable
    assert excitation._other_commands(True) is excitation._other_commands(True)
    own = np.array([[0.2, 0.5], [0.1, -0.5]])
    excitation.settings = GreedySettings(others=own)
    np.testing.assert_array_equal(excitation._other_commands(False), own)
    assert own.flags.writeable  # the caller's array is not frozen
