"""The localizers' pure functions against hand-computed cases (no env)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import anonloc_env
from anonloc_env.camera import Camera, survey
from anonloc_env.geometry import rotate
from anonloc_env.identify import SensorModel, log_i0e, ring_loglik
from anonloc_env.neighbours import pairs_within, pairs_within_each
from baselines import angular, linear, motion
from baselines.localizers import CHI2_THRESHOLD
from baselines.matching import decide, match_nearest, scores_to_belief


def test_pairs_within_matches_brute_force() -> None:
    rng = np.random.default_rng(0)
    a, b = rng.uniform(0, 50, (80, 2)), rng.uniform(0, 50, (90, 2))
    i, j, dist = pairs_within(a, b, 6.0)
    brute = {(p, q) for p in range(80) for q in range(90) if np.hypot(*(a[p] - b[q])) <= 6.0}
    assert set(zip(i.tolist(), j.tolist(), strict=True)) == brute
    np.testing.assert_allclose(dist, np.hypot(*(b[j] - a[i]).T))
    assert (np.diff(i * 90 + j) > 0).all()  # sorted by i, then j (the identifier relies on it)


def test_pairs_within_each_uses_each_points_own_radius() -> None:
    rng = np.random.default_rng(1)
    a, b = rng.uniform(0, 50, (80, 2)), rng.uniform(0, 50, (90, 2))
    radius = rng.choice([0.5, 3.0, 6.0, 20.0], 80)
    i, j, dist = pairs_within_each(a, b, radius)
    brute = {(p, q) for p in range(80) for q in range(90) if np.hypot(*(a[p] - b[q])) <= radius[p]}
    assert set(zip(i.tolist(), j.tolist(), strict=True)) == brute
    np.testing.assert_allclose(dist, np.hypot(*(b[j] - a[i]).T))
    assert (np.diff(i * 90 + j) > 0).all()


def test_match_nearest_pairs_each_point_with_its_closest() -> None:
    first = np.array([[0.0, 0.0], [10.0, 0.0], [20.0, 0.0]])
    second = np.array([[19.5, 0.2], [0.3, -0.1], [50.0, 50.0]])
    np.testing.assert_array_equal(match_nearest(first, second, 2.0), [2, 0, -1])


# -- angular (paper Algorithm 1) -------------------------------------------------------------


def test_faithful_angular_compares_same_index_without_sign_or_wrap() -> None:
    # Robot rotates by 0.5 rad; as printed, |theta_i(p) - theta_j(p)| with the same p.
    res = angular.faithful_residuals(np.array([0.1, 3.0]), np.array([0.6, -2.8]), np.array([0.5]))
    np.testing.assert_allclose(res, [[0.0, abs(0.5 - 5.8)]])


def test_faithful_angular_fails_when_the_picture_is_shuffled() -> None:
    """Failure mode of the paper's index assumption: the same robots, rows swapped."""
    first = np.array([[0.0, 0.0, 0.2], [50.0, 0.0, 0.7]])
    second = first[::-1].copy()
    second[:, 2] += [0.1, 0.4]  # robot B turned by 0.1, robot A (row 1 now) by 0.4
    rotation_a = np.array([0.4])
    faithful = angular.faithful_residuals(first[:, 2], second[:, 2], rotation_a)
    corrected = angular.residuals(first, second, rotation_a, max_shift=1.0)
    assert np.argmin(corrected[0]) == 1  # the corrected test finds robot A in row 1
    assert np.argmin(faithful[0]) == 0  # the faithful one answers row 0: wrong


def test_corrected_angular_wraps_across_pi() -> None:
    """A CCW turn of 0.3 rad from 3.0 rad ends at -2.983 rad: the faithful |difference| says
    5.98 rad and misses it; the corrected test sees exactly 0.3."""
    first = np.array([[0.0, 0.0, 3.0]])
    second = np.array([[0.0, 0.0, 3.3 - 2 * math.pi]])
    res = angular.residuals(first, second, np.array([0.3]), max_shift=1.0)
    assert res[0, 0] == pytest.approx(0.0, abs=1e-12)
    assert angular.faithful_residuals(first[:, 2], second[:, 2], np.array([0.3]))[0, 0] > 5.0


