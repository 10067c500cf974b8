"""Method A of the paper: angular variation (Algorithm 1), faithful and corrected.

Between two pictures each robot turns in place at a rate ``rate`` (rad/s) for ``duration`` seconds.
It is the detection whose heading changed by ``rate * duration``.

* :func:`faithful_residuals`: Algorithm 1 as printed, with only its typos fixed so that it runs
  (``min``/``mini`` and ``t1``/``dt``; as printed it always answers the last row). Kept: the same
  index ``p`` is assumed to be the same robot in both pictures, and ``|theta_i - theta_j|`` drops
  the sign and is never wrapped.
* :func:`residuals`: the corrected test. Detections are paired across pictures by nearest
  neighbour (robots turning in place do not move), the heading change is signed and wrapped, and
  a row is accepted only if its residual is within the noise.
"""

from __future__ import annotations

import numpy as np

from baselines.matching import match_nearest, wrap_angle


def faithful_residuals(
    theta_first: np.ndarray, theta_second: np.ndarray, rotation: np.ndarray
) -> np.ndarray:
    """``(R, n)`` residuals ``|r * dt - |theta_i(p) - theta_j(p)||`` of Algorithm 1.

    Args:
        theta_first: headings of the first picture's rows (rad).
        theta_second: headings of the second picture's rows (rad), compared index by index.
        rotation: ``(R,)`` each robot's commanded rotation ``r * dt`` (rad).
    Rows past the shorter picture cannot be compared and get ``inf``.
    """
    n = len(theta_second)
    common = min(len(theta_first), n)
    delta = np.full(n, np.inf)
    delta[:common] = np.abs(theta_first[:common] - theta_second[:common])
    return np.abs(np.atleast_1d(rotation)[:, None] - delta[None, :])


def residuals(
    first: np.ndarray, second: np.ndarray, rotation: np.ndarray, max_shift: float
) -> np.ndarray:
    """``(R, n)`` corrected residuals ``|wrap(wrap(theta_q - theta_p) - rotation)|``.

    Args:
        first: ``(m, 3)`` rows ``(u, v, theta)`` of the first picture.
        second: ``(n, 3)`` rows of the second picture.
        rotation: ``(R,)`` each robot's own heading change between the pictures (rad).
        max_shift: farthest a detection of a robot turning in place can move between pictures
            (image units): noise plus the wheel base. Rows with no partner get ``inf``.
    """
    match = match_nearest(first[:, :2], second[:, :2], max_shift)
    change = np.full(len(second), np.nan)
    ok = match >= 0
    change[ok] = wrap_angle(second[ok, 2] - first[match[ok], 2])
    res = np.abs(wrap_angle(change[None, :] - np.atleast_1d(rotation)[:, None]))
    return np.where(np.isnan(res), np.inf, res)
