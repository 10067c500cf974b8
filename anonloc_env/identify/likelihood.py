"""The likelihood maths: how a candidate row extends a track, its log-likelihood and new state.

The filter scores a batch of (track, row) candidates under the model of
:mod:`anonloc_env.identify.model`: the ring density while the heading is unknown, an extended
Kalman filter on ``(theta, log s)`` once it is known. :func:`children` is the general path, every
case; :mod:`anonloc_env.identify.kernels` holds faster forms of two of its uses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np

from anonloc_env.geometry import rotate, wrap_angle
from anonloc_env.identify.arrays import everything, near_best, take_field
from anonloc_env.identify.contact import (
    PressedInterval,
    first_heading_variance,
    mix_pushes,
    tail_candidates,
    tails,
)
from anonloc_env.identify.gate import PRUNE_NATS
from anonloc_env.identify.model import (
    GATE_SIGMAS,
    LOG_2PI,
    SensorModel,
    push_covariance,
    push_isotropic,
    ring_loglik,
)
from anonloc_env.identify.tracks import Tracks
from anonloc_env.odometry import Interval


class Scoring(NamedTuple):
    """What scoring a candidate reads besides the pictures: the sensor model, ``log P_D`` (the
    robot is in the picture) and the variance of a detected heading (rad^2, with its floor)."""

    model: SensorModel
    log_pd: float
    theta_var: float


class Pairs(NamedTuple):
    """One interval's candidate pairs and what scoring them reads: ``i_pair``/``j_pair`` index
    rows of ``prev`` (the previous picture) and ``rows`` (the new one), within any robot's
    reach; ``pix_var`` is the pixel variance (image units^2) and ``log_bg`` the log density of
    a background row."""

    prev: np.ndarray
    rows: np.ndarray
    i_pair: np.ndarray
    j_pair: np.ndarray
    interval: Interval
    pix_var: float
    log_bg: float


def children(
    parent: Tracks,
    rows: np.ndarray,
    cand: np.ndarray,
    interval: Interval,
    pix_var: float,
    log_bg: float | np.ndarray,
    scoring: Scoring,
) -> Tracks:
    """The general path: extend each parent track by candidate row ``cand`` (same length), its
    weight and state, whatever the parent knows. ``log_bg`` is what a link is divided by (a
    log); children far below their robot's best child are dropped (:func:`pruned`)."""
    if len(cand) == 0:
        return Tracks.empty()
    z = rows[cand]
    child = Child.start(parent)
    score_cases(Geometry(parent, z, interval, scoring.model, pix_var), parent, child)
    if scoring.model.orientation:
        orientation(z[:, 2], scoring.theta_var, child.theta, child.p_tt, child.loglik)
    logw = parent.logw + scoring.log_pd + child.loglik - log_bg
    if not scoring.model.filter_position:
        return pruned(parent.slot, cand, z, logw, child, pix_var)
    keep, _ = near_best(parent.slot, logw, PRUNE_NATS)
    out = fresh_children(keep, parent.slot, cand, z, logw, child, pix_var)
    return filter_positions(out, parent, keep, interval, scoring.model)