# -- linear (paper II.B) ----------------------------------------------------------------------


def _two_robot_pictures() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Robot A drives straight 4 then 2 units; robot B drives 4 then 2 but turns 90 degrees."""
    p0 = np.array([[0.0, 0.0], [0.0, 10.0]])
    p1 = np.array([[4.0, 0.0], [4.0, 10.0]])
    p2 = np.array([[6.0, 0.0], [4.0, 12.0]])
    return p0, p1, p2


def test_faithful_linear_cannot_tell_a_turning_robot_with_the_same_ratio() -> None:
    p0, p1, p2 = _two_robot_pictures()
    rows, deviation = linear.faithful_search(p0, p1, p2, np.array([2.0]))
    assert deviation[0] == 0.0  # both tracks give exactly the ratio 2: a tie
    assert rows[0] == 0  # argmin takes the first, right here only by luck of the order
    swapped_rows, _ = linear.faithful_search(p0[::-1], p1[::-1], p2[::-1], np.array([2.0]))
    assert swapped_rows[0] == 0  # ... and robot B's row once the rows are listed the other way


def test_corrected_linear_tests_ratio_collinearity_and_direction() -> None:
    p0, p1, p2 = _two_robot_pictures()
    chi2 = linear.residuals(p0, p1, p2, np.array([2.0]), 0.1, 10.0, 10.0)
    assert chi2[0, 0] == pytest.approx(0.0, abs=1e-12)
    assert chi2[0, 1] > 100.0  # B turned: far off the straight-line prediction
    # r - q - k (q - p) on a hand-made noisy triple: e = (6.3, 0.4) - (4, 0) - 0.5 (4, 0).
    chi2 = linear.residuals(p0[:1], p1[:1], np.array([[6.3, 0.4]]), np.array([2.0]), 1.0, 9, 9)
    assert chi2[0, 0] == pytest.approx((0.3**2 + 0.4**2) / (1 + 1.5**2 + 0.5**2))


def test_faithful_linear_refuses_huge_pictures() -> None:
    big = np.zeros((300, 2))
    with pytest.raises(ValueError, match="O\\(n\\^3\\)"):
        linear.faithful_search(big, big, big, np.array([1.0]))


# -- motion (paper II.C, eq. 15-24) ------------------------------------------------------------


def worked_example(phi: float) -> dict[str, float | np.ndarray]:
    """The paper's eq. 15-23 on one robot: scale 21.42, own displacement d, image heading at
    picture m such that theta_m + alpha = phi."""
    scale = 21.42
    d = np.array([0.3, 0.4])  # A, B (times the control step)
    alpha = math.atan2(d[1], d[0])
    theta = phi - alpha
    delta = scale * rotate(d, theta)
    return {"scale": scale, "d": d, "alpha": alpha, "theta": theta, "delta": delta}


def test_eq_16_to_19_on_a_worked_example() -> None:
    ex = worked_example(phi=1.0)
    d, delta, scale = ex["d"], ex["delta"], ex["scale"]
    A, B = d
    C, D = delta / scale  # eq. 18 and its y twin
    rho = math.hypot(A, B)  # eq. 19: 0.5
    assert rho == pytest.approx(0.5)
    # eq. 20 and 22: the x row and the y row both give theta_m.
    assert math.acos(C / rho) - math.atan(B / A) == pytest.approx(ex["theta"])
    assert math.asin(D / rho) - math.atan(B / A) == pytest.approx(ex["theta"])
    # Both rows are solvable exactly when |q - p| = s |d| (C^2 + D^2 = rho^2).
    assert pytest.approx(rho**2) == C**2 + D**2


@pytest.mark.parametrize("phi", [0.3, 1.2, 2.5, -0.7])
def test_faithful_motion_agrees_on_the_true_pair_when_no_wrap_is_needed(phi: float) -> None:
    ex = worked_example(phi)
    p_m = np.array([[100.0, 100.0]])
    dev = motion.faithful_deviation(p_m, p_m + ex["delta"], ex["d"][None], ex["scale"])
    assert dev[0, 0, 0] == pytest.approx(0.0, abs=1e-9)


def test_faithful_motion_fails_without_wrapping() -> None:
    """Failure mode of comparing angles without wrapping: for theta_m + alpha in (-pi, -pi/2)
    the x and y rows' solutions differ by 2 pi on the matching branch, so the true pair shows
    a large disagreement (here 1.28 rad) although the motion fits exactly."""
    ex = worked_example(phi=-2.5)
    p_m = np.array([[100.0, 100.0]])
    dev = motion.faithful_deviation(p_m, p_m + ex["delta"], ex["d"][None], ex["scale"])
    assert dev[0, 0, 0] == pytest.approx(2 * math.pi - 5.0, abs=1e-9)
    corrected = motion.residuals(
        np.array([[100.0, 100.0, ex["theta"]]]),
        np.array([[*(np.array([100.0, 100.0]) + ex["delta"]), ex["theta"] + 0.1]]),
        ex["d"][None],
        np.array([0.1]),
        ex["scale"],
        0.5,
        50.0,
    )
    assert corrected[0, 0] == pytest.approx(0.0, abs=1e-12)


def test_scale_free_motion_predicts_the_second_leg() -> None:
    """eq. 24: with the scale unknown, leg 1 gives s and theta; leg 2 is predicted exactly."""
    scale, theta = 33.0, 0.7
    d1, dphi1, d2 = np.array([0.5, 0.1]), 0.4, np.array([0.3, -0.2])
    p0 = np.array([[10.0, 10.0]])
    p1 = p0 + scale * rotate(d1, theta)
    p2 = p1 + scale * rotate(d2, theta + dphi1)
    chi2 = motion.scale_free_residuals(
        p0, p1, p2, d1[None], np.array([dphi1]), d2[None], 0.5, 100.0, 100.0
    )
    assert chi2[0, 0] == pytest.approx(0.0, abs=1e-9)
    dev = motion.faithful_scale_free_deviation(p0, p1, p2, d1[None], np.array([dphi1]), d2[None])
    assert dev[0, 0] == pytest.approx(0.0, abs=1e-9)  # here arctan keeps the quadrant


@pytest.mark.parametrize("first_leg", [0.5, 0.02])
def test_scale_free_chi_square_is_calibrated_under_pixel_noise(first_leg: float) -> None:
    """The true track's chi-square has 2 degrees of freedom under Gaussian pixel noise, also
    when the first leg is barely longer than the noise (a 0.02 m leg is 0.66 px at 33 px/m,
    sigma 1 px): the variance propagates the noise exactly through the linear prediction.
    4000 seeded draws: the mean of chi2(2) is 2 with a standard error of 0.032; tolerance 0.15."""
    rng = np.random.default_rng(7)
    scale, sigma, n = 33.0, 1.0, 4000
    chi2 = np.empty(n)
    for t in range(n):
        theta, dphi1 = rng.uniform(-np.pi, np.pi, 2)
        d1 = first_leg * np.array([np.cos(a := rng.uniform(-np.pi, np.pi)), np.sin(a)])
        d2 = rng.uniform(0.1, 0.5) * np.array([np.cos(b := rng.uniform(-np.pi, np.pi)), np.sin(b)])
        p0 = rng.uniform(0, 100, (1, 2))
        p1 = p0 + scale * rotate(d1, theta)
        p2 = p1 + scale * rotate(d2, theta + dphi1)
        noisy = [p + rng.normal(0.0, sigma, 2) for p in (p0, p1, p2)]
        chi2[t] = motion.scale_free_residuals(
            *noisy, d1[None], np.array([dphi1]), d2[None], sigma, 1e3, 1e3
        )[0, 0]
    assert abs(chi2.mean() - 2.0) < 0.15


def test_decide_with_a_margin_refuses_a_close_runner_up() -> None:
    """A margin of 2 ln 99 asks the chosen row to be 99 times as likely as any other."""
    chi2 = np.array([[0.0, 5.0], [0.0, 12.0], [1.0, np.inf]])
    margin = 2 * math.log(99.0)
    np.testing.assert_array_equal(decide(chi2, 15.0, margin), [-1, 0, 0])
    np.testing.assert_array_equal(decide(chi2, 15.0), [0, 0, 0])


def test_faithful_scale_free_loses_the_quadrant() -> None:
    """The paper's arctan(B/A): when the leg points left, theta comes out off by pi."""
    scale, theta = 30.0, 2.5  # the first leg points into the left half-plane
    d1, dphi1, d2 = np.array([0.5, 0.1]), 0.2, np.array([0.4, 0.0])
    p0 = np.array([[0.0, 0.0]])
    p1 = p0 + scale * rotate(d1, theta)
    p2 = p1 + scale * rotate(d2, theta + dphi1)
    dev = motion.faithful_scale_free_deviation(p0, p1, p2, d1[None], np.array([dphi1]), d2[None])
    assert dev[0, 0] == pytest.approx(2 * scale * 0.4, rel=1e-9)  # predicted backwards


