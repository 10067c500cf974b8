"""A picture's children of the tracks: how each hypothesis of the previous picture, explicit
(a track) or implicit (the uniform weight over the previous rows), extends to the newest one.

The :class:`~anonloc_env.identify.filter.Identifier` gathers the pairs of rows within any robot's
reach, then asks a :class:`Builder` for each kind of child: a track anchored at a previous row
continued by a row near it (``anchored``); a track missed before, continued by a row near its
prediction (``from_missed``); the uniform weight anchored at a pair that fits the robot's motion
(``from_uniform``); a track missed now (``missed``); and the uniform weight missed now
(``uniform_missed``, or ``uniform_lost`` when there are too many previous rows).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from anonloc_env import compiled
from anonloc_env.geometry import rotate, wrap_angle
from anonloc_env.identify import first_step, fused_calls, kernels
from anonloc_env.identify.arrays import group_starts, rank_in_group
from anonloc_env.identify.gate import Gate, uniform_gate
from anonloc_env.identify.likelihood import Pairs, Scoring, children
from anonloc_env.identify.model import GATE_SIGMAS, push_isotropic, ring_loglik_bound
from anonloc_env.identify.pool import Pool
from anonloc_env.identify.tracks import Tracks
from anonloc_env.neighbours import expand_ranges, pairs_within_each
from anonloc_env.odometry import Interval

#: Only a robot's heaviest tracks are continued through a miss; the rest of their weight
#: returns to "position unknown" (kept, never lost).
MISSED_PER_ROBOT = 32
#: Candidates of the anchored tracks scored per block (whole robots, about this many).
ANCHORED_BLOCK = 65536
#: Nats added to a candidate's bound before it is compared with its robot's floor (rounding,
#: and the likelihood's own approximations): a margin, never a change of what is kept.
BOUND_SLACK = 1.0


class Builder(NamedTuple):
    """What building one interval's children reads of the identifier, and the builders.

    Attributes:
        scoring: the sensor model, ``log P_D`` and the detected heading's variance.
        prior: each robot's uniform log weight over the previous picture's rows, those rows'
            bias in it, and the other robots between the pictures (``None``: clutter model).
        log_miss: ``log (1 - P_D)``.
        fast: take the fast kernels where they apply.
        pool: the identifier's reused blocks, where the first leg writes its tracks (None: new
            arrays).
    """

    scoring: Scoring
    prior: kernels.Prior
    log_miss: float
    fast: bool
    pool: Pool | None = None

    def anchored(self, tracks: Tracks, anchored: np.ndarray, pairs: Pairs) -> Tracks:
        """The children of tracks ``anchored`` (indices into ``tracks``, each at a row of the
        previous picture): every row paired with theirs that passes the gate, scored by
        :func:`~anonloc_env.identify.kernels.known_children` (heading and scale known, nothing
        carried) or :func:`~anonloc_env.identify.likelihood.children`.

        Done in blocks of whole robots of about :data:`ANCHORED_BLOCK` candidates, so that the
        temporaries stay small; each robot's children are pruned within its block, as they
        would be all at once."""
        prev, rows, i_pair, j_pair, interval, pix_var, log_bg = pairs
        # i_pair is sorted: the pairs of row r are offsets[r]:offsets[r + 1].
        offsets = np.searchsorted(i_pair, np.arange(len(prev) + 1), side="left")
        fast = Tracks.empty()
        if self.fast and compiled.mode() is not None:  # robots that know heading and scale
            sure, anchored = fused_calls.known_robots(tracks, anchored)
            if len(sure):
                sub = tracks.select(sure)
                lo, hi = offsets[sub.row], offsets[sub.row + 1]
                links, scoring = self.prior.links, self.scoring
                fast = fused_calls.known_compiled(
                    sub, lo, hi, j_pair, pairs, links, scoring, self.pool
                )
            if not len(anchored):
                return fast
        row = tracks.row[anchored]
        counts = offsets[row + 1] - offsets[row]
        robot_start = group_starts(tracks.slot[anchored])
        robot_end = np.append(robot_start[1:], len(anchored))
        ends = np.cumsum(counts)[robot_end - 1]  # candidates up to the end of each robot
        cut = np.searchsorted(ends, np.arange(ANCHORED_BLOCK, int(ends[-1]), ANCHORED_BLOCK))
        bounds = np.concatenate([[0], robot_end[cut], [len(anchored)]])
        bounds = bounds[np.flatnonzero(np.diff(bounds, prepend=-1))]  # repeats dropped
        scoring = self.scoring
        out = []
        together = anchored[-1] - anchored[0] + 1 == len(anchored)  # a range: blocks are views
        for lo, hi in zip(bounds[:-1].tolist(), bounds[1:].tolist(), strict=True):
            if together:
                block = tracks.window(int(anchored[lo]), int(anchored[hi - 1]) + 1)
            else:
                block = tracks.take(anchored[lo:hi])
            gate = Gate.of(block, interval, scoring.model, pix_var, scoring.theta_var)
            parent = np.repeat(np.arange(hi - lo), counts[lo:hi])
            cand = j_pair[expand_ranges(offsets[block.row], counts[lo:hi])]
            keep = gate.passes(parent, rows, cand)
            parent, cand = parent[keep], cand[keep]
            bg = self._link_bg(block.row[parent], cand, log_bg)
            if self.fast and gate.moved is not None:
                known = kernels.known_children
                out.append(known(block, gate, parent, rows, cand, interval, pix_var, bg, scoring))
            else:
                parents = block.take(parent)
                out.append(children(parents, rows, cand, interval, pix_var, bg, scoring))
        return fused_calls.merge_by_robot(fast, Tracks.concat(out))

    def from_missed(self, unseen: Tracks, pairs: Pairs, radius: float) -> Tracks:
        """The children of tracks ``unseen``, each missed in the previous picture: the rows
        around their prediction that pass the gate, by the general path. Carried motion and
        grown position noise widen each track's search beyond ``radius``."""
        rows, interval, pix_var = pairs.rows, pairs.interval, pairs.pix_var
        model = self.scoring.model
        carried = np.hypot(unseen.carry[:, 0], unseen.carry[:, 1])
        wider = radius + model.scale_bounds[1] * carried + GATE_SIGMAS * np.sqrt(unseen.pos_var)
        a, b, _ = pairs_within_each(unseen.pos, rows[:, :2], np.maximum(wider, 1e-9))
        fast = Tracks.empty()
        if self.fast and compiled.mode() is not None:  # robots that know heading and scale
            known, rest = fused_calls.known_robots(unseen, np.arange(len(unseen)))
            if len(known):  # a is sorted: track h's candidates are b[lo[h]:hi[h]].
                lo = np.searchsorted(a, known, side="left")
                hi = np.searchsorted(a, known, side="right")
                sub, links, scoring = unseen.select(known), self.prior.links, self.scoring
                fast = fused_calls.known_compiled(sub, lo, hi, b, pairs, links, scoring, self.pool)
            if not len(rest):
                return fast
            if len(known):  # the others' own candidates, renumbered
                a, b = fused_calls.renumbered(a, b, rest, len(unseen))
                unseen = unseen.select(rest)
        gate = Gate.of(unseen, interval, model, pix_var, self.scoring.theta_var)
        keep = gate.passes(a, rows, b)
        bg = self._link_bg(unseen.row[a[keep]], b[keep], pairs.log_bg)
        parents = unseen.take(a[keep])
        slow = children(parents, rows, b[keep], interval, pix_var, bg, self.scoring)
        return fused_calls.merge_by_robot(fast, slow)

    def from_uniform(
        self,
        live: np.ndarray,
        pairs: Pairs,
        dist: np.ndarray,
        var_d: np.ndarray,
        floor: np.ndarray | None = None,
    ) -> list[Tracks]:
        """Anchor the uniform weight of robots ``live``: every pair whose length ``dist`` fits
        its motion (the fast first leg's tracks, then the general path's, each grouped by
        robot). ``floor``: each robot's log weight below which a child would be pruned anyway
        (from its other children; None: not known): the general path drops the candidates whose
        bound is below it before scoring them."""
        model, interval, pix_var = self.scoring.model, pairs.interval, pairs.pix_var
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
        counts = np.searchsorted(sorted_len, hi, side="right") - start
        out = []
        ring = first_step.applies(self.fast, self.scoring)  # no heading, scale known: compiled
        if ring or (self.fast and model.orientation and model.scale is not None):
            # Heading detected, or not (ring), and scale known: robots nothing pushed take the
            # fast first leg.
            n = len(self.prior.uniform)
            pushed = np.zeros(n, bool) if interval.push is None else interval.push > 0
            fused = ~pushed[live]
            leg = (live[fused], start[fused], counts[fused], by_length, pairs)
            if ring:
                out.append(
                    first_step.ring_leg(*leg, dist, floor, self.prior, self.scoring, BOUND_SLACK)
                )
            else:
                out.append(kernels.first_leg(*leg, self.prior, self.scoring, self.pool))
            if fused.all():
                return out
            live, start, counts = live[~fused], start[~fused], counts[~fused]
        pick = by_length[expand_ranges(start, counts)]
        slot = np.repeat(live, counts)
        out.append(self._uniform_children(slot, pick, pairs, dist, floor))
        return out

    def _uniform_children(
        self,
        slot: np.ndarray,
        pick: np.ndarray,
        pairs: Pairs,
        dist: np.ndarray,
        floor: np.ndarray | None,
    ) -> Tracks:
        """The uniform weight of robot ``slot[k]`` anchored at pair ``pick[k]``, by the general
        path: a parent track at the pair's first row, extended by
        ``likelihood.children`` (those whose bound reaches ``floor``, where given, and, without
        headings, those whose weight does: the others would be pruned anyway. Under
        ``drone-hover`` at N = 1000 they are 150,000 of the third picture's 216,000, most at
        rows where a robot may have come back into view)."""
        prev, rows, i_pair, j_pair, interval, pix_var, log_bg = pairs
        model, theta_var = self.scoring.model, self.scoring.theta_var
        floored = floor is not None and model.scale is not None and not model.orientation
        keep = uniform_gate(
            slot, pick, i_pair, j_pair, prev, rows, interval, model, pix_var, theta_var
        )
        pick, slot = pick[keep], slot[keep]
        p_row = i_pair[pick]
        bg = self._link_bg(p_row, j_pair[pick], log_bg)
        if floored:
            assert floor is not None
            reach = self._ring_bound(slot, p_row, dist[pick], pairs) - bg >= floor[slot]
            if not reach.all():
                keep = np.flatnonzero(reach)
                pick, slot, p_row = pick[keep], slot[keep], p_row[keep]
                if isinstance(bg, np.ndarray):  # per link (the others persist)
                    bg = bg[keep]
        known = model.scale is not None
        parent = Tracks.fresh(
            slot,
            p_row,
            prev[p_row, :2],
            self.prior.uniform[slot] + self._bias(p_row),
            pos_var=pix_var,
            theta=prev[p_row, 2] if model.orientation else np.nan,
            p_tt=theta_var if model.orientation else np.inf,
            log_s=math.log(model.scale) if model.scale is not None else np.nan,
            p_ss=0.0 if known else np.inf,
        )
        out = children(parent, rows, j_pair[pick], interval, pix_var, bg, self.scoring)
        if floored:
            assert floor is not None
            above = out.logw >= floor[out.slot]
            if not above.all():
                out = out.take(np.flatnonzero(above))
        return out

    def _ring_bound(
        self, slot: np.ndarray, p_row: np.ndarray, r: np.ndarray, pairs: Pairs
    ) -> np.ndarray:
        """An upper bound of the log weight (less the link's background) of the uniform weight's
        child of robot ``slot`` from row ``p_row`` along a pair ``r`` long, when the heading is
        not detected and the scale is known: the ring likelihood of ``score_cases`` (case A,
        the variance it takes for a track just anchored) bounded by ``ring_loglik_bound``,
        plus ``BOUND_SLACK``."""
        model, interval, pix_var = self.scoring.model, pairs.interval, pairs.pix_var
        assert model.scale is not None
        s = model.scale
        var_d, _ = interval.variances(model.odometry_noise)
        rho = np.hypot(interval.d[:, 0], interval.d[:, 1])
        var = 2.0 * pix_var + s**2 * var_d + (model.scale_spread * s * rho) ** 2
        if interval.push is not None:
            var = var + s**2 * push_isotropic(interval, model)
        ll = ring_loglik_bound(r, s * rho[slot], var[slot])
        prior = self.prior.uniform[slot] + self._bias(p_row)
        return prior + self.scoring.log_pd + ll + BOUND_SLACK

    def missed(
        self, tracks: Tracks, interval: Interval, pix_var: float, floor: np.ndarray
    ) -> tuple[Tracks, np.ndarray, np.ndarray]:
        """Continue a robot's heaviest tracks through a miss: to the predicted position if the
        heading and scale are known, otherwise still anchored at their newest detection with the
        robot's own motion carried (the next row is tested on the whole displacement). The
        weight of the other tracks returns to "position unknown". Continuations below their
        robot's ``floor`` (log weight; pruned anyway) are not returned."""
        logw = tracks.logw + self.log_miss
        if self.prior.links is not None:
            logw = logw + self.prior.links.miss(tracks.row)
        # Tracks are kept sorted by robot, heaviest first (see Identifier._normalise_and_prune).
        rank = rank_in_group(tracks.slot)
        kept = rank < MISSED_PER_ROBOT
        lost = np.flatnonzero(~kept)
        kept &= logw >= floor[tracks.slot]
        predicts = np.isfinite(tracks.theta) & np.isfinite(tracks.log_s)
        var_d, var_dphi = interval.variances(self.scoring.model.odometry_noise)
        push_var = push_isotropic(interval, self.scoring.model)
        k = np.flatnonzero(kept & predicts)
        slot = tracks.slot[k]
        d = interval.d[slot]
        s = np.exp(tracks.log_s[k])
        rho = np.hypot(*d.T)
        predicted = Tracks.fresh(
            slot,
            np.full(len(k), -1),
            tracks.pos[k] + rotate(d, tracks.theta[k]) * s[:, None],
            logw[k],
            pos_var=tracks.pos_var[k]
            + s**2 * (var_d[slot] + push_var[slot])
            + (s * rho) ** 2 * tracks.p_tt[k],
            theta=wrap_angle(tracks.theta[k] + interval.dphi[slot]),
            p_tt=tracks.p_tt[k] + var_dphi[slot],
            log_s=tracks.log_s[k],
            p_ts=tracks.p_ts[k],
            p_ss=tracks.p_ss[k],
        )
        c = np.flatnonzero(kept & ~predicts)
        carried = tracks.take(c)
        carried.logw = logw[c]
        carried.row = np.full(len(c), -1)
        slot = carried.slot
        scale_known = np.isfinite(carried.log_s)
        s_high = self.scoring.model.scale_bounds[1]
        s = np.where(scale_known, np.exp(np.where(scale_known, carried.log_s, 0.0)), s_high)
        carried.pos_var = carried.pos_var + s**2 * (var_d[slot] + push_var[slot])
        carried.p_tt = carried.p_tt + var_dphi[slot]
        carried.carry, carried.turn = carried.own_motion(interval)
        return Tracks.concat([predicted, carried]), tracks.slot[lost], logw[lost]

    def uniform_missed(
        self,
        live: np.ndarray,
        prev: np.ndarray,
        interval: Interval,
        pix_var: float,
        at: np.ndarray | None = None,
    ) -> Tracks:
        """The uniform weight of robots ``live`` over the rows of ``prev`` (or over its rows
        ``at`` only), missed in the new picture: a track anchored at every such row, the
        robot's own motion carried."""
        model, theta_var = self.scoring.model, self.scoring.theta_var
        which = np.arange(len(prev)) if at is None else at
        slot = np.repeat(live, len(which))
        p_row = np.tile(which, len(live))
        var_d, var_dphi = interval.variances(model.odometry_noise)
        s = model.scale if model.scale is not None else model.scale_bounds[1]
        if model.orientation:
            theta = prev[p_row, 2].astype(np.float64)
            p_tt: np.ndarray | float = theta_var + var_dphi[slot]
        else:
            theta, p_tt = np.full(len(slot), np.nan), np.inf
        known = model.scale is not None
        pos = prev[p_row, :2].astype(np.float64)
        pos_var = pix_var + s**2 * (var_d + push_isotropic(interval, model))[slot]
        carry, turn = interval.d[slot], interval.dphi[slot].astype(np.float64)
        if model.orientation and known:  # heading and scale known: predicted, as in missed
            pos += rotate(carry, theta) * s
            pos_var += s**2 * (carry**2).sum(axis=1) * theta_var
            theta = wrap_angle(theta + turn)
            carry, turn = np.zeros_like(carry), np.zeros_like(turn)
        logw = self.prior.uniform[slot] + self.log_miss
        links = self.prior.links
        logw = logw + (0.0 if links is None else links.ends[p_row]) + self._bias(p_row)
        return Tracks.fresh(
            slot,
            np.full(len(slot), -1),
            pos,
            logw,
            pos_var=pos_var,
            theta=theta,
            p_tt=p_tt,
            log_s=math.log(s) if known else np.nan,
            p_ss=0.0 if known else np.inf,
            carry=carry,
            turn=turn,
        )

    def uniform_lost(self, live: np.ndarray, n_prev: int, unanchored: np.ndarray) -> None:
        """The uniform weight of robots ``live`` over ``n_prev`` previous rows, missed in the new
        picture, returned to "position unknown" (``unanchored``, in place)."""
        spread = math.log(n_prev)
        if self.prior.links is not None:  # each row weighed by what its miss leaves the others
            every = self.prior.links.ends + self._bias(np.arange(n_prev))
            spread = float(np.logaddexp.reduce(every))
        lost = self.prior.uniform[live] + spread + self.log_miss
        unanchored[live] = np.logaddexp(unanchored[live], lost)

    def _bias(self, row: np.ndarray) -> np.ndarray | float:
        """Log weight of rows ``row`` of the previous picture in its uniform weight."""
        return 0.0 if self.prior.row_bias is None else self.prior.row_bias[row]

    def _link_bg(self, prev_row: np.ndarray, cand: np.ndarray, log_bg: float) -> float | np.ndarray:
        """What a link from ``prev_row`` (-1: missed there) to row ``cand`` is divided by:
        ``lambda`` (the clutter model), or per link when the others persist (as a log)."""
        if self.prior.links is None:
            return log_bg
        return -self.prior.links.detect(prev_row, cand)
