"""Excitations: what a robot does between pictures so that it can be recognised.

Each excitation drives R robots at once, every robot with its own random generator (a robot's
choices never depend on another's). ``commands(step, dt)`` returns physical commands ``v`` (m/s) and
``w`` (rad/s), clipped by the env to the robot's limits.

Defaults follow section III of the paper: turn in place counter-clockwise at up to 9 deg/s
(angular), drive straight at up to 0.1 units/s (linear), or random motion with speeds in
[0.1, 0.5] units/s and turn rates in [-20, 20] deg/s changed at random times every 0 to 3 s, turning
in place at a random rate after a bump (random). ``swarm`` shares one random command stream
between all robots, each blending in a fraction ``jitter`` of its own draw.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from baselines.steps import BeliefView, Step


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
    """

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
        """Called by :class:`SwarmDuty` before each :meth:`commands` when this excitation is the
        robots' deviation: the shared commands ``v``, ``w`` ``(R,)`` of this step and the factor
        ``budget`` its own commands are scaled by. The default ignores them."""

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

    def _draw(self, low: float, high: float, who: np.ndarray) -> np.ndarray:
        return np.array([self.rngs[i].uniform(low, high) for i in who])


class Still(Excitation):
    """Do nothing (a robot that only watches)."""

    def commands(self, step: Step, dt: float) -> tuple[np.ndarray, np.ndarray]:
        return np.zeros(self.n), np.zeros(self.n)


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
        bumped = np.flatnonzero(step.bumper & (self.escape <= 0.0)) if step.bumper.any() else _NONE
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
        due_v = np.flatnonzero(self.v_timer <= 0.0) if self.v_timer.min() <= 0.0 else _NONE
        if len(due_v):
            self.v[due_v] = self._draw(*s.speed, due_v)
            self.v_timer[due_v] = self._draw(0.0, s.change_after, due_v)
        due_w = np.flatnonzero(self.w_timer <= 0.0) if self.w_timer.min() <= 0.0 else _NONE
        if len(due_w):
            self.w[due_w] = self._draw(-s.turn, s.turn, due_w)
            self.w_timer[due_w] = self._draw(0.0, s.change_after, due_w)
        return self._apply_escapes(dt, self.v, self.w)


_NONE = np.zeros(0, dtype=np.int64)  # no robot: skips np.flatnonzero on the common path


#: Jitter of the ``swarm`` excitation when named without one.
SWARM_JITTER = 0.05


class SwarmMotion(BumpEscape):
    """Random motion shared by all robots, with a per-robot jitter.

    The paper's random motion draws each robot's speed, turn rate and change times independently,
    which is what lets a robot tell its own motion from the others'. A swarm often moves as one: a
    shared command stream with small differences. One generator seeded by ``common_seed`` draws
    the shared speeds, turn rates and change times; each robot blends in its own draw from the same
    distribution by a factor ``jitter``: ``v_i = v_shared + jitter * (v_own_i - v_shared)``, so
    ``jitter = 0`` gives identical commands and ``jitter = 1`` independent values (with shared
    change times). After a bump a robot still turns away on its own, as in the paper.

    Robots that must share the stream but are driven by separate instances (one policy per robot)
    share it by being given the same ``common_seed`` (the CLI uses the episode seed).

    Args:
        jitter: how much of each robot's own random draw is blended in, in [0, 1].
        common_seed: seeds the shared command stream (e.g. the episode seed).
        settings: speeds, turn rates and change times (the paper's by default).
    """

    def __init__(
        self,
        jitter: float = SWARM_JITTER,
        common_seed: int = 0,
        settings: RandomSettings | None = None,
    ) -> None:
        super().__init__()
        if not 0.0 <= jitter <= 1.0:
            raise ValueError(f"swarm jitter must be in [0, 1], got {jitter}")
        self.jitter = jitter
        self.common_seed = common_seed
        self.settings = settings or RandomSettings()

    def reset(self, rngs: Sequence[np.random.Generator]) -> None:
        super().reset(rngs)
        s = self.settings
        # A stream of its own, apart from the env's and the robots' generators.
        self.common = np.random.default_rng([self.common_seed, 0x5_3A4D])
        self.v = self._blend(*s.speed)
        self.w = self._blend(-s.turn, s.turn)
        self.v_timer = self.common.uniform(0.0, s.change_after)
        self.w_timer = self.common.uniform(0.0, s.change_after)
        self._reset_escapes()

    def _blend(self, low: float, high: float) -> np.ndarray:
        shared = self.common.uniform(low, high)
        own = self._draw(low, high, np.arange(self.n))
        return np.asarray(shared + self.jitter * (own - shared))

    def commands(self, step: Step, dt: float) -> tuple[np.ndarray, np.ndarray]:
        s = self.settings
        self._start_escapes(step)
        self.v_timer -= dt
        self.w_timer -= dt
        if self.v_timer <= 0.0:
            self.v = self._blend(*s.speed)
            self.v_timer = self.common.uniform(0.0, s.change_after)
        if self.w_timer <= 0.0:
            self.w = self._blend(-s.turn, s.turn)
            self.w_timer = self.common.uniform(0.0, s.change_after)
        return self._apply_escapes(dt, self.v, self.w)


