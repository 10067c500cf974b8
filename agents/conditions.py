"""The training conditions of a general agent: scenarios drawn at random, one per env copy.

A general agent is trained across conditions so that one set of weights holds at any N, density,
noise, clutter, camera and duty (the observation's size does not depend on any of them, see
:mod:`agents.candidate_features`). :func:`training_scenarios` draws them from one seed; the
evaluation conditions of ``docs/agents.md`` are held out: their numbers of robots (10, 20, 50,
100, 1000) are never drawn, and their seeds are never used in training.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

import anonloc_env
from anonloc_env.config import EnvConfig
from baselines.excitations.swarm import DUTY_BUDGET

#: Numbers of robots drawn in training (none of the evaluation conditions' N).
TRAINING_ROBOTS = (3, 6, 14, 30, 40)


@dataclass(frozen=True)
class ConditionRanges:
    """What :func:`training_scenarios` draws from (uniformly, unless said otherwise).

    Attributes:
        robots: numbers of robots, one drawn per copy.
        density: robots per square metre, ``(low, high)`` (drawn log-uniform; up to 6, crowds
            where most robots touch another in most intervals, ``docs/crowds.md``).
        pixel_noise: detection noise (image units, ``(low, high)``).
        p_headings: probability that the camera detects headings.
        p_clutter: probability of a picture with misses and false positives.
        p_miss: miss probability where there is clutter ``(low, high)``.
        false_positives: mean false positives per picture where there is clutter.
        p_swarm: probability of swarm duty.
        budget: swarm deviation budget ``(low, high)``.
        pictures: pictures per episode.
        energy_weight: the reward lost per metre of wheel travel (``reward.energy_weight``).
    """

    robots: tuple[int, ...] = TRAINING_ROBOTS
    density: tuple[float, float] = (0.5, 6.0)
    pixel_noise: tuple[float, float] = (0.5, 2.0)
    p_headings: float = 0.25
    p_clutter: float = 0.4
    p_miss: tuple[float, float] = (0.0, 0.15)
    false_positives: tuple[float, float] = (0.0, 4.0)
    p_swarm: float = 0.25
    budget: tuple[float, float] = (0.1, 0.4)
    pictures: int = 20
    energy_weight: float = 0.3

    def __post_init__(self) -> None:
        if not self.robots or any(n < 1 for n in self.robots):
            raise ValueError(f"robots must be numbers >= 1, got {self.robots}")
        for name in ("p_headings", "p_clutter", "p_swarm"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"{name} must be in [0, 1], got {value}")
        for name in ("density", "pixel_noise", "p_miss", "false_positives", "budget"):
            low, high = getattr(self, name)
            if not 0.0 <= low <= high:
                raise ValueError(f"{name} must be (low, high), 0 <= low <= high: {low, high}")
        if self.density[0] <= 0.0 or self.p_miss[1] >= 1.0 or self.budget[1] > 1.0:
            raise ValueError("density must be > 0, p_miss < 1 and budget <= 1")
        if not self.energy_weight >= 0.0:
            raise ValueError(f"energy_weight must be >= 0, got {self.energy_weight}")
        if self.pictures < 2:
            raise ValueError(f"pictures must be >= 2, got {self.pictures}")


@dataclass(frozen=True)
class Scenario:
    """One drawn condition: the env's config, ``free`` or ``swarm``, and the swarm budget."""

    config: EnvConfig
    condition: str
    budget: float


def draw_scenario(rng: np.random.Generator, ranges: ConditionRanges | None = None) -> Scenario:
    """One scenario drawn with ``rng`` from ``ranges`` (see :class:`ConditionRanges`)."""
    r = ranges or ConditionRanges()
    n = int(rng.choice(r.robots))
    density = math.exp(rng.uniform(math.log(r.density[0]), math.log(r.density[1])))
    side = math.sqrt(n / density)
    clutter = rng.random() < r.p_clutter
    camera = {
        "pixel_noise": float(rng.uniform(*r.pixel_noise)),
        "orientation": bool(rng.random() < r.p_headings),
        "p_miss": float(rng.uniform(*r.p_miss)) if clutter else 0.0,
        "false_positives": float(rng.uniform(*r.false_positives)) if clutter else 0.0,
    }
    swarm = rng.random() < r.p_swarm
    config = anonloc_env.make_config(
        n_robots=n,
        arena_size=(side, side),
        camera=camera,
        reward={"energy_weight": r.energy_weight},
        max_cycles=round(r.pictures / 0.05) + 1,
    )
    return Scenario(config, "swarm" if swarm else "free", float(rng.uniform(*r.budget)))


def training_scenarios(
    copies: int, seed: int, ranges: ConditionRanges | None = None
) -> list[Scenario]:
    """``copies`` scenarios drawn from ``seed`` (one per env copy of a training run)."""
    rng = np.random.default_rng([seed, 0xC0DE])
    return [draw_scenario(rng, ranges) for _ in range(copies)]


#: The validation condition's robots: a training N, none of the evaluation conditions'.
VALIDATION_ROBOTS = 14
#: Validation episodes are seeded from here up (never a training or an evaluation seed: the
#: evaluation seeds of ``benchmarks/agent_eval.py`` start at 100000 and stay below this).
VALIDATION_SEEDS = 900_000


#: Robots per square metre of the crowded validation condition (the crowds of
#: ``benchmarks/agent_conditions.py`` and ``docs/crowds.md``).
VALIDATION_CROWD_DENSITY = 4.0


def validation_scenario(
    condition: str = "free", budget: float = DUTY_BUDGET, pictures: int = 20, density: float = 1.0
) -> Scenario:
    """The validation condition of training runs and searches: :data:`VALIDATION_ROBOTS` robots
    at ``density`` robots per square metre (one; :data:`VALIDATION_CROWD_DENSITY` for the
    crowded one), 1 px of noise, no headings, ``pictures`` pictures, in ``condition`` (``free``
    or ``swarm`` with deviation ``budget``)."""
    side = (VALIDATION_ROBOTS / density) ** 0.5
    config = anonloc_env.make_config(
        n_robots=VALIDATION_ROBOTS,
        arena_size=(side, side),
        camera={"pixel_noise": 1.0, "orientation": False},
        max_cycles=round(pictures / 0.05) + 1,
    )
    return Scenario(config, condition, budget)