def filter_positions(
    out: Tracks, parents: Tracks, index: np.ndarray, interval: Interval, model: SensorModel
) -> Tracks:
    """``out``, the children of tracks ``index`` of ``parents`` (one each, at their detections,
    uncertain by the pixel variance), with ``SensorModel.filter_position``'s positions (in
    place): where the parent knows its heading and scale, the detection combined with the
    parent's predicted position ``p + s R(theta) d`` (a Kalman step on the position alone, the
    prediction's variance taken in its worst direction: the parent's position, the odometry,
    the pushes' largest eigenvalue, the heading and scale over the leg). Consecutive legs
    share a detection's noise: a track anchored at each detection scores a still robot's
    pictures as a random walk, and its rivals' fits vary half as much again as they should
    (docs/crowds.md, eighth round). Every path calls it on the children it keeps, so the
    positions are the same floats whichever path scored them."""
    theta, log_s = parents.theta[index], parents.log_s[index]
    k = np.flatnonzero(np.isfinite(theta) & np.isfinite(log_s))
    if len(k) == 0:
        return out
    slot = out.slot[k]
    s = np.exp(log_s[k])
    step = rotate(interval.d[slot], theta[k]) * s[:, None]
    var_d, _ = interval.variances(model.odometry_noise)
    rho = np.hypot(interval.d[slot, 0], interval.d[slot, 1])
    leg2 = (s * rho) ** 2
    parent = index[k]
    spread = parents.pos_var[parent] + s**2 * var_d[slot] + (model.scale_spread * s * rho) ** 2
    spread = spread + (parents.p_tt[parent] + parents.p_ss[parent]) * leg2
    if interval.push is not None:
        cov = push_covariance(interval, model)[slot]
        half = 0.5 * (cov[:, 0, 0] + cov[:, 1, 1])
        det = cov[:, 0, 0] * cov[:, 1, 1] - cov[:, 0, 1] ** 2
        spread = spread + s**2 * (half + np.sqrt(np.maximum(half**2 - det, 0.0)))
    pix_var = out.pos_var[k]
    gain = pix_var / (spread + pix_var)
    z = out.pos[k]
    out.pos[k] = z + gain[:, None] * (parents.pos[parent] + step - z)
    pos_var = np.array(out.pos_var)  # own copy: a first leg's is shared
    pos_var[k] = spread * gain
    out.pos_var = pos_var
    return out


def pruned(
    slot: np.ndarray,
    cand: np.ndarray,
    z: np.ndarray,
    logw: np.ndarray,
    child: Child,
    pix_var: float,
) -> Tracks:
    """The new tracks of robots ``slot`` (grouped) at rows ``cand`` (detections ``z``), log
    weights ``logw`` and states ``child``, less those more than :data:`PRUNE_NATS` below their
    robot's best: they would be pruned later anyway (the best over all hypotheses is at least as
    high), so they are dropped before they are copied."""
    keep, _ = near_best(slot, logw, PRUNE_NATS)
    return fresh_children(keep, slot, cand, z, logw, child, pix_var)


def fresh_children(
    keep: np.ndarray,
    slot: np.ndarray,
    cand: np.ndarray,
    z: np.ndarray,
    logw: np.ndarray,
    child: Child,
    pix_var: float,
) -> Tracks:
    """The tracks of :func:`pruned`'s candidates ``keep``."""
    count = len(keep)
    return Tracks.fresh(
        slot[keep],
        cand[keep],
        z[keep, :2],
        logw[keep],
        pos_var=pix_var,
        theta=wrap_angle(child.theta[keep]),
        p_tt=child.p_tt[keep],
        log_s=take_field(child.log_s, keep, count),
        p_ts=take_field(child.p_ts, keep, count),
        p_ss=take_field(child.p_ss, keep, count),
    )


def score_cases(geo: Geometry, parent: Tracks, child: Child) -> None:
    """Fill ``child`` (log-likelihood and state) case by case, by what each parent knows."""
    heading_known = np.isfinite(parent.theta)
    scale_known = np.isfinite(parent.log_s)
    s_low, s_high = geo.model.scale_bounds
    # A. heading unknown, scale known: the ring.
    a = ~heading_known & scale_known
    if a.any():
        child.loglik[a] = ring_loglik(geo.r[a], geo.s[a] * geo.rho0[a], geo.iso_var[a])
        learn = a & ~geo.still & (geo.r > 0)
        child.heading_from_displacement(learn, geo)
    # C. heading and scale unknown: the ring over a log-uniform scale.
    c = ~heading_known & ~scale_known
    if c.any():
        scale_free(c, geo, child, s_low, s_high)
        learn = c & ~geo.still & (geo.r > 0)
        child.heading_from_displacement(learn, geo)
        # Too little motion to learn the heading from: the scale stays unknown too.
        unlearnt = c & ~learn
        child.log_s[unlearnt] = np.nan
        child.p_ss[unlearnt] = np.inf
    # D. heading known, scale unknown: the direction is tested, the length sets the scale.
    dd = heading_known & ~scale_known
    if dd.any():
        direction_only(dd, geo, parent, child, s_low, s_high)
    # B. heading known, scale known or estimated: extended Kalman filter on (theta, log s).
    b = heading_known & scale_known
    if b.any():
        kalman(b, geo, parent, child)


