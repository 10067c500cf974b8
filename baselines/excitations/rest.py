"""Rest once sure: :class:`RestWhenSure`, any excitation with the robots that know who they are
at rest, and ``uniform-rest``, chance that rests.

A robot whose largest belief (over the picture's rows, from the team's localizer) is at least
``sure`` at a picture holds still until the next one: ``v = w = 0``, or, on swarm duty (inside
:class:`~baselines.excitations.SwarmDuty`), no deviation from the shared command. The others
drive whatever the wrapped excitation commands, which is still asked every step, so its random
numbers are drawn exactly as without the wrapper. A robot that is no longer sure at a later
picture moves again.

**A rest that probes.** A robot that rests while wrongly sure can stay wrong for good: if the row
it took is another resting robot's, neither moves, and nothing in the pictures speaks against the
mistake (issue 23's grid found one robot wrong at 28 pictures running, at one robot per m²). So a
robot sure at ``probe`` pictures running drives the wrapped excitation's command for one interval
at the ``probe``-th, then rests again while sure. A row that does not move when the robot does
then tells it it was wrong. ``probe = 3`` costs about 1 % of the energy to 99 % on free motion
(most episodes reach 99 % before any robot has rested three pictures) and ended that robot's
mistake after 6 decisions instead of 28 (``docs/agents.md``, *A rest that probes*).

**A rest that yields.** In free motion a resting robot that is bumped reverses out of the bump
as a moving one does (the wrapped excitation's :attr:`~baselines.excitations.Excitation.backoff`)
instead of holding still through it. A robot that drives into a resting one that stays put is
pressed against it, and its escape (reverse slowly while turning at the full rate) leaves it
almost where it was: over that interval it cannot tell itself from any row that did not move,
and resting rows do not. At free N = 300 this was the rest's whole cost in the tail
(``docs/agents.md``, *Why the rest cost pictures at N = 300*). On swarm duty a resting robot
keeps the shared command without deviating (the swarm moves together; a back-off there only
spent energy).

Why it helps (measured, ``docs/agents.md``): once a robot is sure, its own motion tells it
nothing more, and a robot standing still is the easiest of all for the others to tell from
themselves (their odometry says they moved). At one robot per m² it cuts the energy to 99 %
by 22 to 27 % for about 3 % more pictures with ``sure = 0.999``; with ``sure = 0.99`` a robot
that was wrongly sure stops gathering evidence, and the pictures grow by 17 %.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from baselines.excitations.base import Excitation
from baselines.steps import BeliefView, Step

#: The default belief at which a robot rests.
SURE = 0.999
#: By default a robot sure at this many pictures running moves for one interval at the last.
PROBE = 3


class RestWhenSure(Excitation):
    """``inner``'s commands, except for the robots sure of themselves, which rest (see the module
    documentation).

    Args:
        inner: the excitation of the robots that are not sure.
        sure: a robot rests while its largest belief is at least this, in (0.5, 1].
        probe: a robot sure at this many pictures running drives ``inner``'s command for the
            interval after the last of them (an integer >= 2), or None to rest without probing.
        yield_to_bumps: in free motion, a resting robot drives ``inner``'s reverse out of a bump
            (``inner.reversing()``) instead of holding still; False: it holds still (the rest
            before the fourteenth round).

    Raises:
        ValueError: ``sure`` is outside (0.5, 1] (with at most 0.5 two rows could both be "sure"),
            or ``probe`` is neither None nor an integer >= 2.
    """

    def __init__(
        self,
        inner: Excitation,
        sure: float = SURE,
        probe: int | None = PROBE,
        yield_to_bumps: bool = True,
    ) -> None:
        super().__init__()
        if not 0.5 < float(sure) <= 1.0:
            raise ValueError(f"sure must be in (0.5, 1], got {sure!r}")
        if probe is not None and not (
            isinstance(probe, (int, np.integer)) and not isinstance(probe, bool) and probe >= 2
        ):
            raise ValueError(f"probe must be None or an integer >= 2, got {probe!r}")
        self.inner = inner
        self.sure = float(sure)
        self.probe = None if probe is None else int(probe)
        self.yield_to_bumps = bool(yield_to_bumps)
        self.resting = np.zeros(0, bool)
        self.sure_for = np.zeros(0, np.int64)
        self.on_duty = False
        self.held = np.zeros(0, bool)
        """``(R,)`` the robots the latest :meth:`commands` held still."""

    def reset(self, rngs: Sequence[np.random.Generator]) -> None:
        super().reset(rngs)
        self.inner.reset(rngs)
        self.resting = np.zeros(self.n, bool)
        self.sure_for = np.zeros(self.n, np.int64)
        self.on_duty = False
        self.held = np.zeros(self.n, bool)

    def on_observations(self, observations: Sequence[Mapping[str, Any]]) -> None:
        self.inner.on_observations(observations)

    def on_picture(self, step: Step, view: BeliefView) -> None:
        self.inner.on_picture(step, view)
        belief = np.asarray(view.belief, np.float64)
        if belief.ndim != 2 or belief.shape[1] == 0:
            sure = np.zeros(self.n, bool)
        else:
            sure = belief.max(axis=1) >= self.sure
        self.sure_for = np.where(sure, self.sure_for + 1, 0)
        self.resting = sure
        if self.probe is not None:
            self.resting = sure & (self.sure_for % self.probe != 0)

    def follow(self, v: np.ndarray, w: np.ndarray, budget: float) -> None:
        self.inner.follow(v, w, budget)
        self.on_duty = True

    def commands(self, step: Step, dt: float) -> tuple[np.ndarray, np.ndarray]:
        v, w = self.inner.commands(step, dt)
        still = self.resting
        if self.yield_to_bumps and not self.on_duty:
            still = still & ~self.inner.reversing()
        self.held = still
        return np.where(still, 0.0, v), np.where(still, 0.0, w)

    def reversing(self) -> np.ndarray:
        return self.inner.reversing() & ~self.held


def at_rest(own: Excitation, sure: float | None) -> Excitation:
    """``own`` at rest once its belief reaches ``sure`` (:class:`RestWhenSure`), or ``own``
    itself when ``sure`` is None: the one place where "no rest" is spelled out (the agent's
    spec, a saved model and the search all read their optional ``rest`` through it)."""
    return own if sure is None else RestWhenSure(own, sure)


def uniform_rest(sure: float = SURE) -> RestWhenSure:
    """``uniform`` (:class:`~baselines.excitations.uniform.UniformChoice`) at rest once its
    belief reaches ``sure``."""
    from baselines.excitations.uniform import UniformChoice

    return RestWhenSure(UniformChoice(), sure)
