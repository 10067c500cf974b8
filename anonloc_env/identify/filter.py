"""The identifier: a multi-hypothesis "which row is me" filter for R robots at once, built on the
model of :mod:`anonloc_env.identify.model` and the tracks of :mod:`anonloc_env.identify.tracks`."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from anonloc_env.geometry import rotate, wrap_angle
from anonloc_env.identify.gate import GATE_CHI2, PRUNE_NATS, Gate, uniform_gate, worst_variance
from anonloc_env.identify.model import (
    GATE_SIGMAS,
    LOG_2PI,
    SensorModel,
    log_background,
    push_isotropic,
    ring_loglik,
)
from anonloc_env.identify.others import Links, links_between
from anonloc_env.identify.tracks import (
    Child,
    Geometry,
    Tracks,
    direction_only,
    group_starts,
    is_shared,
    kalman,
    orientation,
    rank_in_group,
    scale_free,
    shared,
    take_field,
)
from anonloc_env.neighbours import expand_ranges, pairs_within, pairs_within_each
from anonloc_env.odometry import Interval

#: Only a robot's heaviest tracks are continued through a miss; the rest of their weight
#: returns to "position unknown" (kept, never lost).
MISSED_PER_ROBOT = 32
#: Candidates of the first leg scored per block (whole robots, about this many): small enough
#: that the block's temporaries stay in cache and are not fresh memory to fault in.
BLOCK = 8192
#: Candidates of the anchored tracks scored per block (whole robots, about this many).
ANCHORED_BLOCK = 65536


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


def add_grouped(total: np.ndarray, slot: np.ndarray, logw: np.ndarray) -> None:
    """``total[i] = logaddexp(total[i], logsumexp(logw[slot == i]))``, ``slot`` grouped."""
    if len(slot) == 0:
        return
    starts = group_starts(slot)
    top = np.maximum.reduceat(logw, starts)
    shift = np.where(np.isfinite(top), top, 0.0)
    sizes = np.diff(np.append(starts, len(slot)))
    sums = np.add.reduceat(np.exp(logw - np.repeat(shift, sizes)), starts)
    which = slot[starts]
    total[which] = np.logaddexp(total[which], shift + np.log(sums))


def near_best(slot: np.ndarray, logw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(keep, floor)``: the indices of the weights ``logw`` at most :data:`PRUNE_NATS` below
    the best of their robot (``slot`` grouped; never -inf or nan), and each one's floor."""
    starts = group_starts(slot)
    best = np.maximum.reduceat(logw, starts)
    floor = np.repeat(best, np.diff(np.append(starts, len(slot)))) - PRUNE_NATS
    return np.flatnonzero(logw >= floor), floor


def wrap_fast(angle: np.ndarray) -> np.ndarray:
    """:func:`~anonloc_env.geometry.wrap_angle` up to rounding, in ``[-pi, pi]``: ``angle`` less
    its nearest multiple of 2 pi, a tenth of the cost of ``np.mod`` (for the first leg's blocks,
    where the result is only squared or added to a heading that is wrapped again)."""
    turns = angle * (0.5 / math.pi)
    np.rint(turns, out=turns)
    turns *= 2.0 * math.pi
    return np.subtract(angle, turns, out=turns)


