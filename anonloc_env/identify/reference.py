"""An exact reference for the identifier on small cases: every track enumerated, nothing gated.

For each robot, every sequence of "which row of each picture was me, or missed" is scored under
the model of :mod:`anonloc_env.identify` without its approximations: no gates, no pruning, no cap
on the tracks continued through a miss, and the heading (and the scale, when unknown) integrated
numerically instead of linearised. Given the heading at the first picture ``theta0`` and the
scale ``s``, a track's positions are a linear-Gaussian chain (the first detection uniform over the
image, then ``x' = x + s R(theta) d`` plus the model's displacement noise, each detection ``x``
plus pixel noise), so a Kalman filter gives its likelihood exactly; ``theta0`` (uniform) and
``log s`` (uniform over the prior range) are integrated on a grid fine enough to resolve the
narrowest likelihood. A detection of the robot weighs ``P_D f / lambda`` against one of the other
detections (density ``lambda`` over the image, headings uniform), a miss ``1 - P_D``. Where the
model lets the other robots persist (:func:`anonloc_env.identify.others.persists`), each link
between consecutive pictures takes the very same weights as the identifier's
(:func:`~anonloc_env.identify.others.links_between`) in place of ``1 / lambda`` and ``1``.

Exact only where the model's heading is deterministic given ``theta0``: the odometry must be
noise-free (``model.odometry_noise == 0``) and no contact may have pushed a robot
(``interval.push is None``); the scale spread of a tilted camera is kept (the model treats it as
displacement noise). The cost grows as the product of (rows + 1) over the pictures, so it refuses
more than :data:`MAX_TRACKS` tracks per robot (N <= 6 and 5 pictures fit); prefixes that a
bound shows cannot matter (:data:`REFERENCE_MARGIN_NATS`) are dropped as it goes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from anonloc_env.geometry import wrap_angle
from anonloc_env.identify.model import LOG_2PI, SensorModel, log_background
from anonloc_env.identify.others import Links, links_between
from anonloc_env.odometry import Interval

#: Most tracks enumerated per robot.
MAX_TRACKS = 200_000
#: Grid points per standard deviation of the narrowest likelihood in theta0 or log s (the
#: midpoint rule on a Gaussian this well sampled errs by about exp(-2 pi^2 3^2) = 1e-77).
POINTS_PER_SIGMA = 3.0
#: A track prefix is dropped only when, in the most favourable future for it and the least for
#: the best one, it stays this far below (exp(-60) times at most MAX_TRACKS tracks: < 1e-20).
REFERENCE_MARGIN_NATS = 60.0


class _Weights(NamedTuple):
    """``log P_D``, ``log (1 - P_D)``, ``log lambda`` per picture and the pixel variance."""

    log_pd: float
    log_miss: float
    log_bg: list[float]
    pix_var: float


def _log_weights(model: SensorModel, pictures: list[np.ndarray]) -> _Weights:
    """The :class:`_Weights` as the identifier takes them (the same floors, the same
    ``crowd_noise``)."""
    log_pd = math.log(min(model.p_detect, 1.0 - 1e-6))
    log_miss = math.log(max(1.0 - model.p_detect, 1e-6))
    log_bg = [log_background(model, len(rows)) for rows in pictures]
    extent = max((float(np.abs(r[:, :2]).max()) for r in pictures if len(r)), default=1.0)
    # The crowd's noise floor (``SensorModel.crowd_noise``) as the identifier takes it.
    pix_var = (model.pixel_noise * model.crowd_noise) ** 2 + (1e-4 + 1e-6 * extent) ** 2
    return _Weights(log_pd, log_miss, log_bg, pix_var)


def _grids(
    model: SensorModel, intervals: list[Interval], robot: int, pix_var: float
) -> tuple[np.ndarray, np.ndarray]:
    """Midpoint grids over ``theta0`` and ``log s`` resolving the narrowest likelihood."""
    s_low, s_high = model.scale_bounds
    rho = [float(np.hypot(*iv.d[robot])) for iv in intervals]
    longest = max([r for r in rho if r > 0], default=0.0)
    widths = [math.pi]
    if longest > 0:
        # The heading and log scale are known to about sigma / (s |d|) after one leg; k legs
        # shrink that by sqrt(k).
        widths.append(math.sqrt(2 * pix_var) / (s_low * longest) / math.sqrt(len(intervals)))
    if model.orientation:
        widths.append(max(model.orientation_noise, 1e-3) / math.sqrt(len(intervals) + 1))
    step = min(widths) / POINTS_PER_SIGMA
    n_theta = int(min(max(math.ceil(2 * math.pi / step), 64), 16384))
    theta = -math.pi + (np.arange(n_theta) + 0.5) * (2 * math.pi / n_theta)
    if s_high > s_low:
        span = math.log(s_high / s_low)
        n_s = int(min(max(math.ceil(span / step), 8), 2048))
        log_s = math.log(s_low) + (np.arange(n_s) + 0.5) * (span / n_s)
    else:
        log_s = np.array([math.log(s_low)])
    return theta, log_s


def exact_beliefs(
    model: SensorModel,
    pictures: list[np.ndarray],
    intervals: list[Interval],
    *,
    chunk: int = 64,
) -> list[tuple[np.ndarray, np.ndarray]]:
    """The exact posterior of every robot at every picture.

    Args:
        model: the sensor model (``odometry_noise`` must be 0).
        pictures: the ``(n_k, 3)`` rows ``(u, v, theta)`` of pictures ``0 .. K-1``.
        intervals: the ``K - 1`` intervals between them (R robots each; no pushes).
        chunk: memory cap: live tracks times grid points at most ``chunk * MAX_TRACKS``.

    Returns:
        For each picture k: ``(belief, missing)`` with ``belief`` ``(R, n_k)``, the probability
        that row j is robot i, and ``missing`` ``(R,)`` that robot i is in none of the rows
        (the same quantities as ``Identifier.belief()`` and ``Identifier.missing()``).

    Raises:
        ValueError: noisy odometry, pushes, mismatched lengths, or too many tracks.
    """
    if model.odometry_noise != 0.0:
        raise ValueError(
            f"the exact reference needs model.odometry_noise == 0, got {model.odometry_noise}"
        )
    if len(intervals) != len(pictures) - 1:
        raise ValueError(
            f"intervals must be one fewer than pictures ({len(pictures) - 1}), got {len(intervals)}"
        )
    if any(iv.push is not None for iv in intervals):
        raise ValueError("the exact reference needs intervals without pushes (interval.push)")
    pictures = [np.asarray(p, dtype=np.float64).reshape(-1, 3) for p in pictures]
    tracks = math.prod(len(p) + 1 for p in pictures)
    if tracks > MAX_TRACKS:
        raise ValueError(f"{tracks} tracks per robot exceed MAX_TRACKS={MAX_TRACKS}")
    n_robots = len(intervals[0].d) if intervals else 1
    out = [(np.zeros((n_robots, len(p))), np.zeros(n_robots)) for p in pictures]
    for robot in range(n_robots):
        for k, (belief, missing) in enumerate(_one_robot(model, pictures, intervals, robot, chunk)):
            out[k][0][robot] = belief
            out[k][1][robot] = missing
    return out


def _one_robot(
    model: SensorModel,
    pictures: list[np.ndarray],
    intervals: list[Interval],
    robot: int,
    chunk: int,
) -> list[tuple[np.ndarray, float]]:
    """Robot ``robot``'s ``(belief, missing)`` at every picture (see :func:`exact_beliefs`)."""
    weights = _log_weights(model, pictures)
    links = _links(model, pictures, weights)
    th0, s = _grid_points(model, intervals, robot, weights.pix_var)
    var_z = model.orientation_noise**2 + 1e-10
    turn = np.concatenate([[0.0], np.cumsum([iv.dphi[robot] for iv in intervals])])
    best_gain, miss_down = _gain_bounds(model, weights, links, var_z)
    prefixes = _Prefixes.start(th0.shape[1])
    out = []
    for k, rows in enumerate(pictures):
        if k > 0:
            prefixes.predict(intervals[k - 1].d[robot], th0 + turn[k - 1], s, model.scale_spread)
        prefixes, row = prefixes.branch(len(rows))
        seen = row >= 0
        _weigh_misses(prefixes, seen, weights.log_miss, links[k])
        if len(rows):
            z = rows[np.maximum(row, 0)]
            _weigh_detections(prefixes, row, weights.log_pd, weights.log_bg[k], links[k])
            _weigh_positions(prefixes, seen, z, model.image_area, weights.pix_var)
            if model.orientation:
                _weigh_headings(prefixes, seen, z, th0 + turn[k], var_z)
            prefixes.anchored = prefixes.anchored | seen
        # Integrate over the grid (prior: uniform, 1 / points per point).
        logw = np.logaddexp.reduce(prefixes.loglik, axis=1) - math.log(th0.shape[1])
        out.append(_posterior(logw, row, len(rows) + 1))
        if k + 1 < len(pictures):
            later = slice(k + 1, None)
            bounds = best_gain[later], miss_down[later]
            prefixes = _drop_hopeless(prefixes, logw, *bounds, weights.log_miss)
            if len(prefixes.loglik) * th0.shape[1] > chunk * MAX_TRACKS:
                raise ValueError(
                    f"{len(prefixes.loglik)} live tracks x {th0.shape[1]} grid points: too large"
                )
    return out


