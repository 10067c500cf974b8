"""The identifier: a multi-hypothesis "which row is me" filter for R robots at once, built on the
model of :mod:`anonloc_env.identify.model`, the tracks of :mod:`anonloc_env.identify.tracks` and
their children of :mod:`anonloc_env.identify.children` (scored by the likelihood of
:mod:`anonloc_env.identify.likelihood`, the general path, with the fast kernels of
:mod:`anonloc_env.identify.kernels` where they apply)."""

from __future__ import annotations

import math

import numpy as np

from anonloc_env import compiled
from anonloc_env.identify import first_step, fused, fused_calls, kernels
from anonloc_env.identify.anchors import sure_moves
from anonloc_env.identify.arrays import add_grouped, group_starts, rank_in_group
from anonloc_env.identify.camera_pose import Registration, apply
from anonloc_env.identify.children import MISSED_PER_ROBOT, Builder
from anonloc_env.identify.contact import break_tracks, pressed_interval
from anonloc_env.identify.footprint import Footprint
from anonloc_env.identify.gate import PRUNE_NATS
from anonloc_env.identify.likelihood import Pairs, Scoring
from anonloc_env.identify.model import GATE_SIGMAS, SensorModel, log_background
from anonloc_env.identify.others import Links, links_between
from anonloc_env.identify.out_of_view import OutOfView, claimed_elsewhere
from anonloc_env.identify.pool import Pool, empty, first_picture_blocks, taken
from anonloc_env.identify.tracks import Tracks
from anonloc_env.neighbours import pairs_within
from anonloc_env.odometry import Interval


