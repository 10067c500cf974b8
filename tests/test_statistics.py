"""baselines.statistics: the intervals from scipy, pinned against known values."""

from __future__ import annotations

import math

import numpy as np
import pytest

from baselines.paper import Rate
from baselines.statistics import Interval95, bootstrap_mean, km_median, wilson

Z95 = 1.959964


def _wilson_by_hand(successes: int, trials: int) -> tuple[float, float]:
    """The hand-written interval this module replaced (baselines/paper.py before issue 28)."""
    p = successes / trials
    centre = (p + Z95**2 / (2 * trials)) / (1 + Z95**2 / trials)
    half = Z95 * math.sqrt(p * (1 - p) / trials + Z95**2 / (4 * trials**2)) / (1 + Z95**2 / trials)
    return max(0.0, centre - half), min(1.0, centre + half)


def test_wilson_matches_the_old_formula_on_a_grid_to_the_printed_digit() -> None:
    # Every count up to 40 trials and at the reproduce table's 130, 200 and 236: the same
    # interval to 1e-8, so the same table to its printed 0.1 %; the bounds always hold the rate.
    for trials in [*range(1, 41), 130, 200, 236]:
        for successes in range(trials + 1):
            low, high = wilson(successes, trials)
            old_low, old_high = _wilson_by_hand(successes, trials)
            assert abs(low - old_low) < 1e-8
            assert abs(high - old_high) < 1e-8
            assert (
                f"{100 * low:.1f} {100 * high:.1f}" == f"{100 * old_low:.1f} {100 * old_high:.1f}"
            )
            assert low <= successes / trials <= high


def test_wilson_known_values() -> None:
    assert wilson(5, 5)[1] == 1.0  # exactly: the old formula gave 0.9999999999999999
    assert wilson(0, 10) == pytest.approx((0.0, 0.27753), abs=1e-5)
    assert wilson(168, 200) == pytest.approx((0.78286, 0.88433), abs=1e-5)
    assert wilson(0, 0) == (0.0, 1.0)
    assert str(Rate(118, 118)) == "100.0 % [96.8, 100.0]"
    low, high = wilson(50, 100, confidence=0.99)
    assert (low, high) == pytest.approx((0.37528, 0.62472), abs=1e-5)


@pytest.mark.parametrize(
    ("args", "match"),
    [((3, 2), "successes"), ((-1, 5), "successes"), ((1, 5, 1.0), "confidence")],
)
def test_wilson_bad_input(args: tuple, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        wilson(*args)


def test_bootstrap_mean_percentile_interval() -> None:
    values = np.arange(1.0, 21.0)  # mean 10.5, standard error 5.766 / sqrt(20) = 1.29
    a = bootstrap_mean(values)
    assert a == bootstrap_mean(values)  # seeded
    assert a.mean == 10.5
    # The percentile interval of a symmetric sample: about mean +- 1.96 standard errors.
    assert a.low == pytest.approx(10.5 - 1.96 * 1.29, abs=0.2)
    assert a.high == pytest.approx(10.5 + 1.96 * 1.29, abs=0.2)
    assert bootstrap_mean(values, seed=1) != a
    assert bootstrap_mean([4.0, 4.0]) == Interval95(4.0, 4.0, 4.0)
    assert bootstrap_mean([3.0]) == Interval95(3.0, 3.0, 3.0)
    assert math.isnan(bootstrap_mean([]).mean)
    with pytest.raises(ValueError, match="resamples"):
        bootstrap_mean(values, resamples=0)
    with pytest.raises(ValueError, match="confidence"):
        bootstrap_mean(values, confidence=0.0)


def _loglog_band(survival: float, greenwood: float) -> tuple[float, float]:
    """The pointwise 95 % band of a survival estimate by the log-log transform, by hand."""
    se = math.sqrt(greenwood) / abs(math.log(survival))
    centre = math.log(-math.log(survival))
    return (
        math.exp(-math.exp(centre + Z95 * se)),
        math.exp(-math.exp(centre - Z95 * se)),
    )


def test_km_median_of_a_small_censored_case_by_hand() -> None:
    # Events at 1, 3, 4, 6; censored at 2 and 5. Kaplan-Meier: S(1) = 5/6, S(3) = 5/6 * 3/4 =
    # 0.625, S(4) = 0.625 * 2/3 = 0.417 (the median: first S <= 1/2), S(6) = 0.
    times = [1, 2, 3, 4, 5, 6]
    reached = [True, False, True, True, False, True]
    m = km_median(times, reached)
    assert (m.median, m.episodes, m.reached) == (4.0, 6, 4)
    # Lower bound: the band's lower edge at t = 1 (Greenwood 1/30) is already below 1/2.
    low_at_1, _ = _loglog_band(5 / 6, 1 / 30)
    assert low_at_1 == pytest.approx(0.273, abs=1e-3)
    assert m.low == 1.0
    # Upper bound: the band's upper edge stays above 1/2 at 4 (Greenwood 1/30 + 1/12 + 1/6)
    # and drops only at 6, where the estimate is 0.
    _, high_at_4 = _loglog_band(0.625 * 2 / 3, 1 / 30 + 1 / 12 + 1 / 6)
    assert high_at_4 == pytest.approx(0.766, abs=1e-3)
    assert m.high == 6.0
    assert str(m) == "4 [1, 6]"


def test_km_median_against_the_uncensored_median_and_bounds() -> None:
    # Without censoring the Kaplan-Meier median is the sample's lower median.
    rng = np.random.default_rng(0)
    times = rng.integers(1, 30, size=41).astype(float)
    m = km_median(times, [True] * 41)
    assert m.median == np.sort(times)[20]
    assert m.low <= m.median <= m.high < math.inf
    # Every episode at the same picture: no spread, a zero-width interval.
    tied = km_median([3] * 10, [True] * 10)
    assert (tied.median, tied.low, tied.high) == (3.0, 3.0, 3.0)


def test_km_median_when_too_few_episodes_finish() -> None:
    # Fewer than half reached: the median is not bounded above, and says so.
    m = km_median([2, 30, 30, 30], [True, False, False, False])
    assert m.median == math.inf
    assert m.high == math.inf
    assert str(m).startswith("inf")
    none = km_median([30, 30], [False, False])
    assert (none.median, none.reached) == (math.inf, 0)
    assert math.isnan(km_median([], []).median)
    # Censoring is not an event: the censored mean is a lower bound the median can exceed.
    five = km_median([1, 1, 20, 20, 20], [True, True, False, False, False])
    assert five.median == math.inf


def test_km_median_bad_input() -> None:
    with pytest.raises(ValueError, match="one length"):
        km_median([1, 2], [True])
    with pytest.raises(ValueError, match="finite"):
        km_median([1, math.inf], [True, False])
    with pytest.raises(ValueError, match="confidence"):
        km_median([1, 2], [True, True], confidence=1.5)
