"""The background law of :func:`anonloc_env.identify.model.log_background`."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy import stats
from test_identify_reference import _model

from anonloc_env.identify.model import log_background


def test_without_a_robot_count_the_clutter_is_poisson_from_the_row_count() -> None:
    model = _model(p_detect=0.9)
    for n_rows in (1, 5, 40):
        assert log_background(model, n_rows) == pytest.approx(
            math.log(max(n_rows - 0.9, 0.5) / model.image_area)
        )


def test_with_a_robot_count_it_is_the_other_robots_and_poisson_false_positives() -> None:
    """lambda = n P(B = n) / (P(B = n - 1) A), B = Binomial(N - 1, P_D) + Poisson(F)."""
    model = _model(p_detect=0.85, n_robots=8, false_positives=1.5)
    others = stats.binom.pmf(np.arange(8), 7, 0.85)
    law = np.convolve(others, stats.poisson.pmf(np.arange(40), 1.5))
    for n_rows in (1, 4, 8, 12):
        expected = n_rows * law[n_rows] / (law[n_rows - 1] * model.image_area)
        assert log_background(model, n_rows) == pytest.approx(math.log(expected), rel=1e-9)


def test_a_full_picture_says_the_robot_is_in_it() -> None:
    """Every robot seen and no false positives: "I was missed" is all but ruled out."""
    model = _model(p_detect=0.9, n_robots=10)
    full = log_background(model, 10)
    assert full < log_background(replace(model, n_robots=None), 10) - 5.0
    assert log_background(model, 9) > full  # one robot missing: it may be me


def test_n_robots_is_checked() -> None:
    with pytest.raises(ValueError, match="n_robots"):
        _model(n_robots=0)
    with pytest.raises(ValueError, match="false_positives"):
        _model(false_positives=-1.0)
