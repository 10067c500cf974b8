"""The uniform weight's first step without headings, compiled (numba, the optional ``fast``
extra; see ``anonloc_env.compiled``).

When the heading is not detected and the scale is known, a robot whose position is still
unknown is anchored at every pair of rows whose length fits its motion (the ring of
``likelihood.score_cases``' case A). At the second picture of an episode that is every robot
and every pair within reach: 700,000 candidates at N = 1000, most of a picture's time on the
general path (``Builder._uniform_children``). ``ring_leg`` gives that path's tracks, to the
bit, for robots nothing pushed (pushed robots keep the general path): ``uniform_gate``, the
bound of ``Builder._ring_bound`` against the robot's floor, ``likelihood.children`` (the ring
log-likelihood, the first heading from the displacement) and its prune.

Only ``+ - * /``, comparisons and ``min``/``max`` happen inside the compiled passes, each
expression parenthesised as numpy evaluates it. The transcendentals (``hypot``, ``log``,
``exp``, ``arctan2``), whose vectorised numpy forms may differ from the C library's in the last
bit, stay numpy calls between the passes, on arrays laid out as the general path lays them out
(strided columns of ``(K, 2)`` arrays where it takes those), so that each gives the same floats.
``tests/test_identify_fused.py`` runs the identifier with the kernels on and off and compares
every field of every track; ``tests/test_identify_bound.py`` does so under both drone presets.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from anonloc_env import compiled
from anonloc_env.compiled import jit
from anonloc_env.geometry import wrap_angle
from anonloc_env.identify.arrays import shared
from anonloc_env.identify.gate import GATE_CHI2, PRUNE_NATS, worst_variance
from anonloc_env.identify.kernels import Prior
from anonloc_env.identify.likelihood import Pairs, Scoring
from anonloc_env.identify.model import (
    I0_LARGE,
    I0_SMALL,
    LOG_2PI,
    LOG_I0E_ROOT_MAX,
    push_isotropic,
)
from anonloc_env.identify.tracks import Tracks

#: Rows of the per-robot table the compiled passes read (``(len, R)``).
GATE_RHO, GATE_VAR, BOUND_RHO, BOUND_VAR, BOUND_LOG_VAR, UNIFORM, FLOOR = range(7)
RING_RHO, RING_VAR, RING_LOG_VAR, STILL, VAR_DPHI, ANGLE_D, DPHI = range(7, 14)
#: Rows of the per-pair table: the pair's length (``hypot`` of its displacement, as
#: ``uniform_gate`` and ``Geometry`` take it), its length from the neighbour search (as the
#: bound takes it), the row bias of its first row, what a link along it is divided by and its
#: direction (``arctan2`` of its displacement).
LENGTH, DIST, BIAS, BACKGROUND, ANGLE = range(5)


def applies(fast: bool, scoring: Scoring) -> bool:
    """Whether ``ring_leg`` replaces the general path: the fast kernels wanted and compiled,
    the heading not detected, the scale known."""
    model = scoring.model
    if not fast or model.orientation or model.scale is None:
        return False
    return compiled.mode() is not None


def ring_leg(
    live: np.ndarray,
    start: np.ndarray,
    counts: np.ndarray,
    by_length: np.ndarray,
    pairs: Pairs,
    dist: np.ndarray,
    floor: np.ndarray | None,
    prior: Prior,
    scoring: Scoring,
    slack: float,
) -> Tracks:
    """Equals ``Builder._uniform_children`` (to the bit, the tracks in its order) for robots
    ``live`` (none pushed), heading not detected, scale known: robot ``live[k]``'s candidates
    are the pairs ``by_length[start[k]:start[k] + counts[k]]``, ``dist`` each pair's length,
    ``floor`` each robot's log weight below which a child is pruned anyway (None: not known),
    ``slack`` the bound's margin (nats, ``children.BOUND_SLACK``)."""
    total = int(counts.sum())
    if total == 0:
        return Tracks.empty()
    robot, pair = _tables(pairs, dist, floor, prior, scoring)
    bound = floor is not None
    k_of = np.empty(total, dtype=np.int64)
    pick = np.empty(total, dtype=np.int64)
    x = np.empty(total)
    n = _gated(live, start, counts, by_length, robot, pair, GATE_CHI2, bound, (k_of, pick, x))
    k_of, pick, x = k_of[:n], pick[:n], x[:n]
    with np.errstate(divide="ignore"):
        log_x = np.log(x) if bound else x  # the bound's log (x = 0: -inf, a bound of 0)
    numbers = np.array([scoring.log_pd, LOG_I0E_ROOT_MAX, slack, LOG_2PI])
    n = _ringed(live, k_of, pick, log_x, robot, pair, numbers, bound, x)
    k_of, pick, x = k_of[:n], pick[:n], x[:n]
    # log_i0e's logs: of I0 (small x) or of its asymptotic series (large x), and of x.
    poly = np.empty(n)
    _i0_terms(x, poly)
    log_poly = np.log(poly)
    with np.errstate(divide="ignore"):
        log_x = np.log(x)
    kept = np.empty(n, dtype=np.int64)
    logw = np.empty(n)
    p_tt = np.empty(n)
    theta = np.empty(n)
    count = _pruned(
        live, k_of, pick, x, log_poly, log_x, robot, pair, numbers, PRUNE_NATS,
        (kept, logw, p_tt, theta),
    )  # fmt: skip
    kept, logw, p_tt, theta = kept[:count], logw[:count], p_tt[:count], theta[:count]
    slot = live[k_of[kept]]
    row = pairs.j_pair[pick[kept]]
    assert scoring.model.scale is not None
    return Tracks.fresh(
        slot,
        row,
        pairs.rows[row, :2],
        logw,
        pos_var=pairs.pix_var,
        theta=wrap_angle(theta),
        p_tt=p_tt,
        log_s=math.log(scoring.model.scale),
    )


