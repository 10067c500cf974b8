"""Reward functions. The env calls one after every step; any object with the
:class:`RewardFunction` interface fits (``env(reward_fn=...)``).

A reward function sees a :class:`StepContext` (what happened during the step, the new picture if
one was taken) and returns one float per robot. It is told at reset which task it serves, so it
can size its state.

Built in:

* :class:`InformationGain` (the default): at each new picture, how much more probable robot i's
  true row became (``log P_k(true_k) - log P_{k-1}(true_{k-1})``, in nats), under the Bayesian
  identifier of :mod:`anonloc_env.identify` fed the true noise model and what the robots observed;
  minus the energy cost at every step. Over an episode the information terms add up to
  ``log P_K(true) - log P_0(true)``: the log-probability gained on the truth since the first
  picture. A ``bayes`` team built for the env reads this identifier instead of running its own
  (``baselines.make_team("bayes", env)``).
* :class:`EnergyCost`: ``r_i = -energy_weight * dt * (|v_i| + turn_cost * |w_i|)``, minus the
  weighted wheel travel of the step (cheap: no identifier runs).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

from anonloc_env import compiled
from anonloc_env.camera import Picture
from anonloc_env.config import EnvConfig
from anonloc_env.odometry import Interval
from anonloc_env.robot_view import OdometryLog, Step, seen_rows

if TYPE_CHECKING:
    from anonloc_env.identify import Identifier


@dataclass(frozen=True)
class StepContext:
    """What a reward function may look at after a step.

    Attributes:
        config: the task configuration.
        time: time at the end of the step (s since reset).
        v: ``(N,)`` forward speed commands held during the step (m/s), after clipping.
        w: ``(N,)`` turn rate commands (rad/s), after clipping.
        contact: ``(N,)`` True where a contact pushed or blocked a robot during the step (its
            bumper fired).
        picture: the picture taken at the end of this step, or None.
        interval: each robot's own motion between the previous picture and ``picture`` (see
            :class:`anonloc_env.odometry.Interval`), or None if no picture came before it: the
            env's own dead reckoning, in float64.
        observed: builds :attr:`seen` (the env sets it; None: built without observations).
    """

    config: EnvConfig
    time: float
    v: np.ndarray
    w: np.ndarray
    contact: np.ndarray
    picture: Picture | None
    interval: Interval | None
    observed: Callable[[], Step] | None = field(default=None, repr=False, compare=False)

    @property
    def seen(self) -> Step:
        """What the robots observed at this step, read back from the arrays of their
        observations exactly as ``baselines`` policies read them
        (:class:`anonloc_env.robot_view.Step`: float32 rows and odometry, in float64). Built
        on each access.

        Raises:
            ValueError: the context was built without the robots' observations.
        """
        if self.observed is None:
            raise ValueError("this StepContext was built without the robots' observations")
        return self.observed()


@runtime_checkable
class RewardFunction(Protocol):
    """What the env needs of a reward function: ``reset`` and ``__call__``.

    A protocol, not a base class: a reward function has no state or helpers to inherit, so any
    object with these two methods fits (the env checks them with ``isinstance`` when it is
    built), with no import from this package needed. Subclassing it explicitly is allowed too.

    The env calls, in every episode:

    1. ``reset(config, rng, picture)`` at ``env.reset``, after the first picture is taken;
    2. ``__call__(context)`` once after every ``env.step``, with what happened during the step
       (:class:`StepContext`); it returns one reward per robot, in robot order.

    Optional: an attribute ``needs_statistics = False`` says that the function never reads the
    per-interval statistics of :class:`anonloc_env.odometry.Interval` (path, squared increments,
    contacts) in ``context.interval``: the env then skips keeping them, which makes ``step``
    cheaper. Without it the env keeps them.

    A reward function may read the ground truth (``picture.true_index``): rewards are the env's,
    not the robots' observations.

    Example (:class:`EnergyCost` is another)::

        class MovePenalty:
            needs_statistics = False

            def reset(self, config, rng, picture=None):
                pass

            def __call__(self, context):
                return -np.hypot(context.v, context.w)  # (N,)

        env = anonloc_env.parallel_env(reward_fn=MovePenalty())

    A worked example that runs in an env is on the docs page *Extending*
    (``examples/custom_reward.py``).
    """

    def reset(
        self, config: EnvConfig, rng: np.random.Generator, picture: Picture | None = None
    ) -> None:
        """Start an episode.

        Args:
            config: the task (its ``n_robots`` sizes the rewards; ``config.reward`` holds the
                reward's weights).
            rng: the env's generator: draw any randomness from it, so episodes replay.
            picture: the picture taken at reset, None inside a blackout.
        """

    def __call__(self, context: StepContext) -> np.ndarray:
        """Return the ``(N,)`` float rewards (one per robot, in robot order) for the step that
        ``context`` describes."""
        ...


def turn_cost(config: EnvConfig) -> float:
    """The wheel travel (m) a turn of one radian costs: ``config.reward.turn_cost``, or half the
    robot's size when that is None (each wheel of a differential drive at the robot's edge)."""
    cost = config.reward.turn_cost
    return config.robot.size / 2.0 if cost is None else cost


def wheel_travel(
    v: np.ndarray, w: np.ndarray, cost: float, duration: float | np.ndarray
) -> np.ndarray:
    """Wheel travel (m) of commands ``v`` (m/s), ``w`` (rad/s) held for ``duration`` (s), a turn
    costing ``cost`` m per radian: ``duration * (|v| + cost |w|)``, elementwise (broadcast)."""
    # In place, in the order of the formula: the same bits as the expression, fewer arrays.
    travel = np.abs(w) * cost
    travel += np.abs(v)
    travel *= duration
    return travel


def energy(config: EnvConfig, v: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Wheel travel (m) of each robot during one control step: ``dt * (|v| + turn_cost |w|)``
    (:func:`wheel_travel` with :func:`turn_cost`)."""
    return wheel_travel(v, w, turn_cost(config), config.dt)


