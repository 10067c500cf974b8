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


def test_the_push_covariance_is_the_formula_and_kept_read_only() -> None:
    """``S S^T / 3`` plus ``(P^2 - |S|^2) / 6`` in every direction (zeros without contacts),
    computed once and read-only; a copy with other pushes computes its own."""
    rng = np.random.default_rng(2)
    plain = _interval(2)
    assert not plain.push_covariance().any()
    push_sum = rng.normal(scale=0.01, size=(7, 2))
    push = np.hypot(*push_sum.T) * rng.uniform(0.5, 2.0, 7)
    interval = dataclasses.replace(plain, push=push, push_sum=push_sum)
    cov = interval.push_covariance()
    spread = np.maximum(push**2 - (push_sum**2).sum(axis=1), 0.0) / 6.0
    expected = push_sum[:, :, None] * push_sum[:, None, :] / 3.0
    expected += spread[:, None, None] * np.eye(2)
    np.testing.assert_array_equal(cov, expected)
    assert interval.push_covariance() is cov
    with pytest.raises(ValueError, match="read-only"):
        cov += 1.0
    wider = dataclasses.replace(interval, push=push * 2.0)
    assert (wider.push_covariance() != cov).any()
