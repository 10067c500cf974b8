"""The identifier's fast kernels: two uses of the general path of
:mod:`anonloc_env.identify.likelihood`, computed faster for the cases that dominate large N.

Each kernel says which general path it equals; ``Identifier(fast=False)`` takes the general path
everywhere instead, and ``tests/test_identify_paths.py`` checks that the two agree (bit-identical
where the arithmetic is the same, within rounding where it is reordered).

* :func:`first_leg`: a robot's "position unknown" anchored at every pair of rows, when headings
  are detected and the scale is known (the first interval of an episode, where every row of both
  pictures is a candidate);
* :func:`known_children`: tracks that know their heading and scale extended by candidate rows
  (every interval after the first few).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from anonloc_env import compiled
from anonloc_env.geometry import wrap_angle
from anonloc_env.identify import fused, fused_calls
from anonloc_env.identify.arrays import (
    columns,
    group_sizes,
    group_starts,
    near_best,
    positions,
    take_field,
)
from anonloc_env.identify.gate import GATE_CHI2, PRUNE_NATS, Gate, worst_variance
from anonloc_env.identify.likelihood import (
    Child,
    Pairs,
    Scoring,
    filter_positions,
    fresh_children,
    orientation,
    pruned,
)
from anonloc_env.identify.model import LOG_2PI
from anonloc_env.identify.others import Links
from anonloc_env.identify.pool import Pool
from anonloc_env.identify.tracks import Tracks
from anonloc_env.neighbours import expand_ranges
from anonloc_env.odometry import Interval

#: Candidates of the first leg scored per block (whole robots, about this many): small enough
#: that the block's temporaries stay in cache and are not fresh memory to fault in.
BLOCK = 8192


def wrap_fast(angle: np.ndarray) -> np.ndarray:
    """:func:`~anonloc_env.geometry.wrap_angle` up to rounding, in ``[-pi, pi]``: ``angle`` less
    its nearest multiple of 2 pi, a tenth of the cost of ``np.mod`` (for the first leg's blocks,
    where the result is only squared or added to a heading that is wrapped again)."""
    turns = angle * (0.5 / math.pi)
    np.rint(turns, out=turns)
    turns *= 2.0 * math.pi
    return np.subtract(angle, turns, out=turns)


class Prior(NamedTuple):
    """What the first leg's weights start from: ``uniform`` ``(R,)`` each robot's log weight of
    each row of the previous picture, ``row_bias`` the log weight of each of those rows in it
    (None: all alike), and ``links`` the other robots between the pictures (None: clutter)."""

    uniform: np.ndarray
    row_bias: np.ndarray | None
    links: Links | None


class _Robots(NamedTuple):
    """The first leg's terms that depend on the robot alone, ``(R,)`` each: the gate's centre
    and denominators, the heading Kalman step's variances (``b``, ``a`` as in
    :func:`~anonloc_env.identify.likelihood.kalman_heading`), the detected heading's variance
    and gain, and the weight's constant part."""

    gate_dx: np.ndarray
    gate_dy: np.ndarray
    gate_pos: np.ndarray
    gate_turn: np.ndarray
    b: np.ndarray
    a: np.ndarray
    p_tt1: np.ndarray
    var_o: np.ndarray
    gain: np.ndarray
    const: np.ndarray


class _Frames(NamedTuple):
    """Per pair: its displacement in the frame of the heading detected at its first row
    (``fx``, ``fy``), that heading, the detected turn, and the heading detected at its second
    row."""

    fx: np.ndarray
    fy: np.ndarray
    theta0: np.ndarray
    turn: np.ndarray
    seen: np.ndarray


