"""Retrain the agent bundled with the package (``agents/data/agent.zip``), from a fresh clone.

Usage (from the repository's root, after the README's install with the ``rl`` extra)::

    python -m benchmarks.train_bundled --minutes 40 --out runs
    cp runs/bundled/selected.zip agents/data/agent.zip

It runs :func:`agents.train.train` with :data:`BUNDLED`: scenarios drawn across conditions
(``condition="mixed"``, :mod:`agents.conditions`: N in 3, 6, 14, 30 and 40, density, noise,
headings, misses and false positives, free or swarm, redrawn every episode), ``greedy``
imitated first (``imitation`` robot-decisions, softened by ``temperature``), then PPO with the
``team`` reward until the wall-clock budget ends. One seed; on 2 cores with nothing else
running, ``--minutes 30`` gives about the run behind the bundled agent (``docs/agents.md``
states the figures). The run ends by printing its pictures to 99 % against random motion on
the progress display's evaluation seeds.

Then it selects the checkpoint to ship (early stopping on a validation condition): every
``--every``-th checkpoint and the final agent play 40 episodes of the progress display's
condition (14 robots, a training N; seeds 900000 to 900039, never an evaluation seed), and the
one with the fewest pictures to 99 % (censored mean; ties: less energy) is copied to
``selected.zip`` in the run folder.
"""

from __future__ import annotations

import argparse
import dataclasses
import re
import shutil
from pathlib import Path

import numpy as np

from agents.evaluation import censored, play
from agents.policy import LearnedExcitation, load_model
from agents.train import PROGRESS_SEEDS, TrainConfig, evaluation_scenario, train

#: The bundled agent's training run (``minutes`` and ``out`` come from the command line).
BUNDLED = TrainConfig(
    condition="mixed",
    reward="team",
    energy_weight=0.3,
    imitation=40_000,
    temperature=30.0,
    n_envs=12,
    n_steps=32,
    batch_size=880,
    n_epochs=4,
    learning_rate=3e-4,
    gamma=0.95,
    ent_coef=0.01,
    eval_episodes=8,
    timesteps=10**8,
    checkpoint_every=35_200,
    seed=0,
    name="bundled",
    progress=True,
)


#: Validation episodes per candidate checkpoint.
VALIDATION_EPISODES = 40


def validate(path: Path, config: TrainConfig) -> tuple[float, float]:
    """Censored pictures to 99 % and energy (m) of the agent at ``path`` on the validation
    condition (see the module doc)."""
    scenario, condition, budget = evaluation_scenario(config)
    model = load_model(path)
    seeds = range(PROGRESS_SEEDS, PROGRESS_SEEDS + VALIDATION_EPISODES)
    pictures = int(scenario.max_cycles * scenario.dt / scenario.schedule.picture_interval)
    results = play(scenario, condition, budget, lambda: LearnedExcitation(model), seeds, pictures)
    firsts, spent = zip(*(censored(r, pictures) for r in results), strict=True)
    return float(np.mean(firsts)), float(np.mean(spent))


def select(directory: Path, config: TrainConfig, every: int) -> Path:
    """Validate every ``every``-th checkpoint and the final agent; copy the best to
    ``selected.zip`` and return it."""
    found = sorted(
        (directory / "checkpoints").glob("agent_*_steps.zip"),
        key=lambda p: int(re.findall(r"\d+", p.stem)[-1]),
    )
    candidates = [*found[every - 1 :: every], directory / "agent.zip"]
    scores = {}
    for path in candidates:
        scores[path] = validate(path, config)
        print(f"{path.name}: {scores[path][0]:.2f} pictures, {scores[path][1]:.2f} m", flush=True)
    best = min(scores, key=lambda p: scores[p])
    shutil.copyfile(best, directory / "selected.zip")
    print(f"selected {best.name}", flush=True)
    return directory / "selected.zip"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=40.0, help="wall-clock budget")
    parser.add_argument("--out", default="runs", help="folder of the runs")
    parser.add_argument("--every", type=int, default=10, help="validate every k-th checkpoint")
    args = parser.parse_args()
    config = dataclasses.replace(BUNDLED, minutes=args.minutes, out=args.out)
    result = train(config)
    print(result, flush=True)
    select(result.directory, config, args.every)


if __name__ == "__main__":
    main()
