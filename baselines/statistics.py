"""Confidence intervals, from scipy: one module for every figure the project reports.

* :func:`wilson`: a success rate's Wilson score interval
  (``scipy.stats.binomtest(k, n).proportion_ci(method="wilson")``);
* :func:`bootstrap_mean`: a mean with its percentile-bootstrap interval
  (``scipy.stats.bootstrap``, seeded);
* :func:`paired_ratio`: ``mean(a) / mean(b)`` of two excitations played on the same seeds, with
  a bootstrap interval that resamples the episodes jointly (numpy only);
* :func:`km_median`: the Kaplan-Meier median of a time that some episodes never reach (pictures
  to 99 %), with its interval (``scipy.stats.ecdf`` on ``scipy.stats.CensoredData``).

>>> wilson(168, 200)  # doctest: +ELLIPSIS
(0.7828..., 0.8843...)
>>> km_median([2, 3, 3, 5, 30], [True, True, True, True, False]).median
3.0

scipy is in the ``baselines`` and ``cli`` extras (not the core install): it is imported when a
function here is first called, and its absence raises an error naming the extra.
"""

from __future__ import annotations

import inspect
import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from types import ModuleType
from typing import Any

import numpy as np


def _stats() -> ModuleType:
    """``scipy.stats``, or an ImportError naming the extra that installs it."""
    try:
        from scipy import stats
    except ImportError as error:
        raise ImportError(
            "confidence intervals need scipy: pip install 'anonloc[baselines]'"
        ) from error
    return stats


def _check_confidence(confidence: float) -> None:
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence}")


def wilson(successes: int, trials: int, confidence: float = 0.95) -> tuple[float, float]:
    """The Wilson score interval of ``successes`` out of ``trials``, as fractions.

    scipy's bounds always hold the rate (5 of 5 gives an upper bound of exactly 1.0).
    ``(0.0, 1.0)`` without trials.

    Raises:
        ValueError: ``trials`` < 0, ``successes`` outside [0, trials], or ``confidence``
            outside (0, 1).
    """
    _check_confidence(confidence)
    if trials < 0 or not 0 <= successes <= max(trials, 0):
        raise ValueError(
            f"successes must be in [0, trials] and trials >= 0, got {successes} of {trials}"
        )
    if trials == 0:
        return (0.0, 1.0)
    result = _stats().binomtest(int(successes), int(trials))
    ci = result.proportion_ci(confidence_level=confidence, method="wilson")
    return (float(ci.low), float(ci.high))


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


def _seed_keyword() -> str:
    """``scipy.stats.bootstrap``'s seed argument: ``rng`` since scipy 1.15, ``random_state``
    before (the floor is 1.13)."""
    parameters = inspect.signature(_stats().bootstrap).parameters
    return "rng" if "rng" in parameters else "random_state"


def bootstrap_mean(
    values: Sequence[float], confidence: float = 0.95, resamples: int = 10_000, seed: int = 0
) -> Interval95:
    """The mean of ``values`` with a percentile-bootstrap interval (``scipy.stats.bootstrap``,
    seeded, so reproducible). One value gives a zero-width interval; none gives nans.

    Raises:
        ValueError: ``confidence`` outside (0, 1) or ``resamples`` < 1.
    """
    _check_confidence(confidence)
    if resamples < 1:
        raise ValueError(f"resamples must be >= 1, got {resamples}")
    x = np.asarray(values, dtype=np.float64)
    if len(x) == 0:
        return Interval95(math.nan, math.nan, math.nan)
    mean = float(x.mean())
    if len(x) == 1 or np.all(x == x[0]):  # (scipy refuses one value; no spread to resample)
        return Interval95(mean, mean, mean)
    seeding: dict[str, Any] = {_seed_keyword(): np.random.default_rng(seed)}
    result = _stats().bootstrap(
        (x,),
        np.mean,
        n_resamples=resamples,
        confidence_level=confidence,
        method="percentile",
        vectorized=True,
        **seeding,
    )
    interval = result.confidence_interval
    return Interval95(mean, float(interval.low), float(interval.high))