def first_leg(
    robots: np.ndarray,
    start: np.ndarray,
    counts: np.ndarray,
    by_length: np.ndarray,
    pairs: Pairs,
    prior: Prior,
    scoring: Scoring,
    pool: Pool | None = None,
) -> Tracks:
    """Equals the general path ``Identifier(fast=False)`` takes for robots nothing pushed,
    heading detected, scale known: a parent track per pair at its first row (position variance
    ``pix_var``, the detected heading with variance ``theta_var``, the known scale), gated by
    :func:`~anonloc_env.identify.gate.uniform_gate` and extended by
    :func:`~anonloc_env.identify.likelihood.children` (whose case B is
    :func:`~anonloc_env.identify.likelihood.kalman_heading`, then
    :func:`~anonloc_env.identify.likelihood.orientation`). Beliefs agree up to rounding.

    Robot ``robots[k]``'s candidates are the pairs ``by_length[start[k]:start[k] + counts[k]]``.
    Computed in the robot's frame at the pair's first row: the pair is turned once, what depends
    on the robot alone is computed once per robot, and no parent track is built. The tracks come
    grouped by robot, heaviest first within each; with the kernels compiled, in a block of
    ``pool`` where given.
    """
    rows, j_pair = pairs.rows, pairs.j_pair
    model = scoring.model
    assert model.scale is not None
    total = int(counts.sum())
    if total == 0:
        return Tracks.empty()
    s = math.exp(math.log(model.scale))  # the scale a parent track holds, as children reads it
    per_robot = _robot_terms(s, pairs, prior, scoring)
    frames = _frames(pairs)
    # In blocks of whole robots small enough to stay in cache.
    ends = np.cumsum(counts)
    cuts = np.searchsorted(ends, np.arange(BLOCK, total, BLOCK), side="left")
    cuts = np.concatenate([[0], cuts, [len(robots)]])  # sorted: drop repeats without
    cuts = cuts[np.flatnonzero(np.diff(cuts, prepend=-1))]  # np.unique (it imports numpy.ma)
    leg = _Leg(cuts, robots, start, counts, by_length, s, per_robot, frames, pairs, prior, scoring)
    p_tt = per_robot.p_tt1 * (1 - per_robot.gain)  # what each robot's tracks keep
    if compiled.mode() is not None:  # the same floats in one call
        slot, row, pos, logw, theta, p_tt = _first_leg_compiled(leg, p_tt, pool)
    else:
        slot, pick, logw, theta = _first_leg_blocks(leg)
        row = j_pair[pick]
        pos, p_tt = positions(rows, row), p_tt[slot]
    return Tracks.fresh(
        slot, row, pos, logw, pos_var=pairs.pix_var, theta=theta, p_tt=p_tt, log_s=math.log(s)
    )


class _Leg(NamedTuple):
    """One first leg: robot ``robots[k]``'s candidates are the pairs
    ``by_length[start[k]:start[k] + counts[k]]``, scored in blocks of robots
    ``cuts[b]:cuts[b + 1]`` at the scale ``s``."""

    cuts: np.ndarray
    robots: np.ndarray
    start: np.ndarray
    counts: np.ndarray
    by_length: np.ndarray
    s: float
    per_robot: _Robots
    frames: _Frames
    pairs: Pairs
    prior: Prior
    scoring: Scoring


