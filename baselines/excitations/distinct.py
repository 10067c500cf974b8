"""Distinct motion: a new random command at every picture, reversing out of bumps and escaping
jams (:class:`DistinctMotion`, :class:`BackOff`), and the check of a range of commands that the
active excitations share (:func:`check_command_box`)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from baselines.excitations.base import NOBODY, Excitation
from baselines.steps import Step


def check_command_box(speed: tuple[float, float], turn: float) -> None:
    """Refuse a range of speeds ``(low, high)`` (m/s) or a largest turn rate (rad/s) that no
    robot command can take."""
    low, high = speed
    if not 0.0 <= low <= high:
        raise ValueError(f"speed must be (low, high) with 0 <= low <= high m/s, got {speed}")
    if not turn >= 0.0:
        raise ValueError(f"turn must be >= 0 rad/s, got {turn}")


@dataclass
class DistinctSettings:
    """Distinct motion, all rates in SI units.

    Attributes:
        speed: range of forward speeds (m/s), drawn at every picture.
        turn: largest turn rate (rad/s); rates are uniform in ``[-turn, turn]``, drawn at every
            picture and for every back-off.
        back_speed: speed of the reverse drive after a bump (m/s).
        back_time: range of that reverse drive's duration (s).
    """

    speed: tuple[float, float] = (0.1, 0.3)
    turn: float = 0.5
    back_speed: float = 0.3
    back_time: tuple[float, float] = (0.5, 1.0)

    def __post_init__(self) -> None:
        check_command_box(self.speed, self.turn)
        if not self.back_speed >= 0.0:
            raise ValueError(f"back_speed must be >= 0 m/s, got {self.back_speed}")
        if not 0.0 <= self.back_time[0] <= self.back_time[1]:
            raise ValueError(
                f"back_time must be (low, high) with 0 <= low <= high s, got {self.back_time}"
            )


class BackOff:
    """Reversing out of a bump, a part an excitation holds: after a bump the robot drives
    backwards at ``back_speed`` while turning at a random rate in ``[-turn, turn]`` for a random
    time in ``back_time``, then resumes its own motion.

    Turning in place (:class:`~baselines.excitations.BumpEscape`) leaves a jammed robot where it is,
    and a robot that does not move cannot be told from another one that does not move either
    (without detected headings, a turn in place is invisible): jammed robots are the last ones
    identified under the paper's random motion. Reversing frees them and keeps them moving.

    The excitation resets it with its robots' generators (:meth:`reset`) and lets it wrap its
    commands (:meth:`commands`): the back-off draws for the robots that just bumped, then asks the
    excitation for its own commands, then replaces those of the robots reversing.

    Args:
        settings: ``back_speed``, ``back_time`` and ``turn``.
    """

    def __init__(self, settings: DistinctSettings) -> None:
        self.settings = settings
        self.rngs: list[np.random.Generator] = []
        self.backing = np.zeros(0)
        """``(R,)`` time left reversing (s)."""
        self.rate = np.zeros(0)
        """``(R,)`` the turn rate while reversing (rad/s)."""
        self.speed = np.zeros(0)
        """``(R,)`` the speed of the reverse drive (m/s)."""

    def reset(self, rngs: Sequence[np.random.Generator]) -> None:
        """Start an episode with the excitation's generators (one per robot; drawn in turn with
        the excitation's own draws)."""
        self.rngs = list(rngs)
        self.backing = np.zeros(len(self.rngs))
        self.rate = np.zeros(len(self.rngs))
        self.speed = np.zeros(len(self.rngs))

    def turn_rates(self, hit: np.ndarray) -> list[float]:
        """The turn rates (rad/s) of the robots ``hit`` while they reverse: uniform in
        ``[-turn, turn]``, one draw each from its generator."""
        turn = self.settings.turn
        return [self.rngs[i].uniform(-turn, turn) for i in hit]

    def note(self, step: Step) -> None:
        """Called first at every step with what the robots observed (does nothing here)."""

    def start(self, hit: np.ndarray) -> None:
        """Start the back-off of the robots ``hit``: its duration, then its turn rate, drawn
        from each robot's generator (two numbers per robot)."""
        if not len(hit):
            return
        b = self.settings
        self.backing[hit] = [self.rngs[i].uniform(*b.back_time) for i in hit]
        self.rate[hit] = self.turn_rates(hit)
        self.speed[hit] = b.back_speed

    def commands(
        self,
        step: Step,
        dt: float,
        own: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    ) -> tuple[np.ndarray, np.ndarray]:
        """The commands of this step: ``own(hit)`` (the excitation's ``(v, w)``, told which
        robots ``hit`` just bumped), with those of the robots reversing replaced."""
        self.note(step)
        hit = np.flatnonzero(step.bumper & (self.backing <= 0.0)) if step.bumper.any() else NOBODY
        self.start(hit)
        v, w = own(hit)
        backing = self.backing > 0.0
        self.backing = np.maximum(self.backing - dt, 0.0)
        return np.where(backing, -self.speed, v), np.where(backing, self.rate, w)


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

    def __init__(self, settings: DistinctSettings | None = None, escape: bool = True) -> None:
        super().__init__()
        self.settings = settings or DistinctSettings()
        self.backoff = BackOff(self.settings)
        if escape:  # imported here: the reflex and gaps' escape build on this module
            from baselines.excitations.gaps import GapSettings
            from baselines.excitations.reflex import BumpReflex

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