@dataclass(frozen=True)
class SurvivalMedian:
    """The Kaplan-Meier median of a time some episodes never reach, with its interval.

    Attributes:
        median: the first time at which the Kaplan-Meier survival estimate is at most 1/2
            (``inf`` if it never is: fewer than half the episodes are known to have reached it).
        low: lower bound: the first time at which the survival band's lower edge is at most 1/2
            (``inf`` if never).
        high: upper bound: the same for the band's upper edge (``inf`` if it never drops to
            1/2: the data bound the median only from below).
        episodes: how many episodes.
        reached: how many reached it (the others are censored at their last time).
    """

    median: float
    low: float
    high: float
    episodes: int
    reached: int

    def __str__(self) -> str:
        def text(x: float) -> str:
            return f"{x:.3g}" if math.isfinite(x) else "inf"

        if self.episodes == 0:
            return "n/a"
        return f"{text(self.median)} [{text(self.low)}, {text(self.high)}]"


def km_median(
    times: Sequence[float], reached: Sequence[bool], confidence: float = 0.95
) -> SurvivalMedian:
    """The Kaplan-Meier median of ``times`` and its pointwise confidence interval.

    An episode that reached the event at ``times[i]`` has ``reached[i]`` True; one that did not
    is right-censored at ``times[i]`` (its last picture: the event, if ever, came later). The
    survival function and its pointwise band (Greenwood's variance, the ``log-log``
    transform, so the band stays in [0, 1]) are scipy's (``ecdf(CensoredData).sf``). The median
    is the first time at which the estimate is at most 1/2; its interval runs from the first
    time the band's lower edge is, to the first time its upper edge is (Brookmeyer and
    Crowley's construction, as R's ``survfit`` reports it). Where the estimate is 0 (every
    episode still running there reached the event), the band is taken as 0 too: the formula is
    undefined there and nothing is left at risk.

    Returns:
        a :class:`SurvivalMedian`; its bounds are ``inf`` where the band never drops to 1/2
        (too few episodes reached the event to bound it), and all nan without episodes.

    Raises:
        ValueError: ``times`` and ``reached`` differ in length, a time is not finite, or
            ``confidence`` is outside (0, 1).
    """
    _check_confidence(confidence)
    t = np.asarray(times, dtype=np.float64)
    done = np.asarray(reached, dtype=bool)
    if t.shape != done.shape or t.ndim != 1:
        raise ValueError(
            f"times and reached must be 1-D of one length, got {t.shape} and {done.shape}"
        )
    if not np.all(np.isfinite(t)):
        raise ValueError("times must be finite (censor an unfinished episode at its last time)")
    if len(t) == 0:
        return SurvivalMedian(math.nan, math.nan, math.nan, 0, 0)
    if not done.any():
        return SurvivalMedian(math.inf, math.inf, math.inf, len(t), 0)
    stats = _stats()
    sample = stats.CensoredData.right_censored(t, ~done)
    sf = stats.ecdf(sample).sf
    with warnings.catch_warnings():  # (nan where the estimate is 0 or 1: handled below)
        warnings.simplefilter("ignore", RuntimeWarning)
        band = sf.confidence_interval(confidence, method="log-log")
    point = sf.probabilities
    lower = np.where(point == 0.0, 0.0, np.nan_to_num(band.low.probabilities, nan=1.0))
    upper = np.where(point == 0.0, 0.0, np.nan_to_num(band.high.probabilities, nan=1.0))

    def first_at_half(curve: np.ndarray) -> float:
        below = np.flatnonzero(curve <= 0.5)
        return float(sf.quantiles[below[0]]) if len(below) else math.inf

    return SurvivalMedian(
        median=first_at_half(point),
        low=first_at_half(lower),
        high=first_at_half(upper),
        episodes=len(t),
        reached=int(done.sum()),
    )


def paired_ratio(
    a: Sequence[float] | np.ndarray, b: Sequence[float] | np.ndarray, resamples: int = 10_000
) -> Interval95:
    """``mean(a) / mean(b)`` over episodes played on the same seeds, with a 95 % bootstrap
    interval that resamples the episodes jointly (seeded)."""
    x, y = np.asarray(a, np.float64), np.asarray(b, np.float64)
    if x.shape != y.shape or not len(x):
        raise ValueError(f"paired samples must have one equal length > 0, got {x.shape, y.shape}")
    pick = np.random.default_rng(0).integers(0, len(x), size=(resamples, len(x)))
    ratios = x[pick].mean(axis=1) / np.maximum(y[pick].mean(axis=1), 1e-12)
    low, high = np.quantile(ratios, [0.025, 0.975])
    return Interval95(float(x.mean() / max(y.mean(), 1e-12)), float(low), float(high))