def _links(model: SensorModel, pictures: list[np.ndarray], weights: _Weights) -> list[Links | None]:
    """The links between consecutive pictures (:func:`links_between`; ``None`` for the first
    picture and where the clutter model holds)."""
    links: list[Links | None] = [None]
    for k in range(1, len(pictures)):  # each link knows how the rows of the one before moved
        links.append(
            links_between(
                model, pictures[k - 1], pictures[k], weights.log_bg[k], weights.pix_var, links[-1]
            )
        )
    return links


def _grid_points(
    model: SensorModel, intervals: list[Interval], robot: int, pix_var: float
) -> tuple[np.ndarray, np.ndarray]:
    """``(theta0, s)`` at every point of the grid over ``theta0`` and ``log s``, as ``(1, G)``."""
    theta_grid, log_s_grid = _grids(model, intervals, robot, pix_var)
    th0 = np.repeat(theta_grid, len(log_s_grid))[None, :]
    s = np.exp(np.tile(log_s_grid, len(theta_grid)))[None, :]
    return th0, s


def _gain_bounds(
    model: SensorModel, weights: _Weights, links: list[Links | None], var_z: float
) -> tuple[list[float], list[float]]:
    """Per picture, bounds on what it can multiply a track's weight by (log): at most
    ``best_gain``, and a miss's link at least ``miss_down``."""
    log_pd, log_miss, log_bg, pix_var = weights
    # At most the best detection (a Kalman innovation is at least 2 pixel variances wide), at
    # least a miss (always there).
    heading_gain = LOG_2PI - 0.5 * math.log(2 * math.pi * var_z) if model.orientation else 0.0
    # With the others persisting, a link's weight in place of -log lambda is at most
    # max(starts) + max(ends, 0) + max(extra, 0); a miss's lies in [min(ends, 0), max(ends, 0)].
    link_up = [-b for b in log_bg]
    miss_up = [0.0] * len(log_bg)
    miss_down = [0.0] * len(log_bg)
    for k, link in enumerate(links):
        if link is not None and len(link.starts) and len(link.ends):
            top_end = max(float(link.ends.max()), 0.0)
            top_extra = max(float(link.extra.max()), 0.0) if len(link.extra) else 0.0
            link_up[k] = float(link.starts.max()) + top_end + top_extra
            miss_up[k] = top_end
            miss_down[k] = min(float(link.ends.min()), 0.0)
    best_gain = [
        max(
            log_miss + m,
            log_pd + u - LOG_2PI - math.log(2 * pix_var) + heading_gain,
            log_pd + u,
        )
        for u, m in zip(link_up, miss_up, strict=True)
    ]
    return best_gain, miss_down


