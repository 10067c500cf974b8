"""How fast a team is recognised: pictures until most robots are identified, and the energy spent.

The measure compares excitations (hand-designed or learned) that all feed one identifier: the
first picture at which at least ``fraction`` of the robots present in it are correctly identified
(their team's localizer decided, at its threshold, on their true row), and the mean wheel travel
per robot until that picture.

>>> import anonloc_env, baselines
>>> from baselines.runner import run_episode
>>> env = anonloc_env.AnonLocEnv(anonloc_env.make_config(n_robots=3, max_cycles=200))
>>> team = baselines.make_team("bayes", env, excitation="random")
>>> picture, energy = pictures_to_identify(run_episode(env, team, seed=0))
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from baselines.runner import EpisodeResult


def pictures_to_identify(
    result: EpisodeResult, fraction: float = 0.99, localizer: str = ""
) -> tuple[int | None, float]:
    """The first picture at which ``fraction`` of the robots present are correctly identified.

    Args:
        result: an episode from :func:`baselines.runner.run_episode`.
        fraction: share of the robots present in a picture that must be identified, in (0, 1].
            With N robots all present, ``ceil(fraction * N)`` of them.
        localizer: whose decisions count: ``""`` the team's own, else a listener's name.

    Returns:
        ``(picture, energy)``: the picture's index (0 is the picture taken at reset, so ``k``
        means ``k`` intervals of motion), and the mean over all robots of the wheel travel (m)
        until that picture; ``(None, nan)`` if no picture of the episode reached ``fraction``.
        Pictures without any robot in them never count.

    Raises:
        ValueError: ``fraction`` outside (0, 1].
    """
    if not 0.0 < fraction <= 1.0:
        raise ValueError(f"fraction must be in (0, 1], got {fraction}")
    present: dict[int, int] = {}
    correct: dict[int, int] = {}
    spent: dict[int, list[float]] = {}
    for rec in result.records:
        if rec.localizer != localizer:
            continue
        spent.setdefault(rec.picture, []).append(rec.energy)
        if rec.true_index >= 0:
            present[rec.picture] = present.get(rec.picture, 0) + 1
            correct[rec.picture] = correct.get(rec.picture, 0) + int(rec.correct)
    for picture in sorted(present):
        # An integer comparison: 99 of 100 robots reach 0.99 despite rounding.
        if correct[picture] >= math.ceil(fraction * present[picture] - 1e-9):
            return picture, float(np.mean(spent[picture]))
    return None, math.nan


@dataclass(frozen=True)
class Interval95:
    """A mean and its confidence interval.

    Attributes:
        mean: the sample mean (nan without samples).
        low: lower bound of the interval.
        high: upper bound.
    """

    mean: float
    low: float
    high: float

    def __str__(self) -> str:
        return f"{self.mean:.3g} [{self.low:.3g}, {self.high:.3g}]"


@dataclass(frozen=True)
class IdentificationSummary:
    """:func:`pictures_to_identify` over several episodes.

    Attributes:
        episodes: number of episodes.
        identified: how many reached the fraction (the means are over those only).
        pictures: picture index at which they did (mean and interval).
        energy: mean wheel travel per robot until then (m; mean and interval).
    """

    episodes: int
    identified: int
    pictures: Interval95
    energy: Interval95


def bootstrap_mean(
    values: Sequence[float], confidence: float = 0.95, resamples: int = 10_000, seed: int = 0
) -> Interval95:
    """The mean of ``values`` with a percentile-bootstrap interval (seeded, so reproducible).

    Raises:
        ValueError: ``confidence`` outside (0, 1) or ``resamples`` < 1.
    """
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence}")
    if resamples < 1:
        raise ValueError(f"resamples must be >= 1, got {resamples}")
    x = np.asarray(values, dtype=np.float64)
    if len(x) == 0:
        return Interval95(math.nan, math.nan, math.nan)
    rng = np.random.default_rng(seed)
    means = x[rng.integers(0, len(x), size=(resamples, len(x)))].mean(axis=1)
    tail = (1.0 - confidence) / 2.0
    low, high = np.quantile(means, [tail, 1.0 - tail])
    return Interval95(float(x.mean()), float(low), float(high))


def summarize(
    results: Sequence[EpisodeResult],
    fraction: float = 0.99,
    confidence: float = 0.95,
    localizer: str = "",
) -> IdentificationSummary:
    """:func:`pictures_to_identify` of each episode, summarised with bootstrap intervals."""
    scores = [pictures_to_identify(r, fraction, localizer) for r in results]
    reached = [(p, e) for p, e in scores if p is not None]
    return IdentificationSummary(
        episodes=len(results),
        identified=len(reached),
        pictures=bootstrap_mean([p for p, _ in reached], confidence),
        energy=bootstrap_mean([e for _, e in reached], confidence),
    )
