"""Train the learned excitations of ``docs/agents.md`` (the runs behind its results table).

Usage::

    python benchmarks/train_conditions.py free-10 10 free 28            # Deep Sets, 28 minutes
    python benchmarks/train_conditions.py swarm-10 10 swarm 28
    python benchmarks/train_conditions.py free-100 100 free 28
    python benchmarks/train_conditions.py free-10-flat 10 free 28 flat
    python benchmarks/train_conditions.py free-10-attention 10 free 20 attention

Arguments: run name, N, condition (``free`` or ``swarm``), wall-clock minutes, and optionally the
extractor (default ``deepsets``). The scenario: N robots in an arena of side sqrt(N) m, 1 px of
pixel noise, no detected headings, episodes of 400 control steps (20 pictures). Runs are written
under ``--out`` (default ``runs/``); evaluate them with ``benchmarks/excitations.py --agent``.
"""

from __future__ import annotations

import argparse
import math

from agents.train import TrainConfig, train


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("name")
    parser.add_argument("robots", type=int)
    parser.add_argument("condition", choices=["free", "swarm"])
    parser.add_argument("minutes", type=float)
    parser.add_argument("extractor", nargs="?", default="deepsets")
    parser.add_argument("--out", default="runs")
    args = parser.parse_args()
    side = math.sqrt(args.robots)
    config = TrainConfig(
        overrides={
            "n_robots": args.robots,
            "arena_size": (side, side),
            "camera": {"pixel_noise": 1.0, "orientation": False},
            "max_cycles": 400,
        },
        condition=args.condition,
        timesteps=10**8,
        minutes=args.minutes,
        n_envs=max(1, 40 // args.robots),
        out=args.out,
        name=args.name,
        extractor=args.extractor,
        energy_weight=0.3,
        ent_coef=0.005,
        gamma=0.95,
        checkpoint_every=100_000,
        seed=0,
    )
    print(train(config), flush=True)


if __name__ == "__main__":
    main()