# -- scoring and deciding ---------------------------------------------------------------------


def test_beliefs_and_decisions_from_scores() -> None:
    chi2 = np.array([[0.0, 2 * math.log(3.0), np.inf], [np.inf, np.inf, np.inf]])
    belief = scores_to_belief(chi2)
    np.testing.assert_allclose(belief[0], [0.75, 0.25, 0.0])
    np.testing.assert_allclose(belief[1], [1 / 3] * 3)
    np.testing.assert_array_equal(decide(chi2, 1.0), [0, -1])


def test_log_i0e_matches_numpy() -> None:
    x = np.array([0.0, 0.5, 3.7, 3.8, 10.0, 200.0])
    np.testing.assert_allclose(
        log_i0e(x), np.log(np.i0(x)) - x, rtol=0, atol=5e-7
    )  # A&S: 2e-7 relative


def test_ring_density_integrates_to_one() -> None:
    """The ring likelihood is a density over the plane (checked numerically in polar form)."""
    r = np.linspace(1e-6, 40.0, 200_001)
    for rho, var in [(10.0, 2.0), (0.0, 1.0), (3.0, 9.0)]:
        dens = np.exp(ring_loglik(r, np.full_like(r, rho), np.full_like(r, var)))
        total = np.trapezoid(dens * 2 * math.pi * r, r)
        assert total == pytest.approx(1.0, abs=1e-6)


