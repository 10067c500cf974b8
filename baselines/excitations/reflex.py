"""The bump reflex of the excitations that choose among candidate commands (``greedy``,
``uniform``, ``code`` and the learned agent): :class:`BumpReflex`.

After a first bump a robot reverses out of it as ``distinct`` does (a
:class:`~baselines.excitations.BackOff`: 0.3 m/s for 0.5 to 1 s at a uniform turn rate). A robot
that is *pressed*, whose bumper fires again after it fired in the interval between the two
pictures before, is jammed against a wall or a neighbour, in a crowd: reversing fast there bumps
the robot behind and a small turn drives it back into what it hit. So it escapes as ``gaps``'
unsure robots do (:class:`~baselines.excitations.gaps.Escape`: 0.08 m/s for 0.7 to 1.2 s,
turning at the full rate one way or the other), and comes out facing away from what it hit.
Pressed is what the identifier tests too (``anonloc_env.identify.Identifier._pressed``: pushed
in this interval and in the one before) and what a robot knows without the picture (its bumper).

Both back-offs draw two numbers per bump from the robot's generator (the duration, then the
turn), so the robots' later draws (their candidates) are the same numbers whichever way a robot
left a bump; where no robot is ever pressed the commands are bit for bit those of the plain
back-off (``tests/test_reflex.py``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from baselines.excitations.backoff import BackOff, DistinctSettings
from baselines.excitations.gaps import Escape
from baselines.steps import Step


class BumpReflex(BackOff):
    """Reverse out of a first bump (``back``); escape when pressed (``escape``; see the module).

    Args:
        back: the back-off after a bump (``back_speed``, ``back_time``, ``turn``).
        escape: the escape of a pressed robot (``back_speed``, ``back_time``, ``turn``: the full
            rate it turns at); ``None``: a pressed robot backs off as after a first bump.
    """

    def __init__(self, back: DistinctSettings, escape: DistinctSettings | None) -> None:
        super().__init__(back)
        self.escape = None if escape is None else Escape(escape)
        self.bumped = np.zeros(0, bool)
        """``(R,)`` the bumper fired in the interval under way (since the newest picture)."""
        self.before = np.zeros(0, bool)
        """``(R,)`` the bumper fired in the interval that ended at the newest picture."""
        self.escapes = 0
        """Escapes started in this episode."""
        self._picture = False

    def reset(self, rngs: Sequence[np.random.Generator]) -> None:
        super().reset(rngs)
        if self.escape is not None:
            self.escape.reset(rngs)
        self.bumped = np.zeros(self.n, bool)
        self.before = np.zeros(self.n, bool)
        self.escapes = 0
        self._picture = False

    @property
    def n(self) -> int:
        """Number of robots."""
        return len(self.rngs)

    def pressed(self, step: Step) -> np.ndarray:
        """``(R,)`` at a new picture, the robots pushed in the interval that ended with it and in
        the one before (``Identifier._pressed``'s test, from the bumpers), without changing any
        state: a feature a policy can read in ``on_picture`` (before this step's
        ``commands``)."""
        return (self.bumped | step.bumper) & self.before

    def start(self, hit: np.ndarray) -> None:
        if self.escape is None or not len(hit):  # (nobody hit: most control steps)
            super().start(hit)
            return
        pressed = self.before[hit]
        super().start(hit[~pressed])
        stuck = hit[pressed]
        if len(stuck):
            self.escape.start(stuck)
            self.backing[stuck] = self.escape.backing[stuck]
            self.rate[stuck] = self.escape.rate[stuck]
            self.speed[stuck] = self.escape.speed[stuck]
            self.escapes += len(stuck)

    def note(self, step: Step) -> None:
        """Take in this step's bumpers. A bump at a new picture belongs to the interval the
        picture ends (the env takes the picture after the step's physics): the intervals move on
        at the next step, after the back-off of this one was drawn."""
        if self._picture:
            self.before, self.bumped = self.bumped, np.zeros(self.n, bool)
        self.bumped |= step.bumper
        self._picture = step.new_picture
