"""What the policies of ``baselines`` read: one step of their robots' observations
(:class:`Step`, :func:`read_step` and :class:`OdometryLog`, defined with the env in
``anonloc_env.robot_view``, whose default reward reads the same), and what an excitation is
told at a new picture (:class:`BeliefView`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from anonloc_env.config import EnvConfig
from anonloc_env.identify import SensorModel
from anonloc_env.odometry import Interval
from anonloc_env.robot_view import OdometryLog, Step, read_step

__all__ = ["BeliefView", "OdometryLog", "Step", "read_step"]


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