class _Geometry(NamedTuple):
    """Per robot, as ``likelihood.Geometry`` computes it for a track just anchored: the scale
    it holds, ``|d|``, the variance with the pushes and whether it moved too little to learn a
    heading from."""

    s: np.ndarray
    rho0: np.ndarray
    iso_var: np.ndarray
    still: np.ndarray


def _tables(
    pairs: Pairs, dist: np.ndarray, floor: np.ndarray | None, prior: Prior, scoring: Scoring
) -> tuple[np.ndarray, np.ndarray]:
    """The per-robot ``(14, R)`` and per-pair ``(5, P)`` tables (see the row names above),
    each number computed by the numpy expression of the general path."""
    model, interval, pix_var = scoring.model, pairs.interval, pairs.pix_var
    assert model.scale is not None
    s = model.scale
    n = len(interval.d)
    d = interval.d
    var_d, var_dphi = interval.variances(model.odometry_noise)
    robot = np.zeros((14, n))
    # uniform_gate
    robot[GATE_RHO] = s * np.hypot(d[:, 0], d[:, 1])
    robot[GATE_VAR] = worst_variance(np.arange(n), interval, model, pix_var) + pix_var
    # Builder._ring_bound
    rho = np.hypot(interval.d[:, 0], interval.d[:, 1])
    var = 2.0 * pix_var + s**2 * var_d + (model.scale_spread * s * rho) ** 2
    if interval.push is not None:
        var = var + s**2 * push_isotropic(interval, model)
    robot[BOUND_RHO] = s * rho
    robot[BOUND_VAR] = var
    robot[BOUND_LOG_VAR] = np.log(var)
    robot[UNIFORM] = prior.uniform
    robot[FLOOR] = -np.inf if floor is None else floor
    # likelihood.Geometry and ring_loglik
    geo = _geometry(pairs, scoring)
    robot[RING_RHO] = geo.s * geo.rho0
    robot[RING_VAR] = geo.iso_var
    robot[RING_LOG_VAR] = np.log(geo.iso_var)
    robot[STILL] = geo.still
    robot[VAR_DPHI] = var_dphi
    robot[ANGLE_D] = np.arctan2(d[:, 1], d[:, 0])  # Geometry.ang_d
    robot[DPHI] = interval.dphi
    prev, rows, i_pair, j_pair = pairs.prev, pairs.rows, pairs.i_pair, pairs.j_pair
    pair = np.zeros((5, len(i_pair)))
    delta = rows[j_pair, :2] - prev[i_pair, :2]
    pair[LENGTH] = np.hypot(delta[:, 0], delta[:, 1])
    pair[ANGLE] = np.arctan2(delta[:, 1], delta[:, 0])  # Geometry.ang_delta
    pair[DIST] = dist
    if prior.row_bias is not None:
        pair[BIAS] = prior.row_bias[i_pair]
    if prior.links is not None:  # per link (the others persist), as Builder._link_bg
        pair[BACKGROUND] = -prior.links.detect(i_pair, j_pair)
    else:
        pair[BACKGROUND] = pairs.log_bg
    return robot, pair


