"""Gates: a cheap, generous test of which (hypothesis, row) candidates are worth scoring.

Every variance is taken at its largest (the largest scale, pushes spread evenly), and a candidate
is dropped only when no weighting could keep it within ``PRUNE_NATS`` of its robot's best: a
chi-square above :data:`GATE_CHI2`. What a hypothesis predicts is computed once per hypothesis
(a centre, a ring radius around it, a spread), and each candidate costs a few gathers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from anonloc_env.geometry import wrap_angle
from anonloc_env.identify.arrays import is_shared
from anonloc_env.identify.model import SensorModel
from anonloc_env.identify.tracks import Tracks
from anonloc_env.odometry import Interval

#: Hypotheses more than this many nats below their robot's best are dropped (a factor 3e-7:
#: what is dropped cannot move a 0.99 decision).
PRUNE_NATS = 15.0
#: On a chi-square (-0.5 chi2 is the log-likelihood): generous enough to keep anything within
#: ``PRUNE_NATS`` of the best, with 5 nats to spare for the normalising terms.
GATE_CHI2 = 2.0 * (2.0 * PRUNE_NATS + 5.0)


def worst_variance(
    slot: np.ndarray, interval: Interval, model: SensorModel, pix_var: float
) -> np.ndarray:
    """Per candidate robot: the displacement variance per component at the largest scale, the
    model's pushes all along one direction (``push_share push^2 / 3``), without the position
    variance of the hypothesis."""
    s_high = model.scale_bounds[1]
    var_d, _ = interval.variances(model.odometry_noise)
    push = interval.push if interval.push is not None else np.zeros(len(interval.d))
    rho = s_high * np.hypot(interval.d[:, 0], interval.d[:, 1])
    pushes = model.push_share * push**2 / 3.0
    per_robot = pix_var + s_high**2 * (var_d + pushes) + (model.scale_spread * rho) ** 2
    return per_robot[slot]


@dataclass
class Gate:
    """What each hypothesis predicts for the next detection: within ``ring`` of ``centre``
    (``(H, 2)``, image units) with variance ``spread``; with a detected heading, one near
    ``turn`` with variance ``turn_var`` (``inf``: not tested)."""

    centre: np.ndarray
    ring: np.ndarray
    spread: np.ndarray
    turn: np.ndarray
    turn_var: np.ndarray
    #: When every track knows its heading and scale and carries no motion (:meth:`of`):
    #: ``(H, 2)`` the predicted displacement ``s R(theta) d``, the scale ``s`` and ``|d|``,
    #: for the Kalman step to reuse; None otherwise.
    moved: np.ndarray | None = None
    scale: np.ndarray | None = None
    rho0: np.ndarray | None = None

    def __post_init__(self) -> None:
        self.rings = bool(np.any(self.ring > 0.0))
        self.turns = bool(np.any(np.isfinite(self.turn_var)))

    @classmethod
    def of(
        cls,
        tracks: Tracks,
        interval: Interval,
        model: SensorModel,
        pix_var: float,
        theta_var: float,
    ) -> Gate:
        """The gate of every explicit track: a point where the heading and scale are known,
        a ring where only the scale is, no test otherwise."""
        slot = tracks.slot
        d, dphi = tracks.own_motion(interval)
        rho0 = np.hypot(d[:, 0], d[:, 1])
        var = worst_variance(slot, interval, model, pix_var) + tracks.pos_var
        _, var_dphi = interval.variances(model.odometry_noise)
        has_theta = np.isfinite(tracks.theta)
        has_scale = np.isfinite(tracks.log_s)
        known = has_theta & has_scale
        if known.all():  # the usual case after a few pictures: no masks needed
            gate = cls._all_known(tracks, d, dphi, rho0, var, var_dphi, model, theta_var)
            if not (tracks.turn.any() or tracks.carry.any()):
                return gate
            gate.moved = gate.scale = gate.rho0 = None  # d is not the robot's own motion
            return gate
        ring = has_scale & ~has_theta
        s = np.exp(np.where(has_scale, tracks.log_s, 0.0))
        theta = np.where(has_theta, tracks.theta, 0.0)
        c, sn = np.cos(theta), np.sin(theta)
        centre = tracks.pos.copy()
        centre[known, 0] += (s * (c * d[:, 0] - sn * d[:, 1]))[known]
        centre[known, 1] += (s * (sn * d[:, 0] + c * d[:, 1]))[known]
        spread = np.full(len(tracks), np.inf)
        spread[known] = var[known] + (s * rho0)[known] ** 2 * tracks.p_tt[known]
        spread[ring] = 2.0 * var[ring]
        radius = np.where(ring, s * rho0, 0.0)
        turn_var = np.full(len(tracks), np.inf)
        if model.orientation:
            turn_var[known] = (tracks.p_tt + var_dphi[slot] + theta_var)[known]
        return cls(centre, radius, spread, theta + dphi, turn_var)

    @classmethod
    def _all_known(
        cls,
        tracks: Tracks,
        d: np.ndarray,
        dphi: np.ndarray,
        rho0: np.ndarray,
        var: np.ndarray,
        var_dphi: np.ndarray,
        model: SensorModel,
        theta_var: float,
    ) -> Gate:
        """:meth:`of` when every track knows its heading and scale (the same arithmetic)."""
        if is_shared(tracks.log_s):  # one scale for all: its exp once
            s = np.broadcast_to(np.exp(tracks.log_s[:1]), (len(tracks),))
        else:
            s = np.exp(tracks.log_s)
        theta = tracks.theta
        c, sn = np.cos(theta), np.sin(theta)
        moved = np.empty((len(tracks), 2))
        moved[:, 0] = s * (c * d[:, 0] - sn * d[:, 1])
        moved[:, 1] = s * (sn * d[:, 0] + c * d[:, 1])
        centre = tracks.pos + moved
        spread = var + (s * rho0) ** 2 * tracks.p_tt
        if model.orientation:
            turn_var = tracks.p_tt + var_dphi[tracks.slot] + theta_var
        else:
            turn_var = np.full(len(tracks), np.inf)
        return cls(centre, np.zeros(len(tracks)), spread, theta + dphi, turn_var, moved, s, rho0)

    def passes(self, parent: np.ndarray, rows: np.ndarray, cand: np.ndarray) -> np.ndarray:
        """``(K,)`` True where row ``rows[cand[k]]`` may extend hypothesis ``parent[k]``.

        The turn is tested only where the position passes (the chi-square only grows)."""
        dx = rows[cand, 0] - self.centre[parent, 0]
        dy = rows[cand, 1] - self.centre[parent, 1]
        if self.rings:
            miss = np.hypot(dx, dy) - self.ring[parent]
            chi2 = miss * miss
        else:
            chi2 = dx * dx + dy * dy
        chi2 /= self.spread[parent]
        if not self.turns:
            return chi2 <= GATE_CHI2
        ok = np.flatnonzero(chi2 <= GATE_CHI2)
        p = parent[ok]
        turn = wrap_angle(rows[cand[ok], 2] - self.turn[p])
        out = np.zeros(len(parent), dtype=bool)
        out[ok] = chi2[ok] + turn**2 / self.turn_var[p] <= GATE_CHI2
        return out


def uniform_gate(
    slot: np.ndarray,
    pair: np.ndarray,
    i_pair: np.ndarray,
    j_pair: np.ndarray,
    prev: np.ndarray,
    rows: np.ndarray,
    interval: Interval,
    model: SensorModel,
    pix_var: float,
    theta_var: float,
) -> np.ndarray:
    """``(K,)`` True where robot ``slot[k]``, position unknown, may have moved along pair
    ``pair[k]``: from row ``i_pair`` of the previous picture ``prev`` to row ``j_pair`` of
    ``rows``.

    The same test as ``Gate.passes`` for a hypothesis just anchored at the pair's first row
    (position variance ``pix_var``, the detected heading if any, the known scale if any), computed
    in the robot's frame, ``|q - p - s R(theta_p) d| = |R(-theta_p) (q - p) - s d|``, so that
    the rotation is done once per pair.
    """
    if model.scale is None:
        return np.ones(len(slot), dtype=bool)  # the length window is the whole test
    s = model.scale
    d = interval.d[slot]
    var = worst_variance(slot, interval, model, pix_var) + pix_var
    delta = rows[j_pair, :2] - prev[i_pair, :2]
    if not model.orientation:
        length = np.hypot(delta[:, 0], delta[:, 1])[pair] - s * np.hypot(d[:, 0], d[:, 1])
        return length * length / (2.0 * var) <= GATE_CHI2
    _, var_dphi = interval.variances(model.odometry_noise)
    theta = prev[i_pair, 2]
    c, sn = np.cos(theta), np.sin(theta)
    # The pair in the frame of the heading detected at its first row, and its turn.
    fx = (c * delta[:, 0] + sn * delta[:, 1])[pair]
    fy = (c * delta[:, 1] - sn * delta[:, 0])[pair]
    ex = fx - s * d[:, 0]
    ey = fy - s * d[:, 1]
    rho2 = d[:, 0] ** 2 + d[:, 1] ** 2
    chi2 = (ex * ex + ey * ey) / (var + s * s * rho2 * theta_var)
    turn = wrap_angle((rows[j_pair, 2] - theta)[pair] - interval.dphi[slot])
    chi2 += turn * turn / (2.0 * theta_var + var_dphi[slot])
    return chi2 <= GATE_CHI2