class Identifier:
    """Multi-hypothesis "which row is me" filter for R robots at once.

    Call :meth:`update` with every picture (and each robot's motion since the previous one), then
    read :meth:`belief`. The robots share nothing but the pictures: robot i's belief depends only
    on the pictures and ``interval`` row i.

    Args:
        model: the sensor model (see :class:`SensorModel`).
        n_robots: R, the number of robots identified at once.
        max_tracks: most hypotheses kept per robot (the best ones).
        fast: take the fast kernels where they apply (the default); ``False`` forces the
            general path everywhere, the reference the kernels are tested against (same
            beliefs up to rounding, several times slower at large N).
    """

    def __init__(
        self, model: SensorModel, n_robots: int, max_tracks: int = 1024, *, fast: bool = True
    ) -> None:
        self.model = model
        self.n = n_robots
        self.max_tracks = max_tracks
        self.fast = fast
        # A robot is never certain to be in a picture (it may leave the view): a floor of 1e-6
        # keeps its identity recoverable without costing more than one miss per track.
        self.log_pd = math.log(min(model.p_detect, 1.0 - 1e-6))
        self.log_miss = math.log(max(1.0 - model.p_detect, 1e-6))
        self.reset()

    def reset(self) -> None:
        """Forget everything: no picture seen."""
        self.tracks = Tracks.empty()
        self.uniform = np.full(self.n, -np.inf)  # log weight of each row of the newest picture
        self.unanchored = np.zeros(self.n)  # log weight of "position unknown"
        self.rows: np.ndarray | None = None  # newest picture (n_rows, 3)
        # The other robots between the previous picture and the newest (None: clutter model).
        self.links: Links | None = None
        # Log weight of each row of the newest picture in the uniform weight (None: all alike):
        # with the others persisting, a row that continues another robot's is less likely mine.
        self.row_bias: np.ndarray | None = None
        self._belief: np.ndarray | None = None
        self._shares: tuple[np.ndarray, ...] | None = None
        self._missing: np.ndarray | None = None
        self.pictures = 0

    # -- noise floors: float32 observations limit what "noise free" can mean ---------------------
    def _pixel_var(self, rows: np.ndarray) -> float:
        extent = float(np.abs(rows[:, :2]).max()) if len(rows) else 1.0
        floor = 1e-4 + 1e-6 * extent
        return self.model.pixel_noise**2 + floor**2

    def _theta_var(self) -> float:
        return self.model.orientation_noise**2 + 1e-10

    def update(self, rows: np.ndarray, interval: Interval | None = None) -> None:
        """Take in a picture.

        Args:
            rows: ``(n, 3)`` detections ``(u, v, theta)`` of the new picture (no padding).
            interval: each robot's motion since the previous picture; ignored for the first one.
        """
        rows = np.asarray(rows, dtype=np.float64).reshape(-1, 3)
        n_rows = len(rows)
        log_bg = log_background(self.model, n_rows)
        if self.rows is None or interval is None:
            # A first picture (or one with no known motion before it): start from "unknown".
            parts: list[Tracks] = []
            before = np.zeros(self.n)
            unanchored = before + self.log_miss
            self.links = None
        else:
            parts, unanchored = self._extend(rows, interval, log_bg)
            before = self.unanchored
        bias = None if self.links is None else self.links.starts + log_bg
        # "Position unknown" before the picture: now seen at any row alike, or still unknown.
        fresh = before + self.log_pd - math.log(self.model.image_area) - log_bg
        self.uniform = fresh if n_rows else np.full(self.n, -np.inf)
        self.unanchored = unanchored
        self.rows = rows
        self.row_bias = bias
        self.pictures += 1
        self._normalise_and_prune(parts)
        self._compute_belief()

    # -- one interval ----------------------------------------------------------------------------
    def _extend(
        self, rows: np.ndarray, interval: Interval, log_bg: float
    ) -> tuple[list[Tracks], np.ndarray]:
        model = self.model
        assert self.rows is not None
        prev = self.rows
        pix_var = self._pixel_var(np.concatenate([prev, rows]))
        self.links = links_between(model, prev, rows, log_bg, pix_var, self.links)
        var_d, _ = interval.variances(model.odometry_noise)
        s_high = model.scale_bounds[1]
        spread = model.scale_spread
        # Reach of each robot in the image: its path at the largest scale plus the noise.
        sigma_max = np.sqrt(
            2 * pix_var + s_high**2 * var_d + (spread * s_high * interval.path) ** 2
        )
        push = interval.push if interval.push is not None else 0.0
        travel = interval.path * (1 + GATE_SIGMAS * model.odometry_noise) + push
        reach = s_high * travel + GATE_SIGMAS * sigma_max
        radius = float(reach.max()) if len(reach) else 0.0
        i_pair, j_pair, dist = pairs_within(prev[:, :2], rows[:, :2], max(radius, 1e-9))
        parts: list[Tracks] = []
        unanchored = self.unanchored + self.log_miss  # unknown before, missed again

        # 1. Explicit tracks anchored at a row of the previous picture: candidate rows by pairs.
        tracks = self.tracks
        anchored = np.flatnonzero(tracks.row >= 0)
        if len(anchored):
            pairs = Pairs(prev, rows, i_pair, j_pair, interval, pix_var, log_bg)
            parts.append(self._anchored(tracks, anchored, pairs))
        # 2. Explicit tracks missed in the previous picture: candidates around their prediction.
        missed = np.flatnonzero(tracks.row < 0)
        if len(missed):
            unseen = tracks.take(missed)
            gate = Gate.of(unseen, interval, model, pix_var, self._theta_var())
            # Carried motion and grown position noise widen each track's search.
            carried = np.hypot(unseen.carry[:, 0], unseen.carry[:, 1])
            wider = radius + s_high * carried + GATE_SIGMAS * np.sqrt(unseen.pos_var)
            a, b, _ = pairs_within_each(unseen.pos, rows[:, :2], np.maximum(wider, 1e-9))
            keep = gate.passes(a, rows, b)
            bg = self._link_bg(unseen.row[a[keep]], b[keep], log_bg)
            parts.append(self._children(unseen.take(a[keep]), rows, b[keep], interval, pix_var, bg))
        # 4. The implicit uniform weight over previous rows: anchor it at every plausible pair
        # (computed before 3, which it helps prune; appended after it).
        live = np.flatnonzero(np.isfinite(self.uniform))
        anchored_uniform: list[Tracks] = []
        if len(live) and len(i_pair):
            anchored_uniform = self._from_uniform(
                live, prev, rows, i_pair, j_pair, dist, interval, pix_var, var_d, log_bg
            )
        # 3. Every explicit track may be missed in the new picture. A continuation more than
        # PRUNE_NATS below its robot's best child would be pruned at once: it is not built.
        if len(tracks):
            floor = np.full(self.n, -np.inf)
            for part in [*parts, *anchored_uniform]:
                if len(part):
                    starts = group_starts(part.slot)
                    top = np.maximum.reduceat(part.logw, starts)
                    which = part.slot[starts]
                    floor[which] = np.maximum(floor[which], top - PRUNE_NATS)
            continued, lost_slot, lost_logw = self._missed(tracks, interval, pix_var, floor)
            parts.append(continued)
            add_grouped(unanchored, lost_slot, lost_logw)
        parts.extend(anchored_uniform)
        if len(live):
            # ... or the robot was missed now: still at one of the previous rows, its own motion
            # carried (as many rows as a robot's tracks continued through a miss), or its
            # position is unknown again.
            if len(prev) <= MISSED_PER_ROBOT:
                parts.append(self._uniform_missed(live, prev, interval, pix_var))
            else:
                spread = math.log(len(prev))
                if self.links is not None:  # each row weighed by what its miss leaves the others
                    every = self.links.ends + self._bias(np.arange(len(prev)))
                    spread = float(np.logaddexp.reduce(every))
                lost = self.uniform[live] + spread + self.log_miss
                unanchored[live] = np.logaddexp(unanchored[live], lost)
        return [p for p in parts if len(p)], unanchored

    def _bias(self, row: np.ndarray) -> np.ndarray | float:
        """Log weight of rows ``row`` of the previous picture in its uniform weight."""
        return 0.0 if self.row_bias is None else self.row_bias[row]

    def _link_bg(self, prev_row: np.ndarray, cand: np.ndarray, log_bg: float) -> float | np.ndarray:
        """What a link from ``prev_row`` (-1: missed there) to row ``cand`` is divided by:
        ``lambda`` (the clutter model), or per link when the others persist (as a log)."""
        if self.links is None:
            return log_bg
        return -self.links.detect(prev_row, cand)

    def _anchored(self, tracks: Tracks, anchored: np.ndarray, pairs: Pairs) -> Tracks:
        """The children of tracks ``anchored`` (indices into ``tracks``, each at a row of the
        previous picture): every row paired with theirs that passes the gate, scored by
        :meth:`_known_children` (heading and scale known, nothing carried) or :meth:`_children`.

        Done in blocks of whole robots of about :data:`ANCHORED_BLOCK` candidates, so that the
        temporaries stay small; each robot's children are pruned within its block, as they
        would be all at once."""
        prev, rows, i_pair, j_pair, interval, pix_var, log_bg = pairs
        # i_pair is sorted: the pairs of row r are offsets[r]:offsets[r + 1].
        offsets = np.searchsorted(i_pair, np.arange(len(prev) + 1), side="left")
        row = tracks.row[anchored]
        counts = offsets[row + 1] - offsets[row]
        robot_start = group_starts(tracks.slot[anchored])
        robot_end = np.append(robot_start[1:], len(anchored))
        ends = np.cumsum(counts)[robot_end - 1]  # candidates up to the end of each robot
        cut = np.searchsorted(ends, np.arange(ANCHORED_BLOCK, int(ends[-1]), ANCHORED_BLOCK))
        bounds = np.concatenate([[0], robot_end[cut], [len(anchored)]])
        bounds = bounds[np.flatnonzero(np.diff(bounds, prepend=-1))]  # repeats dropped
        theta_var = self._theta_var()
        children = []
        together = anchored[-1] - anchored[0] + 1 == len(anchored)  # a range: blocks are views
        for lo, hi in zip(bounds[:-1].tolist(), bounds[1:].tolist(), strict=True):
            if together:
                block = tracks.window(int(anchored[lo]), int(anchored[hi - 1]) + 1)
            else:
                block = tracks.take(anchored[lo:hi])
            gate = Gate.of(block, interval, self.model, pix_var, theta_var)
            parent = np.repeat(np.arange(hi - lo), counts[lo:hi])
            cand = j_pair[expand_ranges(offsets[block.row], counts[lo:hi])]
            keep = gate.passes(parent, rows, cand)
            parent, cand = parent[keep], cand[keep]
            bg = self._link_bg(block.row[parent], cand, log_bg)
            if self.fast and gate.moved is not None:
                child = self._known_children(block, gate, parent, rows, cand, interval, pix_var, bg)
            else:
                child = self._children(block.take(parent), rows, cand, interval, pix_var, bg)
            children.append(child)
        return Tracks.concat(children)

    def _from_uniform(
        self,
        live: np.ndarray,
        prev: np.ndarray,
        rows: np.ndarray,
        i_pair: np.ndarray,
        j_pair: np.ndarray,
        dist: np.ndarray,
        interval: Interval,
        pix_var: float,
        var_d: np.ndarray,
        log_bg: float,
    ) -> list[Tracks]:
        """Anchor the uniform weight of robots ``live``: every pair whose length fits its motion
        (the fused first leg's tracks, then the general path's, each grouped by robot)."""
        pairs = Pairs(prev, rows, i_pair, j_pair, interval, pix_var, log_bg)
        model = self.model
        s_low, s_high = model.scale_bounds
        rho0 = np.hypot(*interval.d[live].T)
        push_iso = push_isotropic(interval, model)[live]
        sigma = np.sqrt(
            s_high**2 * push_iso
            + 2 * pix_var
            + s_high**2 * var_d[live]
            + (model.scale_spread * s_high * rho0) ** 2
        )
        lo = s_low * rho0 - GATE_SIGMAS * sigma
        hi = s_high * rho0 + GATE_SIGMAS * sigma
        by_length = np.argsort(dist, kind="stable")
        sorted_len = dist[by_length]
        start = np.searchsorted(sorted_len, lo, side="left")
        stop = np.searchsorted(sorted_len, hi, side="right")
        counts = stop - start
        if self.fast and model.orientation and model.scale is not None:
            # Heading and scale known: robots nothing pushed take the fused first leg.
            pushed = np.zeros(self.n, bool) if interval.push is None else interval.push > 0
            fused = ~pushed[live]
            first = self._first_leg(live[fused], start[fused], counts[fused], by_length, pairs)
            if fused.all():
                return [first]
            live, start, counts = live[~fused], start[~fused], counts[~fused]
            pick = by_length[expand_ranges(start, counts)]
            rest = self._uniform_children(np.repeat(live, counts), pick, pairs)
            return [first, rest]
        pick = by_length[expand_ranges(start, counts)]
        return [self._uniform_children(np.repeat(live, counts), pick, pairs)]

    def _uniform_children(self, slot: np.ndarray, pick: np.ndarray, pairs: Pairs) -> Tracks:
        """The uniform weight of robot ``slot[k]`` anchored at pair ``pick[k]``, by the general
        path: a parent track at the pair's first row, extended by :meth:`_children`."""
        prev, rows, i_pair, j_pair, interval, pix_var, log_bg = pairs
        model = self.model
        keep = uniform_gate(
            slot, pick, i_pair, j_pair, prev, rows, interval, model, pix_var, self._theta_var()
        )
        pick, slot = pick[keep], slot[keep]
        p_row = i_pair[pick]
        bg = self._link_bg(p_row, j_pair[pick], log_bg)
        n_par = len(pick)
        if model.orientation:
            theta = prev[p_row, 2]
            p_tt = np.full(n_par, self._theta_var())
        else:
            theta = np.full(n_par, np.nan)
            p_tt = np.full(n_par, np.inf)
        log_scale = math.log(model.scale) if model.scale is not None else np.nan
        known = model.scale is not None
        parent = Tracks(
            slot=slot,
            row=p_row,
            pos=prev[p_row, :2],
            pos_var=np.full(n_par, pix_var),
            theta=theta,
            p_tt=p_tt,
            log_s=np.full(n_par, log_scale),
            p_ts=np.zeros(n_par),
            p_ss=np.zeros(n_par) if known else np.full(n_par, np.inf),
            logw=self.uniform[slot] + self._bias(p_row),
            carry=np.zeros((n_par, 2)),
            turn=np.zeros(n_par),
        )
        return self._children(parent, rows, j_pair[pick], interval, pix_var, bg)

    def _first_leg(
        self,
        robots: np.ndarray,
        start: np.ndarray,
        counts: np.ndarray,
        by_length: np.ndarray,
        pairs: Pairs,
    ) -> Tracks:
        """:meth:`_uniform_children` for robots nothing pushed, heading detected, scale known.

        The same gate (:func:`uniform_gate`), heading Kalman step (``_kalman_heading``) and
        detected-heading step (:func:`orientation`), computed in the robot's frame at the pair's
        first row: the pair is turned once, what depends on the robot alone is computed once per
        robot, and no parent track is built (every parent has position variance ``pix_var``,
        heading variance ``theta_var``, the known scale). Candidates are grouped by robot.
        """
        prev, rows, i_pair, j_pair, interval, pix_var, log_bg = pairs
        model = self.model
        assert model.scale is not None
        total = int(counts.sum())
        if total == 0:
            return Tracks.empty()
        s = math.exp(math.log(model.scale))  # the scale a parent track holds, as _children reads it
        theta_var = self._theta_var()
        n = len(interval.d)
        var_d, var_dphi = interval.variances(model.odometry_noise)
        dx, dy, dphi = interval.d[:, 0], interval.d[:, 1], interval.dphi
        rho2 = dx**2 + dy**2
        rho0 = np.hypot(dx, dy)
        # Per robot: the gate's denominators, and the Kalman step's variances (see _kalman_heading).
        gate_var = worst_variance(np.arange(n), interval, model, pix_var) + pix_var
        gate_pos = gate_var + model.scale**2 * rho2 * theta_var
        gate_turn = 2.0 * theta_var + var_dphi
        gate_dx, gate_dy = model.scale * dx, model.scale * dy
        b = pix_var + pix_var + s**2 * var_d + (model.scale_spread * s * rho0) ** 2
        a = b + theta_var * (s * s * rho2)
        p_tt1 = np.maximum(theta_var * b / a, 1e-14) + var_dphi
        var_o = p_tt1 + theta_var
        gain = p_tt1 / var_o
        const = self.uniform + (
            -LOG_2PI
            - 0.5 * np.log(b * a)
            - 0.5 * (math.log(2 * math.pi) + np.log(var_o))
            + self.log_pd
            - log_bg
        )
        # Per pair: its displacement in the frame of the heading detected at its first row.
        theta0 = prev[i_pair, 2]
        delta = rows[j_pair, :2] - prev[i_pair, :2]
        c, sn = np.cos(theta0), np.sin(theta0)
        fx_pair = c * delta[:, 0] + sn * delta[:, 1]
        fy_pair = c * delta[:, 1] - sn * delta[:, 0]
        turn_pair = rows[j_pair, 2] - theta0
        seen = rows[j_pair, 2]
        # Per candidate, in blocks of whole robots small enough to stay in cache: the gate, the
        # heading Kalman step, the detected heading, and the prune (as _children does: more than
        # PRUNE_NATS below the robot's best child). What is kept is written to `out`.
        out_slot = np.empty(total, dtype=np.int64)
        out_pick = np.empty(total, dtype=np.int64)
        out_logw = np.empty(total)
        out_theta = np.empty(total)
        count = 0
        ends = np.cumsum(counts)
        cuts = np.searchsorted(ends, np.arange(BLOCK, total, BLOCK), side="left")
        cuts = np.concatenate([[0], cuts, [len(robots)]])  # sorted: drop repeats without
        cuts = cuts[np.flatnonzero(np.diff(cuts, prepend=-1))]  # np.unique (it imports numpy.ma)
        for lo, hi in zip(cuts[:-1].tolist(), cuts[1:].tolist(), strict=True):
            sl = np.repeat(robots[lo:hi], counts[lo:hi])
            pk = by_length[expand_ranges(start[lo:hi], counts[lo:hi])]
            # The gate.
            ex = fx_pair[pk] - gate_dx[sl]
            ey = fy_pair[pk] - gate_dy[sl]
            e2 = ex * ex + ey * ey
            turn = wrap_fast(turn_pair[pk] - dphi[sl])
            chi2 = e2 / gate_pos[sl] + turn * turn / gate_turn[sl]
            ok = np.flatnonzero(chi2 <= GATE_CHI2)
            sl, pk, e2 = sl[ok], pk[ok], e2[ok]
            if s != model.scale:
                ex = fx_pair[pk] - s * dx[sl]
                ey = fy_pair[pk] - s * dy[sl]
                e2 = ex * ex + ey * ey
            else:
                ex, ey = ex[ok], ey[ok]
            # The heading Kalman step, then the detected heading.
            h_e = s * (dx[sl] * ey - dy[sl] * ex)
            a_k = a[sl]
            maha = (e2 - theta_var * h_e * h_e / a_k) / b[sl]
            theta1 = theta0[pk] + theta_var * h_e / a_k + dphi[sl]
            err = wrap_fast(seen[pk] - theta1)
            logw = const[sl] - 0.5 * maha - 0.5 * (err * err / var_o[sl])
            if self.links is not None:  # the others persist: per link instead of lambda
                logw += log_bg + self.links.detect(i_pair[pk], j_pair[pk])
            if self.row_bias is not None:
                logw += self.row_bias[i_pair[pk]]
            # The prune.
            keep, floor = near_best(sl, logw)
            first = group_starts(sl)
            # Heaviest first within each robot, the order _normalise_and_prune keeps (the
            # tracks then come out in runs that Tracks.gather copies as slices).
            group = np.repeat(np.arange(len(first)), np.diff(np.append(first, len(sl))))
            key = group[keep] * (2.0 * PRUNE_NATS + 2.0) + (floor[keep] + PRUNE_NATS - logw[keep])
            keep = keep[np.argsort(key)]  # deterministic; ties are equal weights
            end = count + len(keep)
            sk = out_slot[count:end] = sl[keep]
            out_pick[count:end] = pk[keep]
            out_logw[count:end] = logw[keep]
            out_theta[count:end] = wrap_angle(theta1[keep] + gain[sk] * err[keep])
            count = end
        slot, pick = out_slot[:count], out_pick[:count]
        row = j_pair[pick]
        return Tracks(
            slot=slot,
            row=row,
            pos=rows[row, :2],
            pos_var=shared(pix_var, count),
            theta=out_theta[:count],
            p_tt=(p_tt1 * (1 - gain))[slot],
            log_s=shared(math.log(s), count),
            p_ts=shared(0.0, count),
            p_ss=shared(0.0, count),
            logw=out_logw[:count],
            carry=shared(0.0, count, 2),
            turn=shared(0.0, count),
        )

    def _uniform_missed(
        self, live: np.ndarray, prev: np.ndarray, interval: Interval, pix_var: float
    ) -> Tracks:
        """The uniform weight of robots ``live`` over the rows of ``prev``, missed in the new
        picture: a track anchored at every row, the robot's own motion carried."""
        model = self.model
        slot = np.repeat(live, len(prev))
        p_row = np.tile(np.arange(len(prev)), len(live))
        n_par = len(slot)
        var_d, var_dphi = interval.variances(model.odometry_noise)
        s = model.scale if model.scale is not None else model.scale_bounds[1]
        if model.orientation:
            theta = prev[p_row, 2].astype(np.float64)
            p_tt = np.full(n_par, self._theta_var()) + var_dphi[slot]
        else:
            theta = np.full(n_par, np.nan)
            p_tt = np.full(n_par, np.inf)
        known = model.scale is not None
        pos = prev[p_row, :2].astype(np.float64)
        pos_var = pix_var + s**2 * (var_d + push_isotropic(interval, model))[slot]
        carry, turn = interval.d[slot], interval.dphi[slot].astype(np.float64)
        if model.orientation and known:  # heading and scale known: predicted, as in _missed
            pos += rotate(carry, theta) * s
            pos_var += s**2 * (carry**2).sum(axis=1) * self._theta_var()
            theta = wrap_angle(theta + turn)
            carry, turn = np.zeros_like(carry), np.zeros_like(turn)
        return Tracks(
            slot=slot,
            row=np.full(n_par, -1),
            pos=pos,
            pos_var=pos_var,
            theta=theta,
            p_tt=p_tt,
            log_s=np.full(n_par, math.log(s) if known else np.nan),
            p_ts=np.zeros(n_par),
            p_ss=np.zeros(n_par) if known else np.full(n_par, np.inf),
            logw=self.uniform[slot]
            + self.log_miss
            + (0.0 if self.links is None else self.links.ends[p_row])
            + self._bias(p_row),
            carry=carry,
            turn=turn,
        )

    def _missed(
        self, tracks: Tracks, interval: Interval, pix_var: float, floor: np.ndarray
    ) -> tuple[Tracks, np.ndarray, np.ndarray]:
        """Continue a robot's heaviest tracks through a miss: to the predicted position if the
        heading and scale are known, otherwise still anchored at their newest detection with the
        robot's own motion carried (the next row is tested on the whole displacement). The
        weight of the other tracks returns to "position unknown". Continuations below their
        robot's ``floor`` (log weight; pruned anyway) are not returned."""
        logw = tracks.logw + self.log_miss
        if self.links is not None:
            logw = logw + self.links.miss(tracks.row)
        # Tracks are kept sorted by robot, heaviest first (see _normalise_and_prune).
        rank = rank_in_group(tracks.slot)
        kept = rank < MISSED_PER_ROBOT
        lost = np.flatnonzero(~kept)
        kept &= logw >= floor[tracks.slot]
        predicts = np.isfinite(tracks.theta) & np.isfinite(tracks.log_s)
        var_d, var_dphi = interval.variances(self.model.odometry_noise)
        push_var = push_isotropic(interval, self.model)
        k = np.flatnonzero(kept & predicts)
        slot = tracks.slot[k]
        d = interval.d[slot]
        s = np.exp(tracks.log_s[k])
        rho = np.hypot(*d.T)
        moved = rotate(d, tracks.theta[k]) * s[:, None]
        predicted = Tracks(
            slot=slot,
            row=np.full(len(k), -1),
            pos=tracks.pos[k] + moved,
            pos_var=tracks.pos_var[k]
            + s**2 * (var_d[slot] + push_var[slot])
            + (s * rho) ** 2 * tracks.p_tt[k],
            theta=wrap_angle(tracks.theta[k] + interval.dphi[slot]),
            p_tt=tracks.p_tt[k] + var_dphi[slot],
            log_s=tracks.log_s[k],
            p_ts=tracks.p_ts[k],
            p_ss=tracks.p_ss[k],
            logw=logw[k],
            carry=shared(0.0, len(k), 2),
            turn=shared(0.0, len(k)),
        )
        c = np.flatnonzero(kept & ~predicts)
        carried = tracks.take(c)
        carried.logw = logw[c]
        carried.row = np.full(len(c), -1)
        slot = carried.slot
        scale_known = np.isfinite(carried.log_s)
        s_high = self.model.scale_bounds[1]
        s = np.where(scale_known, np.exp(np.where(scale_known, carried.log_s, 0.0)), s_high)
        carried.pos_var = carried.pos_var + s**2 * (var_d[slot] + push_var[slot])
        carried.p_tt = carried.p_tt + var_dphi[slot]
        carried.carry, carried.turn = carried.own_motion(interval)
        return Tracks.concat([predicted, carried]), tracks.slot[lost], logw[lost]

    def _children(
        self,
        parent: Tracks,
        rows: np.ndarray,
        cand: np.ndarray,
        interval: Interval,
        pix_var: float,
        log_bg: float | np.ndarray,
    ) -> Tracks:
        """Extend each parent track by candidate row ``cand`` (same length): weight and state."""
        model = self.model
        if len(cand) == 0:
            return Tracks.empty()
        z = rows[cand]
        geo = Geometry(parent, z, interval, model, pix_var)
        child = Child.start(parent)
        heading_known = np.isfinite(parent.theta)
        scale_known = np.isfinite(parent.log_s)
        s_low, s_high = model.scale_bounds
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
        # The detected heading, if any, is one more measurement.
        if model.orientation:
            orientation(z[:, 2], self._theta_var(), child.theta, child.p_tt, child.loglik)
        logw = parent.logw + self.log_pd + child.loglik - log_bg
        # Children more than PRUNE_NATS below their robot's best child are pruned later anyway
        # (the best over all hypotheses is at least as high): drop them before they are copied.
        # Parents come grouped by robot, so the best child of each robot is a reduceat.
        slot = parent.slot
        keep, _ = near_best(slot, logw)
        return Tracks(
            slot=slot[keep],
            row=cand[keep],
            pos=z[keep, :2],
            pos_var=shared(pix_var, len(keep)),
            theta=wrap_angle(child.theta[keep]),
            p_tt=child.p_tt[keep],
            log_s=child.log_s[keep],
            p_ts=child.p_ts[keep],
            p_ss=child.p_ss[keep],
            logw=logw[keep],
            carry=shared(0.0, len(keep), 2),
            turn=shared(0.0, len(keep)),
        )

    def _known_children(
        self,
        tracks: Tracks,
        gate: Gate,
        parent: np.ndarray,
        rows: np.ndarray,
        cand: np.ndarray,
        interval: Interval,
        pix_var: float,
        log_bg: float | np.ndarray,
    ) -> Tracks:
        """:meth:`_children` of tracks ``parent`` (indices into ``tracks``) when every track
        knows its heading and scale and carries no motion (``gate.moved`` is set): the same
        arithmetic, the prediction ``s R(theta) d`` taken from the gate, and only the fields
        the Kalman step reads gathered. Candidates with a push or an estimated scale take the
        general :func:`kalman`."""
        model = self.model
        if len(cand) == 0:
            return Tracks.empty()
        assert gate.moved is not None
        assert gate.scale is not None
        assert gate.rho0 is not None
        slot = tracks.slot[parent]
        z = rows[cand]
        var_d_all, var_dphi_all = interval.variances(model.odometry_noise)
        count = len(parent)
        s, rho0 = take_field(gate.scale, parent, count), gate.rho0[parent]
        th, ptt = tracks.theta[parent], tracks.p_tt[parent]
        log_s, p_ts, p_ss = (
            take_field(f, parent, count) for f in (tracks.log_s, tracks.p_ts, tracks.p_ss)
        )
        # _kalman_heading, with Geometry's base variance.
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
        loglik = -LOG_2PI - 0.5 * np.log(b * a) - 0.5 * maha
        theta = th + ptt * h_e / a + interval.dphi[slot]
        p_tt = np.maximum(ptt * b / a, 1e-14) + var_dphi_all[slot]
        if is_shared(p_ss) and is_shared(p_ts) and p_ss[0] == 0.0 and p_ts[0] == 0.0:
            general = np.zeros(count, dtype=bool)  # the scale known, as it is in a first leg
        else:
            general = (p_ss != 0.0) | (p_ts != 0.0)
        if interval.push is not None:
            general |= interval.push[slot] > 0
        if general.any():
            g = np.flatnonzero(general)
            sub = tracks.take(parent[g])
            child = Child.start(sub)
            kalman(np.ones(len(g), bool), Geometry(sub, z[g], interval, model, pix_var), sub, child)
            loglik[g], theta[g], p_tt[g] = child.loglik, child.theta, child.p_tt
            log_s, p_ts, p_ss = np.array(log_s), np.array(p_ts), np.array(p_ss)  # own copies
            log_s[g], p_ts[g], p_ss[g] = child.log_s, child.p_ts, child.p_ss
        if model.orientation:
            orientation(z[:, 2], self._theta_var(), theta, p_tt, loglik)
        logw = tracks.logw[parent] + self.log_pd + loglik - log_bg
        # Pruned as _children does: more than PRUNE_NATS below the robot's best child.
        keep, _ = near_best(slot, logw)
        count = len(keep)
        return Tracks(
            slot=slot[keep],
            row=cand[keep],
            pos=z[keep, :2],
            pos_var=shared(pix_var, count),
            theta=wrap_angle(theta[keep]),
            p_tt=p_tt[keep],
            log_s=take_field(log_s, keep, count),
            p_ts=take_field(p_ts, keep, count),
            p_ss=take_field(p_ss, keep, count),
            logw=logw[keep],
            carry=shared(0.0, count, 2),
            turn=shared(0.0, count),
        )

    def _normalise_and_prune(self, parts: list[Tracks]) -> None:
        """Prune, sort and normalise the new tracks, ``parts`` one after the other (gathered
        once, in the final order: the parts are never concatenated)."""
        parts = [p for p in parts if len(p)]
        if len(parts) == 1:
            slot, logw = parts[0].slot, parts[0].logw
        else:
            slot = np.concatenate([np.zeros(0, np.int64)] + [p.slot for p in parts])
            logw = np.concatenate([np.zeros(0)] + [p.logw for p in parts])
        n_rows = 0 if self.rows is None else len(self.rows)
        log_rows = math.log(n_rows) if n_rows else -np.inf
        if n_rows and self.row_bias is not None:
            log_rows = float(np.logaddexp.reduce(self.row_bias))
        uniform_total = self.uniform + log_rows
        best = np.maximum(uniform_total, self.unanchored)
        if len(slot):
            np.maximum.at(best, slot, logw)
        lost = ~np.isfinite(best)
        if lost.any():  # the model ruled everything out (it does not fit): start over
            self.unanchored[lost] = 0.0
            best[lost] = 0.0
        keep = logw >= best[slot] - PRUNE_NATS
        if lost.any():
            keep &= ~lost[slot]
        kept = None if keep.all() else np.flatnonzero(keep)
        if kept is not None:
            slot, logw = slot[kept], logw[kept]
        # Sort by robot, heaviest first (one key: every kept weight is within PRUNE_NATS of its
        # robot's best), and cap the number of tracks per robot: keep the heaviest. The fields
        # are gathered once, in the final order.
        order = np.argsort(slot * (2.0 * PRUNE_NATS + 2.0) + (best[slot] - logw), kind="stable")
        rank = rank_in_group(slot[order])
        if rank.max(initial=0) >= self.max_tracks:
            order = order[rank < self.max_tracks]
        tracks = Tracks.gather(parts, order if kept is None else kept[order])
        # Normalise each robot's weights to sum to one.
        sums = np.exp(uniform_total - best) + np.exp(self.unanchored - best)
        sums += np.bincount(
            tracks.slot, weights=np.exp(tracks.logw - best[tracks.slot]), minlength=self.n
        )
        total = best + np.log(sums)
        tracks.logw = tracks.logw - total[tracks.slot]
        self.uniform = self.uniform - total
        self.unanchored = self.unanchored - total
        # Implicit weights too small to matter stop costing anything.
        self.uniform[self.uniform + log_rows < -PRUNE_NATS] = -np.inf
        self.unanchored[self.unanchored < -PRUNE_NATS] = -np.inf
        self.tracks = tracks

    def _compute_belief(self) -> None:
        """Each robot's total weight and what each track's weight is of it; the ``(R, n)``
        table itself is filled when :meth:`belief` first asks for it."""
        tracks = self.tracks
        weights = np.exp(tracks.logw)
        seen = tracks.row >= 0
        if seen.all():
            slot, row, seen_w = tracks.slot, tracks.row, weights
            missing = np.exp(self.unanchored)
        else:
            slot, row, seen_w = tracks.slot[seen], tracks.row[seen], weights[seen]
            missing = np.exp(self.unanchored) + np.bincount(
                tracks.slot[~seen], weights=weights[~seen], minlength=self.n
            )
        uniform = np.exp(self.uniform)
        n_rows = 0 if self.rows is None else len(self.rows)
        spread = np.ones(n_rows) if self.row_bias is None else np.exp(self.row_bias)
        total = (
            np.bincount(slot, weights=seen_w, minlength=self.n) + spread.sum() * uniform + missing
        )
        # Each weight divided by its robot's total before any table is filled.
        self._shares = (slot, row, seen_w / total[slot], uniform / total, spread)
        self._belief = None
        self._missing = missing / total

    def belief(self) -> np.ndarray:
        """``(R, n)`` probability that each row of the newest picture is robot i.

        A row of it sums to ``1 - missing()[i]``, not to 1: robot i may be out of the picture
        (missed). ``np.column_stack([belief(), missing()])`` is the full distribution over the
        ``n + 1`` outcomes, rows summing to 1. Built on the first call after each picture (an
        ``(R, n)`` table; :meth:`belief_at` reads one entry per robot without it).

        Raises:
            RuntimeError: before the first :meth:`update` (there is no picture yet).
        """
        if self._belief is None:
            if self._shares is None:
                raise RuntimeError("no picture yet: call update() first")
            slot, row, share, uniform, spread = self._shares
            n_rows = len(spread)
            belief = np.bincount(
                slot * n_rows + row, weights=share, minlength=self.n * n_rows
            ).reshape(self.n, n_rows)
            belief = belief.astype(np.float64, copy=False)  # bincount of nothing is int64
            if uniform.any():
                belief += uniform[:, None] * spread[None, :]
            self._belief = belief
        return self._belief

    def belief_at(self, rows: np.ndarray) -> np.ndarray:
        """``(R,)``: ``belief()[i, rows[i]]``, or ``missing()[i]`` where ``rows[i] < 0``, the
        same numbers without building the ``(R, n)`` table (what the env's reward reads).

        Args:
            rows: ``(R,)`` integer row of the newest picture for each robot, or -1.

        Raises:
            RuntimeError: before the first :meth:`update`.
            ValueError: ``rows`` of the wrong shape, or a row outside ``[-1, n)``.
        """
        if self._shares is None or self._missing is None:
            raise RuntimeError("no picture yet: call update() first")
        slot, row, share, uniform, spread = self._shares
        rows = np.asarray(rows)
        if rows.shape != (self.n,) or not np.issubdtype(rows.dtype, np.integer):
            raise ValueError(f"rows must be an integer array of shape ({self.n},), got {rows!r}")
        if len(rows) and (rows.min() < -1 or rows.max() >= len(spread)):
            raise ValueError(f"rows must lie in [-1, {len(spread)}), got {rows!r}")
        match = row == rows[slot]
        out = np.bincount(slot[match], weights=share[match], minlength=self.n)
        out = out.astype(np.float64, copy=False)
        seen = rows >= 0
        if uniform.any():
            out[seen] += uniform[seen] * spread[rows[seen]]
        out[~seen] = self._missing[~seen]
        return out

    def missing(self) -> np.ndarray:
        """``(R,)`` probability that robot i is not in the newest picture (the last column of the
        full distribution: see :meth:`belief`).

        Raises:
            RuntimeError: before the first :meth:`update`, as :meth:`belief` does.
        """
        if self._missing is None:
            raise RuntimeError("no picture yet: call update() first")
        return self._missing
