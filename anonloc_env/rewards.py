"""Reward functions. The env calls one after every step; any object with this interface fits.

A reward function sees a :class:`StepContext` (what happened during the step, the new picture if
one was taken) and returns one float per robot. It is told at reset which task it serves, so it
can size its state.

Built in:

* :class:`EnergyCost` (the default): ``r_i = -energy_weight * dt * (|v_i| + turn_cost * |w_i|)``,
  minus the wheel travel of the step, weighted.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from anonloc_env.camera import Picture
from anonloc_env.config import EnvConfig


@dataclass(frozen=True)
class StepContext:
    """What a reward function may look at after a step.

    Attributes:
        config: the task configuration.
        time: time at the end of the step (s since reset).
        v: ``(N,)`` forward speed commands held during the step (m/s), after clipping.
        w: ``(N,)`` turn rate commands (rad/s), after clipping.
        contact: ``(N,)`` True where a robot touched a wall or another robot.
        picture: the picture taken at the end of this step, or None.
        odometry_between: ``(N, 3)`` each robot's own motion ``(dx, dy, dphi)`` between the
            previous picture and ``picture`` (robot frame at the previous picture), or None.
    """

    config: EnvConfig
    time: float
    v: np.ndarray
    w: np.ndarray
    contact: np.ndarray
    picture: Picture | None
    odometry_between: np.ndarray | None


@runtime_checkable
class RewardFunction(Protocol):
    """Interface of a reward function."""

    def reset(self, config: EnvConfig, rng: np.random.Generator) -> None:
        """Start an episode of ``config``; ``rng`` is the env's generator."""

    def __call__(self, context: StepContext) -> np.ndarray:
        """Return ``(N,)`` rewards for the step described by ``context``."""
        ...


def energy(config: EnvConfig, v: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Wheel travel (m) of each robot during one control step: ``dt * (|v| + turn_cost |w|)``."""
    turn_cost = config.reward.turn_cost
    if turn_cost is None:
        turn_cost = config.robot.size / 2.0
    # In place, in the order of the formula: the same bits as the expression, fewer arrays.
    travel = np.abs(w)
    travel *= turn_cost
    travel += np.abs(v)
    travel *= config.dt
    return travel


class EnergyCost:
    """Reward ``-energy_weight * energy`` per step (see :func:`energy`)."""

    def reset(self, config: EnvConfig, rng: np.random.Generator) -> None:
        """Nothing to remember between steps."""

    def __call__(self, context: StepContext) -> np.ndarray:
        """Minus the weighted wheel travel of each robot."""
        reward = energy(context.config, context.v, context.w)
        reward *= -context.config.reward.energy_weight
        return reward
