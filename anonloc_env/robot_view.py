"""What the robots observed, read back: the newest picture's rows and each robot's own motion
between pictures.

A robot sees, at every step, what its observation holds and nothing else. :func:`read_step`
gathers one step of R robots' observations into a :class:`Step`; :class:`OdometryLog` turns the
per-step own odometry into what the identifier needs at each picture: an
:class:`~anonloc_env.odometry.Interval` (displacement, heading change, distance rolled, the
squares of the per-step increments for the noise model, how far contacts may have pushed it, and
the command ``(v, w)`` set at the interval's start). The policies of ``baselines`` read their
observations so, and the env's default reward reads the very same arrays (see
:class:`anonloc_env.rewards.InformationGain`), so the two agree to the bit.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

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
        footprint: ``(4, 2)`` the newest picture's field of view in the frame of ``rows``, where
            the observations carry it (a moving camera with ground landmarks; float64 of the
            float32 observed), else ``None``; read only at a new picture.
    """

    rows: np.ndarray
    new_picture: bool
    odometry: np.ndarray
    bumper: np.ndarray
    between: np.ndarray
    interval: float
    footprint: np.ndarray | None = None


def read_step(observations: Sequence[Mapping[str, Any]]) -> Step:
    """Gather one step of R robots' observations (R >= 1, all of the same env and picture).

    Raises:
        ValueError: the observations do not show the same picture (they come from different
            envs), or a key is missing.
    """
    first = observations[0]
    try:
        new_picture = bool(first["new_picture"][0] > 0.5)
        odometry = np.array([o["odometry"] for o in observations], dtype=np.float64)
        bumper = np.array([o["bumper"][0] for o in observations]) > 0.5
        if not new_picture:  # the picture and the interval only matter when they are new
            return gather_step(False, odometry, bumper)
        for other in observations[1:]:
            if other["detections"] is not first["detections"] and not np.array_equal(
                other["detections"], first["detections"]
            ):
                raise ValueError(
                    "a team's robots must share one env: their observations show different pictures"
                )
        between = np.array([o["odometry_between"] for o in observations], dtype=np.float64)
        return gather_step(
            True,
            odometry,
            bumper,
            first["detections"],
            first["mask"],
            between,
            float(first["interval"][0]),
            first.get("footprint"),
        )
    except KeyError as missing:
        raise ValueError(f"observation lacks the key {missing.args[0]!r}") from None


def gather_step(
    new_picture: bool,
    odometry: np.ndarray,
    bumper: np.ndarray,
    detections: np.ndarray | None = None,
    mask: np.ndarray | None = None,
    between: np.ndarray | None = None,
    interval: float = 0.0,
    footprint: np.ndarray | None = None,
) -> Step:
    """The :class:`Step` of R robots from their observation's arrays, stacked in robot order:
    ``odometry`` ``(R, 3)`` float64 (of the float32 observed), ``bumper`` ``(R,)`` bool, and at a
    new picture its ``detections`` ``(D, 3)`` and ``mask`` ``(D,)`` (float32, as observed),
    ``between`` ``(R, 3)`` float64, the ``interval`` (s) and, where observed, the picture's
    ``footprint`` ``(4, 2)`` (float64 of the float32). :func:`read_step` (from the robots'
    observation dicts) and the env (from the arrays it builds them from) both come here, so the
    two give the same bits."""
    if not new_picture:
        return Step(_NO_ROWS, False, odometry, bumper, np.zeros((len(odometry), 3)), 0.0)
    assert detections is not None
    assert mask is not None
    assert between is not None
    rows = np.asarray(detections)[np.asarray(mask) > 0.5].astype(np.float64)
    seen_footprint = None if footprint is None else np.asarray(footprint, np.float64)
    return Step(rows, True, odometry, bumper, between, interval, seen_footprint)


def seen_rows(detections: np.ndarray) -> np.ndarray:
    """A picture's rows as the robots observe them (float32, as in their observations), in
    float64: what :func:`read_step` gives for that picture."""
    return np.asarray(detections, dtype=np.float32).astype(np.float64)


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

    def observe(self, step: Step) -> Interval | None:
        """Take in one step; return the interval that ended if a picture arrived."""
        if not step.new_picture:
            self.stats.add_motion(self.last, step.odometry, step.bumper, self.speed)
            self.last = step.odometry
            return None
        # The last step before the picture is seen only through the whole interval's motion.
        self.stats.add_motion(self.last, step.between, step.bumper, self.speed)
        interval = self.stats.interval(step.between[:, :2], step.between[:, 2], self.held)
        self.reset()
        self.last = step.odometry
        return interval
