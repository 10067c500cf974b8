"""Episodes of an excitation on fixed seeds, and the censored pictures to 99 % they took.

Used by the training run's progress display (:class:`agents.callbacks.ProgressEvaluation`),
its closing comparison against random motion, and ``benchmarks/agent_eval.py``.

>>> results = play(config, "free", 0.2, lambda: make_excitation("random"), range(4), 20)
>>> censored_pictures(results, 20)  # doctest: +SKIP
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import numpy as np

import anonloc_env
import baselines
from agents.spec import on_duty
from anonloc_env.config import EnvConfig
from baselines.excitations import Excitation
from baselines.runner import EpisodeResult, run_episode
from baselines.scoring import pictures_to_identify


def play(
    config: EnvConfig,
    condition: str,
    budget: float,
    make: Callable[[], Excitation],
    seeds: Iterable[int],
    pictures: int,
) -> list[EpisodeResult]:
    """One episode per seed of ``bayes`` robots driven by ``make()``'s excitation (the deviation
    of ``baselines.excitations.SwarmDuty``, seeded by the episode seed, on ``swarm``
    duty), up to ``pictures`` pictures after the first."""
    env = anonloc_env.AnonLocEnv(config, reward_fn=anonloc_env.EnergyCost())
    out = []
    for seed in seeds:
        excitation = on_duty(condition, make(), budget, common_seed=seed)
        team = baselines.make_team("bayes", env, excitation=excitation)
        out.append(run_episode(env, team, seed, max_pictures=pictures + 1))
    env.close()
    return out


def censored(result: EpisodeResult, pictures: int) -> tuple[int, float]:
    """``(picture, energy)`` at which 99 % of the robots present were identified, or, for an
    episode that never got there, ``pictures`` and the energy spent by its last picture."""
    first, energy = pictures_to_identify(result)
    if first is not None:
        return first, energy
    last = max(rec.picture for rec in result.records)
    return pictures, float(np.mean([r.energy for r in result.records if r.picture == last]))


def censored_pictures(results: list[EpisodeResult], pictures: int) -> float:
    """The censored mean pictures to 99 % over ``results`` (see :func:`censored`)."""
    return float(np.mean([censored(r, pictures)[0] for r in results]))
