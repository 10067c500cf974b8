"""The candidate commands that ``greedy``, ``uniform`` and the learned agent choose among: their
box (:class:`GreedySettings`, named for the excitation that introduced it), their draw
(:func:`candidate_commands`), a fair pick among them (:func:`coin`), and the base of the
excitations that hold one command in that box per picture (:class:`HeldCommand`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from baselines.excitations.backoff import DistinctSettings, check_command_box
from baselines.excitations.base import Excitation
from baselines.excitations.draws import uniform_rows
from baselines.excitations.gaps import GapSettings
from baselines.excitations.reflex import BumpReflex
from baselines.steps import Step


@dataclass
class GreedySettings:
    """Settings of ``baselines.active.GreedyIdentification`` (the candidates' number and box and
    the back-off also of ``uniform`` and the learned agent), all rates in SI units.

    Attributes:
        candidates: number of candidate commands drawn per robot and picture, >= 1.
        speed: range of candidate forward speeds (m/s). On swarm duty, deviations are drawn in
            ``[-speed[1], speed[1]]``.
        turn: largest candidate turn rate (rad/s); rates are uniform in ``[-turn, turn]``.
        others: the other robots' commands ``(v, w)`` (m/s, rad/s), equally likely; ``None``: a
            3 x 5 grid over the candidates' box (the other robots are like this one).
        hypotheses: most rows kept as hypotheses per robot, >= 1.
        floor: rows below this belief are no hypothesis, in [0, 1).
        ring_samples: points per ring when the heading is unknown, >= 1.
        energy_weight: nats of expected entropy worth one metre of wheel travel, >= 0; a small
            value breaks ties (a robot sure of itself drives the cheapest candidate).
        back: the back-off after a first bump (only ``back_speed``, ``back_time`` and ``turn``
            are used).
        escape: the back-off of a pressed robot, whose bumper fires again after it fired in
            the interval before (``baselines.excitations.reflex``; by default ``gaps``'
            escape: 0.08 m/s for 0.7 to 1.2 s at the full turn rate of 1 rad/s); ``None``: as
            after a first bump.
    """

    candidates: int = 8
    speed: tuple[float, float] = (0.1, 0.5)
    turn: float = 1.0
    others: tuple[tuple[float, float], ...] | None = None
    hypotheses: int = 6
    floor: float = 1e-3
    ring_samples: int = 8
    energy_weight: float = 0.1
    back: DistinctSettings = field(default_factory=DistinctSettings)
    escape: DistinctSettings | None = field(default_factory=lambda: GapSettings().escape())

    def __post_init__(self) -> None:
        for name in ("candidates", "hypotheses", "ring_samples"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
        check_command_box(self.speed, self.turn)
        if not 0.0 <= self.floor < 1.0:
            raise ValueError(f"floor must be in [0, 1), got {self.floor}")
        if not self.energy_weight >= 0.0:
            raise ValueError(f"energy_weight must be >= 0 nats/m, got {self.energy_weight}")
        if self.others is not None and len(self.others) == 0:
            raise ValueError("others must hold at least one command (v, w), or be None")

    def reflex(self) -> BumpReflex:
        """The bump reflex these settings describe (``back``, and ``escape`` when pressed)."""
        return BumpReflex(self.back, self.escape)

    def other_commands(self, deviation: bool) -> np.ndarray:
        """``(S, 2)`` the other robots' commands (deviations on swarm duty)."""
        if self.others is not None:
            return np.asarray(self.others, dtype=np.float64).reshape(-1, 2)
        low = -self.speed[1] if deviation else self.speed[0]
        v, w = np.meshgrid(
            np.linspace(low, self.speed[1], 3), np.linspace(-self.turn, self.turn, 5)
        )
        return np.stack([v.ravel(), w.ravel()], axis=1)


def candidate_commands(
    rngs: Sequence[np.random.Generator],
    candidates: int,
    speed: tuple[float, float],
    turn: float,
    deviation: bool,
) -> np.ndarray:
    """``(R, C, 2)`` candidate commands ``(v, w)``, robot ``i``'s from ``rngs[i]``: ``C``
    speeds uniform in ``speed`` (m/s; ``[-speed[1], speed[1]]`` for a swarm ``deviation``),
    then ``C`` turn rates uniform in ``[-turn, turn]`` (rad/s)."""
    low = -speed[1] if deviation else speed[0]
    drawn = uniform_rows(rngs, [(low, speed[1]), (-turn, turn)], candidates)  # (R, 2, C)
    return np.ascontiguousarray(drawn.transpose(0, 2, 1))


def coin(rngs: Sequence[np.random.Generator], sides: int) -> np.ndarray:
    """``(R,)`` one fair pick in ``[0, sides)`` per robot, one uniform number from each
    generator (the same number, and the same pick, as ``agents.policy.draw`` of zero logits)."""
    u = np.fromiter((rng.random() for rng in rngs), np.float64, len(rngs))
    return np.minimum((u * sides).astype(np.int64), sides - 1)


class HeldCommand(Excitation):
    """Base of the excitations that set one command per robot at every picture
    (``on_picture`` sets ``self.v``, ``self.w``), hold it until the next, reverse out of bumps
    and escape them when pressed (a :class:`~baselines.excitations.reflex.BumpReflex`); on swarm
    duty ``self.following`` is true from the reset on.

    Args:
        settings: the box of the commands and the bump reflex (``GreedySettings()`` by
            default).
    """

    backoff: BumpReflex  # narrows Excitation.backoff: this excitation always has one

    def __init__(self, settings: GreedySettings | None = None) -> None:
        super().__init__()
        self.settings = settings or GreedySettings()
        self.backoff = self.settings.reflex()
        self.following = False

    def reset(self, rngs: Sequence[np.random.Generator]) -> None:
        super().reset(rngs)
        self.v = np.zeros(self.n)
        self.w = np.zeros(self.n)
        self.following = False
        self.backoff.reset(rngs)

    def follow(self, v: np.ndarray, w: np.ndarray, budget: float) -> None:
        self.following = True

    def commands(self, step: Step, dt: float) -> tuple[np.ndarray, np.ndarray]:
        return self.backoff.commands(step, dt, lambda hit: (self.v, self.w))
