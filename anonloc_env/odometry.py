"""Own-frame dead reckoning: what a robot knows of its own motion since the latest picture.

A robot integrates its wheel encoders in its own frame at the latest picture: after moving ``ds``
forward and turning ``dth`` (per physics sub-step),
``d += ds * (cos(phi), sin(phi))`` then ``phi += dth``, where ``phi`` is the heading change since
the picture. This is exactly how the physics integrates a unicycle over a sub-step, so without
noise the world displacement between two pictures equals ``R(theta_k) d`` to rounding error.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from anonloc_env import compiled
from anonloc_env.world import WheelTravel

_FLOAT64 = np.dtype(np.float64)
_NO_NORMALS = np.zeros((2, 0))  # what the compiled step reads without noise (nothing)


@dataclass(frozen=True)
class Interval:
    """Each robot's own motion between two consecutive pictures (arrays over R robots).

    Attributes:
        d: ``(R, 2)`` displacement in the robot's frame at the first picture (m).
        dphi: ``(R,)`` heading change (rad).
        path: ``(R,)`` distance rolled, sum of ``|ds|`` (m).
        sum_ds2: ``(R,)`` sum over control steps of the squared distance (m^2).
        sum_dth2: ``(R,)`` sum over control steps of the squared turn (rad^2).
        push: ``(R,)`` how far contacts may have moved the robot unseen by its wheels (m), the sum
            of a bound per control step in contact (see :func:`push_bound`); None: no contact.
        push_sum: ``(R, 2)`` those bounds times the robot's lateral direction at each contact,
            summed, in its frame at the first picture (wheels see forward motion, so what a
            contact adds unseen is sideways).
        command: ``(R, 2)`` the command ``(v, w)`` (m/s, rad/s) the robot's controller set at the
            interval's first control step, just after the first picture (an excitation that holds
            one command between pictures holds it throughout); None where the commands are not
            recorded (the env's own odometry). The paper's faithful angular and linear methods
            read it.
    """

    d: np.ndarray
    dphi: np.ndarray
    path: np.ndarray
    sum_ds2: np.ndarray
    sum_dth2: np.ndarray
    push: np.ndarray | None = None
    push_sum: np.ndarray | None = None
    command: np.ndarray | None = None

    @classmethod
    def exact(cls, d: np.ndarray, dphi: np.ndarray) -> Interval:
        """An interval known without odometry noise (path = straight distance)."""
        d = np.atleast_2d(np.asarray(d, dtype=np.float64))
        zeros = np.zeros(len(d))
        return cls(d, np.atleast_1d(np.asarray(dphi, float)), np.hypot(*d.T), zeros, zeros)

    def variances(self, noise: float) -> tuple[np.ndarray, np.ndarray]:
        """``(var_d, var_dphi)``: variance of each component of ``d`` (m^2) and of ``dphi``.

        Per-step multiplicative noise ``noise`` on distance and turn: the distance errors add
        ``noise^2 sum ds^2``; heading errors accumulated along the path swing the displacement by
        about ``path^2 noise^2 sum dth^2 / 3``; split evenly over the two components. Contacts are
        in :meth:`push_covariance`.
        """
        # Computed once per noise (the identifier asks about eight times a picture) and kept
        # beside the fields, not as one (copies made field by field recompute them): read-only
        # arrays, shared by the callers.
        known: dict[float, tuple[np.ndarray, np.ndarray]] = self.__dict__.setdefault(
            "_variances", {}
        )
        cached = known.get(noise)
        if cached is not None:
            return cached
        var_dphi = noise**2 * self.sum_dth2
        var_d = noise**2 * (self.sum_ds2 + self.path**2 * self.sum_dth2 / 3.0) / 2.0
        if isinstance(var_d, np.ndarray) and isinstance(var_dphi, np.ndarray):
            var_d.flags.writeable = False
            var_dphi.flags.writeable = False
            known[noise] = (var_d, var_dphi)
        return var_d, var_dphi

    def push_covariance(self) -> np.ndarray:
        """``(R, 2, 2)`` covariance (m^2, robot frame at the first picture) of what contacts may
        have moved the robot unseen: ``S S^T / 3`` along the summed lateral direction ``S``
        (a slide along a wall adds up in one direction), plus ``(P^2 - |S|^2) / 6`` in every
        direction for pushes that point different ways (``P`` = :attr:`push`). Computed once
        (the identifier asks several times a picture), read-only, as :meth:`variances`."""
        cached = self.__dict__.get("_push_covariance")
        if cached is not None:
            return cached
        n = len(self.d)
        if self.push is None or self.push_sum is None:
            cov = np.zeros((n, 2, 2))
        else:
            s = self.push_sum
            spread = np.maximum(self.push**2 - (s**2).sum(axis=1), 0.0) / 6.0
            cov = s[:, :, None] * s[:, None, :] / 3.0 + spread[:, None, None] * np.eye(2)
        cov.flags.writeable = False
        self.__dict__["_push_covariance"] = cov
        return cov

    @property
    def reach(self) -> np.ndarray:
        """``(R,)`` farthest the robot may be from where it started (m): path plus pushes."""
        return self.path + (self.push if self.push is not None else 0.0)


def push_bound(speed: np.ndarray, v_max: float, dt: float) -> np.ndarray:
    """How far a contact may move a robot sideways in one control step (m): its own commanded
    distance (a robot sliding along a wall moves at most that far) plus a quarter of the fastest
    any robot drives (others may shove it)."""
    return (np.abs(speed) + 0.25 * v_max) * dt


def lateral(phi: np.ndarray) -> np.ndarray:
    """``(R, 2)`` unit vectors to the robots' left, in their frame at the last picture, for
    heading changes ``phi`` since that picture."""
    return np.column_stack([-np.sin(phi), np.cos(phi)])


class IntervalStatistics:
    """What the likelihood model needs to know about an interval besides its displacement:
    distance rolled, squared per-step increments, and the contacts' sideways bound. Used by the
    env (for its reward) and by the policies (from their own observations) alike.

    Args:
        n: number of robots.
        v_max: the robots' top speed (m/s), for :func:`push_bound`.
        dt: the control step (s).
    """

    def __init__(self, n: int, v_max: float, dt: float) -> None:
        self.n, self.v_max, self.dt = n, v_max, dt
        self.clear()

    def clear(self) -> None:
        """Start a new interval."""
        # One array, so that the compiled steps (compiled.interval_step, compiled.integrate)
        # take it in one piece.
        self.sums = np.zeros((4, self.n))
        """``(4, N)`` the rows ``path``, ``sum_ds2``, ``sum_dth2`` and ``push`` (views of it)."""
        self.path, self.sum_ds2, self.sum_dth2, self.push = self.sums
        self.push_sum = np.zeros((self.n, 2))
        self.contacts = False

    def add_motion(
        self, before: np.ndarray, now: np.ndarray, bumper: np.ndarray, speed: np.ndarray
    ) -> None:
        """One control step from the robots' own odometry: ``(R, 3)`` ``(dx, dy, dphi)`` since
        the last picture ``before`` and ``now`` the step, contacts ``bumper`` ``(R,)`` during it
        at commanded ``speed`` ``(R,)`` (m/s)."""
        if (
            bumper.dtype == np.bool_
            and before.dtype == _FLOAT64
            and now.dtype == _FLOAT64
            and speed.dtype == _FLOAT64
            and compiled.mode() is not None
        ):  # the same floats, one call
            bounds = np.array([self.v_max, self.dt])
            sums, push_sum = self.sums, self.push_sum
            if compiled.interval_step(before, now, bumper, speed, bounds, sums, push_sum):
                self.contacts = True
            return
        increment = now - before
        if bumper.any():
            who = np.flatnonzero(bumper)
            self.add_contacts(who, speed[who], before[who, 2])
        self.add_step(np.hypot(increment[:, 0], increment[:, 1]), increment[:, 2].copy())

    def add_step(self, distance: np.ndarray, turn: np.ndarray) -> None:
        """One control step: ``distance`` rolled (>= 0) and ``turn`` (rad), both ``(N,)``;
        the arrays are consumed (squared in place)."""
        self.path += distance
        distance *= distance
        self.sum_ds2 += distance
        turn *= turn
        self.sum_dth2 += turn

    def add_contacts(self, who: np.ndarray, speed: np.ndarray, phi: np.ndarray) -> None:
        """Robots ``who`` were in contact during a step, commanded at ``speed`` (m/s, theirs),
        at heading ``phi`` (rad) relative to the interval's start."""
        bound = push_bound(speed, self.v_max, self.dt)
        self.push[who] += bound
        self.push_sum[who] += bound[:, None] * lateral(phi)
        self.contacts = True

    def interval(
        self, d: np.ndarray, dphi: np.ndarray, command: np.ndarray | None = None
    ) -> Interval:
        """The interval that ended with displacement ``d`` ``(N, 2)`` and turn ``dphi``;
        ``command`` ``(N, 2)``: the ``(v, w)`` set at its first step, if recorded."""
        return Interval(
            d=np.array(d, dtype=np.float64),
            dphi=np.array(dphi, dtype=np.float64),
            path=self.path.copy(),
            sum_ds2=self.sum_ds2.copy(),
            sum_dth2=self.sum_dth2.copy(),
            push=self.push.copy() if self.contacts else None,
            push_sum=self.push_sum.copy() if self.contacts else None,
            command=command,
        )


class Odometry:
    """Dead reckoning of N robots at once, reset at each picture.

    Args:
        n: number of robots.
        noise: standard deviation of the multiplicative error on each control step's distance and
            turn (``RobotConfig.odometry_noise``).
    """

    def __init__(
        self, n: int, noise: float, v_max: float = 0.0, dt: float = 0.0, statistics: bool = True
    ) -> None:
        self.n = n
        self.noise = noise
        self.v_max = v_max
        self.dt = dt
        self.statistics = statistics
        """Whether to keep the per-interval statistics (path, squared increments, contacts) that
        the likelihood model needs; without them intervals report the straight distance."""
        self.since_picture = np.zeros((n, 3))
        """``(N, 3)`` own-frame ``(dx, dy, dphi)`` since the latest picture (m, m, rad)."""
        self.stats = IntervalStatistics(n, v_max, dt)

    def integrate(self, motion: WheelTravel, rng: np.random.Generator, speed: np.ndarray) -> None:
        """Add one control step of wheel motion (with noise drawn from ``rng`` if any);
        ``speed`` ``(N,)`` is the commanded forward speed (m/s), for the contact bound."""
        stats = self.statistics
        if stats and motion.contact.any():
            who = np.flatnonzero(motion.contact)
            self.stats.add_contacts(who, speed[who], self.since_picture[who, 2])
        noisy = self.noise > 0.0
        odo = self.since_picture
        if compiled.mode() is not None:  # the same floats in one call, add_step's included
            normals = rng.standard_normal((2, self.n)) if noisy else _NO_NORMALS
            sums = self.stats.sums
            compiled.integrate(
                odo, motion.forward, motion.turned, normals, self.noise, noisy, sums, stats
            )
            return
        if noisy:
            distance_factor, turn_factor = 1.0 + self.noise * rng.standard_normal((2, self.n))
        x, y, phi = odo[:, 0], odo[:, 1], odo[:, 2]  # column views, updated in place
        if stats:
            step_ds = np.zeros(self.n)  # this control step's distance and turn, all sub-steps
            step_dth = np.zeros(self.n)
        for ds, dth in zip(motion.forward, motion.turned, strict=True):
            if noisy:
                ds = ds * distance_factor
                dth = dth * turn_factor
            if stats:
                step_ds += np.abs(ds)
                step_dth += dth
            dx = np.cos(phi)
            dx *= ds
            dy = np.sin(phi)
            dy *= ds
            x += dx
            y += dy
            phi += dth
        if stats:
            self.stats.add_step(step_ds, step_dth)

    def mark_picture(self) -> Interval:
        """Start a new interval at a picture; return the one just ended."""
        ended = self.since_picture
        if not self.statistics:
            self.since_picture = np.zeros((self.n, 3))
            return Interval.exact(ended[:, :2], ended[:, 2])
        interval = self.stats.interval(ended[:, :2], ended[:, 2])
        self.since_picture = np.zeros((self.n, 3))
        self.stats.clear()
        return interval
