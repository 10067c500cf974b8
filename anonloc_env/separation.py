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

Candidate pairs come from pymunk's broad phase, not from a numpy neighbour search (which costs
more than the whole step): every robot carries a *sensor* shape, the circle around its shape
grown by a margin, that only meets other sensors. Sensors push nothing, but pymunk keeps an
arbiter for every pair of sensors that touch, and ``pymunk.batch`` reads those pairs in one C
call. The margin covers what two robots can move towards each other in one sub-step, so every
pair that can overlap after the move is a candidate.

Positions are complex numbers ``x + iy`` (a view of the world's state array) and headings unit
complex numbers ``e = exp(i theta)``: the coordinates of a centre offset ``d`` in robot k's frame
are ``d * conj(e_k)``. Two squares of the same size reach equally far on all four edge normals,
``h * (1 + |cos a| + |sin a|)`` with ``h`` the half size and ``a`` the difference of headings,
so by the separating-axis theorem they overlap by that reach minus the largest of the four
coordinates of ``d``, along that coordinate's axis. Projections move robots without turning
them, so the axes and the reach are computed once per sub-step.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pymunk
import pymunk.batch as pmb

from anonloc_env.config import RobotConfig

#: Overlap (fraction of the size) that a projection leaves between two robots: a contact that
#: pymunk still sees, so that its solver keeps stopping the robots there.
ALLOWED_OVERLAP = 0.01
#: The projections stop once no pair overlaps by more than this (fraction of the size).
STOP_OVERLAP = 0.03
#: Most projections per sub-step (a bound on the cost of a crowd jammed into a corner).
MAX_PROJECTIONS = 100
#: Shape filters: robots and walls collide with each other, sensors only with sensors.
SOLID = pymunk.ShapeFilter(categories=0b01, mask=0b01)
SENSOR = pymunk.ShapeFilter(categories=0b10, mask=0b10)
_PAIR_FIELDS = pmb.ArbiterFields.BODY_A_ID | pmb.ArbiterFields.BODY_B_ID
_NO_PAIRS = np.zeros((0, 2), dtype=np.intp)


class Separator:
    """Finds the robots that may overlap and pushes them apart.

    Args:
        space: the pymunk space; one sensor shape per robot is added to it.
        bodies: the robots' bodies, in the order of the pose rows.
        robot: the robots' shape and size.
        margin: how far (m) each sensor reaches beyond its robot; at least what a robot can move
            in one sub-step (its corners included), so that no new contact is missed.
    """

    def __init__(
        self, space: pymunk.Space, bodies: list[pymunk.Body], robot: RobotConfig, margin: float
    ) -> None:
        self.space = space
        self.n = len(bodies)
        self.square = robot.shape == "square"
        self.size = robot.size
        self.half = robot.size / 2.0
        self.allowed = ALLOWED_OVERLAP * robot.size
        self.stop = (STOP_OVERLAP - ALLOWED_OVERLAP) * robot.size
        for body in bodies:
            # A circle around the robot's shape: a superset of its grown shape, and the cheapest
            # collision test pymunk has.
            sensor = pymunk.Circle(body, robot.radius + margin)
            sensor.sensor = True
            sensor.filter = SENSOR
            space.add(sensor)
        # Body ids (addresses) to rows, the static body (walls) to row n.
        ids = np.array([b.id for b in bodies] + [space.static_body.id], dtype=np.uintp)
        order = np.argsort(ids)
        self._sorted_ids = ids[order]
        self._static_id = ids[-1]
        self._rows = order
        self._buffer = pmb.Buffer()

    def candidates(self) -> np.ndarray:
        """``(P, 2)`` rows ``(i, j)``, ``i < j``: every pair of robots whose sensors touch, once."""
        buffer = self._buffer
        buffer.clear()
        pmb.get_space_arbiters(self.space, _PAIR_FIELDS, buffer)
        ids = np.frombuffer(buffer.int_buf(), dtype=np.uintp)
        if np.count_nonzero(ids == self._static_id) * 2 == ids.size:  # none, or walls only
            return _NO_PAIRS
        pairs = self._rows[np.searchsorted(self._sorted_ids, ids)].reshape(-1, 2)
        pairs.sort(axis=1)
        # Robot-wall pairs (row n) go; a pair touching with its solid shapes has a second
        # arbiter besides its sensors': keep one of each (sorted keys, repeats dropped).
        pairs = pairs[pairs[:, 1] < self.n]
        key = pairs[:, 0] * self.n
        key += pairs[:, 1]
        key.sort()
        first = np.empty(key.size, dtype=bool)
        first[:1] = True
        np.not_equal(key[1:], key[:-1], out=first[1:])
        return np.column_stack(np.divmod(key[first], self.n))

    def separate(self, xy: np.ndarray, theta: np.ndarray, clamp: Callable[[], None]) -> None:
        """Push overlapping robots apart in place, keeping them inside the arena.

        Args:
            xy: ``(N, 2)`` float64 positions (m) whose rows are contiguous (a view of the
                world's state is fine), changed in place.
            theta: ``(N,)`` headings (rad), unchanged.
            clamp: keeps the positions inside the arena (in place); called after every
                projection that moved a robot, so the walls do not give way.
        """
        pairs = self.candidates()
        if len(pairs) == 0:
            return
        z = xy.view(np.complex128)[:, 0]  # x + iy, writing into xy
        i, j = pairs[:, 0], pairs[:, 1]
        if self.square:
            heading = np.exp(1j * theta[pairs])  # (P, 2)
            frames = heading.conj()
            twist = heading[:, 1] * frames[:, 0]  # exp(i (theta_j - theta_i))
            # What the pair may overlap before it is pushed: its reach less the allowed overlap.
            limit = self.half * (1.0 + np.abs(twist.real) + np.abs(twist.imag)) - self.allowed
        else:
            limit = np.float64(self.size - self.allowed)
        rows = None  # the projections' arrays, built at the first one (most sub-steps need none)
        for _ in range(MAX_PROJECTIONS):
            d = z[j] - z[i]
            if self.square:
                coords = (d[:, None] * frames).view(np.float64)  # (P, 4): d in both frames
                extent = np.abs(coords)
                push = limit - extent.max(axis=1)
            else:
                dist = np.abs(d)
                push = limit - dist
            if not push.max() > self.stop:
                return
            if rows is None:
                n, rows, flat = self.n, np.arange(len(pairs)), pairs.T.ravel()
                if self.square:
                    # The four edge normals of each pair: e_i, i e_i, e_j, i e_j.
                    axes = np.repeat(heading, 2, axis=1)
                    axes[:, 1::2] *= 1j
            if self.square:
                best = extent.argmax(axis=1)
                along = coords[rows, best]
                normal = axes[rows, best] * np.where(along < 0.0, -1.0, 1.0)
            else:
                normal = np.where(dist > 0.0, d / np.where(dist > 0.0, dist, 1.0), 1.0)
            # Each robot moves half the excess overlap of every pair it is in, j along the
            # normal (which points from i to j), i against it.
            move = np.maximum(push, 0.0) * 0.5 * normal
            weights = np.concatenate([-move, move])
            z += np.bincount(flat, weights.real, n) + 1j * np.bincount(flat, weights.imag, n)
            clamp()