class Geometry:
    """Per candidate (parent track, new row): the displacement and its noise.

    What every case needs is computed at once; the directions and lengths only some cases use
    are computed when first asked for.

    Attributes:
        d: ``(K, 2)`` own displacement of the parent's robot (m).
        rho0: ``|d|``.
        dphi: own heading change (rad); ``var_dphi`` its variance.
        delta: ``(K, 2)`` image displacement from the parent's position to the row.
        s: scale the parent assumes (its estimate, or the largest possible).
        push_var: isotropic variance per component of the unseen contact pushes (image units).
        base_var: isotropic variance per component without the pushes; ``iso_var`` with them.
    """

    def __init__(
        self, parent: Tracks, z: np.ndarray, interval: Interval, model: SensorModel, pix_var: float
    ) -> None:
        self.slot = slot = parent.slot
        self.model = model
        self.interval = interval
        self.d, self.dphi = d, _ = parent.own_motion(interval)
        self.rho0 = rho0 = np.hypot(d[:, 0], d[:, 1])
        var_d_all, var_dphi_all = interval.variances(model.odometry_noise)
        self.var_dphi = var_dphi_all[slot]
        self.delta = z[:, :2] - parent.pos
        scale_known = np.isfinite(parent.log_s)
        self.s_high = s_high = model.scale_bounds[1]
        if scale_known.all():
            s = np.exp(parent.log_s)
        else:
            s = np.where(scale_known, np.exp(np.where(scale_known, parent.log_s, 0.0)), s_high)
        self.s = s
        self.base_var = (
            pix_var + parent.pos_var + s**2 * var_d_all[slot] + (model.scale_spread * s * rho0) ** 2
        )
        if interval.push is None:
            self.pushed = np.zeros(len(slot), dtype=bool)
            self.iso_var = self.base_var
        else:
            self.pushed = interval.push[slot] > 0
            self.iso_var = self.base_var + s**2 * push_isotropic(interval, model)[slot]

    @cached_property
    def r(self) -> np.ndarray:
        """``|delta|``."""
        return np.hypot(self.delta[:, 0], self.delta[:, 1])

    @cached_property
    def ang_delta(self) -> np.ndarray:
        """Direction of ``delta`` (rad)."""
        return np.arctan2(self.delta[:, 1], self.delta[:, 0])

    @cached_property
    def ang_d(self) -> np.ndarray:
        """Direction of ``d`` (rad)."""
        return np.arctan2(self.d[:, 1], self.d[:, 0])

    @cached_property
    def still(self) -> np.ndarray:
        """Too little motion to learn the heading from."""
        return self.s_high * self.rho0 < 2.0 * np.sqrt(self.iso_var)

    def narrowed(self, which: np.ndarray) -> Geometry:
        """Candidates ``which`` under the narrow pushes of a
        :class:`~anonloc_env.identify.contact.PressedInterval` (the pushes as they were)."""
        assert isinstance(self.interval, PressedInterval)
        assert self.interval.narrow is not None
        narrow = self.interval.narrow
        out = object.__new__(Geometry)
        for name in ("slot", "d", "dphi", "rho0", "var_dphi", "delta", "s", "base_var", "pushed"):
            setattr(out, name, getattr(self, name)[which])
        out.model, out.interval, out.s_high = self.model, narrow, self.s_high
        out.iso_var = out.base_var + out.s**2 * push_isotropic(narrow, self.model)[out.slot]
        return out

    def push_cov(self, which: np.ndarray) -> np.ndarray:
        """``(k, 2, 2)`` unseen contact pushes (m^2, robot frame) of candidates ``which``."""
        return push_covariance(self.interval, self.model)[self.slot[which]]

    def standing_loglik(self, which: np.ndarray) -> np.ndarray:
        """Log density of the displacement of a robot that did not move, for ``which``."""
        var = self.iso_var[which]
        return -LOG_2PI - np.log(var) - self.r[which] ** 2 / (2 * var)


