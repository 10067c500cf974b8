"""Method C of the paper: localization during random motion, faithful and corrected.

A robot that moved by ``d`` in its own frame (heading change ``dphi``) between two pictures moved
by ``s R(theta) d`` in the image, ``theta`` its unknown image heading at the first picture.

* :func:`faithful_deviation`: eq. 15-23 as printed. For each pair ``(p, q)``, the x row gives
  ``theta = +-arccos(C / rho) - alpha`` and the y row ``theta = arcsin(D / rho) - alpha`` or
  ``pi - arcsin(D / rho) - alpha``, with ``alpha = arctan(B / A)``; the pair whose two angles agree
  best wins, the angles compared without wrapping (the paper's "average angle between x and y
  axes" is this disagreement).
* :func:`residuals`: corrected. Both rows have a solution exactly when ``|q - p| = s |d|``, so
  without a detected heading the test is the length, a chi-square against the noise; with a
  detected heading ``theta_p`` the whole vector ``(q - p) - s R(theta_p) d`` and the heading change
  are tested. Pairs are gated by the reachable radius.
* :func:`scale_free_residuals` (``motion3``, paper eq. 24): the scale unknown, three pictures.
  The first leg gives ``s = |D1| / |d1|`` and ``theta = ang(D1) - ang(d1)``; the second leg is
  predicted and tested. :func:`faithful_scale_free_deviation` is the same search over all n^3
  triples with the paper's ``arctan`` (which loses the quadrant) and no gating.
"""

from __future__ import annotations

import math

import numpy as np

from baselines.matching import chain_triples, min_per_column, pairs_within, rotate, wrap_angle

MAX_FAITHFUL_TRIPLES = 20_000_000


