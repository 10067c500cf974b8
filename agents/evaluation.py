"""Episodes of an excitation on fixed seeds, and the censored pictures to 99 % they took.

Used by the training run's progress display (:class:`agents.callbacks.ProgressEvaluation`),
its closing comparison against random motion, ``benchmarks/agent_eval.py``, and the
validations against ``uniform`` of a search and of a checkpoint selection
(:func:`validate_against_uniform`).

>>> results = play(config, "free", 0.2, lambda: make_excitation("random"), range(4), 20)
>>> censored_pictures(results, 20)  # doctest: +SKIP
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import numpy as np

import anonloc_env
import baselines
from agents.conditions import (
    VALIDATION_CROWD_DENSITY,
    VALIDATION_SEEDS,
    Scenario,
    validation_scenario,
)
from agents.spec import on_duty
from anonloc_env.config import EnvConfig
from baselines.excitations import Excitation
from baselines.excitations.uniform import UniformChoice
from baselines.runner import EpisodeResult, run_episode
from baselines.scoring import pictures_to_identify
from baselines.statistics import Interval95, paired_ratio


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


@dataclass(frozen=True)
class Validation:
    """An excitation against ``uniform`` on one validation condition, on the same episodes.

    Attributes:
        pictures: the ratio of censored mean pictures to 99 %, with its paired 95 % interval.
        energy: the ratio of mean energy to 99 %, with its paired 95 % interval.
        mean: the excitation's censored mean pictures to 99 %.
        uniform: ``uniform``'s censored mean pictures to 99 %.
    """

    pictures: Interval95
    energy: Interval95
    mean: float
    uniform: float


#: Plays a validation condition: ``(scenario, which, seeds, pictures) -> (len(seeds), 2)``
#: censored pictures and energy to 99 %, ``which`` 0 for the excitation, 1 for its ablation.
Player = Callable[[Scenario, int, Sequence[int], int], np.ndarray]


def validation_scenarios(
    crowd: bool = False, pictures: int = 20, keys: Sequence[str] | None = None
) -> list[tuple[str, Scenario]]:
    """The validation conditions by key: ``free`` and ``swarm`` (one robot per m²) and, with
    ``crowd``, ``crowd`` (:data:`agents.conditions.VALIDATION_CROWD_DENSITY` robots per m²,
    free motion); only those named in ``keys`` when given."""
    where = [("free", "free", 1.0), ("swarm", "swarm", 1.0)]
    if crowd:
        where.append(("crowd", "free", VALIDATION_CROWD_DENSITY))
    return [
        (key, validation_scenario(condition, pictures=pictures, density=density))
        for key, condition, density in where
        if keys is None or key in keys
    ]


def validate_against_uniform(
    make: Callable[[], Excitation],
    episodes: int,
    pictures: int,
    ablation: Callable[[], Excitation] = UniformChoice,
    crowd: bool = False,
    player: Player | None = None,
    keys: Sequence[str] | None = None,
    ablation_cache: dict[str, np.ndarray] | None = None,
) -> dict[str, Validation]:
    """``make()``'s excitation against ``ablation()`` (default ``uniform``, its no-learning
    ablation; ``uniform-rest`` for an agent that rests) on the validation condition
    (:func:`agents.conditions.validation_scenario`, seeds from
    :data:`agents.conditions.VALIDATION_SEEDS`), in free motion and on swarm duty (keys
    ``free`` and ``swarm``) and, with ``crowd``, in free motion at
    :data:`agents.conditions.VALIDATION_CROWD_DENSITY` robots per m² (key ``crowd``),
    ``episodes`` episodes of ``pictures`` pictures each. ``player`` plays the episodes instead
    (the same episodes: a search's pool of processes, ``agents.search``); ``keys``: only
    these conditions (default: all of them). ``ablation_cache``: the ablation's episodes by
    key, filled on first use and read after (a search validates many ``make`` against one
    ablation: its episodes are played once; the caller keeps ``episodes`` and ``pictures``
    fixed for one cache)."""
    seeds = range(VALIDATION_SEEDS, VALIDATION_SEEDS + episodes)
    makers = (make, ablation)

    def here(scenario: Scenario, which: int, seeds: Sequence[int], pictures: int) -> np.ndarray:
        played = play(
            scenario.config, scenario.condition, scenario.budget, makers[which], seeds, pictures
        )
        return np.array([censored(r, pictures) for r in played])

    out = {}
    for key, scenario in validation_scenarios(crowd, pictures, keys):
        play_one = player or here
        mine = play_one(scenario, 0, seeds, pictures)
        if ablation_cache is not None and key in ablation_cache:
            chance = ablation_cache[key]
        else:
            chance = play_one(scenario, 1, seeds, pictures)
            if ablation_cache is not None:
                ablation_cache[key] = chance
        out[key] = Validation(
            paired_ratio(mine[:, 0], chance[:, 0]),
            paired_ratio(mine[:, 1], chance[:, 1]),
            float(mine[:, 0].mean()),
            float(chance[:, 0].mean()),
        )
    return out
