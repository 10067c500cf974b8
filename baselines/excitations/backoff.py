"""What the active excitations share: the check of a range of commands
(:func:`check_command_box`), the settings of a motion and its back-off (:class:`DistinctSettings`)
and the back-off out of bumps (:class:`BackOff`), which ``distinct``, ``gaps``' escape and the
bump reflex build on."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from anonloc_env import compiled
from baselines.excitations import backoff_kernels
from baselines.excitations.base import NOBODY
from baselines.excitations.draws import uniform
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
        self.latest = np.zeros(0)
        """``(R,)`` the time left reversing when the latest :meth:`commands` set its commands
        (s): those above 0 reversed at that step (the array itself, never written after)."""

    def reset(self, rngs: Sequence[np.random.Generator]) -> None:
        """Start an episode with the excitation's generators (one per robot; drawn in turn with
        the excitation's own draws)."""
        self.rngs = list(rngs)
        self.backing = np.zeros(len(self.rngs))
        self.rate = np.zeros(len(self.rngs))
        self.speed = np.zeros(len(self.rngs))
        self.latest = self.backing

    def turn_rates(self, hit: np.ndarray) -> list[float]:
        """The turn rates (rad/s) of the robots ``hit`` while they reverse: uniform in
        ``[-turn, turn]``, one draw each from its generator."""
        turn = self.settings.turn
        return [uniform(self.rngs[i], -turn, turn) for i in hit]

    def note(self, step: Step) -> None:
        """Called first at every step with what the robots observed (does nothing here)."""

    def start(self, hit: np.ndarray) -> None:
        """Start the back-off of the robots ``hit``: its duration, then its turn rate, drawn
        from each robot's generator (two numbers per robot)."""
        if not len(hit):
            return
        b = self.settings
        self.backing[hit] = [uniform(self.rngs[i], *b.back_time) for i in hit]
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
        fast = compiled.mode() is not None and _plain_state(self, step.bumper)
        if fast:  # one compiled call each here and below, the same floats
            hit = backoff_kernels.bumped_idle(step.bumper, self.backing)
        elif step.bumper.any():
            hit = np.flatnonzero(step.bumper & (self.backing <= 0.0))
        else:
            hit = NOBODY
        self.start(hit)
        self.latest = self.backing  # replaced below, never written in place
        v, w = own(hit)
        if fast and _plain(v, self.backing) and _plain(w, self.backing):
            out = np.empty((3, len(v)))
            if backoff_kernels.backed_off(self.backing, self.speed, self.rate, v, w, dt, out):
                self.backing = out[2]
            return out[0], out[1]
        backing = self.backing > 0.0
        if not backing.any() and _plain(v, backing) and _plain(w, backing):
            # Nobody reversing (most steps): the times left stay 0 and the commands are the
            # excitation's, in new arrays (what the general line below gives, fewer calls).
            return v.copy(), w.copy()
        self.backing = np.maximum(self.backing - dt, 0.0)
        return np.where(backing, -self.speed, v), np.where(backing, self.rate, w)


_FLOAT64 = np.dtype(np.float64)
_BOOL = np.dtype(np.bool_)


def _plain(x: object, like: np.ndarray, dtype: np.dtype = _FLOAT64) -> bool:
    """Whether ``x`` is a vector of ``dtype`` (float64) of the shape of ``like`` (then
    ``np.where(False, y, x)`` is a copy of ``x``)."""
    return type(x) is np.ndarray and x.dtype == dtype and x.shape == like.shape and x.ndim == 1


def _plain_state(backoff: BackOff, bumper: np.ndarray) -> bool:
    """Whether the back-off's times, speeds and rates are float64 vectors alike and ``bumper``
    a bool one (what the compiled step takes), in one test."""
    b, s, r = backoff.backing, backoff.speed, backoff.rate
    return (
        type(b) is np.ndarray
        and type(s) is np.ndarray
        and type(r) is np.ndarray
        and type(bumper) is np.ndarray
        and b.ndim == 1
        and b.dtype == _FLOAT64
        and s.dtype == _FLOAT64
        and r.dtype == _FLOAT64
        and bumper.dtype == _BOOL
        and b.shape == s.shape == r.shape == bumper.shape
    )