def faithful_deviation(p_m: np.ndarray, p_n: np.ndarray, d: np.ndarray, scale: float) -> np.ndarray:
    """``(R, n_m, n_n)`` disagreement (rad) between the x-row and y-row headings of eq. 20-23.

    Args:
        p_m: ``(n_m, 2)`` detections of the first picture.
        p_n: ``(n_n, 2)`` detections of the second picture.
        d: ``(R, 2)`` each robot's own displacement ``(A, B)`` in its frame (m); the paper's A and
            B times the control step.
        scale: the paper's lambda (image units per metre).
    Pairs where either row has no solution (``|C| > rho`` or ``|D| > rho``) get ``inf``.
    """
    d = np.atleast_2d(d)
    A, B = d[:, 0][:, None, None], d[:, 1][:, None, None]
    rho = np.hypot(A, B)
    delta = (p_n[None, :, :] - p_m[:, None, :]) / scale  # (n_m, n_n, 2)
    C, D = delta[None, ..., 0], delta[None, ..., 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        alpha = np.arctan(B / A)  # eq. 19, as printed: the quadrant is lost
        cx, dy = C / rho, D / rho
        ok = (rho > 0) & (np.abs(cx) <= 1.0) & (np.abs(dy) <= 1.0)
        acos = np.arccos(np.clip(cx, -1, 1))
        asin = np.arcsin(np.clip(dy, -1, 1))
    theta_x = (acos - alpha, -acos - alpha)
    theta_y = (asin - alpha, math.pi - asin - alpha)
    dev = np.min([np.abs(tx - ty) for tx in theta_x for ty in theta_y], axis=0)
    return np.where(ok, dev, np.inf)


def residuals(
    first: np.ndarray,
    second: np.ndarray,
    d: np.ndarray,
    dphi: np.ndarray,
    scale: float,
    pixel_noise: float | np.ndarray,
    reach: float,
    orientation_noise: float | None = None,
    scale_spread: float = 0.0,
) -> np.ndarray:
    """``(R, n_second)`` chi-square of the best pair ending at each row of the second picture.

    Args:
        first, second: ``(n, 3)`` rows ``(u, v, theta)`` of the two pictures.
        d: ``(R, 2)`` own displacements (m); dphi: ``(R,)`` own heading changes (rad).
        scale: image units per metre.
        pixel_noise: detection noise per coordinate (image units), > 0: a scalar or ``(R,)``.
        reach: farthest any robot can move between the pictures (image units).
        orientation_noise: noise of a detected heading (rad); None if headings are not detected.
            With headings the chi-square has 3 degrees of freedom (vector and turn), else 1.
        scale_spread: relative standard deviation of the local scale about ``scale`` (a tilted
            camera's scale varies across the arena): the predicted length is off by that
            fraction, in the variance.
    """
    d = np.atleast_2d(d)
    dphi = np.atleast_1d(dphi)
    n_robots = len(d)
    out = np.full((n_robots, len(second)), np.inf)
    i, j, dist = pairs_within(first[:, :2], second[:, :2], reach)
    if len(i) == 0:
        return out
    var = (
        2.0 * np.broadcast_to(np.asarray(pixel_noise, dtype=np.float64), (n_robots,))[:, None] ** 2
    )
    if orientation_noise is None:
        length = scale * np.hypot(*d.T)  # (R,)
        var_scale = (scale_spread * length[:, None]) ** 2
        chi2 = (dist[None, :] - length[:, None]) ** 2 / (var + var_scale)
    else:
        pred = scale * rotate(d[:, None, :], first[i, 2][None, :])  # (R, P, 2)
        err = (second[j, :2] - first[i, :2])[None] - pred
        turn = wrap_angle(second[j, 2][None, :] - first[i, 2][None, :] - dphi[:, None])
        length2 = (scale * np.hypot(*d.T)) ** 2
        var_heading = length2 * orientation_noise**2  # heading error swing
        var_scale = 0.5 * scale_spread**2 * length2  # along the leg only: half per component
        chi2 = (err**2).sum(-1) / (var + (var_heading + var_scale)[:, None]) + turn**2 / (
            2.0 * orientation_noise**2
        )
    return min_per_column(chi2, j, len(second))


def _predict_second_leg(
    leg1: np.ndarray, d1: np.ndarray, dphi1: np.ndarray, d2: np.ndarray, quadrant_safe: bool
) -> np.ndarray:
    """Predicted second image displacement from the first: scale and heading from leg 1."""
    rho1 = np.hypot(d1[..., 0], d1[..., 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.hypot(leg1[..., 0], leg1[..., 1]) / rho1
        if quadrant_safe:
            theta = np.arctan2(leg1[..., 1], leg1[..., 0]) - np.arctan2(d1[..., 1], d1[..., 0])
        else:
            theta = np.arctan(leg1[..., 1] / leg1[..., 0]) - np.arctan(d1[..., 1] / d1[..., 0])
    return s[..., None] * rotate(d2, theta + dphi1)


def scale_free_residuals(
    p0: np.ndarray,
    p1: np.ndarray,
    p2: np.ndarray,
    d1: np.ndarray,
    dphi1: np.ndarray,
    d2: np.ndarray,
    pixel_noise: float | np.ndarray,
    reach01: float,
    reach12: float,
    var_d1: float | np.ndarray = 0.0,
    var_d2: float | np.ndarray = 0.0,
    var_dphi1: float | np.ndarray = 0.0,
) -> np.ndarray:
    """``(R, n2)`` chi-square (2 dof) of the best three-picture track ending at each row, the
    scale unknown (``motion3``, corrected).

    The prediction ``M leg1`` is linear in the first leg, ``M = (|d2| / |d1|) R(phi)`` with
    ``phi = ang(d2) - ang(d1) + dphi1``, so the pixel noise propagates exactly: the residual
    ``p2 - (I + M) p1 + M p0`` has variance ``sigma^2 (2 + 2 k^2 + 2 k cos phi)`` per component,
    ``k = |d2| / |d1|``. A first leg the robot barely moved carries no scale: ``k`` grows and the
    test stops discriminating rather than trusting a scale made of noise. Odometry errors in
    ``d1`` and ``dphi1`` swing the prediction by ``|pred| sigma_d1 / |d1|`` and
    ``|pred| sigma_dphi1``; an error in ``d2`` by ``s sigma_d2``, ``s = |leg1| / |d1|``.

    Args:
        p0, p1, p2: ``(n_k, 2)`` detections of the three pictures.
        d1, d2: ``(R, 2)`` own displacements over the two intervals (each in the robot's frame at
            the start of its interval); dphi1: ``(R,)`` heading change over the first interval.
        pixel_noise: detection noise (image units), > 0: a scalar or ``(R,)``.
        reach01, reach12: farthest any robot can move over each interval (image units).
        var_d1, var_d2: variance per component of ``d1`` and ``d2`` (m^2): odometry and unseen
            pushes; a scalar or ``(R,)``.
        var_dphi1: variance of ``dphi1`` (rad^2), a scalar or ``(R,)``.
    """
    d1, d2 = np.atleast_2d(d1), np.atleast_2d(d2)
    n_robots = len(d1)

    def per_robot(x: float | np.ndarray) -> np.ndarray:
        return np.broadcast_to(np.asarray(x, dtype=np.float64), (n_robots,))[:, None]

    dphi1 = np.atleast_1d(dphi1)
    out = np.full((n_robots, len(p2)), np.inf)
    a, b, c = chain_triples(p0, p1, p2, reach01, reach12)
    if len(a) == 0:
        return out
    leg1 = (p1[b] - p0[a])[None]  # (1, T, 2)
    leg2 = (p2[c] - p1[b])[None]
    pred = _predict_second_leg(leg1, d1[:, None, :], dphi1[:, None], d2[:, None, :], True)
    rho1 = np.hypot(*d1.T)[:, None]  # (R, 1)
    rho2 = np.hypot(*d2.T)[:, None]
    phi = (np.arctan2(d2[:, 1], d2[:, 0]) - np.arctan2(d1[:, 1], d1[:, 0]) + dphi1)[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        k = rho2 / rho1
        s = np.hypot(*leg1[0].T)[None] / rho1  # (R, T)
        pred_len2 = (pred**2).sum(-1)
        var = (
            per_robot(pixel_noise) ** 2 * (2.0 + 2.0 * k**2 + 2.0 * k * np.cos(phi))
            + pred_len2 * per_robot(var_d1) / rho1**2
            + pred_len2 * per_robot(var_dphi1)
            + s**2 * per_robot(var_d2)
        )
        chi2 = ((leg2 - pred) ** 2).sum(-1) / var
    chi2 = np.where(np.isfinite(chi2), chi2, np.inf)
    return min_per_column(chi2, c, len(p2))


def faithful_scale_free_deviation(
    p0: np.ndarray,
    p1: np.ndarray,
    p2: np.ndarray,
    d1: np.ndarray,
    dphi1: np.ndarray,
    d2: np.ndarray,
) -> np.ndarray:
    """``(R, n2)`` smallest prediction error (image units) over all n^3 triples ending at each
    row, with the paper's ``arctan`` and no gating (``motion3``, faithful)."""
    n0, n1, n2 = len(p0), len(p1), len(p2)
    if n0 * n1 * n2 > MAX_FAITHFUL_TRIPLES:
        raise ValueError(
            f"the faithful motion3 method is O(n^3): {n0}x{n1}x{n2} triples is too many; "
            "use the corrected version (mode='corrected')"
        )
    d1, d2 = np.atleast_2d(d1), np.atleast_2d(d2)
    dphi1 = np.atleast_1d(dphi1)
    leg1 = p1[None, :, :] - p0[:, None, :]  # (n0, n1, 2)
    leg2 = p2[None, :, :] - p1[:, None, :]  # (n1, n2, 2)
    pred = _predict_second_leg(
        leg1[None, :, :, None, :],
        d1[:, None, None, None, :],
        dphi1.reshape(-1, 1, 1, 1),
        d2[:, None, None, None, :],
        False,
    )  # (R, n0, n1, 1, 2)
    err = np.hypot(*(leg2[None, None] - pred).transpose(4, 0, 1, 2, 3))  # (R, n0, n1, n2)
    err = np.where(np.isfinite(err), err, np.inf)
    return err.min(axis=(1, 2))
