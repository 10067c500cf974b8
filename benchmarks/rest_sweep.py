"""Where to rest: ``uniform-rest`` at several beliefs, and the bundled agent's weights scaled
towards ``uniform``, each against ``uniform`` on the same seeds (``docs/agents.md``, *Where to
rest*).

Three sweeps, each printing paired ratios (censored mean pictures to 99 %, mean energy to 99 %)
with 95 % bootstrap intervals (:func:`baselines.statistics.paired_ratio`):

* ``thresholds``: ``RestWhenSure(uniform, sure)`` for each ``--sure`` on the named evaluation
  conditions (:func:`benchmarks.agent_conditions.evaluation_conditions`), seeds from
  ``--first-seed`` (default 910000: never an evaluation, validation or training seed);
* ``probes``: ``RestWhenSure(uniform, sure, probe)`` for each ``--probe`` (0: a rest that never
  probes) at the first ``--sure``, on the named conditions, seeds as for ``thresholds``;
* ``scaled``: the bundled agent's linear weights times each ``--scale`` (0: ``uniform``), at rest
  at ``--sure``, on the validation condition (:func:`agents.evaluation.validate_against_uniform`:
  14 robots, free and swarm, seeds 900000 and up); needs the ``rl`` extra.

Usage::

    python -m benchmarks.rest_sweep thresholds --conditions "free N=30" --episodes 60 \\
        --sure 0.999 0.9999 0.99999
    python -m benchmarks.rest_sweep probes --conditions "free N=30" --episodes 60 --sure 0.9999 \\
        --probe 0 3 5
    python -m benchmarks.rest_sweep scaled --episodes 60 --sure 0.9999 --scale 0 0.5 1
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Mapping
from functools import partial
from typing import Any

import numpy as np

from agents.evaluation import censored, play, validate_against_uniform
from baselines.excitations import Excitation
from baselines.excitations.rest import RestWhenSure, uniform_rest
from baselines.excitations.uniform import UniformChoice
from baselines.statistics import paired_ratio
from benchmarks.agent_conditions import evaluation_conditions

PICTURES = 30
#: Pictures per validation episode of the ``scaled`` sweep (the search's).
VALIDATION_PICTURES = 12


def against_uniform(
    conditions: list[str],
    makers: Mapping[str, Callable[[], Excitation]],
    episodes: int,
    first: int,
) -> None:
    """Print each of ``makers`` against ``uniform`` on each condition, paired on the seeds."""
    seeds = range(first, first + episodes)
    for name in conditions:
        task = evaluation_conditions(PICTURES)[name]

        def run(make: Callable[[], Excitation], task: tuple[Any, str, float] = task) -> np.ndarray:
            results = play(*task, make, seeds, PICTURES)
            return np.array([censored(r, PICTURES) for r in results], np.float64)

        base = run(UniformChoice)
        print(f"{name}: uniform {base[:, 0].mean():.2f} pictures, {base[:, 1].mean():.2f} m")
        for label, make in makers.items():
            got = run(make)
            pictures = paired_ratio(got[:, 0], base[:, 0])
            energy = paired_ratio(got[:, 1], base[:, 1])
            print(f"  {label}: pictures {pictures}, energy {energy}", flush=True)


def thresholds(conditions: list[str], sures: list[float], episodes: int, first: int) -> None:
    """Print ``uniform-rest`` at each belief of ``sures`` against ``uniform``."""
    makers = {f"rest at {sure}": partial(uniform_rest, sure) for sure in sures}
    against_uniform(conditions, makers, episodes, first)


def probes(
    conditions: list[str], sure: float, probes: list[int], episodes: int, first: int
) -> None:
    """Print ``uniform-rest`` at ``sure`` probing every ``probe`` pictures (0: never) against
    ``uniform``."""

    def maker(probe: int | None) -> Callable[[], Excitation]:
        return lambda: RestWhenSure(UniformChoice(), sure, probe)

    makers = {f"rest at {sure}, probe {probe or 'never'}": maker(probe or None) for probe in probes}
    against_uniform(conditions, makers, episodes, first)


def scaled(scales: list[float], sure: float, episodes: int) -> None:
    """Print the bundled agent's weights times each of ``scales``, at rest at ``sure``, against
    ``uniform`` on the validation condition."""
    from agents.policy import load_model
    from agents.search import chooser

    weights = load_model("bundled").policy.scorer.weights.detach().numpy().astype(np.float64)
    for scale in scales:
        validations = validate_against_uniform(
            chooser(scale * weights, sure), episodes, VALIDATION_PICTURES
        )
        text = ", ".join(
            f"{c}: pictures {v.pictures}, energy {v.energy}" for c, v in validations.items()
        )
        print(f"weights x {scale}: {text}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sweep", choices=["thresholds", "probes", "scaled"])
    parser.add_argument("--conditions", nargs="+", default=["free N=30", "free N=100"])
    parser.add_argument("--sure", type=float, nargs="+", default=[0.999, 0.9999, 0.99999])
    parser.add_argument("--scale", type=float, nargs="+", default=[0.0, 0.25, 0.5, 0.75, 1.0])
    parser.add_argument("--probe", type=int, nargs="+", default=[0, 3])
    parser.add_argument("--episodes", type=int, default=60)
    parser.add_argument("--first-seed", type=int, default=910_000)
    args = parser.parse_args()
    if args.sweep == "thresholds":
        thresholds(args.conditions, args.sure, args.episodes, args.first_seed)
    elif args.sweep == "probes":
        probes(args.conditions, args.sure[0], args.probe, args.episodes, args.first_seed)
    else:
        scaled(args.scale, args.sure[0], args.episodes)


if __name__ == "__main__":
    main()
