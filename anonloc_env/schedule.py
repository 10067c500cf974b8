"""When the camera takes pictures: a nominal interval, optional jitter, optional blackouts."""

from __future__ import annotations

import math

import numpy as np

from anonloc_env.config import ScheduleConfig


class PictureSchedule:
    """Decides at each control step whether a picture is taken.

    Picture k (k = 0, 1, ...) is due at ``k * picture_interval + jitter_k`` (``jitter_0 = 0``) and
    is taken at the end of the first control step at or after that time, unless the time falls in a
    blackout window, in which case it is skipped. Jitter values are drawn from the env's generator
    one picture ahead.

    Args:
        config: the schedule settings.
        dt: the control step (s); times are compared with a tolerance of ``1e-9 * dt``.
        rng: the env's generator.
    """

    def __init__(self, config: ScheduleConfig, dt: float, rng: np.random.Generator) -> None:
        self.config = config
        self._tolerance = 1e-9 * dt
        self._rng = rng
        self._k = 0
        self._due = 0.0

    def in_blackout(self, time: float) -> bool:
        """Whether ``time`` (s) falls inside a blackout window (start included, end excluded)."""
        return any(start <= time < end for start, end in self.config.blackouts)

    def take_now(self, time: float) -> bool:
        """Whether a picture is taken at ``time`` (s); advances the schedule when one was due."""
        if time + self._tolerance < self._due:
            return False
        interval = self.config.picture_interval
        # Skip every due time already passed (a long control step can cover several).
        self._k = max(self._k + 1, math.floor((time + self._tolerance) / interval) + 1)
        jitter = self.config.jitter
        offset = self._rng.uniform(-jitter, jitter) if jitter > 0.0 else 0.0
        self._due = self._k * interval + offset
        return not self.in_blackout(time)
