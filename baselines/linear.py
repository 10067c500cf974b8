"""Method B of the paper: linear speed variation, faithful and corrected.

Across pictures 0, 1, 2 a robot drives straight at ``v0`` then at ``v1``; its own distance ratio
is ``a = v0 T0 / (v1 T1)``, the same in the image whatever the scale.

* :func:`faithful_search`: the paper's test. Every triple ``(p, q, r)`` of rows, O(n^3), and the
  one whose ``|q - p| / |r - q|`` is closest to ``a`` wins; nothing else is checked, and the ratio
  blows up when the second leg is short.
* :func:`residuals`: the corrected test. A straight drive puts ``r`` at ``q + (q - p) / a``: one
  2-D residual tests the ratio, collinearity and direction at once, without dividing by a short
  leg. Triples are found by gating with the reachable radius (near-linear in n) and scored as a
  chi-square with 2 degrees of freedom against the pixel noise.
"""

from __future__ import annotations

import numpy as np

from baselines.matching import chain_triples, min_per_column

#: The faithful search refuses pictures so large that n^3 triples would not fit in memory.
MAX_FAITHFUL_TRIPLES = 20_000_000


def faithful_search(
    p0: np.ndarray, p1: np.ndarray, p2: np.ndarray, ratio: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The paper's O(n^3) ratio search.

    Args:
        p0, p1, p2: ``(n_k, 2)`` detections of the three pictures.
        ratio: ``(R,)`` each robot's own ``a = v0 T0 / (v1 T1)``.

    Returns:
        ``(row, deviation)``: per robot the row of picture 2 of the best triple (-1 if none) and
        its ``|ratio - a|``.
    """
    n0, n1, n2 = len(p0), len(p1), len(p2)
    if n0 * n1 * n2 > MAX_FAITHFUL_TRIPLES:
        raise ValueError(
            f"the faithful linear method is O(n^3): {n0}x{n1}x{n2} triples is too many; "
            "use the corrected version (mode='corrected')"
        )
    ratio = np.atleast_1d(ratio)
    if min(n0, n1, n2) == 0:
        return np.full(len(ratio), -1), np.full(len(ratio), np.inf)
    first = np.linalg.norm(p1[None, :, :] - p0[:, None, :], axis=-1)  # (n0, n1)
    second = np.linalg.norm(p2[None, :, :] - p1[:, None, :], axis=-1)  # (n1, n2)
    with np.errstate(divide="ignore", invalid="ignore"):
        measured = first[:, :, None] / second[None, :, :]  # (n0, n1, n2)
    dev = np.abs(measured[None] - ratio[:, None, None, None]).reshape(len(ratio), -1)
    dev = np.where(np.isnan(dev), np.inf, dev)
    best = np.argmin(dev, axis=1)
    deviation = dev[np.arange(len(ratio)), best]
    rows = np.where(np.isfinite(deviation), best % n2, -1)
    return rows, deviation


def residuals(
    p0: np.ndarray,
    p1: np.ndarray,
    p2: np.ndarray,
    ratio: np.ndarray,
    pixel_noise: float | np.ndarray,
    reach01: float,
    reach12: float,
    scale_change: float | np.ndarray = 0.0,
) -> np.ndarray:
    """``(R, n2)`` chi-square (2 dof) of the best straight-drive track ending at each row.

    Args:
        p0, p1, p2: ``(n_k, 2)`` detections of the three pictures.
        ratio: ``(R,)`` each robot's ``a = v0 T0 / (v1 T1)``, > 0.
        pixel_noise: standard deviation of a detection coordinate (image units), > 0; a scalar or
            ``(R,)`` (a robot whose odometry is less sure tests with a wider tolerance).
        reach01, reach12: how far any robot can move between pictures 0-1 and 1-2 (image units).
        scale_change: relative change of the camera scale between the two legs (a tilted camera's
            scale varies across the arena), a scalar or ``(R,)``: it swings the predicted second
            leg by that fraction of its length, in the variance.
    Rows no track reaches get ``inf``.
    """
    ratio = np.atleast_1d(np.asarray(ratio, dtype=np.float64))
    out = np.full((len(ratio), len(p2)), np.inf)
    a, b, c = chain_triples(p0, p1, p2, reach01, reach12)
    if len(a) == 0:
        return out
    k = 1.0 / ratio[:, None]  # (R, 1): second leg over first
    first = p1[b] - p0[a]  # (T, 2)
    err = (p2[c] - p1[b])[None] - k[..., None] * first[None]  # (R, T, 2)
    # r - q - k (q - p) = r - (1 + k) q + k p: each detection's noise enters with these weights.
    sigma = np.broadcast_to(np.asarray(pixel_noise, dtype=np.float64), ratio.shape)[:, None]
    change = np.broadcast_to(np.asarray(scale_change, dtype=np.float64), ratio.shape)[:, None]
    predicted = k**2 * (first**2).sum(axis=-1)[None]  # (R, T): squared length of k (q - p)
    var = sigma**2 * (1.0 + (1.0 + k) ** 2 + k**2) + change**2 * predicted
    chi2 = (err**2).sum(axis=-1) / var  # (R, T)
    return min_per_column(chi2, c, len(p2))
