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
from baselines.statistics import Interval95, SurvivalMedian, bootstrap_mean, km_median


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
    pictures = sorted({rec.picture for rec in result.records if rec.localizer == localizer})
    robots = sorted({rec.robot for rec in result.records if rec.localizer == localizer})
    column = {picture: k for k, picture in enumerate(pictures)}
    correct = np.zeros((len(robots), len(pictures)), bool)
    present = np.zeros_like(correct)
    energy = np.zeros(correct.shape)
    for rec in result.records:
        if rec.localizer == localizer:
            at = (rec.robot, column[rec.picture])
            correct[at], present[at], energy[at] = rec.correct, rec.true_index >= 0, rec.energy
    first, spent = first_identified(correct, present, energy, fraction)
    return (None, math.nan) if first is None else (pictures[first], spent)


def first_identified(
    correct: np.ndarray, present: np.ndarray, energy: np.ndarray, fraction: float = 0.99
) -> tuple[int | None, float]:
    """The array form of :func:`pictures_to_identify`: ``(R, P)`` arrays of each robot at each
    picture (decided on its true row; in the picture; wheel travel since reset, m). Returns the
    first picture's column at which at least ``ceil(fraction * present)`` robots are correct, and
    the mean energy of all robots then; ``(None, nan)`` if none.

    Raises:
        ValueError: ``fraction`` outside (0, 1].
    """
    if not 0.0 < fraction <= 1.0:
        raise ValueError(f"fraction must be in (0, 1], got {fraction}")
    counted = present.sum(axis=0)
    hits = (correct & present).sum(axis=0)
    # An integer comparison: 99 of 100 robots reach 0.99 despite rounding.
    reached = np.flatnonzero((counted > 0) & (hits >= np.ceil(fraction * counted - 1e-9)))
    if len(reached) == 0:
        return None, math.nan
    first = int(reached[0])
    return first, float(energy[:, first].mean())


@dataclass(frozen=True)
class IdentificationSummary:
    """:func:`pictures_to_identify` over several episodes.

    Attributes:
        episodes: number of episodes.
        identified: how many reached the fraction (the means are over those only).
        pictures: picture index at which they did (mean and interval).
        energy: mean wheel travel per robot until then (m; mean and interval).
        pictures_all: the same over every episode, one that never reached the fraction counted
            at one past its last picture (a lower bound for it: a censored mean).
        median: the Kaplan-Meier median picture with its interval, an episode that never
            reached the fraction censored at its last picture
            (:func:`baselines.statistics.km_median`).
    """

    episodes: int
    identified: int
    pictures: Interval95
    energy: Interval95
    pictures_all: Interval95
    median: SurvivalMedian


def summarize(
    results: Sequence[EpisodeResult],
    fraction: float = 0.99,
    confidence: float = 0.95,
    localizer: str = "",
) -> IdentificationSummary:
    """:func:`pictures_to_identify` of each episode, summarised with bootstrap intervals and
    the Kaplan-Meier median."""
    scores = [pictures_to_identify(r, fraction, localizer) for r in results]
    reached = [(p, e) for p, e in scores if p is not None]
    last = [max((rec.picture for rec in r.records), default=0) for r in results]
    censored = [p if p is not None else 1 + end for (p, _), end in zip(scores, last, strict=True)]
    times = [p if p is not None else end for (p, _), end in zip(scores, last, strict=True)]
    return IdentificationSummary(
        episodes=len(results),
        identified=len(reached),
        pictures=bootstrap_mean([p for p, _ in reached], confidence),
        energy=bootstrap_mean([e for _, e in reached], confidence),
        pictures_all=bootstrap_mean(censored, confidence),
        median=km_median(times, [p is not None for p, _ in scores], confidence),
    )
