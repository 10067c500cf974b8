"""The registration's guess of the robots' motion, and how rows are matched and weighed to it.

Between two pictures every row moves by the camera's change plus its robot's own displacement,
unknown to the others. ``Guess`` says where each row of the previous picture should be now
(ahead of or behind its place on its robot's axis, or anywhere a typical step away) and how far
off that may be; ``Anchors`` are the rows the identifier is sure of (``camera.pooled_motion``).
The helpers here find the rows within reach of the guesses (``Near``), weigh each pair by
its residual (``ways``, ``pair_weights``) and set the guesses' spreads to the residuals' robust
scales (``rescaled``, ``shrunk``). The fit that uses them is
``anonloc_env.identify.camera_pose.Registration``'s.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from anonloc_env.neighbours import _LOOK_AT_ALL as LOOK_AT_ALL
from anonloc_env.neighbours import pairs_within

#: How far (a share of the reach) the rows may move between rounds of matching before the
#: pairs within reach of them are searched again (``Near``).
NEAR_MARGIN = 0.1
#: Median absolute value of a standard Gaussian number.
NORMAL_MAD = 0.6745
#: Cauchy scale of the pair weights, in standard deviations of a pair's residual.
CAUCHY_SIGMAS = 2.5
#: Fewest pairs a robust scale (or the typical displacement) is taken from.
MIN_PAIRS = 4
#: A picture's robust scales are shrunk towards the running ones (from the pictures before) as
#: if those were this many pairs: a scale from a handful of pairs is too noisy to trust, and
#: when the fit locks onto a few pairs that agree by chance it is also too small.
SCALE_PRIOR_PAIRS = 8.0
#: Median length of a two-dimensional standard Gaussian vector: ``sqrt(2 ln 2)``.
RAYLEIGH_MEDIAN = math.sqrt(2.0 * math.log(2.0))


class Anchors(NamedTuple):
    """Rows ``row`` of the previous picture whose robot the identifier is sure of, where each
    should be in the new picture (``target``, ``(K, 2)``, the previous picture's registered
    frame) and the spread of that prediction (``sigma``, image units per component, the new
    row's pixel noise in it): built by ``anchors.sure_moves``."""

    row: np.ndarray
    target: np.ndarray
    sigma: np.ndarray


class Guess(NamedTuple):
    """Where each previous row's robot should be now: ``ahead`` of ``target`` (``(K, 2)``, the
    previous picture's registered frame) along ``axis`` (``(K, 2)`` unit vectors), or
    ``behind`` it, the second ``back_cost`` less likely (its squared Mahalanobis length's
    extra, ``2 log`` of the odds; ``ahead``, ``behind`` and ``back_cost`` 0 where nothing gives
    an axis), and how far off that may be: ``sigma`` across the axis and ``along`` it (image
    units, per component; both ``sigma`` where nothing gives an axis); ``directed``: the
    robots whose last displacement gave the axis; ``sure``: the anchored rows
    (``camera.pooled_motion``)."""

    target: np.ndarray
    sigma: np.ndarray
    directed: np.ndarray
    sure: np.ndarray
    axis: np.ndarray
    along: np.ndarray
    ahead: np.ndarray
    behind: np.ndarray
    back_cost: np.ndarray

    def sub(self, j: np.ndarray) -> Guess:
        """The guesses ``j``."""
        return Guess(*(field[j] for field in self))


def isotropic(target: np.ndarray, sigma: np.ndarray) -> Guess:
    """A guess of spread ``sigma`` in every direction, nothing directed or anchored."""
    count = len(target)
    axis = np.zeros((count, 2))
    axis[:, 0] = 1.0
    zero = np.zeros(count)
    return Guess(
        target,
        sigma,
        nobody(count),
        nobody(count),
        axis,
        sigma.copy(),
        zero,
        zero.copy(),
        zero.copy(),
    )


def anchored(guess: Guess, anchors: Anchors | None, floor: float) -> Guess:
    """``guess`` with the ``anchors``' rows predicted by their robots' own tracks (their
    spreads at least ``floor``, the same in every direction), sure and not directed."""
    if anchors is None:
        return guess
    out = Guess(*(a.copy() for a in guess))
    row = anchors.row
    out.target[row] = anchors.target
    out.sigma[row] = np.maximum(anchors.sigma, floor)
    out.along[row] = out.sigma[row]
    out.axis[row] = (1.0, 0.0)
    out.ahead[row] = out.behind[row] = out.back_cost[row] = 0.0
    out.directed[row] = False
    out.sure[row] = True
    return out


def nobody(count: int) -> np.ndarray:
    """No row anchored: ``(count,)`` False."""
    return np.zeros(count, bool)


class Near:
    """The pairs of rows and ``target`` places within ``reach`` (``pairs_within``'s, the same
    pairs in the same order) as the rows move from one round of matching to the next: where the
    search would run in numpy, the pairs within ``reach`` and a margin of the rows' first places
    are kept, and each round takes those within ``reach`` of the rows' places now, until the
    rows have moved further than the margin (then searched again)."""

    def __init__(self, target: np.ndarray, reach: float) -> None:
        self.target, self.reach = target, reach
        self.margin = NEAR_MARGIN * reach
        self.base: np.ndarray | None = None
        self.i = self.j = np.zeros(0, np.int64)

    def pairs(self, moved: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(row, place)`` pairs within the reach of the rows ``moved``."""
        if len(moved) * len(self.target) <= LOOK_AT_ALL:  # the compiled search: as it is
            i, j, _ = pairs_within(moved, self.target, self.reach)
            return i, j
        if self.base is None or float(np.abs(moved - self.base).max()) > self.margin:
            self.base = moved.copy()
            self.i, self.j, _ = pairs_within(moved, self.target, self.reach + 2.0 * self.margin)
        i, j = self.i, self.j
        keep = np.hypot(*(self.target[j] - moved[i]).T) <= self.reach
        return i[keep], j[keep]


def turned(x: np.ndarray, t0: np.ndarray, t1: np.ndarray) -> np.ndarray:
    """The interleaved ``(u, v)`` rows of ``x`` (``(2K, ...)``) turned onto the unit vectors
    ``(t0, t1)``: each pair's ``(along, across)``."""
    u, v = x[0::2], x[1::2]
    if x.ndim > 1:
        t0, t1 = t0[:, None], t1[:, None]
    out = np.empty_like(x)
    out[0::2], out[1::2] = t0 * u + t1 * v, t0 * v - t1 * u
    return out


def costs(along: np.ndarray, guess: Guess, spread: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For rows ``along`` their guesses' axes from the guesses' targets (image units,
    ``(K,)``): the squared Mahalanobis lengths along the axis (in ``spread``) from the places
    ahead and behind, each with its odds' cost (the likelier way's 0)."""
    ahead = (along - guess.ahead) ** 2 / spread**2 + np.maximum(-guess.back_cost, 0.0)
    behind = (along + guess.behind) ** 2 / spread**2 + np.maximum(guess.back_cost, 0.0)
    return ahead, behind


def ways(
    centre: np.ndarray, fitted: np.ndarray, guess: Guess, spread: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For the rows ``fitted`` (interleaved ``(along, across)`` rows, ``centre`` those of their
    guesses' targets): the place the guesses give them (ahead and behind weighed by how well
    each explains the row, in ``spread`` along the axis, the odds counted), the nearer of the
    two, and ``(K,)`` the variance that weighing adds along the axis (the mixture's
    spread)."""
    ahead, behind = costs(fitted[0::2] - centre[0::2], guess, spread)
    on = 0.5 * (1.0 + np.tanh(0.25 * (behind - ahead)))  # the chance it went on
    mixed, nearer = centre.copy(), centre.copy()
    mixed[0::2] += on * guess.ahead - (1.0 - on) * guess.behind
    nearer[0::2] += np.where(behind < ahead, -guess.behind, guess.ahead)
    return mixed, nearer, on * (1.0 - on) * (guess.ahead + guess.behind) ** 2


def mahalanobis(offset: np.ndarray, guess: Guess) -> np.ndarray:
    """The lengths of ``offset`` ``(K, 2)`` (along and across the guesses' axes, image units,
    from their targets to the rows) from the nearer of their places, in the ``guess``'s
    spreads (the odds counted)."""
    ahead, behind = costs(-offset[:, 0], guess, guess.along)
    return np.sqrt(np.minimum(ahead, behind) + (offset[:, 1] / guess.sigma) ** 2)


def pair_weights(residual: np.ndarray, sigma: np.ndarray, along: np.ndarray) -> np.ndarray:
    """``(2K,)`` the weights of the pairs' rows (along, across their axes; ``residual``
    ``(K, 2)``): their spreads ``along`` and ``sigma``, down-weighted (Cauchy) by the
    residual's length in those spreads."""
    norm = np.hypot(residual[:, 0] / along, residual[:, 1] / sigma)
    cauchy = 1.0 / (1.0 + (norm / CAUCHY_SIGMAS) ** 2)
    out = np.empty(2 * len(sigma))
    out[0::2], out[1::2] = cauchy / along**2, cauchy / sigma**2
    return out


def rescaled(
    residual: np.ndarray, guess: Guess, floor: float
) -> tuple[np.ndarray, np.ndarray, list[float | None]]:
    """The guesses' spreads (across and along their axes, ``guess`` of the pairs) set to their
    residuals' robust scales where a group has :data:`MIN_PAIRS`: the directed pairs across
    and along their axes apart (the median absolute residual over a Gaussian's, 0.6745), the
    others in every direction (the median residual length over a two-dimensional Gaussian's,
    :data:`RAYLEIGH_MEDIAN`); and those scales (``None`` where too few pairs). The anchored
    pairs (``sure``) keep their own spreads, widened by their residuals' robust scale over
    those spreads where that is above one (where a similarity cannot follow the picture, or an
    anchor was wrong)."""
    sigma, along = guess.sigma.copy(), guess.along.copy()
    scales: list[float | None] = [None, None, None]
    sure = guess.sure
    directed, others = guess.directed & ~sure, ~guess.directed & ~sure
    if int(directed.sum()) >= MIN_PAIRS:
        scales[0] = max(float(np.median(np.abs(residual[directed, 1]))) / NORMAL_MAD, floor)
        scales[2] = max(float(np.median(np.abs(residual[directed, 0]))) / NORMAL_MAD, floor)
        sigma[directed], along[directed] = scales[0], scales[2]
    if int(others.sum()) >= MIN_PAIRS:
        norm = np.hypot(residual[others, 0], residual[others, 1])
        scales[1] = max(float(np.median(norm)) / RAYLEIGH_MEDIAN, floor)
        sigma[others] = along[others] = scales[1]
    if int(sure.sum()) >= MIN_PAIRS:
        norm = np.hypot(residual[sure, 0], residual[sure, 1])
        ratio = float(np.median(norm / guess.sigma[sure])) / RAYLEIGH_MEDIAN
        sigma[sure] = along[sure] = guess.sigma[sure] * max(ratio, 1.0)
    return sigma, along, scales


def shrunk(
    sigma: np.ndarray, along: np.ndarray, guess: Guess, running: list[float | None]
) -> tuple[np.ndarray, np.ndarray]:
    """The spreads ``sigma`` (across) and ``along`` of the pairs (``guess``) shrunk towards the
    ``running`` scale of their group (where there is one: the directed pairs across and along
    their axes, the others), weighed as :data:`SCALE_PRIOR_PAIRS` pairs against the group's
    own (the anchored pairs keep theirs)."""
    sigma, along = sigma.copy(), along.copy()
    directed, others = guess.directed & ~guess.sure, ~guess.directed & ~guess.sure
    for group, spread, before in (
        (directed, sigma, running[0]),
        (others, sigma, running[1]),
        (directed, along, running[2]),
        (others, along, running[1]),
    ):
        count = int(group.sum())
        if count and before is not None:
            mixed = SCALE_PRIOR_PAIRS * before**2 + count * np.square(spread[group])
            spread[group] = np.sqrt(mixed / (SCALE_PRIOR_PAIRS + count))
    return sigma, along


def same_pairs(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]) -> bool:
    """Whether two sets of pairs (each sorted as ``Registration._match`` gives) are equal."""
    return bool(
        len(a[0]) == len(b[0]) and np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    )
