"""The identifier on hostile pictures: whatever the rows, every robot's beliefs and its "not in
the picture" are finite and sum to one (hypothesis-generated pictures, the others' model on)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_identify_reference import SIDE, _model

from anonloc_env.identify import Identifier
from anonloc_env.odometry import Interval

coordinate = st.floats(-0.2 * SIDE, 1.2 * SIDE, allow_nan=False)
picture = st.lists(st.tuples(coordinate, coordinate), min_size=0, max_size=12)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    pictures=st.lists(picture, min_size=1, max_size=5),
    robots=st.integers(1, 6),
    p_detect=st.sampled_from([0.7, 0.9, 1.0]),
    false_positives=st.sampled_from([0.0, 1.0, 4.0]),
    repeat=st.sampled_from([0.0, 0.85]),
    duplicate=st.booleans(),
    seed=st.integers(0, 2**16),
)
def test_beliefs_are_a_distribution_whatever_the_rows(
    pictures: list[list[tuple[float, float]]],
    robots: int,
    p_detect: float,
    false_positives: float,
    repeat: float,
    duplicate: bool,
    seed: int,
) -> None:
    model = _model(
        p_detect=p_detect,
        n_robots=robots,
        false_positives=false_positives,
        others_sigma=0.4,
        others_repeat=repeat,
        others_jitter=0.03,
        others_turn=0.3,
        odometry_noise=0.05,
    )
    rng = np.random.default_rng(seed)
    ident = Identifier(model, robots)
    for k, points in enumerate(pictures):
        rows = np.array([[u, v, 0.0] for u, v in points]).reshape(-1, 3)
        if duplicate and len(rows):  # two detections at the very same place
            rows = np.concatenate([rows, rows[:1]])
        interval = None
        if k:
            d = rng.normal(0.0, 0.3, (robots, 2))
            push = np.where(rng.random(robots) < 0.3, rng.uniform(0.0, 0.2, robots), 0.0)
            interval = replace(
                Interval.exact(d, rng.uniform(-1.0, 1.0, robots)),
                push=push,
                push_sum=np.zeros((robots, 2)),
            )
        ident.update(rows, interval)
        full = np.column_stack([ident.belief(), ident.missing()])
        assert np.isfinite(full).all()
        assert (full >= 0.0).all()
        np.testing.assert_allclose(full.sum(axis=1), 1.0, atol=1e-9)
        truth = rng.integers(-1, len(rows), robots) if len(rows) else np.full(robots, -1)
        np.testing.assert_array_equal(
            ident.belief_at(truth),
            np.where(truth >= 0, full[np.arange(robots), truth], full[:, -1]),
        )
