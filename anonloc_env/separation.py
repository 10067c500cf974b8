"""Position correction: pushes overlapping robots apart after every physics sub-step (numpy).

pymunk's contacts are soft. Its solver runs a fixed number of iterations and frictionless squares
wedged in a crowd defeat it (with 300 iterations, 100 robots driven into a corner still overlapped
by two thirds of a size); a robot's turn is not solved at all (bodies have infinite moment), so a
square turning in a crowd sweeps its corners into its neighbours; and a contact that starts during
a sub-step is only seen at the next one. This pass removes what is left, as position-based dynamics
does: Jacobi projections, each moving both robots of every overlapping pair apart by half their
overlap along the separating axis, with the walls as immovable limits (the arena clamp after every
projection), repeated until no pair overlaps by more than :data:`STOP_OVERLAP` of the size (at most
:data:`MAX_PROJECTIONS` times). pymunk's own position correction is switched off (it would correct
the same overlap a second time, a sub-step later, and push robots into their other neighbours); its
solver still stops robots at their contacts.

Candidate pairs come from a Verlet neighbour list, not from pymunk: every pair of robots whose
centres were within ``2 * radius + skin`` when the list was built (a numpy grid search,
:func:`pairs_within_self`). While no robot has moved more than ``skin / 2`` since then, every
pair that can overlap (centres closer than ``2 * radius``: the circles around the shapes meet) is
on the list; a robot that may have moved further triggers a rebuild, every 7 to 10 sub-steps with
random actions. Each sub-step computes every listed pair's exact overlap in one pass of about
twenty numpy calls and returns when none exceeds the stop (most sub-steps). Otherwise the pairs
that overlap or miss by less than :data:`CLOSE_MARGIN` are projected; if a projection moved a
robot further than half that margin, it may have pushed it into a pair left out, and the list is
consulted again.

Positions are complex numbers ``x + iy`` (a view of the world's state array) and headings unit
complex numbers ``e = exp(i theta)``: the coordinates of a centre offset ``d`` in robot k's frame
are ``d * conj(e_k)``. Two squares of the same size reach equally far on all four edge normals,
``h * (1 + |cos a| + |sin a|)`` with ``h`` the half size and ``a`` the difference of headings,
so by the separating-axis theorem they overlap by that reach minus the largest of the four
coordinates of ``d``, along that coordinate's axis. Projections move robots without turning
them, so the axes and the reach are computed once per pass.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import partial

import numpy as np
import pymunk

from anonloc_env import compiled
from anonloc_env.config import RobotConfig
from anonloc_env.neighbours import expand_ranges

#: Overlap (fraction of the size) that a projection leaves between two robots: a contact that
#: pymunk still sees, so that its solver keeps stopping the robots there.
ALLOWED_OVERLAP = 0.01
#: The projections stop once no pair overlaps by more than this (fraction of the size).
STOP_OVERLAP = 0.03
#: Most projections per sub-step (a bound on the cost of a crowd jammed into a corner).
MAX_PROJECTIONS = 100
#: How far (fraction of the size) beyond the circles around two robots the neighbour list
#: reaches: the list is rebuilt once a robot has moved half of it.
SKIN = 1.0
#: How far (fraction of the size) two robots may miss each other and still be projected.
CLOSE_MARGIN = 0.1
#: The largest element of an array (``ndarray.max`` goes through a Python wrapper first).
_MAX = np.maximum.reduce
#: The shape filter of robots and walls (they collide with each other).
SOLID = pymunk.ShapeFilter(categories=0b01, mask=0b01)


class Separator:
    """Finds the robots that may overlap and pushes them apart.

    Args:
        robot: the robots' shape and size.
        n: the number of robots.
    """

    def __init__(self, robot: RobotConfig, n: int) -> None:
        self.n = n
        self.square = robot.shape == "square"
        self.size = robot.size
        self.half = robot.size / 2.0
        self.allowed = ALLOWED_OVERLAP * robot.size
        self.stop = np.float64((STOP_OVERLAP - ALLOWED_OVERLAP) * robot.size)
        # The pairs that overlap, or miss by less than a margin, are projected: a projection
        # that moves no robot further than half the margin cannot push one into a pair left
        # out (along any axis, the pair's centres get at most the margin closer).
        self._margin = np.float64(-CLOSE_MARGIN * robot.size)
        # The neighbour list holds every pair whose circles around the shapes were closer than
        # the skin: until a robot has moved half the skin, no other pair can even touch.
        meet = 2.0 * robot.radius if self.square else robot.size
        self._list_reach = meet + SKIN * robot.size
        # Moves along each axis small enough that no robot moved further than half the skin
        # (or the margin): a sufficient test that needs no square root.
        self._stale = np.float64(SKIN * robot.size / 2.0 / math.sqrt(2.0))
        self._drift = np.float64(CLOSE_MARGIN * robot.size / 2.0 / math.sqrt(2.0))
        self._anchor: np.ndarray | None = None  # positions (x + iy) when the list was built
        self._anchor_xy = np.zeros((n, 2))  # the same as (N, 2) rows (x, y)
        # The compiled pass's bounds (compiled.separate).
        self._params = np.array(
            [self.half, self.allowed, self.stop, self._margin, self._stale, self._drift]
        )
        self._pairs = np.zeros((0, 2), dtype=np.intp)
        self.rebuilds = 0
        """How many times the neighbour list was built."""

    def neighbours(self, z: np.ndarray) -> np.ndarray:
        """The neighbour list: ``(P, 2)`` rows ``(i, j)``, ``i < j``, rebuilt first if a robot
        moved too far since it was built; ``z`` are the positions ``x + iy``."""
        anchor = self._anchor
        if anchor is None or not _moved(z, anchor) <= self._stale:
            self._pairs = pairs_within_self(z, self._list_reach)
            self._anchor = z.copy()
            self._anchor_xy = self._anchor.view(np.float64).reshape(-1, 2)
            self.rebuilds += 1
        return self._pairs

    def first_pass(self) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """What :func:`anonloc_env.compiled.substep` needs to make the compiled correction's
        first pass itself (the neighbour list, where it was built, the bounds): None for
        circles, or when the list must be built first (go through :meth:`separate_compiled`)."""
        if not self.square or self._anchor is None:
            return None
        return self._pairs, self._anchor_xy, self._params

    def separate_compiled(
        self,
        state: np.ndarray,
        heading: np.ndarray,
        low: np.ndarray,
        high: np.ndarray,
        fused: bool,
        first: int = 0,
    ) -> None:
        """:meth:`separate` through :func:`anonloc_env.compiled.separate` (same floats) for
        the positions in the first two columns of ``state`` ``(N + 1, 7)``, clamped to
        ``low``/``high`` as ``World._clamp_to_arena`` does; circles go through :meth:`separate`.
        ``first``: the answer of a first pass already made (``compiled.substep``'s, not 0),
        which this call goes on from."""
        if not self.square:
            xy = state[: self.n, :2]
            clamp = partial(_clamp, xy, low, high)
            self.separate(xy, heading, clamp)
            return
        left, check = MAX_PROJECTIONS, True
        if first < 0:  # the first pass found the list stale
            self._anchor = None
        left -= max(first, 0)
        while left > 0:
            if self._anchor is None:
                self.neighbours(state[: self.n, :2].view(np.complex128)[:, 0])
                check = False
            done = compiled.separate(
                state, self.n, heading, self._pairs, self._anchor_xy, low, high,
                self._params, left, fused, check,
            )  # fmt: skip
            if done < 0:  # the list is stale
                self._anchor = None
                continue
            if done == 0:
                return
            left -= done
            check = True

    def separate(self, xy: np.ndarray, heading: np.ndarray, clamp: Callable[[], None]) -> None:
        """Push overlapping robots apart in place, keeping them inside the arena.

        Args:
            xy: ``(N, 2)`` float64 positions (m) whose rows are contiguous (a view of the
                world's state is fine), changed in place.
            heading: ``(N,)`` unit headings ``exp(i theta)`` (complex), unchanged.
            clamp: keeps the positions inside the arena (in place); called after every
                projection that moved a robot, so the walls do not give way.
        """
        z = xy.view(np.complex128)[:, 0]  # x + iy, writing into xy
        left = MAX_PROJECTIONS
        while left > 0:
            pairs = self.neighbours(z)
            if len(pairs) == 0:
                return
            frames = heading[pairs].conj() if self.square else None
            limit = self._limit(frames)
            push = limit - self._extent(z, pairs, frames)[0]
            if not _MAX(push) > self.stop:
                return  # most sub-steps end here
            near = push > self._margin
            if frames is not None and isinstance(limit, np.ndarray):  # squares
                frames, limit = frames[near], limit[near]
            start = z.copy()
            done = self._project(z, pairs[near], frames, limit, clamp, left)
            if _moved(z, start) <= self._drift:
                return  # every pair that can overlap was among those projected
            left -= done

    def _limit(self, frames: np.ndarray | None) -> np.ndarray | np.float64:
        """What each pair may reach into the other before it is pushed: for squares ``h (1 +
        |cos a| + |sin a|)`` (``a`` the difference of headings, from the pairs' ``(P, 2)``
        conjugate headings ``frames``) less the allowed overlap."""
        if frames is None:
            return np.float64(self.size - self.allowed)
        twist = frames[:, 0] * frames[:, 1].conj()  # exp(i (theta_j - theta_i))
        both = np.abs(twist.view(np.float64)).reshape(-1, 2)
        reach = both[:, 0] + both[:, 1]
        reach *= self.half
        reach += self.half - self.allowed
        return reach

    def _extent(
        self, z: np.ndarray, pairs: np.ndarray, frames: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """How far apart each pair's centres are along its separating axes: the largest, the
        coordinates (``(P, 4)``: the offset in both frames) and their sizes (circles: the
        distance, the offset ``(P,)`` complex and the distance again)."""
        ends = z[pairs]
        d = ends[:, 1] - ends[:, 0]
        if frames is None:
            dist = np.abs(d)
            return dist, d, dist
        coords = (d[:, None] * frames).view(np.float64)  # (P, 4)
        extent = np.abs(coords)
        # Two elementwise maxima: a reduction along a short axis costs more than the work.
        wider = np.maximum(extent[:, :2], extent[:, 2:])
        return np.maximum(wider[:, 0], wider[:, 1]), coords, extent

    def _project(
        self,
        z: np.ndarray,
        pairs: np.ndarray,
        frames: np.ndarray | None,
        limit: np.ndarray | np.float64,
        clamp: Callable[[], None],
        most: int,
    ) -> int:
        """Up to ``most`` projections of ``pairs`` (rows ``(i, j)``; their conjugate headings
        ``frames`` and reach ``limit``), until none overlaps by more than the stop; returns how
        many were made."""
        rows = np.arange(len(pairs))
        # Real and imaginary parts of the moves of i, then of j, summed per robot in one
        # bincount over the interleaved coordinates.
        slots = pairs.T.ravel() * 2
        slots = np.column_stack((slots, slots + 1)).ravel()
        if frames is not None:
            # The four edge normals of each pair: e_i, i e_i, e_j, i e_j.
            axes = np.repeat(frames.conj(), 2, axis=1)
            axes[:, 1::2] *= 1j
        for done in range(most):
            largest, coords, extent = self._extent(z, pairs, frames)
            push = limit - largest
            if not _MAX(push) > self.stop:
                return done
            if frames is not None:
                best = extent.argmax(axis=1)
                along = coords[rows, best]
                normal = axes[rows, best] * np.where(along < 0.0, -0.5, 0.5)
            else:
                normal = np.where(extent > 0.0, coords / np.where(extent > 0.0, extent, 1.0), 1.0)
                normal *= 0.5
            # Each robot moves half the excess overlap of every pair it is in, j along the
            # normal (which points from i to j), i against it.
            move = np.maximum(push, 0.0) * normal
            moves = np.concatenate((-move, move)).view(np.float64)
            z += np.bincount(slots, moves, 2 * self.n).view(np.complex128)
            clamp()
        return most


def pairs_within_self(z: np.ndarray, radius: float) -> np.ndarray:
    """Every pair of points ``z`` (``x + iy``) at most ``radius`` apart, once: ``(P, 2)`` rows
    ``(i, j)`` with ``i < j``, in an order that depends on the points alone.

    A uniform grid with cells ``radius`` wide, as :func:`anonloc_env.neighbours.pairs_within`,
    but each point looks only forward (the rest of its own cell, the cell above, and the three
    cells of the next column: two ranges of consecutive keys), so each pair is found once.
    """
    n = len(z)
    if n < 2:
        return np.zeros((0, 2), dtype=np.intp)
    if compiled.mode() is not None:  # the same pairs in the same order, one call
        pairs, unsure = compiled.forward_pairs(np.stack((z.real, z.imag), 1), float(radius))
        if len(unsure):  # within a millionth of the radius: numpy's modulus decides
            far = np.abs(z[pairs[unsure, 1]] - z[pairs[unsure, 0]]) > radius
            pairs = np.delete(pairs, unsure[far], axis=0)
        return pairs.astype(np.intp, copy=False)
    x, y = z.real, z.imag
    column = np.floor((x - x.min()) / radius).astype(np.intp)
    row = np.floor((y - y.min()) / radius).astype(np.intp) + 1  # a free row below the lowest
    stride = int(row.max()) + 2  # and one above the highest
    key = column * stride + row
    order = np.argsort(key, kind="stable")
    keys = key[order]
    position = np.arange(n)
    # Same column: the points after this one in sorted order, up to the end of the cell above.
    same_end = np.searchsorted(keys, keys + 1, side="right")
    # Next column: the cells beside, below-beside and above-beside.
    next_start = np.searchsorted(keys, keys + (stride - 1), side="left")
    next_end = np.searchsorted(keys, keys + (stride + 1), side="right")
    starts = np.concatenate((position + 1, next_start))
    counts = np.concatenate((same_end - position - 1, next_end - next_start))
    first = np.repeat(np.concatenate((order, order)), counts)
    second = order[expand_ranges(starts, counts)]
    near = np.abs(z[second] - z[first]) <= radius
    first, second = first[near], second[near]
    return np.column_stack((np.minimum(first, second), np.maximum(first, second)))


def _clamp(xy: np.ndarray, low: np.ndarray, high: np.ndarray) -> None:
    """Positions ``xy`` ``(N, 2)`` clamped in place to ``low`` ``(N, 1)`` and ``high``."""
    np.maximum(xy, low, out=xy)
    np.minimum(xy, high, out=xy)


def _moved(z: np.ndarray, before: np.ndarray) -> np.float64:
    """The largest move of a robot along either axis from ``before`` to ``z`` (both ``x + iy``)."""
    return _MAX(np.abs((z - before).view(np.float64)))