class Identifier:
    """Multi-hypothesis "which row is me" filter for R robots at once.

    Call :meth:`update` with every picture (and each robot's motion since the previous one), then
    read :meth:`belief`. The robots share nothing but the pictures: robot i's belief depends only
    on the pictures and ``interval`` row i (unless ``model.pooled_motion``: a moving camera
    registered by the robots the identifier is sure of, a communication the option states).

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
        if fast and compiled.mode() is not None:
            fused.load()  # once per process, not at the first picture
            first_step.load()
        # A robot is never certain to be in a picture (it may leave the view): a floor of 1e-6
        # keeps its identity recoverable without costing more than one miss per track.
        self.log_pd = math.log(min(model.p_detect, 1.0 - 1e-6))
        self.log_miss = math.log(max(1.0 - model.p_detect, 1e-6))
        # float32 observations limit what "noise free" can mean: a floor on the heading noise.
        self.scoring = Scoring(model, self.log_pd, model.orientation_noise**2 + 1e-10)
        # A moving camera: each picture mapped into the set point's frame first (camera_pose).
        self.registration = (
            Registration(model.registration, model.orientation) if model.registration else None
        )
        # The large arrays' memory, kept from picture to picture and from episode to episode.
        self.pool = Pool()
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
        self._flat_spread = True
        self._missing: np.ndarray | None = None
        self.pictures = 0
        self._pushed_run = np.zeros(self.n, np.int64)  # intervals in a row each robot was pushed
        # The newest interval as the model took it, and its pixel variance (None before a second
        # picture): what a decided track's continuation is scored with (contact.continuations).
        self.interval: Interval | None = None
        self.pix_var = 0.0
        self._view: OutOfView | None = None  # the newest picture's footprint (a moving camera)
        if self.registration is not None:
            self.registration.reset()

    @property
    def pushed_run(self) -> np.ndarray:
        """``(R,)`` intervals in a row each robot was pushed, the newest one included (what the
        contact model calls pressed, >= 2, and jammed, > ``crowd_jam``)."""
        return self._pushed_run

    def _pixel_var(self, rows: np.ndarray) -> float:
        """The pixel variance (times ``crowd_noise`` squared in a crowd), floored: float32
        observations limit what "noise free" can mean."""
        extent = float(np.abs(rows[:, :2]).max()) if len(rows) else 1.0
        floor = 1e-4 + 1e-6 * extent
        if self.registration is not None:  # this picture's own registration error in it
            return self.registration.pixel_var * self.model.crowd_noise**2 + floor**2
        return (self.model.pixel_noise * self.model.crowd_noise) ** 2 + floor**2

    def update(
        self,
        rows: np.ndarray,
        interval: Interval | None = None,
        footprint: np.ndarray | None = None,
    ) -> None:
        """Take in a picture.

        Args:
            rows: ``(n, 3)`` detections ``(u, v, theta)`` of the new picture (no padding).
            interval: each robot's motion since the previous picture; ignored for the first one.
            footprint: ``(4, 2)`` the picture's field of view in the frame of ``rows``, where it
                comes with the picture (a moving camera's picture rectified by its landmarks:
                the observation key ``footprint``, ``Picture.footprint``); ignored without the
                model's ``view`` or with a registration (which gives its own).
        """
        rows = np.asarray(rows, dtype=np.float64).reshape(-1, 3)
        if self.registration is not None:  # anchored by the robots it is sure of, if pooled
            sure = None
            if self.model.pooled_motion and interval is not None and self.rows is not None:
                noise = self.registration.prior.pixel_noise
                sure = sure_moves(self.tracks, interval, self.model, noise, self.scoring.theta_var)
            rows = self.registration.register(rows, sure)
        n_rows = len(rows)
        view = self._out_of_view(footprint)
        log_bg = log_background(self.model, n_rows, 1.0 if view is None else view.footprint.share)
        # A robot of unknown position: seen, missed, where (see out_of_view).
        log_seen, log_unseen, edge_bias = self.log_pd, self.log_miss, None
        if view is not None and self.model.view is not None:
            reg = self.registration
            step, error = (reg.prior.spread, reg.error) if reg else self.model.view.fit_spreads
            log_seen, log_unseen, edge_bias = view.unknown(
                self._view, rows, math.hypot(step, error)
            )
        self._view = view
        if self.rows is None or interval is None:
            # A first picture (or one with no known motion before it): start from "unknown".
            parts: list[Tracks] = []
            before = np.zeros(self.n)
            unanchored = before + log_unseen
            self.links = None
            self.interval = None
        else:
            interval = self._pressed(interval)
            self.interval = interval
            parts, unanchored = self._extend(rows, interval, log_bg, view, log_unseen)
            before = self.unanchored
        bias = None if self.links is None else self.links.starts + log_bg
        if edge_bias is not None:
            bias = edge_bias if bias is None else bias + edge_bias
        # "Position unknown" before the picture: now seen at any row alike, or still unknown.
        fresh = before + log_seen - math.log(self.model.image_area) - log_bg
        self.uniform = fresh if n_rows else np.full(self.n, -np.inf)
        self.unanchored = unanchored
        self.rows = rows
        self.row_bias = bias
        self.pictures += 1
        if not len(self.pool) and n_rows and self._pooled() is not None:
            self.pool.reserve(first_picture_blocks(self.n * n_rows * 8))
        self._normalise_and_prune(parts)
        if view is not None and self.model.pooled_motion:  # rows another robot is sure of
            self.tracks, self.uniform, self.unanchored = claimed_elsewhere(
                self.tracks, self.uniform, self.unanchored, self._log_rows()
            )
        self._compute_belief()

    def _out_of_view(self, footprint: np.ndarray | None) -> OutOfView | None:
        """The newest picture's footprint (see :mod:`anonloc_env.identify.footprint`): the
        registered one, or ``footprint`` as it came; None: every robot in view."""
        view, reg = self.model.view, self.registration
        if view is None or (reg is None and footprint is None):
            return None
        if reg is not None:
            fp = Footprint.of(
                view, apply(reg.transform, reg.prior.centre, view.corners()), reg.error
            )
        else:
            fp = Footprint.of(view, np.asarray(footprint, np.float64), view.fit_spreads[1])
        return OutOfView(fp, self.model, self.log_pd, self.log_miss)

    # -- one interval ----------------------------------------------------------------------------
    def _pressed(self, interval: Interval) -> Interval:
        """The interval as the model takes it: robots pressed (pushed now and in the interval
        before) slide consistently, and their tracks may break (see
        :mod:`anonloc_env.identify.contact`)."""
        pushed = np.zeros(self.n, bool) if interval.push is None else interval.push > 0
        self._pushed_run = run = np.where(pushed, self._pushed_run + 1, 0)
        pressed = run >= 2
        model = self.model
        if model.crowd_push_share is None or not pressed.any():
            return interval
        assert self.rows is not None
        assert interval.push is not None
        log_rows = self._log_rows()
        t = self.tracks
        push = np.where(pressed, interval.push, 0.0)
        brk = model.contact_break
        break_tracks(t.logw, t.slot, self.uniform, self.unanchored, log_rows, push, brk)
        shares = (model.push_share, model.crowd_push_share)
        return pressed_interval(interval, run, *shares, model.crowd_jam, model.crowd_jam_tail)

    def _extend(
        self,
        rows: np.ndarray,
        interval: Interval,
        log_bg: float,
        view: OutOfView | None,
        log_unseen: float,
    ) -> tuple[list[Tracks], np.ndarray]:
        """The new picture's tracks (in parts) and each robot's "position unknown" weight
        (``view``: the footprint's misses, or None; ``log_unseen``: a robot of unknown
        position missed)."""
        model = self.model
        assert self.rows is not None
        prev = self.rows
        pix_var = self.pix_var = self._pixel_var(np.concatenate([prev, rows]))
        self.links = links_between(model, prev, rows, log_bg, pix_var, self.links)
        var_d, _ = interval.variances(model.odometry_noise)
        s_high = model.scale_bounds[1]
        # Reach of each robot in the image: its path at the largest scale plus the noise.
        sigma_max = np.sqrt(
            2 * pix_var + s_high**2 * var_d + (model.scale_spread * s_high * interval.path) ** 2
        )
        push = interval.push if interval.push is not None else 0.0
        travel = interval.path * (1 + GATE_SIGMAS * model.odometry_noise) + push
        reach = s_high * travel + GATE_SIGMAS * sigma_max
        radius = float(reach.max()) if len(reach) else 0.0
        i_pair, j_pair, dist = pairs_within(prev[:, :2], rows[:, :2], max(radius, 1e-9))
        pairs = Pairs(prev, rows, i_pair, j_pair, interval, pix_var, log_bg)
        prior = kernels.Prior(self.uniform, self.row_bias, self.links)
        build = Builder(self.scoring, prior, self.log_miss, self.fast, self._pooled())
        parts: list[Tracks] = []
        unanchored = self.unanchored + log_unseen  # unknown before, missed again

        # 1. Explicit tracks anchored at a row of the previous picture: candidate rows by pairs.
        tracks = self.tracks
        anchored = np.flatnonzero(tracks.row >= 0)
        if len(anchored):
            parts.append(build.anchored(tracks, anchored, pairs))
        # 2. Explicit tracks missed in the previous picture: candidates around their prediction.
        missed = np.flatnonzero(tracks.row < 0)
        if len(missed):
            parts.append(build.from_missed(tracks.take(missed), pairs, radius))
        # 4. The implicit uniform weight over previous rows: anchor it at every plausible pair
        # (computed before 3, which it helps prune; appended after it).
        live = np.flatnonzero(np.isfinite(self.uniform))
        anchored_uniform: list[Tracks] = []
        if len(live) and len(i_pair):
            # The tracks' children set a floor the uniform weight's must reach (see children).
            floor = self._prune_floor(parts) if parts else None
            anchored_uniform = build.from_uniform(live, pairs, dist, var_d, floor)
        # 3. Every explicit track may be missed in the new picture. A continuation more than
        # PRUNE_NATS below its robot's best child would be pruned at once: it is not built.
        if len(tracks):
            floor = self._prune_floor([*parts, *anchored_uniform])
            if view is not None:  # a track predicted out of view is missed at no cost
                tracks = view.tracks(tracks, interval, pix_var, radius)
            continued, lost_slot, lost_logw = build.missed(tracks, interval, pix_var, floor)
            if self.registration is not None:  # the frame moved while they went unseen
                continued.pos_var = self.registration.unseen(continued.pos_var)
            parts.append(continued)
            add_grouped(unanchored, lost_slot, lost_logw)
        parts.extend(anchored_uniform)
        if len(live):
            # ... or the robot was missed now: still at one of the previous rows, its own motion
            # carried (as many rows as a robot's tracks continued through a miss), or its
            # position is unknown again.
            if len(prev) <= MISSED_PER_ROBOT:
                missed_now = build.uniform_missed(live, prev, interval, pix_var)
                parts.append(missed_now if view is None else view.uniform_missed(missed_now))
            elif view is None:
                build.uniform_lost(live, len(prev), unanchored)
            else:  # the rows whose robot likely left the view keep a missed track
                leaving = view.leaving(live, prev, interval, pix_var)
                if len(leaving):
                    missed_now = build.uniform_missed(live, prev, interval, pix_var, leaving)
                    parts.append(view.uniform_missed(missed_now))
                view.uniform_lost(live, prev, interval, pix_var, prior, unanchored, leaving)
        return [p for p in parts if len(p)], unanchored

    def _pooled(self) -> Pool | None:
        """The pool, where the kernels are compiled (the numpy path allocates as it goes)."""
        return self.pool if self.fast and compiled.mode() is not None else None

    def _log_rows(self) -> float:
        """Log of the newest picture's rows' total weight in the uniform weight (their count,
        or the sum of their bias)."""
        n_rows = 0 if self.rows is None else len(self.rows)
        if n_rows and self.row_bias is not None:
            return float(np.logaddexp.reduce(self.row_bias))
        return math.log(n_rows) if n_rows else -np.inf

    def _prune_floor(self, parts: list[Tracks]) -> np.ndarray:
        """``(R,)`` :data:`PRUNE_NATS` below each robot's best track in ``parts`` (-inf: none)."""
        floor = np.full(self.n, -np.inf)
        for part in parts:
            if len(part):
                starts = group_starts(part.slot)
                top = np.maximum.reduceat(part.logw, starts)
                which = part.slot[starts]
                floor[which] = np.maximum(floor[which], top - PRUNE_NATS)
        return floor

    def _normalise_and_prune(self, parts: list[Tracks]) -> None:
        """Prune, sort and normalise the new tracks, ``parts`` one after the other (gathered
        once, in the final order: the parts are never concatenated)."""
        parts = [p for p in parts if len(p)]
        pool = self._pooled()
        if len(parts) == 1:
            slot, logw = parts[0].slot, parts[0].logw
        else:
            count = sum(len(p) for p in parts)
            slots = [np.zeros(0, np.int64)] + [p.slot for p in parts]  # none: an empty one
            slot = np.concatenate(slots, out=empty(pool, count, np.int64))
            logw = np.concatenate([np.zeros(0)] + [p.logw for p in parts], out=empty(pool, count))
        log_rows = self._log_rows()
        uniform_total = self.uniform + log_rows
        best = np.maximum(uniform_total, self.unanchored)
        # The fields are gathered once, in the final order (the same order either way).
        index = None
        if self.fast:
            index = fused_calls.pruned_order(slot, logw, best, self.max_tracks, pool)
        if index is None:  # numpy, or a robot the model ruled out
            index = self._pruned_order(parts, slot, logw, best)
        del slot, logw  # their blocks free again
        tracks = Tracks.gather(parts, index, pool)
        del index
        # Normalise each robot's weights to sum to one (``best[tracks.slot]`` and the like
        # taken into blocks of the pool: the same numbers as the expressions they spell out).
        sums = np.exp(uniform_total - best) + np.exp(self.unanchored - best)
        shifted = taken(best, tracks.slot, pool)
        np.subtract(tracks.logw, shifted, out=shifted)
        sums += np.bincount(tracks.slot, weights=np.exp(shifted, out=shifted), minlength=self.n)
        del shifted
        total = best + np.log(sums)
        logw = taken(total, tracks.slot, pool)
        tracks.logw = np.subtract(tracks.logw, logw, out=logw)  # tracks.logw - total[slot]
        self.uniform = self.uniform - total
        self.unanchored = self.unanchored - total
        # Implicit weights too small to matter stop costing anything.
        self.uniform[self.uniform + log_rows < -PRUNE_NATS] = -np.inf
        self.unanchored[self.unanchored < -PRUNE_NATS] = -np.inf
        self.tracks = tracks

    def _pruned_order(
        self, parts: list[Tracks], slot: np.ndarray, logw: np.ndarray, best: np.ndarray
    ) -> np.ndarray:
        """Which tracks ``slot``, ``logw`` (``parts`` one after the other) stay, in their final
        order: each robot's best (``best``, raised in place) less :data:`PRUNE_NATS` at most,
        sorted by robot, heaviest first, at most ``max_tracks`` per robot. A robot the model
        ruled out everywhere starts over (its ``unanchored`` weight reset)."""
        for part in parts:  # np.maximum.at(best, slot, logw), one item per run of a robot
            starts = group_starts(part.slot)
            np.maximum.at(best, part.slot[starts], np.maximum.reduceat(part.logw, starts))
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
        # robot's best), and cap the number of tracks per robot: keep the heaviest.
        order = np.argsort(slot * (2.0 * PRUNE_NATS + 2.0) + (best[slot] - logw), kind="stable")
        rank = rank_in_group(slot[order])
        if rank.max(initial=0) >= self.max_tracks:
            order = order[rank < self.max_tracks]
        return order if kept is None else kept[order]

    def _compute_belief(self) -> None:
        """Each robot's total weight and what each track's weight is of it; the ``(R, n)``
        table itself is filled when :meth:`belief` first asks for it."""
        tracks, pool = self.tracks, self._pooled()
        weights = np.exp(tracks.logw, out=empty(pool, len(tracks)))
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
        share = taken(total, slot, pool)
        share = np.divide(seen_w, share, out=share)  # seen_w / total[slot]
        self._shares = (slot, row, share, uniform / total, spread)
        self._flat_spread = self.row_bias is None  # every row of ``spread`` is one
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
            if self._flat_spread and self._pooled() is not None:  # the same sums, reused memory
                self._belief = self.pool.array((self.n, n_rows))
                fused.belief_table(slot, row, share, uniform, self._belief)
                return self._belief
            belief = np.bincount(
                slot * n_rows + row, weights=share, minlength=self.n * n_rows
            ).reshape(self.n, n_rows)
            belief = belief.astype(np.float64, copy=False)  # bincount of nothing is int64
            if uniform.any():
                if self._flat_spread:  # times one: the same sums, no (R, n) product built
                    belief += uniform[:, None]
                else:
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
