"""Reading observations: the newest picture, and each robot's own motion between pictures.

A localizer sees, at every step, what its robot observes and nothing else. :class:`OdometryLog`
turns the per-step own odometry into what the localizers need at each picture: an
``anonloc_env.odometry.Interval`` (displacement, heading change, distance rolled, the squares
of the per-step increments for the noise model, how far contacts may have pushed it, and the
command ``(v, w)`` the robot set at the interval's start).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from anonloc_env.config import EnvConfig
from anonloc_env.identify import SensorModel
from anonloc_env.odometry import Interval, IntervalStatistics


@dataclass(frozen=True)
class Step:
    """What a team of R robots (one env) observed at one step.

    Attributes:
        rows: ``(n, 3)`` rows ``(u, v, theta)`` of the newest picture (padding removed); read
            only at a new picture (empty otherwise).
        new_picture: whether that picture arrived at this step.
        odometry: ``(R, 3)`` own ``(dx, dy, dphi)`` since the newest picture.
        bumper: ``(R,)`` contact during this step.
        between: ``(R, 3)`` own motion from the previous picture to the newest (read only at a
            new picture; zeros otherwise).
        interval: time between the previous picture and the newest (s).
    """

    rows: np.ndarray
    new_picture: bool
    odometry: np.ndarray
    bumper: np.ndarray
    between: np.ndarray
    interval: float


@dataclass(frozen=True)
class BeliefView:
    """What the robots of a team believe at a new picture: all an excitation that reads beliefs
    (an active one, :mod:`baselines.active`) is told, handed over by the team after its
    localizer took the picture in.

    Attributes:
        rows: ``(n, 3)`` the picture's rows ``(u, v, theta)`` (image units, rad).
        belief: ``(R, n)`` each robot's probability for each row (the team localizer's).
        estimate: ``(R,)`` the row each robot believes is itself, -1 while undecided.
        model: the sensor model the localizer reasons with (noise, misses, scale bounds).
        interval: each robot's own motion since the previous picture (None at the first).
        config: the task as the robots know it (their limits, the picture interval, the reward's
            turn cost).
    """

    rows: np.ndarray
    belief: np.ndarray
    estimate: np.ndarray
    model: SensorModel
    interval: Interval | None
    config: EnvConfig


def read_step(observations: Sequence[Mapping[str, Any]]) -> Step:
    """Gather one step of R robots' observations (R >= 1, all of the same env and picture).

    Raises:
        ValueError: the observations do not show the same picture (they come from different
            envs), or a key is missing.
    """
    first = observations[0]
    n = len(observations)
    try:
        new_picture = bool(first["new_picture"][0] > 0.5)
        odometry = np.array([o["odometry"] for o in observations], dtype=np.float64)
        bumper = np.array([o["bumper"][0] for o in observations]) > 0.5
        if not new_picture:  # the picture and the interval only matter when they are new
            return Step(_NO_ROWS, False, odometry, bumper, np.zeros((n, 3)), 0.0)
        for other in observations[1:]:
            if other["detections"] is not first["detections"] and not np.array_equal(
                other["detections"], first["detections"]
            ):
                raise ValueError(
                    "a team's robots must share one env: their observations show different pictures"
                )
        detections = np.asarray(first["detections"])
        rows = detections[np.asarray(first["mask"]) > 0.5].astype(np.float64)
        between = np.array([o["odometry_between"] for o in observations], dtype=np.float64)
        interval = float(first["interval"][0])
    except KeyError as missing:
        raise ValueError(f"observation lacks the key {missing.args[0]!r}") from None
    return Step(rows, True, odometry, bumper, between, interval)


_NO_ROWS = np.zeros((0, 3))
_NO_ROWS.flags.writeable = False


class OdometryLog:
    """Accumulates each robot's own motion between pictures from its per-step odometry.

    Args:
        n: number of robots R.
        v_max: the robots' top speed (m/s), to bound what contacts do unseen.
        dt: the control step (s).
    """

    def __init__(self, n: int, v_max: float, dt: float) -> None:
        self.n = n
        self.stats = IntervalStatistics(n, v_max, dt)
        self.speed = np.zeros(n)
        """``(R,)`` forward speed commanded for the step under way (set by :meth:`command`)."""
        self.reset()

    def reset(self) -> None:
        """Forget the current interval."""
        self.last = np.zeros((self.n, 3))
        self.stats.clear()
        self.held: np.ndarray | None = None
        """``(R, 2)`` the command ``(v, w)`` set at the current interval's first step."""

    def command(self, v: np.ndarray, w: np.ndarray, speed: np.ndarray) -> None:
        """The robots' commands for the step under way: ``v`` (m/s) and ``w`` (rad/s) as the
        controller set them (the interval's first ones are kept for its ``Interval``), and
        ``speed`` ``(R,)`` the forward speed the env was sent (m/s, for the contact model)."""
        self.speed = speed
        if self.held is None:
            shape = (self.n,)
            self.held = np.column_stack(
                [np.broadcast_to(np.asarray(x, np.float64), shape) for x in (v, w)]
            )

    def _add(self, increment: np.ndarray, bumper: np.ndarray) -> None:
        if bumper.any():
            who = np.flatnonzero(bumper)
            self.stats.add_contacts(who, self.speed[who], self.last[who, 2])
        self.stats.add_step(np.hypot(increment[:, 0], increment[:, 1]), increment[:, 2].copy())

    def observe(self, step: Step) -> Interval | None:
        """Take in one step; return the interval that ended if a picture arrived."""
        if not step.new_picture:
            self._add(step.odometry - self.last, step.bumper)
            self.last = step.odometry
            return None
        # The last step before the picture is seen only through the whole interval's motion.
        self._add(step.between - self.last, step.bumper)
        interval = self.stats.interval(step.between[:, :2], step.between[:, 2], self.held)
        self.reset()
        self.last = step.odometry
        return interval
