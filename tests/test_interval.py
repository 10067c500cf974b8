"""``anonloc_env.odometry.Interval``: its variances, kept once computed."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from anonloc_env.odometry import Interval


def _interval(seed: int) -> Interval:
    rng = np.random.default_rng(seed)
    n = 7
    return Interval(
        d=rng.normal(size=(n, 2)),
        dphi=rng.normal(size=n),
        path=rng.uniform(0.0, 2.0, n),
        sum_ds2=rng.uniform(0.0, 0.1, n),
        sum_dth2=rng.uniform(0.0, 0.3, n),
    )


def test_the_variances_are_the_formulas_and_kept_read_only() -> None:
    """The formulas of the docstring, per noise; asked again, the same values (the arrays kept),
    which no caller can change in place."""
    interval = _interval(0)
    for noise in (0.05, 0.1):
        var_d, var_dphi = interval.variances(noise)
        np.testing.assert_array_equal(var_dphi, noise**2 * interval.sum_dth2)
        expected = noise**2 * (interval.sum_ds2 + interval.path**2 * interval.sum_dth2 / 3.0) / 2.0
        np.testing.assert_array_equal(var_d, expected)
        again = interval.variances(noise)
        assert again[0] is var_d
        assert again[1] is var_dphi
        with pytest.raises(ValueError, match="read-only"):
            var_d += 1.0
    assert interval.variances(0.05)[1][0] != interval.variances(0.1)[1][0]


def test_a_copy_with_other_fields_has_its_own_variances() -> None:
    """A copy with another field (``dataclasses.replace``) computes from its own fields."""
    interval = _interval(1)
    interval.variances(0.1)
    doubled = interval.sum_dth2 * 2.0
    other = dataclasses.replace(interval, sum_dth2=doubled)
    np.testing.assert_array_equal(other.variances(0.1)[1], 0.1**2 * doubled)
    assert interval == dataclasses.replace(interval)  # the kept values are not a field