class EnergyCost:
    """Reward ``-energy_weight * energy`` per step (see :func:`energy`)."""

    needs_statistics = False

    def reset(
        self, config: EnvConfig, rng: np.random.Generator, picture: Picture | None = None
    ) -> None:
        """Nothing to remember between steps."""

    def __call__(self, context: StepContext) -> np.ndarray:
        """Minus the weighted wheel travel of each robot."""
        return self.of(context.config, context.v, context.w)

    @staticmethod
    def of(config: EnvConfig, v: np.ndarray, w: np.ndarray) -> np.ndarray:
        """The ``(N,)`` float64 rewards of commands ``v``, ``w`` ``(N,)`` held for a step, what
        a call with their :class:`StepContext` returns (the env's step calls this directly and
        builds no context)."""
        factor = -config.reward.energy_weight
        if _commands(v, w):  # one compiled call, the same floats
            out = np.empty(len(v))
            compiled.energy_rewards(v, w, turn_cost(config), config.dt, factor, out)
            return out
        reward = energy(config, v, w)
        reward *= factor
        return reward


def _commands(v: object, w: object) -> bool:
    """Whether ``v`` and ``w`` are ``(N,)`` float64 arrays and the compiled kernels are on."""
    return (
        type(v) is np.ndarray
        and type(w) is np.ndarray
        and v.dtype == np.float64
        and w.dtype == np.float64
        and v.ndim == 1
        and v.shape == w.shape
        and compiled.mode() is not None
    )


class InformationGain:
    """Information gained about each robot's identity per picture, minus the energy cost.

    ``r_i = information_weight * (log P_k(true_k) - log P_{k-1}(true_{k-1}))`` at a picture k
    (0 between pictures and at the first), ``- energy_weight * energy`` at every step.
    ``P_k(true_k)`` is the belief the identifier gives robot i's true row of picture k (or "not
    in the picture" if it was missed). The identifier runs for all N robots at every picture
    (tens of milliseconds per picture at N = 1000); use :class:`EnergyCost` where speed matters
    more than this reward.

    The identifier is fed what the robots observed
    (:attr:`anonloc_env.rewards.StepContext.seen`: the picture's rows and each robot's odometry
    as float32, its motion log kept as a team keeps it), so it holds
    the very belief that a ``bayes`` team of all the env's robots computes: such a team, built
    for the env (``baselines.make_team("bayes", env)``), reads :attr:`identifier` instead of
    running a second one.

    Attributes:
        identifier: the episode's :class:`~anonloc_env.identify.Identifier` (a new one at every
            reset; None before the first).
        pictures: pictures it has taken in this episode.
        rows: ``(n, 3)`` the newest of them, as the robots observed it.
    """

    needs_statistics = False  # reads the robots' own view, not the env's interval statistics

    def __init__(self) -> None:
        self.identifier: Identifier | None = None
        self.pictures = 0
        self.rows = np.zeros((0, 3))

    def reset(
        self, config: EnvConfig, rng: np.random.Generator, picture: Picture | None = None
    ) -> None:
        """Start a fresh identifier (with the true noise model) and read the first picture."""
        from anonloc_env.identify import Identifier, SensorModel  # heavy; built once per episode

        # The model is derived once per config (SensorModel.from_config caches it).
        self.identifier = Identifier(SensorModel.from_config(config), config.n_robots)
        self.motion = OdometryLog(config.n_robots, config.robot.v_max, config.dt)
        self.pictures = 0
        self.log_true: np.ndarray | None = None
        if picture is not None:
            footprint = None if picture.footprint is None else seen_rows(picture.footprint)
            rows = seen_rows(picture.detections)
            self.log_true = self._observe(rows, None, picture, footprint)

    def _observe(
        self,
        rows: np.ndarray,
        interval: Interval | None,
        picture: Picture,
        footprint: np.ndarray | None,
    ) -> np.ndarray:
        assert self.identifier is not None  # reset() came first
        self.identifier.update(rows, interval if self.pictures else None, footprint)
        self.pictures += 1
        self.rows = rows
        prob = self.identifier.belief_at(picture.true_index)  # "missing" where not detected
        return np.log(np.maximum(prob, 1e-300))

    def __call__(self, context: StepContext) -> np.ndarray:
        """Minus the weighted energy, plus the weighted information gain at a picture."""
        cfg = context.config.reward
        reward = -cfg.energy_weight * energy(context.config, context.v, context.w)
        seen = context.seen
        self.motion.command(context.v, context.w, np.abs(context.v))
        interval = self.motion.observe(seen)
        if context.picture is not None:
            log_true = self._observe(seen.rows, interval, context.picture, seen.footprint)
            if self.log_true is not None:
                reward = reward + cfg.information_weight * (log_true - self.log_true)
            self.log_true = log_true
        return reward
