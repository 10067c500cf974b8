"""The misses a picture's footprint explains: each hypothesis's chance to be out of view.

The model is :mod:`anonloc_env.identify.footprint`'s. :class:`OutOfView` applies it to the
identifier's hypotheses around the children of :mod:`anonloc_env.identify.children` (which it
leaves as they are): it sets the weight a hypothesis takes into a miss, ``1 - P_D p_in`` instead
of ``1 - P_D``, before the tracks are continued through the miss (so that a track predicted out
of view is not pruned as a miss), after the uniform weight's few missed tracks are built, and in
place of the uniform weight's return to "position unknown". Only hypotheses within reach of an
edge that cuts the arena are touched; the others keep ``1 - P_D`` to the bit.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from anonloc_env.geometry import rotate
from anonloc_env.identify import kernels
from anonloc_env.identify.arrays import is_shared
from anonloc_env.identify.footprint import EDGE_SIGMAS, Footprint
from anonloc_env.identify.gate import worst_variance
from anonloc_env.identify.model import SensorModel
from anonloc_env.identify.tracks import Tracks
from anonloc_env.odometry import Interval

#: Share of a robot's "position unknown" weight taken as anywhere in view after a picture with a
#: footprint, rather than out of view in it (so at its edges now): a robot whose tracks were
#: all lost in view stays recoverable, at 4.6 nats.
ELSEWHERE = 0.01
#: The uniform weight missed in a picture keeps a track at the previous rows whose robot is
#: likely out of view now (``p_in`` below this), at most ``LEAVING_ROWS`` of them.
LEAVING_P_IN = 0.5
LEAVING_ROWS = 32


@dataclass(frozen=True)
class OutOfView:
    """One picture's footprint, applied to the identifier's hypotheses.

    Attributes:
        footprint: the picture's footprint.
        model: the sensor model.
        log_pd: ``log P_D`` as the identifier takes it (floored below 1).
        log_miss: ``log (1 - P_D)``, what a miss costs in view.
    """

    footprint: Footprint
    model: SensorModel
    log_pd: float
    log_miss: float

    @property
    def log_seen(self) -> float:
        """``log (P_D c)``: a robot of unknown position seen, ``c`` the share in view."""
        return self.log_pd + math.log(max(self.footprint.share, 1e-300))

    @property
    def log_unseen(self) -> float:
        """``log (1 - P_D c)``: a robot of unknown position missed."""
        return math.log1p(-math.exp(self.log_seen))

    def unknown(
        self, before: OutOfView | None, rows: np.ndarray, sigma: float
    ) -> tuple[float, float, np.ndarray | None]:
        """A robot of unknown position: ``log P(seen)``, ``log P(missed)`` and the log weight of
        each of ``rows`` in its uniform weight (None: all alike). After a picture with a
        footprint (``before``) it was most likely out of view there (its weight unknown is what
        the misses left), so it comes back at the edges: the strips' re-entry
        (``Footprint.reentry``, motion ``sigma`` per component), but for
        :data:`ELSEWHERE` of it, anywhere in view."""
        if before is None:
            return self.log_seen, self.log_unseen, None
        share = self.footprint.share
        density, back = before.footprint.reentry(rows, sigma)
        seen = ELSEWHERE * share + (1.0 - ELSEWHERE) * back
        log_seen = self.log_pd + math.log(seen)
        area = self.model.image_area
        per_row = (ELSEWHERE * share + (1.0 - ELSEWHERE) * density * area) / seen
        return log_seen, math.log1p(-math.exp(log_seen)), np.log(per_row)

    def _miss(self, p_in: np.ndarray) -> np.ndarray:
        """``log (1 - P_D p_in) - log (1 - P_D)``: what a miss gains out of view."""
        return np.log1p(-math.exp(self.log_pd) * p_in) - self.log_miss

    def _slack(self, var: np.ndarray | float) -> np.ndarray | float:
        """How far inside an edge a point of variance ``var`` may still be out of view (one
        number for a shared field: the same floats, without a pass over every track)."""
        if isinstance(var, np.ndarray) and is_shared(var):
            var = float(var[0])
        return EDGE_SIGMAS * np.sqrt(var + self.footprint.edge_var)

    def tracks(self, tracks: Tracks, interval: Interval, pix_var: float, reach: float) -> Tracks:
        """``tracks`` with their weights shifted by what a miss gains out of view (to continue
        them through the miss): each one's place after ``interval`` predicted, a ring of its own
        motion's length where its heading is unknown. ``reach``: the farthest a robot moves."""
        near = self.footprint.near(tracks.pos, reach + self._slack(tracks.pos_var))
        if not len(near):
            return tracks
        sub = tracks.take(near)
        d, _ = sub.own_motion(interval)
        known = np.isfinite(sub.theta) & np.isfinite(sub.log_s)
        s = np.exp(np.where(np.isfinite(sub.log_s), sub.log_s, 0.0))
        s = np.where(np.isfinite(sub.log_s), s, self.model.scale_bounds[1])
        length2 = s**2 * (d[:, 0] ** 2 + d[:, 1] ** 2)
        centre = sub.pos.copy()
        theta = np.where(known, sub.theta, 0.0)
        centre[known] += (rotate(d, theta) * s[:, None])[known]
        var = sub.pos_var + worst_variance(sub.slot, interval, self.model, pix_var)
        var = var + np.where(known, length2 * np.where(known, sub.p_tt, 0.0), 0.5 * length2)
        logw = tracks.logw.copy()
        logw[near] += self._miss(self.footprint.p_in(centre, var))
        return dataclasses.replace(tracks, logw=logw)

    def uniform_missed(self, part: Tracks) -> Tracks:
        """The uniform weight's missed tracks ``part`` (built as missed in view, their place
        predicted or their motion carried) with the weight a miss gains out of view."""
        s = self.model.scale_bounds[1]
        length2 = s**2 * (part.carry[:, 0] ** 2 + part.carry[:, 1] ** 2)
        var = part.pos_var + 0.5 * length2
        near = self.footprint.near(part.pos, np.sqrt(length2) + self._slack(var))
        if len(near):
            part.logw = part.logw.copy()
            part.logw[near] += self._miss(self.footprint.p_in(part.pos[near], var[near]))
        return part

    def leaving(
        self, live: np.ndarray, prev: np.ndarray, interval: Interval, pix_var: float
    ) -> np.ndarray:
        """Rows of ``prev`` whose robot is likely out of view now (``p_in`` below
        :data:`LEAVING_P_IN` for the robots ``live``' median motion), at most
        :data:`LEAVING_ROWS`, the likeliest out first, in row order. The uniform weight missed
        now keeps a track at each (``Builder.uniform_missed``, as it does at every row of a
        picture of at most ``MISSED_PER_ROBOT`` rows): a robot the drift carried out of view
        before it was identified keeps its place, rather than returning to "position unknown"
        and coming back at any edge."""
        if not len(live) or not len(prev):
            return np.zeros(0, np.int64)
        var = float(np.median(self._lost_var(live, interval, pix_var)[0]))
        near = self.footprint.near(prev[:, :2], self._slack(var))
        if not len(near):
            return near
        p_in = self.footprint.p_in(prev[near, :2], np.full(len(near), var))
        out = p_in < LEAVING_P_IN
        order = np.argsort(p_in[out], kind="stable")[:LEAVING_ROWS]
        return np.sort(near[out][order])

    def _lost_var(
        self, live: np.ndarray, interval: Interval, pix_var: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(L,)`` each robot's place's variance about a previous row after ``interval`` (its
        own motion a ring about it), and that ring's radius squared."""
        model = self.model
        s = model.scale_bounds[1]
        var_d, _ = interval.variances(model.odometry_noise)
        rho2 = s**2 * (interval.d[live, 0] ** 2 + interval.d[live, 1] ** 2)
        return pix_var + s**2 * var_d[live] + 0.5 * rho2, rho2

    def uniform_lost(
        self,
        live: np.ndarray,
        prev: np.ndarray,
        interval: Interval,
        pix_var: float,
        prior: kernels.Prior,
        unanchored: np.ndarray,
        kept: np.ndarray | None = None,
    ) -> None:
        """The uniform weight of robots ``live`` over the ``prev`` rows, missed in the new
        picture, returned to "position unknown" (``unanchored``, in place): each row's robot
        missed with ``1 - P_D p_in`` from its place, its own motion a ring about it; but for
        the rows ``kept``, whose missed tracks the caller keeps."""
        base = np.zeros(len(prev))
        if kept is not None and len(kept):
            base[kept] = -np.inf
        if prior.links is not None:
            base = base + prior.links.ends
        if prior.row_bias is not None:
            base = base + prior.row_bias
        var, rho2 = self._lost_var(live, interval, pix_var)
        near = self.footprint.near(
            prev[:, :2], float(np.sqrt(rho2.max(initial=0.0))) + self._slack(float(var.max()))
        )
        far = np.ones(len(prev), bool)
        far[near] = False
        spread = np.full(len(live), -np.inf)
        if far.any():
            spread[:] = float(np.logaddexp.reduce(base[far])) + self.log_miss
        if len(near):
            centre = np.repeat(prev[near, :2][None], len(live), axis=0).reshape(-1, 2)
            p_in = self.footprint.p_in(centre, np.repeat(var, len(near)))
            terms = base[near][None, :] + np.log1p(-math.exp(self.log_pd) * p_in).reshape(
                len(live), len(near)
            )
            spread = np.logaddexp(spread, np.logaddexp.reduce(terms, axis=1))
        lost = prior.uniform[live] + spread
        unanchored[live] = np.logaddexp(unanchored[live], lost)


#: A robot claims a row of the newest picture when its tracks there hold at least this share of
#: its weight (see ``claimed_elsewhere``).
CLAIM = 0.99
#: Tracks lighter than this share of their robot's weight are not looked at for claims.
CLAIM_SCAN = 0.01


def claimed_elsewhere(
    tracks: Tracks, uniform: np.ndarray, unanchored: np.ndarray, log_rows: float
) -> tuple[Tracks, np.ndarray, np.ndarray]:
    """The identifier's normalised weights after a picture with a footprint, with the rows
    another robot claims taken from the rest: a track of robot ``k`` at a row that robot ``j``
    claims (its tracks there hold ``p >= CLAIM``) is weighed by ``1 - p``, and each touched
    robot's weights are normalised again (its tracks still sorted heaviest first).

    Why: a robot carried out of view is missed there at no cost, while a rival track of it at
    another robot's row gains ``P_D f / lambda`` at every picture (the clutter model draws the
    other rows afresh): a robot stuck in a corner, which the drift carries out of view every
    few pictures, ended on a still robot's row (the windy condition's wrong decisions at
    N = 10). Each row is at most one robot: where another robot is sure of it, mine is the rest.
    Only claims count, not every robot's share of a row (those sum to about one for every row
    while nobody is sure, and would square every belief).

    Args:
        tracks: the tracks (``exp(logw)`` each one's probability), grouped by robot, heaviest
            first.
        uniform: ``(R,)`` each robot's log weight of each row in its uniform weight.
        unanchored: ``(R,)`` each robot's log weight of "position unknown".
        log_rows: log of the rows' total weight in the uniform weight.
    """
    w = np.exp(tracks.logw)
    scan = np.flatnonzero((w >= CLAIM_SCAN) & (tracks.row >= 0))
    if not len(scan):
        return tracks, uniform, unanchored
    n_rows = int(tracks.row.max()) + 1
    key = tracks.slot[scan] * n_rows + tracks.row[scan]
    keys, where = np.unique(key, return_inverse=True)
    held = np.bincount(where, weights=w[scan])
    claim = held >= CLAIM
    if not claim.any():
        return tracks, uniform, unanchored
    robot, row = keys[claim] // n_rows, keys[claim] % n_rows
    by_row = np.full(n_rows, -1)
    by_row[row] = robot  # a robot claims one row at most; two robots one row: both hit
    share = np.zeros(n_rows)
    np.add.at(share, row, held[claim])
    at = tracks.row >= 0
    rival = np.flatnonzero(at & (by_row[np.where(at, tracks.row, 0)] >= 0))
    rival = rival[by_row[tracks.row[rival]] != tracks.slot[rival]]
    if not len(rival):
        return tracks, uniform, unanchored
    others = np.minimum(share[tracks.row[rival]], 1.0 - 1e-6)
    logw = tracks.logw.copy()
    logw[rival] += np.log1p(-others)
    touched = np.unique(tracks.slot[rival])
    # Each touched robot's weights normalised again.
    total = np.exp(uniform + log_rows) + np.exp(unanchored)
    total += np.bincount(tracks.slot, weights=np.exp(logw), minlength=len(uniform))
    shift = np.zeros(len(uniform))
    shift[touched] = np.log(total[touched])
    logw -= shift[tracks.slot]
    # Heaviest first again within the touched robots (their runs, in place).
    inside = np.isin(tracks.slot, touched)
    idx = np.flatnonzero(inside)
    order = np.arange(len(logw))
    order[idx] = idx[np.lexsort((-logw[idx], tracks.slot[idx]))]
    out = tracks.take(order)
    out.logw = logw[order]
    return out, uniform - shift, unanchored - shift
