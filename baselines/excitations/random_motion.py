"""The paper's random motion (section II.C, :class:`RandomMotion`) and the turn away from a bump
that every random motion shares (:class:`BumpEscape`)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from baselines.excitations.base import NOBODY, Excitation
from baselines.steps import Step


@dataclass
class RandomSettings:
    """Random motion (paper section III), all rates in SI units.

    Attributes:
        speed: range of forward speeds (m/s).
        turn: largest turn rate (rad/s); rates are uniform in ``[-turn, turn]``.
        change_after: each of speed and turn rate is redrawn after a time uniform in
            ``[0, change_after]`` s.
        bump_turn: after a bump the robot stops and turns in place at a rate uniform in
            ``[bump_turn / 2, bump_turn]`` (random sign) for ``bump_time`` seconds.
        bump_time: range of that turn's duration (s).
    """

    speed: tuple[float, float] = (0.1, 0.5)
    turn: float = math.radians(20.0)
    change_after: float = 3.0
    bump_turn: float = math.radians(40.0)
    bump_time: tuple[float, float] = (1.0, 2.0)


class BumpEscape(Excitation):
    """Base of the random motions: after a bump a robot stops and turns in place at a random
    rate (random sign) for a random time, as in the paper, before its own motion resumes.

    Subclasses set ``settings`` (a :class:`RandomSettings`), call :meth:`_reset_escapes` in
    ``reset``, and in ``commands`` call :meth:`_start_escapes` first and pass their commands
    through :meth:`_apply_escapes` last.
    """

    settings: RandomSettings

    def _reset_escapes(self) -> None:
        self.escape = np.zeros(self.n)  # time left turning away from a bump (s)
        self.escape_rate = np.zeros(self.n)

    def _start_escapes(self, step: Step) -> None:
        """Robots that just bumped (and are not escaping yet) draw an escape."""
        s = self.settings
        bumped = np.flatnonzero(step.bumper & (self.escape <= 0.0)) if step.bumper.any() else NOBODY
        if len(bumped):
            sign = np.where(self._draw(0.0, 1.0, bumped) < 0.5, -1.0, 1.0)
            self.escape_rate[bumped] = sign * self._draw(s.bump_turn / 2, s.bump_turn, bumped)
            self.escape[bumped] = self._draw(*s.bump_time, bumped)

    def _apply_escapes(
        self, dt: float, v: np.ndarray, w: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """The commands, with those of the robots escaping replaced by a turn in place."""
        escaping = self.escape > 0.0
        self.escape = np.maximum(self.escape - dt, 0.0)
        return np.where(escaping, 0.0, v), np.where(escaping, self.escape_rate, w)


class RandomMotion(BumpEscape):
    """Paper II.C: random speeds and turn rates changed at random moments; turn away after a
    bump. All robots use similar commands (the paper's "worst conditions")."""

    def __init__(self, settings: RandomSettings | None = None) -> None:
        super().__init__()
        self.settings = settings or RandomSettings()

    def reset(self, rngs: Sequence[np.random.Generator]) -> None:
        super().reset(rngs)
        s, everyone = self.settings, np.arange(self.n)
        self.v = self._draw(*s.speed, everyone)
        self.w = self._draw(-s.turn, s.turn, everyone)
        self.v_timer = self._draw(0.0, s.change_after, everyone)
        self.w_timer = self._draw(0.0, s.change_after, everyone)
        self._reset_escapes()

    def commands(self, step: Step, dt: float) -> tuple[np.ndarray, np.ndarray]:
        s = self.settings
        self._start_escapes(step)
        self.v_timer -= dt
        self.w_timer -= dt
        due_v = np.flatnonzero(self.v_timer <= 0.0) if self.v_timer.min() <= 0.0 else NOBODY
        if len(due_v):
            self.v[due_v] = self._draw(*s.speed, due_v)
            self.v_timer[due_v] = self._draw(0.0, s.change_after, due_v)
        due_w = np.flatnonzero(self.w_timer <= 0.0) if self.w_timer.min() <= 0.0 else NOBODY
        if len(due_w):
            self.w[due_w] = self._draw(-s.turn, s.turn, due_w)
            self.w_timer[due_w] = self._draw(0.0, s.change_after, due_w)
        return self._apply_escapes(dt, self.v, self.w)