def _geometry(pairs: Pairs, scoring: Scoring) -> _Geometry:
    """``_Geometry`` of every robot."""
    model, interval, pix_var = scoring.model, pairs.interval, pairs.pix_var
    assert model.scale is not None
    n = len(interval.d)
    d = interval.d
    rho0 = np.hypot(d[:, 0], d[:, 1])
    var_d_all, _ = interval.variances(model.odometry_noise)
    s = np.exp(shared(math.log(model.scale), n))  # a parent's log scale, as it reads it
    base_var = pix_var + pix_var + s**2 * var_d_all + (model.scale_spread * s * rho0) ** 2
    iso_var = base_var
    if interval.push is not None:
        iso_var = base_var + s**2 * push_isotropic(interval, model)
    still = model.scale_bounds[1] * rho0 < 2.0 * np.sqrt(iso_var)
    return _Geometry(s, rho0, iso_var, still)


@jit
def _gated(
    live: np.ndarray,
    start: np.ndarray,
    counts: np.ndarray,
    by_length: np.ndarray,
    robot: np.ndarray,
    pair: np.ndarray,
    chi2_max: float,
    bound: bool,
    out: tuple[np.ndarray, np.ndarray, np.ndarray],
) -> int:
    """``uniform_gate`` of every candidate: writes each one that passes (its index into
    ``live``, its pair and, if ``bound``, the argument ``x`` of the bound's ``log``) into
    ``out``; returns how many."""
    out_k, out_pick, out_x = out
    n = 0
    for k in range(live.shape[0]):
        r = live[k]
        rho, var = robot[GATE_RHO, r], robot[GATE_VAR, r]
        for m in range(start[k], start[k] + counts[k]):
            p = by_length[m]
            length = pair[LENGTH, p] - rho
            if length * length / (2.0 * var) <= chi2_max:
                out_k[n], out_pick[n] = k, p
                if bound:
                    out_x[n] = pair[DIST, p] * robot[BOUND_RHO, r] / robot[BOUND_VAR, r]
                n += 1
    return n


@jit
def _ringed(
    live: np.ndarray,
    k_of: np.ndarray,
    pick: np.ndarray,
    log_x: np.ndarray,
    robot: np.ndarray,
    pair: np.ndarray,
    numbers: np.ndarray,
    bound: bool,
    x: np.ndarray,
) -> int:
    """The bound (if ``bound``: ``log_x`` its logs) against each robot's floor; the candidates
    kept are moved to the front of ``k_of`` and ``pick``, and ``x`` is overwritten with the
    ring likelihood's ``x = r rho / var``. Returns how many are kept."""
    log_pd, root_max, slack, log_2pi = numbers[0], numbers[1], numbers[2], numbers[3]
    n = 0
    for m in range(k_of.shape[0]):
        k, p = k_of[m], pick[m]
        r = live[k]
        if bound:
            tail = root_max - 0.5 * log_x[m]  # np.minimum(0.0, .) of a number, never NaN
            tail = tail if tail < 0.0 else 0.0
            rr, rho, var = pair[DIST, p], robot[BOUND_RHO, r], robot[BOUND_VAR, r]
            e = rr - rho
            ll = -log_2pi - robot[BOUND_LOG_VAR, r] - e * e / (2.0 * var) + tail
            prior = robot[UNIFORM, r] + pair[BIAS, p]
            reach = prior + log_pd + ll + slack
            if not reach - pair[BACKGROUND, p] >= robot[FLOOR, r]:
                continue
        k_of[n], pick[n] = k, p
        x[n] = pair[LENGTH, p] * robot[RING_RHO, r] / robot[RING_VAR, r]
        n += 1
    return n


@jit
def _series(t: float, coefficients: tuple[float, ...]) -> float:
    """``model.series`` of one number (the same floats)."""
    out = coefficients[len(coefficients) - 1] * t
    for k in range(len(coefficients) - 2, 0, -1):
        out = t * (coefficients[k] + out)
    return coefficients[0] + out


