"""The identifier against the exact reference, on small seeded cases drawn from the model itself.

Each case: N robots placed uniformly in the image with uniform headings, driving random legs
with noise-free odometry; each picture holds each robot with probability ``P_D`` (pixel noise,
and heading noise if detected) plus Poisson false positives, shuffled. The identifier's posterior
over the newest picture's rows (plus "not in it") is compared with the enumeration's.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from anonloc_env.geometry import rotate, wrap_angle
from anonloc_env.identify import Identifier, Interval, SensorModel
from anonloc_env.identify.reference import MAX_TRACKS, exact_beliefs, total_variation

SIDE = 600.0  # image side (image units)


def _model(**changes: object) -> SensorModel:
    base = SensorModel(
        scale=100.0,
        scale_range=(50.0, 200.0),
        scale_spread=0.0,
        pixel_noise=1.0,
        orientation=False,
        orientation_noise=0.0,
        p_detect=1.0,
        image_area=SIDE * SIDE,
        odometry_noise=0.0,
    )
    return replace(base, **changes)  # type: ignore[arg-type]  # test helper, fields by name


def simulate(
    model: SensorModel,
    n: int,
    pictures: int,
    false_positives: float,
    seed: int,
    *,
    true_scale: float | None = None,
    leg: float = 0.4,
    margin: float = 0.15,
) -> tuple[list[np.ndarray], list[Interval], list[np.ndarray]]:
    """Rows, intervals and true rows drawn from the model (``true_scale``: the camera's; the
    robots start uniform in the image less ``margin`` of its side on every edge). Legs are
    ``leg`` (m) per component in the robot's frame; with ``model.others_repeat`` a robot's
    displacement from the second leg on repeats its previous one with that probability
    (changed as the model says), the leg following from it."""
    rng = np.random.default_rng(seed)
    scale = model.scale if true_scale is None else true_scale
    assert scale is not None
    pos = rng.uniform(margin * SIDE, (1.0 - margin) * SIDE, (n, 2))
    heading = rng.uniform(-math.pi, math.pi, n)
    rows_out, intervals, truths = [], [], []
    last = np.zeros((n, 2))  # each robot's previous displacement (image units)
    for k in range(pictures):
        if k > 0:
            d = rng.normal(0.0, leg, (n, 2))
            dphi = rng.uniform(-1.0, 1.0, n)
            local = scale * (1.0 + model.scale_spread * rng.standard_normal(n))
            step = rotate(d, heading) * local[:, None]
            if model.others_repeat > 0.0 and k > 1:
                again = rng.random(n) < model.others_repeat
                wide = np.hypot(scale * model.others_jitter, model.others_turn * np.hypot(*last.T))
                step[again] = (last + wide[:, None] * rng.standard_normal((n, 2)))[again]
                d = rotate(step / local[:, None], -heading)
            pos = pos + step
            last = step
            heading = wrap_angle(heading + dphi)
            intervals.append(Interval.exact(d, dphi))
        seen = rng.random(n) < model.p_detect
        det = pos[seen] + model.pixel_noise * rng.standard_normal((int(seen.sum()), 2))
        th = heading[seen] + model.orientation_noise * rng.standard_normal(int(seen.sum()))
        clutter = rng.poisson(false_positives)
        fp = np.column_stack(
            [rng.uniform(0, SIDE, (clutter, 2)), rng.uniform(-math.pi, math.pi, clutter)]
        )
        rows = np.concatenate([np.column_stack([det, wrap_angle(th)]), fp])
        order = rng.permutation(len(rows))
        rows = rows[order]
        true = np.full(n, -1)
        where = np.empty(len(order), dtype=np.int64)
        where[order] = np.arange(len(order))
        true[np.flatnonzero(seen)] = where[: int(seen.sum())]
        rows_out.append(rows)
        truths.append(true)
    return rows_out, intervals, truths


def _distances(model: SensorModel, rows: list[np.ndarray], intervals: list[Interval]) -> np.ndarray:
    ref = exact_beliefs(model, rows, intervals)
    ident = Identifier(model, len(intervals[0].d))
    out = []
    for k, picture in enumerate(rows):
        ident.update(picture, intervals[k - 1] if k else None)
        belief, missing = ref[k]
        out.append(total_variation(ident.belief(), ident.missing(), belief, missing))
    return np.concatenate(out)


CASES = {
    "clean": (_model(), 5, 0.0),
    "misses-and-clutter": (_model(p_detect=0.85), 4, 1.0),
    "misses-and-clutter-robots-counted": (
        _model(p_detect=0.85, n_robots=4, false_positives=1.0),
        4,
        1.0,
    ),
    "misses-and-clutter-others-persist": (
        _model(p_detect=0.85, n_robots=4, false_positives=1.0, others_sigma=0.4),
        4,
        1.0,
    ),
    "misses-and-clutter-others-repeat": (
        _model(
            p_detect=0.85,
            n_robots=4,
            false_positives=1.0,
            others_sigma=0.4,
            others_repeat=0.85,
            others_jitter=0.03,
            others_turn=0.3,
        ),
        4,
        1.0,
    ),
    "headings": (_model(orientation=True, orientation_noise=math.radians(3.0)), 4, 0.5),
    "tilted": (_model(scale_spread=0.02), 5, 0.0),
    "crowd-noise": (_model(crowd_noise=1.2), 5, 0.0),
}


@pytest.mark.slow
@pytest.mark.parametrize(
    ("model", "n", "fp"),
    list(CASES.values()),
    ids=list(CASES),
)
def test_identifier_matches_the_exact_posterior(model: SensorModel, n: int, fp: float) -> None:
    """Total variation <= 0.01 on at least 95 % of robot-pictures (8 seeds x 5 pictures)."""
    tv = np.concatenate(
        [_distances(model, *simulate(model, n, 5, fp, seed)[:2]) for seed in range(8)]
    )
    assert np.mean(tv <= 0.01) >= 0.95, np.sort(tv)[-10:]


def test_reference_takes_the_crowds_noise() -> None:
    """With ``crowd_noise`` (the identifier's noise floor in a crowd) the exact reference takes
    the detections as that much noisier, as the identifier does: the two agree within 0.01, and
    the reference differs from the one with the noise as stated."""
    model = _model(crowd_noise=1.2, pixel_noise=4.0)  # noisy enough for beliefs to differ
    rows, intervals, _ = simulate(model, 4, 4, 0.0, seed=1)
    tv = _distances(model, rows, intervals)
    assert np.mean(tv <= 0.01) >= 0.95, np.sort(tv)[-5:]
    crowd = exact_beliefs(model, rows, intervals)
    stated = exact_beliefs(replace(model, crowd_noise=1.0), rows, intervals)
    apart = [total_variation(*a, *b).max() for a, b in zip(crowd, stated, strict=True)]
    assert max(apart) > 0.05  # 0.054


@pytest.mark.slow
def test_identifier_matches_the_exact_posterior_scale_unknown() -> None:
    """Scale unknown (0.5x to 2x, the truth 0.8x): within 0.01 on 95 % of robot-pictures."""
    model = _model(scale=None, pixel_noise=2.0)
    tv = np.concatenate(
        [
            _distances(model, *simulate(model, 3, 4, 0.0, seed, true_scale=80.0)[:2])
            for seed in range(6)
        ]
    )
    assert np.mean(tv <= 0.01) >= 0.95, np.sort(tv)[-10:]


def test_reference_is_a_posterior_and_finds_the_truth() -> None:
    """Beliefs sum to one with "not in it"; with clean data the truth ends on top."""
    model = _model()
    rows, intervals, truths = simulate(model, 3, 4, 0.0, seed=3)
    ref = exact_beliefs(model, rows, intervals)
    for belief, missing in ref:
        np.testing.assert_allclose(belief.sum(axis=1) + missing, 1.0, atol=1e-12)
    belief, _ = ref[-1]
    np.testing.assert_array_equal(belief.argmax(axis=1), truths[-1])
    assert np.all(belief[np.arange(3), truths[-1]] > 0.99)


def test_reference_refuses_what_it_cannot_do_exactly() -> None:
    model = _model()
    rows, intervals, _ = simulate(model, 2, 3, 0.0, seed=0)
    with pytest.raises(ValueError, match="odometry_noise"):
        exact_beliefs(replace(model, odometry_noise=0.05), rows, intervals)
    with pytest.raises(ValueError, match="one fewer"):
        exact_beliefs(model, rows, intervals[:1])
    pushed = replace(intervals[0], push=np.ones(2), push_sum=np.zeros((2, 2)))
    with pytest.raises(ValueError, match="push"):
        exact_beliefs(model, rows, [pushed, intervals[1]])
    many = [np.zeros((12, 3))] * 5
    with pytest.raises(ValueError, match="MAX_TRACKS"):
        exact_beliefs(model, many, [Interval.exact(np.zeros((2, 2)), np.zeros(2))] * 4)
    assert MAX_TRACKS < 13**5


def test_belief_and_missing_agree_before_and_after_a_picture() -> None:
    """Before any picture both refuse; after one, [belief | missing] is a distribution per robot."""
    ident = Identifier(_model(p_detect=0.8), 3)
    for method in (ident.belief, ident.missing):
        with pytest.raises(RuntimeError, match="no picture yet"):
            method()
    rows = np.array([[10.0, 20.0, 0.1], [200.0, 40.0, -1.0], [90.0, 300.0, 2.0]])
    ident.update(rows, None)
    full = np.column_stack([ident.belief(), ident.missing()])
    assert full.shape == (3, 4)
    np.testing.assert_allclose(full.sum(axis=1), 1.0, atol=1e-12)
    assert np.all(ident.missing() > 0.0)  # p_detect < 1: every robot may be out of the picture
    ident.reset()
    with pytest.raises(RuntimeError, match="no picture yet"):
        ident.missing()
