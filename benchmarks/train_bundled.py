"""Retrain the agent bundled with the package (``agents/data/agent.zip``), from a fresh clone.

Usage (from the repository's root, after the README's install with the ``rl`` extra)::

    python -m benchmarks.train_bundled --minutes 45 --out runs
    cp runs/bundled/selected.zip agents/data/agent.zip

It runs :func:`agents.train.train` with :data:`BUNDLED`: scenarios drawn across conditions
(``condition="mixed"``, :mod:`agents.conditions`: N in 3, 6, 14, 30 and 40, density, noise,
headings, misses and false positives, free or swarm, redrawn every episode), PPO **from
chance** (``imitation=0``: the scorer's last layer is zeroed, so the first policy is
``uniform`` bit for bit), each robot rewarded for its own log-belief and its own wheel travel
(``reward="log_belief"``, ``energy_weight=0.3`` per metre), until the wall-clock budget ends.
One seed. The run ends by printing its pictures to 99 % against random motion on the progress
display's evaluation seeds.

Then it selects the checkpoint to ship against chance (early stopping on the validation
condition of :func:`agents.conditions.validation_scenario`: 30 robots at one per square metre,
seeds 900000 and up, never an evaluation seed): every ``--every``-th checkpoint and the final
agent play ``--episodes`` episodes in free motion and on swarm duty, beside ``uniform`` on the
same seeds, and the one with the smallest cost ``log(P / P_uniform) + 0.5 log(E / E_uniform)``
(P the censored pictures to 99 %, E the energy to 99 %; the cost of ``agents.search``), averaged
over the two conditions, is copied to ``selected.zip`` in the run folder.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import re
import shutil
from pathlib import Path

import numpy as np

from agents.evaluation import validate_against_uniform
from agents.policy import as_saved, load_model
from agents.train import TrainConfig, train
from baselines.statistics import Interval95

#: The bundled agent's training run (``minutes`` and ``out`` come from the command line).
BUNDLED = TrainConfig(
    condition="mixed",
    reward="log_belief",
    energy_weight=0.3,
    imitation=0,
    n_envs=12,
    n_steps=16,
    batch_size=384,
    n_epochs=4,
    learning_rate=3e-4,
    gamma=0.99,
    ent_coef=0.0,
    eval_episodes=4,
    timesteps=10**8,
    checkpoint_every=150_000,
    seed=0,
    name="bundled",
    progress=True,
)


#: Validation episodes per candidate checkpoint and condition.
VALIDATION_EPISODES = 30

#: Weight of the energy ratio in the selection cost (as ``agents.search.SearchConfig``).
ENERGY_WEIGHT = 0.5


#: Pictures per validation episode (an episode that does not reach 99 % counts at this one).
VALIDATION_PICTURES = 20


def validate(path: Path, episodes: int = VALIDATION_EPISODES) -> dict[str, tuple[Interval95, ...]]:
    """The agent at ``path`` against ``uniform`` on the validation condition, free and on swarm
    duty: per condition, the paired ratios of censored means (pictures, energy), with 95 %
    bootstrap intervals (:func:`agents.evaluation.validate_against_uniform`)."""
    model = load_model(path)
    validations = validate_against_uniform(lambda: as_saved(model), episodes, VALIDATION_PICTURES)
    return {condition: (v.pictures, v.energy) for condition, v in validations.items()}


def cost(ratios: dict[str, tuple[Interval95, ...]]) -> float:
    """``log(P / P_uniform) + ENERGY_WEIGHT log(E / E_uniform)``, averaged over conditions."""
    return float(
        np.mean([math.log(p.mean) + ENERGY_WEIGHT * math.log(e.mean) for p, e in ratios.values()])
    )


def select(directory: Path, every: int, episodes: int = VALIDATION_EPISODES) -> Path:
    """Validate every ``every``-th checkpoint and the final agent; copy the one of least
    :func:`cost` to ``selected.zip`` and return it."""
    found = sorted(
        (directory / "checkpoints").glob("agent_*_steps.zip"),
        key=lambda p: int(re.findall(r"\d+", p.stem)[-1]),
    )
    candidates = [*found[every - 1 :: every], directory / "agent.zip"]
    scores = {}
    for path in candidates:
        ratios = validate(path, episodes)
        scores[path] = cost(ratios)
        shown = "; ".join(
            f"{c}: pictures {p.mean:.3f}x [{p.low:.3f}, {p.high:.3f}], "
            f"energy {e.mean:.3f}x [{e.low:.3f}, {e.high:.3f}]"
            for c, (p, e) in ratios.items()
        )
        print(f"{path.name}: {shown}; cost {scores[path]:+.4f}", flush=True)
    best = min(scores, key=lambda p: scores[p])
    shutil.copyfile(best, directory / "selected.zip")
    print(f"selected {best.name}", flush=True)
    return directory / "selected.zip"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=45.0, help="wall-clock budget")
    parser.add_argument("--out", default="runs", help="folder of the runs")
    parser.add_argument("--every", type=int, default=3, help="validate every k-th checkpoint")
    parser.add_argument("--select-only", type=Path, help="only select among this run's agents")
    args = parser.parse_args()
    if args.select_only is not None:
        select(args.select_only, args.every)
        return
    config = dataclasses.replace(BUNDLED, minutes=args.minutes, out=args.out)
    result = train(config)
    print(result, flush=True)
    select(result.directory, args.every)


if __name__ == "__main__":
    main()
