"""Tracks: the explicit hypotheses of all robots, and how one is extended by a candidate row.

A track is which row of each picture was the robot (or that it was missed), with a Gaussian
estimate of its image heading and log scale. :func:`extend` scores a batch of (track, row)
candidates under the model of :mod:`anonloc_env.identify.model`: the ring density while the
heading is unknown, an extended Kalman filter on ``(theta, log s)`` once it is known.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from anonloc_env.geometry import rotate, wrap_angle
from anonloc_env.identify.model import GATE_SIGMAS, LOG_2PI, SensorModel
from anonloc_env.odometry import Interval


@dataclass
class Tracks:
    """Explicit hypotheses of all robots, flat arrays grouped by robot."""

    slot: np.ndarray  # robot of the hypothesis
    row: np.ndarray  # row in the newest picture, -1 if missed there
    pos: np.ndarray  # (H, 2) image position at the newest picture (detection or prediction)
    pos_var: np.ndarray  # variance of that position per component
    theta: np.ndarray  # image heading at the newest picture (nan: unknown)
    p_tt: np.ndarray  # variance of theta
    log_s: np.ndarray  # log scale (nan: unknown)
    p_ts: np.ndarray  # covariance of theta and log s
    p_ss: np.ndarray  # variance of log s
    logw: np.ndarray  # log weight

    @classmethod
    def empty(cls) -> Tracks:
        z = np.zeros(0)
        return cls(
            np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 2)), z, z, z, z, z, z, z
        )

    def take(self, index: np.ndarray) -> Tracks:
        return Tracks(*(getattr(self, f)[index] for f in FIELDS))

    @staticmethod
    def concat(parts: list[Tracks]) -> Tracks:
        return Tracks(*(np.concatenate([getattr(p, f) for p in parts]) for f in FIELDS))

    def __len__(self) -> int:
        return len(self.slot)


FIELDS = ("slot", "row", "pos", "pos_var", "theta", "p_tt", "log_s", "p_ts", "p_ss", "logw")


@dataclass
class Geometry:
    """Per candidate (parent track, new row): the displacement and its noise."""

    d: np.ndarray  # (K, 2) own displacement of the parent's robot (m)
    rho0: np.ndarray  # |d|
    dphi: np.ndarray  # own heading change
    var_dphi: np.ndarray  # its variance
    delta: np.ndarray  # (K, 2) image displacement from the parent's position to the row
    r: np.ndarray  # |delta|
    ang_delta: np.ndarray  # direction of delta
    ang_d: np.ndarray  # direction of d
    s: np.ndarray  # scale the parent assumes (its estimate, or the largest possible)
    push_cov: np.ndarray  # (K, 2, 2) unseen contact pushes (m^2, robot frame)
    base_var: np.ndarray  # isotropic variance per component without the pushes
    iso_var: np.ndarray  # with the pushes spread evenly
    still: np.ndarray  # too little motion to learn the heading from

    @classmethod
    def of(
        cls, parent: Tracks, z: np.ndarray, interval: Interval, model: SensorModel, pix_var: float
    ) -> Geometry:
        slot = parent.slot
        d = interval.d[slot]
        rho0 = np.hypot(d[:, 0], d[:, 1])
        var_d_all, var_dphi_all = interval.variances(model.odometry_noise)
        delta = z[:, :2] - parent.pos
        scale_known = np.isfinite(parent.log_s)
        s_high = model.scale_bounds[1]
        s = np.where(scale_known, np.exp(np.where(scale_known, parent.log_s, 0.0)), s_high)
        push_cov = interval.push_covariance()[slot]
        base_var = (
            pix_var + parent.pos_var + s**2 * var_d_all[slot] + (model.scale_spread * s * rho0) ** 2
        )
        iso_var = base_var + s**2 * 0.5 * (push_cov[:, 0, 0] + push_cov[:, 1, 1])
        return cls(
            d=d,
            rho0=rho0,
            dphi=interval.dphi[slot],
            var_dphi=var_dphi_all[slot],
            delta=delta,
            r=np.hypot(delta[:, 0], delta[:, 1]),
            ang_delta=np.arctan2(delta[:, 1], delta[:, 0]),
            ang_d=np.arctan2(d[:, 1], d[:, 0]),
            s=s,
            push_cov=push_cov,
            base_var=base_var,
            iso_var=iso_var,
            still=s_high * rho0 < 2.0 * np.sqrt(iso_var),
        )

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


def scale_free(mask: np.ndarray, geo: Geometry, child: Child, s_low: float, s_high: float) -> None:
    """Heading and scale unknown: any displacement length in the scale range, log-uniform
    scale, uniform direction (a robot that did not move: the standing density)."""
    moving = mask & ~geo.still
    width = math.log(s_high / s_low) if s_high > s_low else 1e-9
    rr = np.maximum(geo.r[moving], 1e-12)
    sigma = np.sqrt(geo.iso_var[moving])
    rho0 = geo.rho0[moving]
    inside = (rr >= s_low * rho0 - GATE_SIGMAS * sigma) & (
        rr <= s_high * rho0 + GATE_SIGMAS * sigma
    )
    # Density of a 2-D displacement of length r in a uniform direction, r log-uniform.
    child.loglik[moving] = np.where(inside, -LOG_2PI - 2.0 * np.log(rr) - math.log(width), -np.inf)
    standing = mask & geo.still
    child.loglik[standing] = geo.standing_loglik(standing)


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
    predicting ``q = p + s R(theta) d``."""
    k = np.flatnonzero(mask)
    th, ls = parent.theta[k], parent.log_s[k]
    ptt, pts, pss = parent.p_tt[k], parent.p_ts[k], parent.p_ss[k]
    # Unseen pushes (robot frame, scaled to the image) turned by the heading: R C R^T.
    push = geo.push_cov[k] * (geo.s[k] ** 2)[:, None, None]
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


def orientation(
    detected: np.ndarray, var_z: float, theta: np.ndarray, p_tt: np.ndarray, loglik: np.ndarray
) -> None:
    """A detected heading as one more measurement of ``theta`` (variance ``var_z``)."""
    known = np.isfinite(theta)
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