@dataclass
class _Prefixes:
    """Every live track prefix at every one of the ``G`` grid points.

    Attributes:
        taken: ``(T, k)`` the row each prefix took in each picture so far (-1: missed).
        anchored: ``(T,)`` whether it was detected yet.
        mean, var: ``(T, G, 2)`` and ``(T, G)``, the Kalman filter's position estimate.
        loglik: ``(T, G)`` its log likelihood.
    """

    taken: np.ndarray
    anchored: np.ndarray
    mean: np.ndarray
    var: np.ndarray
    loglik: np.ndarray

    @classmethod
    def start(cls, points: int) -> _Prefixes:
        """The empty prefix, before any picture."""
        return cls(
            np.zeros((1, 0), dtype=np.int64),
            np.zeros(1, dtype=bool),
            np.zeros((1, points, 2)),
            np.zeros((1, points)),
            np.zeros((1, points)),
        )

    def take(self, index: np.ndarray) -> _Prefixes:
        """Prefixes ``index``."""
        return _Prefixes(
            self.taken[index],
            self.anchored[index],
            self.mean[index],
            self.var[index],
            self.loglik[index],
        )

    def predict(self, d: np.ndarray, heading: np.ndarray, s: np.ndarray, spread: float) -> None:
        """Move the estimates by the robot's leg ``d`` (its own frame) at each grid point's
        ``heading`` and scale ``s``, the variance grown by the scale ``spread``."""
        step = np.stack(
            [
                np.cos(heading) * d[0] - np.sin(heading) * d[1],
                np.sin(heading) * d[0] + np.cos(heading) * d[1],
            ],
            axis=-1,
        )
        self.mean = self.mean + step * s[..., None]
        self.var = self.var + (spread * s * math.hypot(*d)) ** 2

    def branch(self, n_k: int) -> tuple[_Prefixes, np.ndarray]:
        """Every prefix continued with a miss and with each of ``n_k`` rows, and the row each
        child took (-1: missed)."""
        parent = np.repeat(np.arange(len(self.loglik)), n_k + 1)
        row = np.tile(np.arange(-1, n_k), len(self.loglik))
        children = self.take(parent)
        children.taken = np.column_stack([children.taken, row])
        return children, row


