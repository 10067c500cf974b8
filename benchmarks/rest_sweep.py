"""Where to rest: ``uniform-rest`` at several beliefs, and the bundled agent's weights scaled
towards ``uniform``, each against ``uniform`` on the same seeds (``docs/agents.md``, *Where to
rest*).

Two sweeps, each printing paired ratios (censored mean pictures to 99 %, mean energy to 99 %)
with 95 % bootstrap intervals (:func:`baselines.statistics.paired_ratio`):

* ``thresholds``: ``RestWhenSure(uniform, sure)`` for each ``--sure`` on the named evaluation
  conditions (:func:`benchmarks.agent_conditions.evaluation_conditions`), seeds from
  ``--first-seed`` (default 910000: never an evaluation, validation or training seed);
* ``scaled``: the bundled agent's linear weights times each ``--scale`` (0: ``uniform``), at rest
  at ``--sure``, on the validation condition (:func:`agents.evaluation.validate_against_uniform`:
  14 robots, free and swarm, seeds 900000 and up); needs the ``rl`` extra.

Usage::

    python -m benchmarks.rest_sweep thresholds --conditions "free N=30" --episodes 60 \\
        --sure 0.999 0.9999 0.99999
    python -m benchmarks.rest_sweep scaled --episodes 60 --sure 0.9999 --scale 0 0.5 1
"""

from __future__ import annotations

import argparse
from functools import partial

import numpy as np

from agents.evaluation import censored, play, validate_against_uniform
from baselines.excitations.rest import uniform_rest
from baselines.excitations.uniform import UniformChoice
from baselines.statistics import paired_ratio
from benchmarks.agent_conditions import evaluation_conditions

PICTURES = 30
#: Pictures per validation episode of the ``scaled`` sweep (the search's).
VALIDATION_PICTURES = 12


def thresholds(conditions: list[str], sures: list[float], episodes: int, first: int) -> None:
    """Print ``uniform-rest`` at each belief of ``sures`` against ``uniform``."""
    seeds = range(first, first + episodes)
    for name in conditions:
        config, condition, budget = evaluation_conditions(PICTURES)[name]
        runs = {}
        for sure in [None, *sures]:
            make = UniformChoice if sure is None else partial(uniform_rest, sure)
            results = play(config, condition, budget, make, seeds, PICTURES)
            runs[sure] = np.array([censored(r, PICTURES) for r in results], np.float64)
        base = runs[None]
        print(f"{name}: uniform {base[:, 0].mean():.2f} pictures, {base[:, 1].mean():.2f} m")
        for sure in sures:
            got = runs[sure]
            pictures = paired_ratio(got[:, 0], base[:, 0])
            energy = paired_ratio(got[:, 1], base[:, 1])
            print(f"  rest at {sure}: pictures {pictures}, energy {energy}", flush=True)


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
    parser.add_argument("sweep", choices=["thresholds", "scaled"])
    parser.add_argument("--conditions", nargs="+", default=["free N=30", "free N=100"])
    parser.add_argument("--sure", type=float, nargs="+", default=[0.999, 0.9999, 0.99999])
    parser.add_argument("--scale", type=float, nargs="+", default=[0.0, 0.25, 0.5, 0.75, 1.0])
    parser.add_argument("--episodes", type=int, default=60)
    parser.add_argument("--first-seed", type=int, default=910_000)
    args = parser.parse_args()
    if args.sweep == "thresholds":
        thresholds(args.conditions, args.sure, args.episodes, args.first_seed)
    else:
        scaled(args.scale, args.sure[0], args.episodes)


if __name__ == "__main__":
    main()
