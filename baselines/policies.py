"""Policies: a localizer coupled with the excitation its method prescribes.

One protocol serves hand-written and learned policies alike (:class:`Policy`): SB3's
``predict(observation, state=None, episode_start=None, deterministic=False)``, plus ``reset``,
``estimate`` and ``belief``. A :class:`Team` runs R robots of one env together (every robot still
sees only its own observation); a single-robot :class:`BaselinePolicy` is a team of one.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any, Protocol, runtime_checkable

import numpy as np

from anonloc_env.actions import to_actions_and_speed, to_commands
from anonloc_env.config import EnvConfig
from anonloc_env.odometry import Interval
from baselines.excitations import Excitation
from baselines.localizers import Localizer
from baselines.steps import BeliefView, OdometryLog, Step, read_step


@runtime_checkable
class Policy(Protocol):
    """What every policy offers (SB3's ``predict`` plus localization)."""

    def predict(
        self,
        observation: Mapping[str, Any],
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = False,
    ) -> tuple[np.ndarray, Any]:
        """The action for ``observation`` and the (unused) recurrent state."""
        ...

    def reset(self, seed: int | None = None) -> None:
        """Start an episode; ``seed`` seeds the policy's own random choices."""
        ...

    def estimate(self) -> int | None:
        """The row of the newest picture seen through ``predict`` believed to be this robot, or
        None while undecided."""
        ...

    def belief(self) -> np.ndarray:
        """A probability for each row of that picture."""
        ...


class Team:
    """R robots of one env, each localizing itself, evaluated together.

    Args:
        config: what the robots know of the task.
        localizer: a localizer for R robots.
        excitation: an excitation (it is reset with one generator per robot).
        listeners: more localizers fed the same pictures and motion (e.g. the faithful and
            corrected versions of one method, scored on the very same episodes).
    """

    def __init__(
        self,
        config: EnvConfig,
        localizer: Localizer,
        excitation: Excitation,
        listeners: Mapping[str, Localizer] | None = None,
    ) -> None:
        self.config = config
        self.localizer = localizer
        self.excitation = excitation
        self.listeners = dict(listeners or {})
        for name, listener in self.listeners.items():
            if listener.n != localizer.n:
                raise ValueError(f"listener {name!r} has {listener.n} robots, not {localizer.n}")
        self.n = localizer.n
        self.log = OdometryLog(self.n, config.robot.v_max, config.dt)
        self.reset([None] * self.n)

    def reset(self, seeds: Sequence[int | np.random.SeedSequence | None]) -> None:
        """Start an episode; robot i's random choices come from ``seeds[i]``."""
        if len(seeds) != self.n:
            raise ValueError(f"seeds must have one entry per robot ({self.n}), got {len(seeds)}")
        self.localizer.reset()
        for listener in self.listeners.values():
            listener.reset()
        self.excitation.reset([np.random.default_rng(s) for s in seeds])
        self.log.reset()
        self.pictures_seen = 0
        self.intervals: list[Interval] = []
        """Each interval between pictures seen so far (own motion, as the robots measured it)."""

    def observe(self, observations: Sequence[Mapping[str, Any]]) -> Step:
        """Take in one step of the robots' observations (in robot order): the motion log and, at
        a new picture, every localizer and then the excitation's
        :meth:`~baselines.excitations.Excitation.on_picture` (told what the team's localizer
        now believes, a :class:`~baselines.steps.BeliefView`).
        """
        if len(observations) != self.n:
            raise ValueError(
                f"a team of {self.n} robots was given {len(observations)} observations: build "
                "it for the env it runs in (baselines.make_team(name, env))"
            )
        return self.take(read_step(observations))

    def take(self, step: Step) -> Step:
        """:meth:`observe` for a step already gathered (``AnonLocEnv.step_arrays``'s ``seen``:
        the same bits, without the per-robot dicts); returns ``step``."""
        interval = self.log.observe(step)
        if step.new_picture:
            first = self.pictures_seen == 0
            if first:
                interval = None
            elif interval is not None:
                self.intervals.append(interval)
            for localizer in (self.localizer, *self.listeners.values()):
                localizer.footprint = step.footprint  # where the observations carry it
                localizer.on_picture(step.rows, interval, step.interval)
            self.pictures_seen += 1
            own = self.localizer
            view = BeliefView(step.rows, own.belief, own.estimate, own.model, interval, self.config)
            self.excitation.on_picture(step, view)
        return step

    def command(self, v: np.ndarray, w: np.ndarray) -> np.ndarray:
        """The env's actions ``(R, 2)`` for the commands ``v`` (m/s) and ``w`` (rad/s) of this
        step, recorded in the motion log (each interval carries the command set at its start;
        the contact model reads the speed sent)."""
        actions, speed = to_actions_and_speed(v, w, self.config.robot)
        self.log.command(v, w, speed)
        return actions

    def act(self, observations: Sequence[Mapping[str, Any]]) -> np.ndarray:
        """Actions ``(R, 2)`` for the robots' observations (in robot order)."""
        self.excitation.on_observations(observations)
        step = self.observe(observations)
        v, w = self.excitation.commands(step, self.config.dt)
        return self.command(v, w)

    def _pick(self, listener: str | None) -> Localizer:
        if listener is None:
            return self.localizer
        if listener not in self.listeners:
            raise ValueError(f"unknown listener {listener!r}; this team has {list(self.listeners)}")
        return self.listeners[listener]

    def estimates(self, listener: str | None = None) -> np.ndarray:
        """``(R,)`` row of the newest picture each robot believes is itself, -1 if undecided
        (by the team's own localizer, or by the named listener)."""
        return self._pick(listener).estimate

    def beliefs(self, listener: str | None = None) -> np.ndarray:
        """``(R, n)`` beliefs over the rows of the newest picture."""
        return self._pick(listener).belief


class BaselinePolicy:
    """One robot's policy (a :class:`Team` of one) speaking the :class:`Policy` protocol.

    ``predict`` also takes a batch of observations (each key with a leading batch axis, as from
    an SB3 ``VecEnv``): each batch entry is then a separate robot, possibly in its own env.

    Args:
        name: the policy's name (for display).
        build: makes a team of one robot.
        first: the first team, if already built (else ``build()`` makes it).
    """

    def __init__(self, name: str, build: Callable[[], Team], first: Team | None = None) -> None:
        self.name = name
        self._build = build
        self._teams: list[Team] = [build() if first is None else first]
        self._seed: int | np.random.SeedSequence | None = None

    def reset(self, seed: int | np.random.SeedSequence | None = None) -> None:
        """Start an episode; the robot's random choices come from ``seed`` (a ``SeedSequence``
        is used as is, so a policy can share a team's i-th stream)."""
        self._seed = seed
        if isinstance(seed, np.random.SeedSequence):
            seeds = [seed, *seed.spawn(len(self._teams) - 1)]
        else:
            seeds = np.random.SeedSequence(seed).spawn(len(self._teams))
        for team, s in zip(self._teams, seeds, strict=True):
            team.reset([s])

    def predict(
        self,
        observation: Mapping[str, Any],
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = False,
    ) -> tuple[np.ndarray, Any]:
        batch = np.asarray(observation["detections"]).ndim == 3
        if not batch:
            if episode_start is not None and bool(np.any(episode_start)):
                self.reset(self._seed)
            return self._teams[0].act([observation])[0], state
        size = len(observation["detections"])
        while len(self._teams) < size:
            self._teams.append(self._build())
            self._teams[-1].reset([None])
        starts = np.zeros(size, bool) if episode_start is None else np.asarray(episode_start)
        actions = np.empty((size, 2), np.float32)
        for i in range(size):
            if starts[i]:
                self._teams[i].reset([None])
            single = {key: value[i] for key, value in observation.items()}
            actions[i] = self._teams[i].act([single])[0]
        return actions, state

    def estimate(self) -> int | None:
        row = int(self._teams[0].estimates()[0])
        return None if row < 0 else row

    def belief(self) -> np.ndarray:
        return self._teams[0].beliefs()[0]

    def __repr__(self) -> str:
        return f"BaselinePolicy({self.name!r})"


class PolicyExcitation(Excitation):
    """Any policy (e.g. a learned one) used as the motion of a localizing robot.

    Args:
        policy: speaks :class:`Policy` (``predict`` on a batch of the robots' observations).
        config: the task (the robots' limits turn its actions into commands).
    """

    def __init__(self, policy: Policy, config: EnvConfig) -> None:
        super().__init__()
        self.policy = policy
        self.config = config
        self.observations: list[Any] = []

    def on_observations(self, observations: Sequence[Mapping[str, Any]]) -> None:
        self.observations = list(observations)

    def commands(self, step: Step, dt: float) -> tuple[np.ndarray, np.ndarray]:
        batch = {
            key: np.stack([np.asarray(o[key]) for o in self.observations])
            for key in self.observations[0]
        }
        actions, _ = self.policy.predict(batch, deterministic=True)
        return to_commands(np.asarray(actions).reshape(self.n, 2), self.config.robot)
