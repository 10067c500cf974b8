"""The base class of the excitations (:class:`Excitation`) and the one that does nothing
(:class:`Still`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Protocol

import numpy as np

from baselines.steps import BeliefView, Step

NOBODY = np.zeros(0, dtype=np.int64)  # no robot: skips np.flatnonzero on the common path


class Reverse(Protocol):
    """What ``Excitation.reversing`` reads of a back-off
    (:class:`~baselines.excitations.backoff.BackOff` is one)."""

    latest: np.ndarray
    """``(R,)`` the time left reversing (s) when the latest commands were set."""


class Excitation:
    """Base class of the excitations: what R robots do between pictures so that each can be told
    from the others.

    An excitation drives the robots of one :class:`~baselines.policies.Team` (R robots of one env,
    or one robot). The team calls, in every episode:

    1. :meth:`reset` at the start, with one random generator per robot;
    2. at every control step, in this order: :meth:`on_observations` (the robots' raw
       observations), :meth:`on_picture` (only at a new picture, after the team's localizer took
       it in), :meth:`follow` (only on swarm duty), and last :meth:`commands`.

    Compulsory: :meth:`commands`, returning ``(v, w)``: ``(R,)`` forward speeds (m/s) and turn
    rates (rad/s, counter-clockwise positive), one per robot in robot order. The env clips them to
    the robot's ``v_max`` and ``omega_max``.

    Optional: :meth:`reset` (call ``super().reset(rngs)`` first, then draw the episode's own
    state), :meth:`on_observations`, :meth:`on_picture` (to read what the robots now believe, as
    an active-identification excitation does) and :meth:`follow`. Every random draw comes from
    ``self.rngs[i]`` for robot i, so that episodes replay from their seeds and a robot's choices
    never depend on another's.

    A worked example that runs in an env is on the docs page *Extending*
    (``examples/custom_excitation.py``).

    Attributes:
        rngs: one generator per robot, set by :meth:`reset`.
        backoff: the excitation's reverse out of bumps
            (:class:`~baselines.excitations.backoff.BackOff`), if it has one; None otherwise.
    """

    backoff: Reverse | None = None

    def __init__(self) -> None:
        self.rngs: list[np.random.Generator] = []

    @property
    def n(self) -> int:
        """Number of robots driven."""
        return len(self.rngs)

    def reset(self, rngs: Sequence[np.random.Generator]) -> None:
        """Start an episode; ``rngs`` has one generator per robot (their number is :attr:`n`)."""
        self.rngs = list(rngs)

    def on_observations(self, observations: Sequence[Mapping[str, Any]]) -> None:
        """Called at every step, first, with the robots' observations (robot order, as the env
        gives them). The default does nothing."""

    def on_picture(self, step: Step, view: BeliefView) -> None:
        """Called at every new picture, after the team's localizer has taken it in, before
        :meth:`commands`: ``view`` (a :class:`~baselines.steps.BeliefView`) holds what the robots
        now believe (``belief`` ``(R, n)``, ``estimate`` ``(R,)``), the localizer's sensor
        ``model``, the picture's ``rows``, the ``interval`` just ended and the task's
        ``config``. The default does nothing."""

    def follow(self, v: np.ndarray, w: np.ndarray, budget: float) -> None:
        """Called by :class:`~baselines.excitations.SwarmDuty` before each :meth:`commands` when
        this excitation is the robots' deviation: the shared commands ``v``, ``w`` ``(R,)`` of
        this step and the factor ``budget`` its own commands are scaled by. The default ignores
        them."""

    def commands(self, step: Step, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """The commands held during the coming control step.

        Args:
            step: what the robots observed at this step (:class:`baselines.steps.Step`):
                ``new_picture``, the picture's ``rows`` ``(n, 3)`` (at a new picture),
                ``odometry`` ``(R, 3)`` own ``(dx, dy, dphi)`` (m, rad) since that picture, and
                ``bumper`` ``(R,)`` bool, a contact during the last step.
            dt: the control step (s).

        Returns:
            ``(v, w)``: ``(R,)`` forward speeds (m/s) and ``(R,)`` turn rates (rad/s).
        """
        raise NotImplementedError(f"{type(self).__name__} must implement commands()")

    def reversing(self) -> np.ndarray:
        """``(R,)`` bool: the robots whose latest :meth:`commands` reverse out of a bump (its
        :attr:`backoff` under way); none without a back-off. A wrapper answers for the robots
        it drives."""
        if self.backoff is None:
            return np.zeros(self.n, bool)
        return self.backoff.latest > 0.0

    def _draw(self, low: float, high: float, who: np.ndarray) -> np.ndarray:
        return np.array([self.rngs[i].uniform(low, high) for i in who])


class Still(Excitation):
    """Do nothing (a robot that only watches)."""

    def commands(self, step: Step, dt: float) -> tuple[np.ndarray, np.ndarray]:
        return np.zeros(self.n), np.zeros(self.n)
