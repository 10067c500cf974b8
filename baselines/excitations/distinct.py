"""Distinct motion: a new random command at every picture, reversing out of bumps and escaping
jams (:class:`DistinctMotion`). Its settings and back-off are in
:mod:`~baselines.excitations.backoff` (re-exported here)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from baselines.excitations.backoff import BackOff, DistinctSettings, check_command_box
from baselines.excitations.base import Excitation
from baselines.excitations.gaps import GapSettings
from baselines.excitations.reflex import BumpReflex
from baselines.steps import Step

__all__ = ["BackOff", "DistinctMotion", "DistinctSettings", "check_command_box"]


class DistinctMotion(Excitation):
    """A hand-designed excitation: a new random speed and turn rate at every picture, held until
    the next one; reverse out of bumps (a :class:`BackOff`).

    Drawing the command at each picture (rather than at random moments, as the paper's random
    motion does) spreads the robots' displacements between pictures over the whole range of
    lengths and curvatures, so a wrong hypothesis (another robot's track) rarely moves like the
    robot itself. Never standing still (``speed[0] > 0``) matters as much: two robots that do
    not move look alike. The defaults are the best of the variants measured in
    ``docs/baselines.md`` (Active identification): pictures to identify 99 % of 100 robots
    about halved against the paper's random motion, with less energy.

    A robot *pressed* (its bumper fires again after it fired in the interval before) escapes
    slowly, turning at the full rate, as ``gaps``' unsure robots do (a
    :class:`~baselines.excitations.reflex.BumpReflex`, as ``greedy``'s): reversing fast out of a
    jam bumps the robot behind, and at 4 robots per m² left every episode of the issue 23 grid
    short of 99 % right (``docs/crowds.md``, eighth round). Where no robot is pressed the
    commands are bit for bit those of the plain back-off.

    Args:
        settings: speeds, turn rates and the back-off (defaults above).
        escape: a pressed robot escapes (the default); ``False``: it backs off as after a first
            bump (the motion before issue 23's eighth round).
    """

    backoff: BackOff  # narrows Excitation.backoff: this excitation always has one

    def __init__(self, settings: DistinctSettings | None = None, escape: bool = True) -> None:
        super().__init__()
        self.settings = settings or DistinctSettings()
        self.backoff = BackOff(self.settings)
        if escape:
            self.backoff = BumpReflex(self.settings, GapSettings().escape())

    def reset(self, rngs: Sequence[np.random.Generator]) -> None:
        super().reset(rngs)
        self.v = np.zeros(self.n)
        self.w = np.zeros(self.n)
        self.backoff.reset(rngs)

    def commands(self, step: Step, dt: float) -> tuple[np.ndarray, np.ndarray]:
        return self.backoff.commands(step, dt, lambda hit: self._own(step, hit))

    def _own(self, step: Step, hit: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A new command at every picture, and for the robots that just bumped."""
        s = self.settings
        redraw = np.arange(self.n) if step.new_picture else hit
        if len(redraw):
            self.v[redraw] = self._draw(*s.speed, redraw)
            self.w[redraw] = self._draw(-s.turn, s.turn, redraw)
        return self.v, self.w