@dataclass
class Child:
    """The new tracks' log-likelihoods and states, filled case by case."""

    loglik: np.ndarray
    theta: np.ndarray
    p_tt: np.ndarray
    log_s: np.ndarray
    p_ts: np.ndarray
    p_ss: np.ndarray

    @classmethod
    def start(cls, parent: Tracks) -> Child:
        n = len(parent)
        return cls(
            loglik=np.full(n, -np.inf),
            theta=np.full(n, np.nan),
            p_tt=np.full(n, np.inf),
            log_s=parent.log_s.copy(),
            p_ts=parent.p_ts.copy(),
            p_ss=parent.p_ss.copy(),
        )

    def heading_from_displacement(self, which: np.ndarray, geo: Geometry) -> None:
        """A first heading for ``which``: the image direction of the move minus that of the
        robot's own, turned by its own turn; uncertain by the noise over the length."""
        self.theta[which] = geo.ang_delta[which] - geo.ang_d[which] + geo.dphi[which]
        self.p_tt[which] = (
            geo.iso_var[which] / np.maximum(geo.r[which], 1e-12) ** 2 + geo.var_dphi[which]
        )
        pushed = np.flatnonzero(which & geo.pushed)
        if len(pushed) and geo.model.crowd_push_share is not None:
            cov = geo.push_cov(pushed) * (geo.s[pushed] ** 2)[:, None, None]
            first_heading_variance(pushed, cov, geo.r[pushed], self.p_tt)


#: Quadrature points per standard deviation of the narrowest likelihood in log s (and at most
#: :data:`SCALE_POINTS_MAX` in all) for the first leg with the scale unknown.
SCALE_POINTS_PER_SIGMA = 3.0
SCALE_POINTS_MAX = 512


def scale_free(mask: np.ndarray, geo: Geometry, child: Child, s_low: float, s_high: float) -> None:
    """Heading and scale unknown: the ring density of the displacement (heading marginalised)
    integrated over a log-uniform scale by the midpoint rule, and the scale's posterior mean and
    variance from the same quadrature (its edges are soft, as the pixel noise makes them)."""
    k = np.flatnonzero(mask)
    if len(k) == 0:
        return
    r, rho0, var = geo.r[k], geo.rho0[k], geo.iso_var[k]
    width = math.log(s_high / s_low) if s_high > s_low else 0.0
    if width == 0.0:
        log_s = np.array([math.log(s_low)])
    else:
        narrowest = float(np.min(np.sqrt(var) / np.maximum(s_high * rho0, 1e-12)))
        count = min(max(math.ceil(SCALE_POINTS_PER_SIGMA * width / narrowest), 8), SCALE_POINTS_MAX)
        log_s = math.log(s_low) + (np.arange(count) + 0.5) * (width / count)
    ll = ring_loglik(r[:, None], np.exp(log_s)[None, :] * rho0[:, None], var[:, None])
    top = ll.max(axis=1, keepdims=True)
    w = np.exp(ll - top)
    total = w.sum(axis=1)
    child.loglik[k] = top[:, 0] + np.log(total) - math.log(len(log_s))
    mean = (w * log_s[None, :]).sum(axis=1) / total
    spread = (w * (log_s[None, :] - mean[:, None]) ** 2).sum(axis=1) / total
    child.log_s[k] = mean
    # At least the quadrature's own resolution, so that a sharp posterior is not made exact.
    child.p_ss[k] = spread + (width / len(log_s)) ** 2 / 12.0
    child.p_ts[k] = 0.0


def direction_only(
    mask: np.ndarray,
    geo: Geometry,
    parent: Tracks,
    child: Child,
    s_low: float,
    s_high: float,
) -> None:
    """Heading known, scale unknown: the direction is tested, the length sets the scale."""
    moving = np.flatnonzero(mask & ~geo.still)
    rr = np.maximum(geo.r[moving], 1e-12)
    var = geo.iso_var[moving]
    rho0 = geo.rho0[moving]
    width = math.log(s_high / s_low) if s_high > s_low else 1e-9
    predicted = parent.theta[moving] + geo.ang_d[moving]
    err = wrap_angle(geo.ang_delta[moving] - predicted)
    var_ang = parent.p_tt[moving] + var / rr**2
    sigma = np.sqrt(var)
    inside = (rr >= s_low * rho0 - GATE_SIGMAS * sigma) & (
        rr <= s_high * rho0 + GATE_SIGMAS * sigma
    )
    # Angle density times the log-uniform length density, per unit area (the 1/r Jacobian).
    angle_ll = -0.5 * (math.log(2 * math.pi) + np.log(var_ang) + err**2 / var_ang)
    child.loglik[moving] = np.where(inside, angle_ll - 2.0 * np.log(rr) - math.log(width), -np.inf)
    gain = parent.p_tt[moving] / var_ang
    child.theta[moving] = parent.theta[moving] + gain * err + geo.dphi[moving]
    child.p_tt[moving] = parent.p_tt[moving] * (1 - gain) + geo.var_dphi[moving]
    child.log_s[moving] = np.log(rr / rho0)
    child.p_ss[moving] = var / rr**2
    child.p_ts[moving] = 0.0
    standing = np.flatnonzero(mask & geo.still)
    child.loglik[standing] = geo.standing_loglik(standing)
    child.theta[standing] = parent.theta[standing] + geo.dphi[standing]
    child.p_tt[standing] = parent.p_tt[standing] + geo.var_dphi[standing]


