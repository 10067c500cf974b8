"""Swarm motion: one random command stream shared by all robots, with a per-robot jitter
(:class:`SwarmMotion`), or with a bounded deviation of each robot's own (:class:`SwarmDuty`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from baselines.excitations.base import Excitation
from baselines.excitations.random_motion import BumpEscape, RandomSettings
from baselines.steps import BeliefView, Step

#: Jitter of the ``swarm`` excitation when named without one.
SWARM_JITTER = 0.05
#: The share of the robot's limits ``v_max`` and ``omega_max`` a robot's own deviation may use on
#: swarm duty when none is given (:class:`SwarmDuty`): the one definition of the default budget
#: that the agent's spec, its training, the conditions, the limits and the benchmarks read.
DUTY_BUDGET = 0.2


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

    def __init__(
        self, deviation: Excitation, budget: float = DUTY_BUDGET, common_seed: int = 0
    ) -> None:
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