class SwarmDuty(Excitation):
    """Swarm duty: every robot follows one shared command stream and may only add a bounded
    deviation of its own.

    The shared stream is :class:`SwarmMotion` with jitter 0 (identical commands for all robots,
    each still turning away after a bump). The robot's own motion comes from ``deviation``, any
    excitation (or a learned policy), scaled by ``budget``, which is told the shared command and
    the budget before each step (:meth:`~baselines.excitations.Excitation.follow`)::

        v = v_shared + budget * v_own,   w = w_shared + budget * w_own

    With the own commands within the robot's limits, the deviation is at most ``budget * v_max``
    and ``budget * omega_max`` (the env then clips the sum to the limits).

    Args:
        deviation: the robots' own excitation.
        budget: fraction of ``v_max`` and ``omega_max`` the deviation may use, in [0, 1].
        common_seed: seeds the shared stream (robots of one episode must share it).
    """

    def __init__(self, deviation: Excitation, budget: float = 0.2, common_seed: int = 0) -> None:
        super().__init__()
        if not 0.0 <= budget <= 1.0:
            raise ValueError(f"budget must be in [0, 1], got {budget}")
        self.deviation = deviation
        self.budget = budget
        self.shared = SwarmMotion(0.0, common_seed)

    def reset(self, rngs: Sequence[np.random.Generator]) -> None:
        super().reset(rngs)
        self.shared.reset(rngs)
        self.deviation.reset(rngs)
        # The deviation knows it is on duty from the start (its first picture comes before the
        # first step's follow()).
        self.deviation.follow(self.shared.v, self.shared.w, self.budget)

    def on_observations(self, observations: Sequence[Mapping[str, Any]]) -> None:
        self.deviation.on_observations(observations)

    def on_picture(self, step: Step, view: BeliefView) -> None:
        self.deviation.on_picture(step, view)

    def commands(self, step: Step, dt: float) -> tuple[np.ndarray, np.ndarray]:
        v_shared, w_shared = self.shared.commands(step, dt)
        self.deviation.follow(v_shared, w_shared, self.budget)
        v_own, w_own = self.deviation.commands(step, dt)
        return v_shared + self.budget * v_own, w_shared + self.budget * w_own


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

    Turning in place (:class:`BumpEscape`) leaves a jammed robot where it is, and a robot that
    does not move cannot be told from another one that does not move either (without detected
    headings, a turn in place is invisible): jammed robots are the last ones identified under the
    paper's random motion. Reversing frees them and keeps them moving.

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

    def reset(self, rngs: Sequence[np.random.Generator]) -> None:
        """Start an episode with the excitation's generators (one per robot; drawn in turn with
        the excitation's own draws)."""
        self.rngs = list(rngs)
        self.backing = np.zeros(len(self.rngs))
        self.rate = np.zeros(len(self.rngs))

    def commands(
        self,
        step: Step,
        dt: float,
        own: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    ) -> tuple[np.ndarray, np.ndarray]:
        """The commands of this step: ``own(hit)`` (the excitation's ``(v, w)``, told which
        robots ``hit`` just bumped), with those of the robots reversing replaced."""
        hit = np.flatnonzero(step.bumper & (self.backing <= 0.0)) if step.bumper.any() else _NONE
        if len(hit):
            b = self.settings
            self.backing[hit] = [self.rngs[i].uniform(*b.back_time) for i in hit]
            self.rate[hit] = [self.rngs[i].uniform(-b.turn, b.turn) for i in hit]
        v, w = own(hit)
        backing = self.backing > 0.0
        self.backing = np.maximum(self.backing - dt, 0.0)
        return np.where(backing, -self.settings.back_speed, v), np.where(backing, self.rate, w)


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

    Args:
        settings: speeds, turn rates and the back-off (defaults above).
    """

    def __init__(self, settings: DistinctSettings | None = None) -> None:
        super().__init__()
        self.settings = settings or DistinctSettings()
        self.backoff = BackOff(self.settings)

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