@jit
def _i0_terms(x: np.ndarray, out: np.ndarray) -> None:
    """``out``: what ``model.log_i0e`` takes the ``log`` of at each ``x``: the series of
    ``I0(x)`` below 3.75, of ``I0(x) exp(-x) sqrt(x)`` above (Abramowitz and Stegun 9.8.1-2)."""
    for m in range(x.shape[0]):
        v = x[m]
        if v < 3.75:
            out[m] = _series((v / 3.75) * (v / 3.75), I0_SMALL)
        else:
            out[m] = _series(3.75 / v, I0_LARGE)


@jit
def _pruned(
    live: np.ndarray,
    k_of: np.ndarray,
    pick: np.ndarray,
    x: np.ndarray,
    log_poly: np.ndarray,
    log_x: np.ndarray,
    robot: np.ndarray,
    pair: np.ndarray,
    numbers: np.ndarray,
    nats: float,
    out: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
) -> int:
    """The ring log-likelihood, each child's log weight, the prune of ``likelihood.pruned``
    (each robot's run of candidates at most ``nats`` below its best), the robot's floor
    (``Builder._uniform_children``'s: the children below it would be pruned anyway) and the
    first heading of ``Child.heading_from_displacement`` (NaN, variance inf: none learnt).
    Writes, for each
    kept candidate in order, its index (into ``k_of``), log weight, heading variance and
    heading (before its wrap) into ``out``; returns how many."""
    out_kept, out_logw, out_ptt, out_theta = out
    log_pd, log_2pi = numbers[0], numbers[3]
    total = k_of.shape[0]
    logw = np.empty(total)
    count = 0
    lo = 0
    while lo < total:
        k = k_of[lo]
        hi = lo
        best = -np.inf
        r = live[k]
        rho, var, log_var = robot[RING_RHO, r], robot[RING_VAR, r], robot[RING_LOG_VAR, r]
        while hi < total and k_of[hi] == k:
            v = x[hi]
            i0e = log_poly[hi] - (v if v < 3.75 else 0.5 * log_x[hi])
            p = pick[hi]
            e = pair[LENGTH, p] - rho
            loglik = -log_2pi - log_var - e * e / (2.0 * var) + i0e
            w = robot[UNIFORM, r] + pair[BIAS, p] + log_pd + loglik - pair[BACKGROUND, p]
            logw[hi] = w
            best = w if hi == lo else compiled.maximum(best, w)
            hi += 1
        floor = best - nats
        if robot[FLOOR, r] > floor:  # below the robot's floor: pruned anyway, not returned
            floor = robot[FLOOR, r]
        for m in range(lo, hi):
            if logw[m] >= floor:
                rr = pair[LENGTH, pick[m]]
                out_kept[count], out_logw[count] = m, logw[m]
                if robot[STILL, r] == 0.0 and rr > 0.0:  # a heading learnt
                    top = compiled.maximum(rr, 1e-12)
                    out_ptt[count] = var / (top * top) + robot[VAR_DPHI, r]
                    out_theta[count] = pair[ANGLE, pick[m]] - robot[ANGLE_D, r] + robot[DPHI, r]
                else:
                    out_ptt[count], out_theta[count] = np.inf, np.nan
                count += 1
        lo = hi
    return count


_LOADED: list[bool] = []


def load() -> None:
    """Compile, or load from numba's cache, this module's passes once per process, by calling
    each on a tiny input of the types ``ring_leg`` passes (``Identifier`` calls it beside
    ``fused.load``): the time goes to building the identifier, not to its first picture
    without headings."""
    if _LOADED:
        return
    index = np.zeros(1, dtype=np.int64)
    floats = np.ones(1)
    robot, pair = np.ones((14, 1)), np.ones((5, 1))
    _gated(index, index, index, index, robot, pair, GATE_CHI2, True, (index, index, floats))
    _ringed(index, index, index, floats, robot, pair, np.ones(4), True, floats)
    _i0_terms(floats, floats.copy())
    out = (index.copy(), floats.copy(), floats.copy(), floats.copy())
    _pruned(index, index, index, floats, floats, floats, robot, pair, np.ones(4), 1.0, out)
    _LOADED.append(True)