def kalman(mask: np.ndarray, geo: Geometry, parent: Tracks, child: Child) -> None:
    """Heading known, scale known or estimated: an extended Kalman filter on ``(theta, log s)``
    predicting ``q = p + s R(theta) d``; a pressed robot's likelihood mixes its wide pushes with
    narrow ones (:func:`~anonloc_env.identify.contact.mix_pushes`)."""
    kalman_step(mask, geo, parent, child)
    tail = tail_candidates(geo.interval, geo.slot, geo.model.crowd_push_tail)
    tail = tail[mask[tail]]
    if len(tail):
        sub_parent = parent.take(tail)
        sub = Child.start(sub_parent)
        kalman_step(np.ones(len(tail), bool), geo.narrowed(tail), sub_parent, sub)
        weight = tails(geo.interval, geo.slot[tail], geo.model.crowd_push_tail)
        child.loglik[tail] = mix_pushes(child.loglik[tail], sub.loglik, weight)


def kalman_step(mask: np.ndarray, geo: Geometry, parent: Tracks, child: Child) -> None:
    """:func:`kalman` with the pushes of ``geo``'s interval as they are."""
    k = np.flatnonzero(mask)
    sel = everything(k, len(mask))
    # Scale known exactly and no contact: the filter is on theta alone (see kalman_heading).
    simple = (parent.p_ss[sel] == 0.0) & (parent.p_ts[sel] == 0.0) & ~geo.pushed[sel]
    if simple.all():
        kalman_heading(k, geo, parent, child)
        return
    kalman_heading(k[simple], geo, parent, child)
    k = k[~simple]
    th, ls = parent.theta[k], parent.log_s[k]
    ptt, pts, pss = parent.p_tt[k], parent.p_ts[k], parent.p_ss[k]
    # Unseen pushes (robot frame, scaled to the image) turned by the heading: R C R^T.
    push = geo.push_cov(k) * (geo.s[k] ** 2)[:, None, None]
    c, sn = np.cos(th), np.sin(th)
    cxx, cxy, cyy = push[:, 0, 0], push[:, 0, 1], push[:, 1, 1]
    q11 = c * c * cxx - 2 * c * sn * cxy + sn * sn * cyy
    q12 = c * sn * (cxx - cyy) + (c * c - sn * sn) * cxy
    q22 = sn * sn * cxx + 2 * c * sn * cxy + c * c * cyy
    s = np.exp(ls)
    pred = rotate(geo.d[k], th) * s[:, None]  # h(x) = s R(theta) d
    h_t = rotate(pred, math.pi / 2.0)  # dh/dtheta
    h_s = pred  # dh/dlog s
    e = geo.delta[k] - pred
    # S = base I + R C R^T + H P H^T with H = [h_t h_s] (2x2), P = [[ptt, pts], [pts, pss]].
    hp_t = h_t * ptt[:, None] + h_s * pts[:, None]  # H P first column
    hp_s = h_t * pts[:, None] + h_s * pss[:, None]  # H P second column
    base = geo.base_var[k]
    s11 = base + q11 + hp_t[:, 0] * h_t[:, 0] + hp_s[:, 0] * h_s[:, 0]
    s12 = q12 + hp_t[:, 0] * h_t[:, 1] + hp_s[:, 0] * h_s[:, 1]
    s22 = base + q22 + hp_t[:, 1] * h_t[:, 1] + hp_s[:, 1] * h_s[:, 1]
    det = s11 * s22 - s12**2
    i11, i12, i22 = s22 / det, -s12 / det, s11 / det
    maha = e[:, 0] ** 2 * i11 + 2 * e[:, 0] * e[:, 1] * i12 + e[:, 1] ** 2 * i22
    child.loglik[k] = -LOG_2PI - 0.5 * np.log(det) - 0.5 * maha
    # Gain K = P H^T S^-1 (2x2); rows: theta, log s.
    sinv_e = np.column_stack([i11 * e[:, 0] + i12 * e[:, 1], i12 * e[:, 0] + i22 * e[:, 1]])
    dth = np.einsum("ij,ij->i", hp_t, sinv_e)
    dls = np.einsum("ij,ij->i", hp_s, sinv_e)
    # P' = P - (H P)^T S^-1 (H P)
    a_t = np.column_stack(
        [i11 * hp_t[:, 0] + i12 * hp_t[:, 1], i12 * hp_t[:, 0] + i22 * hp_t[:, 1]]
    )
    a_s = np.column_stack(
        [i11 * hp_s[:, 0] + i12 * hp_s[:, 1], i12 * hp_s[:, 0] + i22 * hp_s[:, 1]]
    )
    child.theta[k] = th + dth + geo.dphi[k]
    child.p_tt[k] = np.maximum(ptt - np.einsum("ij,ij->i", hp_t, a_t), 1e-14) + geo.var_dphi[k]
    child.log_s[k] = ls + dls
    child.p_ts[k] = pts - np.einsum("ij,ij->i", hp_t, a_s)
    child.p_ss[k] = np.maximum(pss - np.einsum("ij,ij->i", hp_s, a_s), 0.0)