# -- property: a noise-free trajectory always scores its own row best -------------------------

coords = st.floats(-200.0, 200.0, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(
    others=st.lists(st.tuples(coords, coords, coords, coords), min_size=1, max_size=6),
    start=st.tuples(coords, coords),
    heading=st.floats(-math.pi, math.pi),
    d=st.tuples(st.floats(0.2, 2.0), st.floats(-1.0, 1.0)),
    dphi=st.floats(-1.0, 1.0),
)
def test_noise_free_own_row_scores_best(others, start, heading, d, dphi) -> None:
    scale = 20.0
    own_first = np.array([*start, heading])
    own_second = np.array(
        [*(np.array(start) + scale * rotate(np.array(d), heading)), heading + dphi]
    )
    first = np.array([own_first] + [[o[0], o[1], o[2]] for o in others])
    second = np.array([own_second] + [[o[0] + o[3], o[1] - o[3], o[2] + 0.5] for o in others])
    chi2 = motion.residuals(first, second, np.array([d]), np.array([dphi]), scale, 0.5, 500.0, 0.02)
    assert chi2[0, 0] == pytest.approx(0.0, abs=1e-6)
    # Best, and strictly: every other row scores worse, unless it is a copy of the robot's own
    # second row (two robots in one spot with one heading cannot be told apart).
    offset = second[1:] - own_second
    offset[:, 2] = np.angle(np.exp(1j * offset[:, 2]))
    copies = np.all(np.abs(offset) < 1e-6, axis=1)
    assert np.all(chi2[0, 1:][~copies] > 1e-3)


def test_tilted_camera_scale_change_keeps_straight_drives_in_the_linear_gate() -> None:
    """A 4.24 degree tilt (the paper presets) changes the scale by about 1 % per metre: with
    pixel noise as small as the image path's (0.005 px), a straight drive's second leg misses
    the scale-free prediction by far more than the noise unless the scale change is in the
    variance. 200 seeded straight drives of 0.3-1 m legs anywhere in the arena: all pass the
    gate with it; without it most fail."""
    config = anonloc_env.make_config("paper-linear", camera={"pixel_noise": 0.005})
    camera = Camera(config)
    gradient = survey(config).scale_gradient
    assert 0.005 < gradient < 0.02
    rng = np.random.default_rng(3)
    width, height = config.arena_size
    with_change, without = [], []
    for _ in range(200):
        heading = rng.uniform(-np.pi, np.pi)
        direction = np.array([np.cos(heading), np.sin(heading)])
        len0, len1 = rng.uniform(0.3, 1.0, 2)
        start = rng.uniform([1.0, 1.0], [width - 1.0, height - 1.0])
        ground = np.array([start, start + len0 * direction, start + (len0 + len1) * direction])
        p0, p1, p2 = (row[None] for row in camera.project(ground))
        ratio = np.array([len0 / len1])
        change = gradient * 0.5 * (len0 + len1)
        with_change.append(linear.residuals(p0, p1, p2, ratio, 0.005, 1e3, 1e3, change)[0, 0])
        without.append(linear.residuals(p0, p1, p2, ratio, 0.005, 1e3, 1e3)[0, 0])
    assert max(with_change) < CHI2_THRESHOLD[2]
    assert np.mean(np.asarray(without) > CHI2_THRESHOLD[2]) > 0.5


def test_tilted_camera_scale_spread_keeps_true_moves_in_the_motion_gate() -> None:
    """The known-scale motion test predicts the image length with the arena's mean scale; on a
    tilted camera the local scale differs by up to a few percent. With image-path pixel noise
    (0.005 px) 200 seeded true moves all pass the 1-dof gate with the spread in the variance;
    without it most fail."""
    config = anonloc_env.make_config("paper-motion", camera={"pixel_noise": 0.005})
    camera = Camera(config)
    model = SensorModel.from_config(config)
    rng = np.random.default_rng(4)
    width, height = config.arena_size
    with_spread, without = [], []
    for _ in range(200):
        start = rng.uniform([0.5, 0.5], [width - 0.5, height - 0.5])
        d = rng.uniform(0.2, 0.5) * np.array([np.cos(a := rng.uniform(-np.pi, np.pi)), np.sin(a)])
        first = np.c_[camera.project(start[None]), [0.0]]
        second = np.c_[camera.project((start + d)[None]), [0.0]]
        args = (first, second, d[None], np.zeros(1), model.scale, 0.005, 1e3)
        with_spread.append(motion.residuals(*args, None, model.scale_spread)[0, 0])
        without.append(motion.residuals(*args)[0, 0])
    assert max(with_spread) < CHI2_THRESHOLD[1]
    assert np.mean(np.asarray(without) > CHI2_THRESHOLD[1]) > 0.5