def _weigh_misses(p: _Prefixes, seen: np.ndarray, log_miss: float, link: Links | None) -> None:
    """A miss weighs ``1 - P_D``, and where the others persist what it leaves them."""
    p.loglik[~seen] += log_miss
    if link is not None:
        p.loglik[~seen] += link.miss(p.taken[~seen, -2])[:, None]


def _weigh_detections(
    p: _Prefixes, row: np.ndarray, log_pd: float, log_bg: float, link: Links | None
) -> None:
    """A detection weighs ``P_D / lambda``, or ``P_D`` times the link's weight where the others
    persist."""
    seen = row >= 0
    if link is None:
        p.loglik[seen] += log_pd - log_bg
    else:
        p.loglik[seen] += log_pd + link.detect(p.taken[seen, -2], row[seen])[:, None]


def _weigh_positions(
    p: _Prefixes, seen: np.ndarray, z: np.ndarray, image_area: float, pix_var: float
) -> None:
    """A first detection ``z`` is uniform over the image; a later one weighs the Kalman
    filter's innovation, which updates the estimate."""
    first = seen & ~p.anchored
    again = seen & p.anchored
    p.loglik[first] -= math.log(image_area)
    p.mean[first] = z[first][:, None, :2]
    p.var[first] = pix_var
    if again.any():
        e = z[again][:, None, :2] - p.mean[again]
        total = p.var[again] + pix_var
        p.loglik[again] += -LOG_2PI - np.log(total) - (e**2).sum(-1) / (2 * total)
        gain = p.var[again] / total
        p.mean[again] = p.mean[again] + gain[..., None] * e
        p.var[again] = p.var[again] * (1 - gain)


def _weigh_headings(
    p: _Prefixes, seen: np.ndarray, z: np.ndarray, heading: np.ndarray, var_z: float
) -> None:
    """A detected heading against the grid point's ``heading``, over the uniform heading of the
    other detections."""
    err = wrap_angle(z[seen][:, None, 2] - heading)
    p.loglik[seen] += LOG_2PI - 0.5 * (math.log(2 * math.pi * var_z) + err**2 / var_z)


def _posterior(logw: np.ndarray, row: np.ndarray, options: int) -> tuple[np.ndarray, float]:
    """``(belief, missing)`` from the prefixes' log weights ``logw`` and newest rows ``row``."""
    w = np.exp(logw - logw.max())
    w /= w.sum()
    belief = np.bincount(row + 1, weights=w, minlength=options)
    return belief[1:], float(belief[0])


def _drop_hopeless(
    p: _Prefixes, logw: np.ndarray, best_gain: list[float], miss_down: list[float], log_miss: float
) -> _Prefixes:
    """The prefixes that can matter at a later picture (``best_gain``, ``miss_down``: the
    later pictures' bounds): dropped are those that would stay :data:`REFERENCE_MARGIN_NATS`
    below the best even if every later picture multiplied them by the most possible and the
    best by the least (a bound, not an approximation: about 1e-17 at most)."""
    up = sum(best_gain)
    down = len(best_gain) * log_miss + sum(miss_down)
    keep = logw + up >= logw.max() + down - REFERENCE_MARGIN_NATS
    return p.take(np.flatnonzero(keep))


def total_variation(
    belief: np.ndarray, missing: np.ndarray, ref_belief: np.ndarray, ref_missing: np.ndarray
) -> np.ndarray:
    """``(R,)`` total variation distance between two posteriors over rows plus "not in it"."""
    return 0.5 * (np.abs(belief - ref_belief).sum(axis=1) + np.abs(missing - ref_missing))