def kalman_heading(k: np.ndarray, geo: Geometry, parent: Tracks, child: Child) -> None:
    """:func:`kalman` with the scale known exactly and no push: with ``h = s R(theta) d``
    turned a quarter, ``S = b I + p_tt h h^T``, so with ``a = b + p_tt |h|^2`` (Sherman and
    Morrison) ``det S = b a``, ``e^T S^-1 e = (|e|^2 - p_tt (h.e)^2 / a) / b``, the gain is
    ``p_tt h^T / a`` and the new variance ``p_tt b / a``."""
    if len(k) == 0:
        return
    k = everything(k, len(parent))  # type: ignore[assignment]  # a slice selects alike
    th = parent.theta[k]
    ptt = parent.p_tt[k]
    s = geo.s[k]
    c, sn = np.cos(th), np.sin(th)
    dx, dy = geo.d[k, 0], geo.d[k, 1]
    px = s * (c * dx - sn * dy)  # predicted displacement s R(theta) d
    py = s * (sn * dx + c * dy)
    ex = geo.delta[k, 0] - px
    ey = geo.delta[k, 1] - py
    h_e = px * ey - py * ex  # h . e with h = (-py, px)
    b = geo.base_var[k]
    a = b + ptt * (px * px + py * py)
    maha = (ex * ex + ey * ey - ptt * h_e * h_e / a) / b
    child.loglik[k] = -LOG_2PI - 0.5 * np.log(b * a) - 0.5 * maha
    child.theta[k] = th + ptt * h_e / a + geo.dphi[k]
    child.p_tt[k] = np.maximum(ptt * b / a, 1e-14) + geo.var_dphi[k]
    # log s, p_ts (0) and p_ss (0) stay as the parent's (Child.start copied them).


def orientation(
    detected: np.ndarray, var_z: float, theta: np.ndarray, p_tt: np.ndarray, loglik: np.ndarray
) -> None:
    """A detected heading as one more measurement of ``theta`` (variance ``var_z``)."""
    known = np.isfinite(theta)
    if known.all():
        err = wrap_angle(detected - theta)
        var = p_tt + var_z
        loglik += -0.5 * (math.log(2 * math.pi) + np.log(var) + err**2 / var)
        gain = p_tt / var
        theta += gain * err
        p_tt *= 1 - gain
        return
    err = wrap_angle(detected[known] - theta[known])
    var = p_tt[known] + var_z
    loglik[known] += -0.5 * (math.log(2 * math.pi) + np.log(var) + err**2 / var)
    gain = p_tt[known] / var
    theta[known] = theta[known] + gain * err
    p_tt[known] = p_tt[known] * (1 - gain)
    # A heading learnt nowhere else comes from the detection itself.
    unknown = ~known
    theta[unknown] = detected[unknown]
    p_tt[unknown] = var_z
