"""How the identifier calls its compiled children (:mod:`anonloc_env.identify.fused`): the
arrays each kernel takes, built from the tracks, the pair of pictures and the model, and the
tracks made of what it returns; which robots' tracks may take them
(:func:`known_robots`); the general Kalman step that both the compiled and the numpy children
hand their pushed robots and estimated scales to (:func:`general_step`).

The numpy forms these equal are :func:`anonloc_env.identify.kernels.known_children` and
:func:`anonloc_env.identify.likelihood.children`; ``tests/test_identify_fused.py`` runs both.
"""

from __future__ import annotations

import math

import numpy as np

from anonloc_env import compiled
from anonloc_env.identify import fused
from anonloc_env.identify.arrays import (
    group_sizes,
    group_starts,
    is_shared,
    near_best,
    positions,
    take_field,
)
from anonloc_env.identify.contact import PressedInterval, mix_pushes, tail_candidates, tails
from anonloc_env.identify.gate import GATE_CHI2, PRUNE_NATS, worst_variance
from anonloc_env.identify.likelihood import (
    Child,
    Geometry,
    Pairs,
    Scoring,
    filter_positions,
    fresh_children,
    kalman,
    orientation,
    pruned,
)
from anonloc_env.identify.model import LOG_2PI, SensorModel, push_covariance
from anonloc_env.identify.others import Links
from anonloc_env.identify.pool import Pool, empty, taken
from anonloc_env.identify.tracks import Tracks
from anonloc_env.odometry import Interval


def needs_general(
    p_ts: np.ndarray, p_ss: np.ndarray, interval: Interval, slot: np.ndarray
) -> np.ndarray:
    """Candidates whose parent's scale is estimated (not known exactly) or whose robot was
    pushed: :func:`~anonloc_env.identify.kernels.known_children` and :func:`known_compiled`
    hand them to the general Kalman step."""
    if is_shared(p_ss) and is_shared(p_ts) and p_ss[0] == 0.0 and p_ts[0] == 0.0:
        general = np.zeros(len(slot), dtype=bool)  # the scale known, as it is in a first leg
    else:
        general = (p_ss != 0.0) | (p_ts != 0.0)
    if interval.push is not None:
        general |= interval.push[slot] > 0
    return general


def general_step(
    child: Child,
    g: np.ndarray,
    tracks: Tracks,
    parents: np.ndarray,
    z: np.ndarray,
    interval: Interval,
    pix_var: float,
    model: SensorModel,
) -> None:
    """Candidates ``g`` of ``child`` (parent tracks ``parents`` of ``tracks``, rows ``z``)
    scored by the general :func:`~anonloc_env.identify.likelihood.kalman` instead; by
    :func:`anonloc_env.identify.fused.general_kalman` where the kernels are on (the same
    floats; ``exp`` and ``log`` taken by numpy around it)."""
    if compiled.mode() is None:
        sub = tracks.take(parents)
        out = Child.start(sub)
        kalman(np.ones(len(g), bool), Geometry(sub, z, interval, model, pix_var), sub, out)
        new = (out.loglik, out.theta, out.p_tt, out.log_s, out.p_ts, out.p_ss)
    else:
        var_d, var_dphi = interval.variances(model.odometry_noise)
        robots = np.stack([interval.d[:, 0], interval.d[:, 1], var_d, interval.dphi, var_dphi])
        log_s = _one(tracks.log_s) if is_shared(tracks.log_s) else tracks.log_s[parents]
        fields = tuple(_one(f) for f in (tracks.theta, tracks.p_tt, tracks.p_ts, tracks.p_ss))
        x = fused.general_inputs(
            parents.astype(np.int64),
            (*fields, _one(tracks.pos_var)),
            log_s,
            np.exp(log_s),
            tracks.pos,
            tracks.slot.astype(np.int64),
            robots,
            np.ascontiguousarray(push_covariance(interval, model), dtype=np.float64),
            z,
        )
        step = fused.general_kalman(x, pix_var, model.scale_spread)
        loglik = -LOG_2PI - 0.5 * np.log(step[0]) - 0.5 * step[1]
        slot = tracks.slot[parents]
        tail = tail_candidates(interval, slot, model.crowd_push_tail)
        if len(tail):  # pressed robots: the narrow pushes mixed in (contact.mix_pushes)
            assert isinstance(interval, PressedInterval)
            assert interval.narrow is not None
            cov = push_covariance(interval.narrow, model)[slot[tail]]
            x = np.ascontiguousarray(x[:, tail])  # C order, the one compiled at load()
            x[10], x[11], x[12] = cov[:, 0, 0], cov[:, 0, 1], cov[:, 1, 1]
            narrow = fused.general_kalman(x, pix_var, model.scale_spread)
            narrow_ll = -LOG_2PI - 0.5 * np.log(narrow[0]) - 0.5 * narrow[1]
            weight = tails(interval, slot[tail], model.crowd_push_tail)
            loglik[tail] = mix_pushes(loglik[tail], narrow_ll, weight)
        new = (loglik, step[2], step[3], step[4], step[5], step[6])
    child.loglik[g], child.theta[g], child.p_tt[g] = new[:3]
    # Own copies: the parents' fields may be shared.
    child.log_s, child.p_ts, child.p_ss = (
        np.array(f) for f in (child.log_s, child.p_ts, child.p_ss)
    )
    child.log_s[g], child.p_ts[g], child.p_ss[g] = new[3:]