def _first_leg_blocks(leg: _Leg) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The first leg's blocks, each by :func:`_first_leg_block`: ``(slot, pair, log weight,
    heading)`` of what is kept."""
    counts, start, robots = leg.counts, leg.start, leg.robots
    total = int(counts.sum())
    out_slot = np.empty(total, dtype=np.int64)
    out_pick = np.empty(total, dtype=np.int64)
    out_logw = np.empty(total)
    out_theta = np.empty(total)
    count = 0
    for lo, hi in zip(leg.cuts[:-1].tolist(), leg.cuts[1:].tolist(), strict=True):
        sl = np.repeat(robots[lo:hi], counts[lo:hi])
        pk = leg.by_length[expand_ranges(start[lo:hi], counts[lo:hi])]
        sl, pk, logw, theta = _first_leg_block(
            sl, pk, leg.s, leg.per_robot, leg.frames, leg.pairs, leg.prior, leg.scoring
        )
        end = count + len(sl)
        out_slot[count:end], out_pick[count:end] = sl, pk
        out_logw[count:end], out_theta[count:end] = logw, theta
        count = end
    return out_slot[:count], out_pick[:count], out_logw[:count], out_theta[:count]


def _first_leg_compiled(
    leg: _Leg, p_tt: np.ndarray, pool: Pool | None = None
) -> tuple[np.ndarray, ...]:
    """:func:`_first_leg_blocks` and the tracks' rows, positions and heading variances (``p_tt``
    of each robot) by :func:`anonloc_env.identify.fused.first_leg` (the same floats), written
    into one allocation (a block of ``pool`` where given): ``(slot, row, pos, logw, theta,
    p_tt)``."""
    pairs, prior, by_length = leg.pairs, leg.prior, leg.by_length
    per_pair = np.zeros((2, len(pairs.i_pair)))
    if prior.links is not None:  # for every pair, added as _first_leg_block adds it
        per_pair[0] = pairs.log_bg + prior.links.detect(pairs.i_pair, pairs.j_pair)
    if prior.row_bias is not None:
        per_pair[1] = prior.row_bias[pairs.i_pair]
    d, dphi = pairs.interval.d, pairs.interval.dphi
    model_scale = leg.scoring.model.scale
    assert model_scale is not None
    numbers = [leg.s, model_scale, leg.scoring.theta_var, GATE_CHI2, PRUNE_NATS]
    total = int(leg.counts.sum())
    kinds = [(np.int64, 0), (np.int64, 0), (np.float64, 2)] + [(np.float64, 0)] * 3
    out = columns(total, kinds) if pool is None else pool.columns(total, kinds)
    count = fused.first_leg(
        leg.cuts,
        leg.robots.astype(np.int64),
        leg.start.astype(np.int64),
        leg.counts.astype(np.int64),
        (
            pairs.j_pair[by_length].astype(np.int64),
            np.vstack([np.array(leg.per_robot), p_tt]),
            np.array(leg.frames).take(by_length, axis=1),  # C order, as the kernel is compiled
            per_pair.take(by_length, axis=1),
            (prior.links is not None, prior.row_bias is not None),
            np.stack([d[:, 0], d[:, 1], dphi]),
            np.array(numbers, dtype=np.float64),
            np.ascontiguousarray(pairs.rows, dtype=np.float64),
        ),
        tuple(out),
    )
    return tuple(a[:count] for a in out)


def _robot_terms(s: float, pairs: Pairs, prior: Prior, scoring: Scoring) -> _Robots:
    """The first leg's per-robot terms (see :class:`_Robots`) at the scale ``s``."""
    model, theta_var = scoring.model, scoring.theta_var
    assert model.scale is not None
    interval, pix_var = pairs.interval, pairs.pix_var
    var_d, var_dphi = interval.variances(model.odometry_noise)
    dx, dy = interval.d[:, 0], interval.d[:, 1]
    rho2 = dx**2 + dy**2
    rho0 = np.hypot(dx, dy)
    gate_var = worst_variance(np.arange(len(dx)), interval, model, pix_var) + pix_var
    b = pix_var + pix_var + s**2 * var_d + (model.scale_spread * s * rho0) ** 2
    a = b + theta_var * (s * s * rho2)
    p_tt1 = np.maximum(theta_var * b / a, 1e-14) + var_dphi
    var_o = p_tt1 + theta_var
    const = prior.uniform + (
        -LOG_2PI
        - 0.5 * np.log(b * a)
        - 0.5 * (math.log(2 * math.pi) + np.log(var_o))
        + scoring.log_pd
        - pairs.log_bg
    )
    return _Robots(
        gate_dx=model.scale * dx,
        gate_dy=model.scale * dy,
        gate_pos=gate_var + model.scale**2 * rho2 * theta_var,
        gate_turn=2.0 * theta_var + var_dphi,
        b=b,
        a=a,
        p_tt1=p_tt1,
        var_o=var_o,
        gain=p_tt1 / var_o,
        const=const,
    )


def _frames(pairs: Pairs) -> _Frames:
    """Every pair turned into the frame of the heading detected at its first row."""
    prev, rows, i_pair, j_pair = pairs.prev, pairs.rows, pairs.i_pair, pairs.j_pair
    theta0 = prev[i_pair, 2]
    delta = rows[j_pair, :2] - prev[i_pair, :2]
    c, sn = np.cos(theta0), np.sin(theta0)
    fx = c * delta[:, 0] + sn * delta[:, 1]
    fy = c * delta[:, 1] - sn * delta[:, 0]
    return _Frames(fx, fy, theta0, rows[j_pair, 2] - theta0, rows[j_pair, 2])


