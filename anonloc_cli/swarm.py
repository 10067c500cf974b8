"""Swarm-like motion: every robot gets almost the same commands (the ``swarm`` sweep).

The paper's random motion (:class:`baselines.excitations.RandomMotion`) draws each robot's speed,
turn rate and change times independently, which is what lets a robot tell its own motion from the
others'. A swarm often moves as one: a shared command stream with small differences. Here one
generator seeded by ``common_seed`` draws the shared speeds, turn rates and change times; each
robot blends in its own draw from the same distribution by a factor ``jitter``::

    v_i = v_shared + jitter * (v_own_i - v_shared)

so ``jitter = 0`` gives identical commands and ``jitter = 1`` independent values (with shared change
times). After a bump a robot still turns away on its own, as in the paper.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from baselines.excitations import BumpEscape, RandomSettings
from baselines.observations import Step


class SwarmMotion(BumpEscape):
    """Random motion shared by all robots, with a per-robot jitter.

    Args:
        jitter: how much of each robot's own random draw is blended in, in [0, 1].
        common_seed: seeds the shared command stream (e.g. the episode seed).
        settings: speeds, turn rates and change times (the paper's by default).
    """

    def __init__(
        self, jitter: float, common_seed: int, settings: RandomSettings | None = None
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
