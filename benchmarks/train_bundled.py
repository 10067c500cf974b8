"""Retrain the agent bundled with the package (``agents/data/agent.zip``), from a fresh clone.

Usage (from the repository's root, after the README's install with the ``rl`` extra)::

    python -m benchmarks.train_bundled --minutes 30 --out runs
    cp runs/bundled/agent.zip agents/data/agent.zip

It runs :func:`agents.train.train` with :data:`BUNDLED`: scenarios drawn across conditions
(``condition="mixed"``, :mod:`agents.conditions`: N in 3, 6, 14, 30 and 40, density, noise,
headings, misses and false positives, free or swarm, redrawn every episode), ``greedy``
imitated first (``imitation`` robot-decisions, softened by ``temperature``), then PPO with the
``team`` reward until the wall-clock budget ends. One seed; on 2 cores with nothing else
running, ``--minutes 30`` gives about the run behind the bundled agent (``docs/agents.md``
states the figures). The run ends by printing its pictures to 99 % against random motion on
the progress display's evaluation seeds.
"""

from __future__ import annotations

import argparse
import dataclasses

from agents.train import TrainConfig, train

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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=30.0, help="wall-clock budget")
    parser.add_argument("--out", default="runs", help="folder of the runs")
    args = parser.parse_args()
    result = train(dataclasses.replace(BUNDLED, minutes=args.minutes, out=args.out))
    print(result, flush=True)


if __name__ == "__main__":
    main()