def _one(field: np.ndarray) -> np.ndarray:
    """A track field as a kernel takes it: ``(1,)`` where shared, else the field itself."""
    return np.array(field[:1]) if is_shared(field) else field


def known_robots(tracks: Tracks, index: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(known, rest)``: tracks ``index`` (increasing, grouped by robot) split by robot into
    those of the robots whose tracks ``index`` all know their heading and scale and carry no
    motion (what :func:`known_compiled` takes) and the others (the general path), each in the
    order of ``index``. A robot's children depend on its own tracks alone, so each robot gets
    the same children whichever path its neighbours take."""
    theta, log_s, turn, carry = (
        _selected(f, index) for f in (tracks.theta, tracks.log_s, tracks.turn, tracks.carry)
    )  # the four fields the test reads, not all of tracks.select(index)
    known = np.isfinite(theta) & np.isfinite(log_s)
    if turn.any() or carry.any():
        known &= (turn == 0.0) & ~carry.any(axis=1)
    if known.all():
        return index, index[:0]
    slot = _selected(tracks.slot, index)
    starts = group_starts(slot)
    whole = np.repeat(np.minimum.reduceat(known, starts), group_sizes(slot, starts))
    return index[whole], index[~whole]


def _selected(field: np.ndarray, index: np.ndarray) -> np.ndarray:
    """``Tracks.select(index)``'s ``field`` (``index`` increasing, not empty): a view where
    ``index`` is a range, else :func:`~anonloc_env.identify.arrays.take_field`'s."""
    if index[-1] - index[0] + 1 == len(index):
        return field[int(index[0]) : int(index[-1]) + 1]
    return take_field(field, index, len(index))


def renumbered(
    a: np.ndarray, b: np.ndarray, index: np.ndarray, n: int
) -> tuple[np.ndarray, np.ndarray]:
    """Of pairs ``a[k] - b[k]`` (track ``a[k]`` of ``n``), those of tracks ``index``
    (increasing), in order, ``a`` renumbered to its position in ``index``."""
    place = np.full(n, -1, dtype=np.int64)
    place[index] = np.arange(len(index))
    mine = place[a]
    keep = np.flatnonzero(mine >= 0)
    return mine[keep], b[keep]


def pruned_order(
    slot: np.ndarray, logw: np.ndarray, best: np.ndarray, cap: int, pool: Pool | None = None
) -> np.ndarray | None:
    """The identifier's pruned and sorted order of the tracks ``slot``, ``logw`` by
    :func:`anonloc_env.identify.fused.pruned_order` (the order of
    ``Identifier._pruned_order``, without its temporaries), ``best`` raised in place; None
    where the kernels are off, or a robot's best is not finite (``best`` then untouched). The
    order is written into a block of ``pool`` where given."""
    if compiled.mode() is None:
        return None
    raised = best.copy()
    into = empty(pool, len(slot), np.int64)
    slot = slot.astype(np.int64, copy=False)
    index, ok = fused.pruned_order(slot, logw, raised, PRUNE_NATS, cap, into)
    if not ok:
        return None
    best[:] = raised
    return index


def merge_by_robot(first: Tracks, second: Tracks) -> Tracks:
    """The tracks of ``first`` and ``second`` (each grouped by robot, no robot in both) in one,
    grouped by robot in order, each robot's tracks in their order."""
    if not len(first) or not len(second):
        return second if not len(first) else first
    both = Tracks.concat([first, second])
    return both.take(np.argsort(both.slot, kind="stable"))


def known_compiled(
    sub: Tracks,
    lo: np.ndarray,
    hi: np.ndarray,
    cand: np.ndarray,
    pairs: Pairs,
    links: Links | None,
    scoring: Scoring,
    pool: Pool | None = None,
) -> Tracks:
    """The children of tracks ``sub`` that all know their heading and scale and carry no motion,
    track ``h``'s candidate rows ``cand[lo[h]:hi[h]]``, by the compiled kernels (the same
    floats): the gate of ``Gate.of`` and ``Gate.passes``, then
    :func:`~anonloc_env.identify.kernels.known_children` (which
    equals :func:`~anonloc_env.identify.likelihood.children` for such tracks), the general Kalman
    step for the candidates it hands there, the detected heading and the prune, in one pass
    over the candidates instead of blocks of numpy calls (its per-candidate arrays in blocks of
    ``pool`` where given). ``Builder.anchored`` and ``Builder.from_missed`` take it."""
    rows, interval, pix_var = pairs.rows, pairs.interval, pairs.pix_var
    model = scoring.model
    s = np.exp(sub.log_s[:1]) if is_shared(sub.log_s) else np.exp(sub.log_s)
    var_d, var_dphi = interval.variances(model.odometry_noise)
    n = len(interval.d)
    worst = worst_variance(np.arange(n), interval, model, pix_var)
    total, count = int((hi - lo).sum()), len(sub)
    index, out = fused.known_children(
        np.stack([sub.slot, lo, hi], out=empty(pool, (3, count), np.int64)),
        np.stack([sub.pos[:, 0], sub.pos[:, 1], sub.theta, sub.p_tt], out=empty(pool, (4, count))),
        np.array(sub.pos_var[:1] if is_shared(sub.pos_var) else sub.pos_var),  # writable
        np.ascontiguousarray(s, dtype=np.float64),
        np.stack([interval.dphi, worst, var_d, var_dphi]),
        np.ascontiguousarray(interval.d, dtype=np.float64),
        np.ascontiguousarray(cand, dtype=np.int64),  # read only: copied only if it must be
        np.ascontiguousarray(rows, dtype=np.float64),
        np.array([pix_var, model.scale_spread, scoring.theta_var, GATE_CHI2]),
        bool(model.orientation),
        empty(pool, (2, total), np.int64),
        empty(pool, (4, total)),
    )
    places = taken(cand, index[1], pool)  # cand[index[1]]
    return _finish_compiled(sub, index[0], places, pairs, links, scoring, out, pool)


def _finish_compiled(
    sub: Tracks,
    parent: np.ndarray,
    cand: np.ndarray,
    pairs: Pairs,
    links: Links | None,
    scoring: Scoring,
    out: np.ndarray,
    pool: Pool | None = None,
) -> Tracks:
    """What :func:`known_compiled` does after the gate and the Kalman step of
    :func:`anonloc_env.identify.fused.known_children` (track ``parent[k]`` at row ``cand[k]``,
    ``out``): the log, the general Kalman step where
    :func:`~anonloc_env.identify.kernels.known_children` takes it, then the
    detected heading, the weights and the prune
    (:func:`anonloc_env.identify.fused.finish_known`). The per-candidate arrays of the
    common path, and the tracks', in blocks of ``pool`` where given (the same numbers as the
    expressions the comments spell out)."""
    rows, interval, pix_var, log_bg = pairs.rows, pairs.interval, pairs.pix_var, pairs.log_bg
    model = scoring.model
    count = len(parent)
    slot = taken(sub.slot, parent, pool)  # sub.slot[parent]
    child = Child(
        loglik=_loglik(out, pool),
        theta=out[2],
        p_tt=out[3],
        log_s=take_field(sub.log_s, parent, count),
        p_ts=take_field(sub.p_ts, parent, count),
        p_ss=take_field(sub.p_ss, parent, count),
    )
    general = needs_general(child.p_ts, child.p_ss, interval, slot)
    if general.any():
        g = np.flatnonzero(general)
        general_step(child, g, sub, parent[g], rows[cand[g]], interval, pix_var, model)
    bg = np.array([log_bg]) if links is None else -links.detect(sub.row[parent], cand)
    if model.orientation and not np.isfinite(child.theta).all():  # numpy's other branch
        orientation(rows[cand, 2], scoring.theta_var, child.theta, child.p_tt, child.loglik)
        logw = sub.logw[parent] + scoring.log_pd + child.loglik - (bg if len(bg) > 1 else bg[0])
        if not model.filter_position:
            return pruned(slot, cand, rows[cand], logw, child, pix_var)
        near, _ = near_best(slot, logw, PRUNE_NATS)
        tracks = fresh_children(near, slot, cand, rows[cand], logw, child, pix_var)
        return filter_positions(tracks, sub, parent[near], interval, model)
    log_var = child.p_tt
    if model.orientation:  # np.log(child.p_tt + scoring.theta_var)
        log_var = np.add(child.p_tt, scoring.theta_var, out=empty(pool, count))
        np.log(log_var, out=log_var)
    theta, p_tt = child.theta, child.p_tt  # rows of out, or the general step's: our own
    keep, logw = fused.finish_known(
        slot,  # int64, contiguous, fresh
        taken(rows[:, 2], cand, pool),  # rows[cand, 2]
        child.loglik,
        theta,
        p_tt,
        log_var,
        taken(sub.logw, parent, pool),  # sub.logw[parent]
        bg,
        np.array([scoring.theta_var, math.log(2 * math.pi), scoring.log_pd, PRUNE_NATS]),
        bool(model.orientation),
        empty(pool, count, np.int64),
        empty(pool, count),
    )
    del log_var
    kept = len(keep)
    c = taken(cand, keep, pool)  # cand[keep]
    theta = taken(theta, keep, pool)  # wrap_angle(theta[keep]), in place
    np.add(theta, math.pi, out=theta)
    np.mod(theta, 2.0 * math.pi, out=theta)
    np.subtract(theta, math.pi, out=theta)
    tracks = Tracks.fresh(
        taken(slot, keep, pool),  # slot[keep]
        c,
        _positions(rows, c, pool),
        taken(logw, keep, pool),  # logw[keep]
        pos_var=pix_var,
        theta=theta,
        p_tt=taken(p_tt, keep, pool),  # p_tt[keep]
        log_s=take_field(child.log_s, keep, kept),
        p_ts=take_field(child.p_ts, keep, kept),
        p_ss=take_field(child.p_ss, keep, kept),
    )
    if model.filter_position:
        filter_positions(tracks, sub, parent[keep], interval, model)
    return tracks


def _positions(rows: np.ndarray, index: np.ndarray, pool: Pool | None) -> np.ndarray:
    """``positions(rows, index)``, in a block of ``pool`` where given and large enough."""
    out = empty(pool, (len(index), 2))
    if out.base is None:  # a fresh array: numpy's own take
        return positions(rows, index)
    return rows[:, :2].take(index, axis=0, out=out, mode="clip")


def _loglik(out: np.ndarray, pool: Pool | None) -> np.ndarray:
    """``-LOG_2PI - 0.5 * np.log(out[0]) - 0.5 * out[1]`` (the same operations in the same
    order), in blocks of ``pool`` where given."""
    loglik = np.log(out[0], out=empty(pool, out.shape[1]))
    np.multiply(0.5, loglik, out=loglik)
    np.subtract(-LOG_2PI, loglik, out=loglik)
    half = np.multiply(0.5, out[1], out=empty(pool, out.shape[1]))
    return np.subtract(loglik, half, out=loglik)
