"""The candidates of several env copies scored in one call (``baselines.active.
entropies_together``) give each robot the bits its own copy's call gives, and so does the
belief VecEnv that scores its copies that way."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import pytest

import anonloc_env
from agents.conditions import ConditionRanges, training_scenarios
from agents.spec import AgentSpec, Reward
from baselines import active
from baselines.active import (
    Hypotheses,
    PredictionGeometry,
    ScoringJob,
    entropies_together,
    expected_entropy,
    unicycle,
)

if TYPE_CHECKING:  # the VecEnv needs stable-baselines3 (the rl extra): imported where used
    from agents.vec import AnonLocVecEnv


def _job(rng: np.random.Generator, r: int, k: int, known: float, spread: float) -> ScoringJob:
    """A random job: ``r`` robots, ``k`` hypotheses (some of weight 0, zeros last), a share
    ``known`` of known headings, hypotheses up to ``spread`` image units apart."""
    weight = rng.random((r, k)) * (rng.random((r, k)) < 0.6)
    weight[:, 0] += 0.01
    weight = -np.sort(-weight, axis=1)
    hyp = Hypotheses(
        weight=weight / weight.sum(axis=1, keepdims=True),
        pos=rng.uniform(0.0, spread, (r, k, 2)),
        theta=rng.uniform(-math.pi, math.pi, (r, k)),
        theta_var=rng.uniform(1e-4, 1e-1, (r, k)),
        known=rng.random((r, k)) < known,
    )
    geo = PredictionGeometry(
        scale=float(rng.uniform(50.0, 150.0)),
        pixel_var=float(rng.uniform(0.5, 4.0)),
        scale_spread=float(rng.uniform(0.0, 0.1)),
        clutter=float(rng.uniform(1e-6, 1e-4)),
        p_detect=float(rng.uniform(0.8, 1.0)),
        duration=0.5,
    )
    cand = np.stack([rng.uniform(0.1, 0.5, (r, 8)), rng.uniform(-1.0, 1.0, (r, 8))], axis=-1)
    own = unicycle(cand[..., 0], cand[..., 1], 0.5)
    others = unicycle(rng.uniform(0.1, 0.5, (r, 15)), rng.uniform(-1.0, 1.0, (r, 15)), 0.5)
    return ScoringJob(cand, hyp, geo, own, others, np.zeros((r, 8)), 8)


def test_jobs_scored_together_equal_each_jobs_own_call() -> None:
    """Jobs of different sizes, geometry, headings and hypotheses: stacked where their shapes
    agree, each robot's entropies are its own job's, to the bit."""
    rng = np.random.default_rng(11)
    jobs = [
        _job(rng, r, k, known, 400.0)
        for r, k, known in [(5, 6, 1.0), (3, 6, 1.0), (7, 6, 0.3), (4, 2, 1.0), (6, 6, 0.0)]
    ]
    together = entropies_together(jobs)
    for job, entropy in zip(jobs, together, strict=True):
        assert entropy.shape == job.commands.shape[:2]
        np.testing.assert_array_equal(entropy, job.entropy())


def test_far_apart_hypotheses_keep_the_bits_of_the_unclamped_densities(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Densities of exponents below ``EXP_FLOOR`` (hypotheses far apart, which underflow) are
    raised to ``exp(EXP_FLOOR)``: the expected entropies are those of the exact densities."""
    rng = np.random.default_rng(4)
    jobs = [_job(rng, 9, 6, known, 5000.0) for known in (1.0, 0.5, 0.0)]
    clamped = [job.entropy() for job in jobs]
    monkeypatch.setattr(active, "EXP_FLOOR", -np.inf)
    with np.errstate(under="ignore"):
        exact = [job.entropy() for job in jobs]
    for a, b in zip(clamped, exact, strict=True):
        np.testing.assert_array_equal(a, b)


def test_hypotheses_that_weigh_nothing_for_every_robot_are_left_out_without_a_trace(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """``expected_entropy`` leaves out the hypotheses of weight 0 for every robot: the result is
    that of computing them all."""
    rng = np.random.default_rng(8)
    for known in (1.0, 0.4):
        job = _job(rng, 6, 6, known, 400.0)
        weight = job.hyp.weight.copy()
        weight[:, 2:] = 0.0  # columns 2 to 5 weigh nothing for everyone
        weight[:, 1] *= rng.random(6) < 0.5  # column 1 for some
        weight /= weight.sum(axis=1, keepdims=True)
        hyp = Hypotheses(weight, job.hyp.pos, job.hyp.theta, job.hyp.theta_var, job.hyp.known)
        short = expected_entropy(hyp, job.own, job.others, job.geo)
        monkeypatch.setattr(active, "_live", lambda h: h)
        every = expected_entropy(hyp, job.own, job.others, job.geo)
        monkeypatch.undo()
        np.testing.assert_array_equal(short, every)


def _rollout(venv: AnonLocVecEnv, steps: int) -> list[tuple[object, ...]]:
    rng = np.random.default_rng(0)
    venv.seed(3)
    out: list[tuple[object, ...]] = [tuple(venv.reset().values())]
    for _ in range(steps):
        obs, rewards, dones, infos = venv.step(rng.integers(0, 8, venv.num_envs))
        teacher = [info["teacher"] for info in infos]
        out.append((*obs.values(), rewards, dones, teacher))
    return out


@pytest.mark.parametrize("mixed", [False, True])
def test_the_vec_env_scores_its_copies_together_with_the_bits_of_one_by_one(
    monkeypatch: pytest.MonkeyPatch, mixed: bool
) -> None:
    """A seeded run of the belief VecEnv (clutter and misses; or copies of different scenarios,
    redrawn at every episode's end) equals the same run with every copy scored by its own
    call, observations, rewards, ends and teachers to the bit; the first pictures of the copies
    that start an episode together are scored together too."""
    pytest.importorskip("stable_baselines3")
    import agents.vec
    from agents.vec import AnonLocVecEnv

    def build() -> AnonLocVecEnv:
        spec = AgentSpec(reward=Reward(identity="team"))
        if mixed:
            ranges = ConditionRanges(pictures=3)
            scenarios = training_scenarios(4, seed=1, ranges=ranges)
            return AnonLocVecEnv(scenarios[0].config, scenarios=scenarios, redraw=ranges)
        config = anonloc_env.make_config(
            n_robots=8, max_cycles=100, camera={"p_miss": 0.08, "false_positives": 2.0}
        )
        return AnonLocVecEnv(config, n_envs=3, spec=spec)

    stacked: list[int] = []
    original = active.expected_entropy

    def counted(hyp: Hypotheses, *args: object) -> np.ndarray:
        stacked.append(len(hyp.weight))
        return original(hyp, *args)  # type: ignore[arg-type]

    monkeypatch.setattr(active, "expected_entropy", counted)
    together = _rollout(build(), 12)
    sizes = {crew.n for crew in build().crews}
    assert max(stacked) > max(sizes)  # robots of several copies did go through one call
    if not mixed:  # every call, the first pictures of new episodes included, stacks all copies
        assert set(stacked) == {3 * 8}
        assert len(stacked) > 12 + 1  # the resets' calls came too
    monkeypatch.setattr(agents.vec, "entropies_together", lambda jobs: [j.entropy() for j in jobs])
    one_by_one = _rollout(build(), 12)
    for a, b in zip(together, one_by_one, strict=True):
        for x, y in zip(a, b, strict=True):
            np.testing.assert_array_equal(x, y)