def _first_leg_block(
    sl: np.ndarray,
    pk: np.ndarray,
    s: float,
    r: _Robots,
    f: _Frames,
    pairs: Pairs,
    prior: Prior,
    scoring: Scoring,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One block of the first leg, robot ``sl[k]`` along pair ``pk[k]`` (whole robots): the
    gate, the heading Kalman step, the detected heading and the prune (as
    :func:`~anonloc_env.identify.likelihood.children` prunes). Returns what is kept, heaviest
    first within each robot: ``(slot, pair, log weight, heading)``."""
    dx, dy, dphi = pairs.interval.d[:, 0], pairs.interval.d[:, 1], pairs.interval.dphi
    theta_var = scoring.theta_var
    # The gate.
    ex = f.fx[pk] - r.gate_dx[sl]
    ey = f.fy[pk] - r.gate_dy[sl]
    e2 = ex * ex + ey * ey
    turn = wrap_fast(f.turn[pk] - dphi[sl])
    chi2 = e2 / r.gate_pos[sl] + turn * turn / r.gate_turn[sl]
    ok = np.flatnonzero(chi2 <= GATE_CHI2)
    sl, pk, e2 = sl[ok], pk[ok], e2[ok]
    if s != scoring.model.scale:
        ex = f.fx[pk] - s * dx[sl]
        ey = f.fy[pk] - s * dy[sl]
        e2 = ex * ex + ey * ey
    else:
        ex, ey = ex[ok], ey[ok]
    # The heading Kalman step, then the detected heading.
    h_e = s * (dx[sl] * ey - dy[sl] * ex)
    a_k = r.a[sl]
    maha = (e2 - theta_var * h_e * h_e / a_k) / r.b[sl]
    theta1 = f.theta0[pk] + theta_var * h_e / a_k + dphi[sl]
    err = wrap_fast(f.seen[pk] - theta1)
    logw = r.const[sl] - 0.5 * maha - 0.5 * (err * err / r.var_o[sl])
    i_pair = pairs.i_pair[pk]
    if prior.links is not None:  # the others persist: per link instead of lambda
        logw += pairs.log_bg + prior.links.detect(i_pair, pairs.j_pair[pk])
    if prior.row_bias is not None:
        logw += prior.row_bias[i_pair]
    # The prune, then heaviest first within each robot (the order the filter keeps: the tracks
    # then come out in runs that Tracks.gather copies as slices).
    keep, floor = near_best(sl, logw, PRUNE_NATS)
    first = group_starts(sl)
    group = np.repeat(np.arange(len(first)), group_sizes(sl, first))
    key = group[keep] * (2.0 * PRUNE_NATS + 2.0) + (floor[keep] + PRUNE_NATS - logw[keep])
    keep = keep[np.argsort(key, kind="stable")]  # ties in the order of the candidates
    sk = sl[keep]
    return sk, pk[keep], logw[keep], wrap_angle(theta1[keep] + r.gain[sk] * err[keep])


def known_children(
    tracks: Tracks,
    gate: Gate,
    parent: np.ndarray,
    rows: np.ndarray,
    cand: np.ndarray,
    interval: Interval,
    pix_var: float,
    log_bg: float | np.ndarray,
    scoring: Scoring,
) -> Tracks:
    """Equals :func:`~anonloc_env.identify.likelihood.children` of tracks ``parent`` (indices
    into ``tracks``) when every track knows its heading and scale and carries no motion
    (``gate.moved`` is set): the same arithmetic as its case B
    (:func:`~anonloc_env.identify.likelihood.kalman_heading`), bit for bit, with the prediction
    ``s R(theta) d`` taken from the gate and only the fields the Kalman step reads gathered.
    Candidates with a push or an estimated scale take the general
    :func:`~anonloc_env.identify.likelihood.kalman`."""
    if len(cand) == 0:
        return Tracks.empty()
    assert gate.moved is not None
    assert gate.scale is not None
    assert gate.rho0 is not None
    model = scoring.model
    slot = tracks.slot[parent]
    z = rows[cand]
    var_d_all, var_dphi_all = interval.variances(model.odometry_noise)
    count = len(parent)
    s, rho0 = take_field(gate.scale, parent, count), gate.rho0[parent]
    th, ptt = tracks.theta[parent], tracks.p_tt[parent]
    log_s, p_ts, p_ss = (
        take_field(f, parent, count) for f in (tracks.log_s, tracks.p_ts, tracks.p_ss)
    )
    # kalman_heading, with Geometry's base variance.
    b = (
        pix_var
        + take_field(tracks.pos_var, parent, count)
        + s**2 * var_d_all[slot]
        + (model.scale_spread * s * rho0) ** 2
    )
    px, py = gate.moved[parent, 0], gate.moved[parent, 1]
    pos = tracks.pos[parent]
    ex = (z[:, 0] - pos[:, 0]) - px
    ey = (z[:, 1] - pos[:, 1]) - py
    h_e = px * ey - py * ex
    a = b + ptt * (px * px + py * py)
    maha = (ex * ex + ey * ey - ptt * h_e * h_e / a) / b
    child = Child(
        loglik=-LOG_2PI - 0.5 * np.log(b * a) - 0.5 * maha,
        theta=th + ptt * h_e / a + interval.dphi[slot],
        p_tt=np.maximum(ptt * b / a, 1e-14) + var_dphi_all[slot],
        log_s=log_s,
        p_ts=p_ts,
        p_ss=p_ss,
    )
    general = fused_calls.needs_general(p_ts, p_ss, interval, slot)
    if general.any():
        g = np.flatnonzero(general)
        fused_calls.general_step(child, g, tracks, parent[g], z[g], interval, pix_var, model)
    if model.orientation:
        orientation(z[:, 2], scoring.theta_var, child.theta, child.p_tt, child.loglik)
    logw = tracks.logw[parent] + scoring.log_pd + child.loglik - log_bg
    if not model.filter_position:
        return pruned(slot, cand, z, logw, child, pix_var)
    keep, _ = near_best(slot, logw, PRUNE_NATS)
    out = fresh_children(keep, slot, cand, z, logw, child, pix_var)
    return filter_positions(out, tracks, parent[keep], interval, model)
