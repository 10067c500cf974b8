"""The paper's prescribed motions (section II.A and II.B): turn in place (:class:`Angular`) or
drive straight (:class:`Linear`), at a new random rate or speed after every picture."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from baselines.excitations.base import Excitation
from baselines.steps import Step


@dataclass
class AngularSettings:
    """Turn in place at a rate drawn uniformly in ``(0, max_rate]`` rad/s at every picture.

    ``counter_clockwise=False`` also draws negative rates.
    """

    max_rate: float = math.radians(9.0)
    counter_clockwise: bool = True


class Angular(Excitation):
    """Paper II.A: turn in place at a new random rate after every picture."""

    def __init__(self, settings: AngularSettings | None = None) -> None:
        super().__init__()
        self.settings = settings or AngularSettings()
        self.rate = np.zeros(0)

    def reset(self, rngs: Sequence[np.random.Generator]) -> None:
        super().reset(rngs)
        self.rate = np.zeros(self.n)

    def commands(self, step: Step, dt: float) -> tuple[np.ndarray, np.ndarray]:
        if step.new_picture:
            s = self.settings
            low = 0.0 if s.counter_clockwise else -s.max_rate
            self.rate = self._draw(low, s.max_rate, np.arange(self.n))
        return np.zeros(self.n), self.rate.copy()


@dataclass
class LinearSettings:
    """Drive straight at a speed drawn uniformly in ``[min_speed, max_speed]`` m/s per picture
    (the paper: "random linear speeds limited to 0.1 unit/second")."""

    max_speed: float = 0.1
    min_speed: float = 0.0


class Linear(Excitation):
    """Paper II.B: drive straight, at a new random speed after every picture."""

    def __init__(self, settings: LinearSettings | None = None) -> None:
        super().__init__()
        self.settings = settings or LinearSettings()
        self.speed = np.zeros(0)
        self.speeds: list[np.ndarray] = []

    def reset(self, rngs: Sequence[np.random.Generator]) -> None:
        super().reset(rngs)
        self.speed = np.zeros(self.n)
        self.speeds = []

    def commands(self, step: Step, dt: float) -> tuple[np.ndarray, np.ndarray]:
        if step.new_picture:
            s = self.settings
            self.speed = self._draw(s.min_speed, s.max_speed, np.arange(self.n))
            self.speeds.append(self.speed.copy())
        return self.speed.copy(), np.zeros(self.n)
