"""BenchMARL's MAPPO on the belief task, beside the bundled agent and ``uniform``.

Trains MAPPO (BenchMARL 1.5, MLP actor on each robot's observation, MLP critic on the global
state) on ``AnonLocTask.BELIEF`` in the agents' evaluation condition ``free N=10``
(:func:`benchmarks.agent_conditions.evaluation_conditions`), then plays the trained policy, the
bundled agent and ``uniform`` (the no-learning ablation: a fair coin among the same candidates)
on the same held-out seeds (from ``--first-seed``, never seen in training: BenchMARL seeds its
envs from ``--seed``), every robot with the ``bayes`` identifier, and reports the figures of
``benchmarks/agent_eval.py`` (censored pictures to 99 % with a 95 % bootstrap interval, share
reached, energy, confident decisions wrong) and the training's time.

Usage (from the repository's root, with the ``benchmarl`` extra)::

    python -m benchmarks.benchmarl_belief --frames 12000 --json results/benchmarl.json
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable
from pathlib import Path

from benchmarl.experiment import Experiment

from agents.benchmarl import AnonLocTask, BenchmarlExcitation, experiment, settings
from agents.evaluation import play
from agents.policy import as_saved, load_model
from baselines.excitations import Excitation
from baselines.registry import EXCITATIONS
from benchmarks.agent_conditions import evaluation_conditions
from benchmarks.agent_eval import row_text, score, write_rows

CONDITION = "free N=10"


def overrides(pictures: int) -> dict[str, object]:
    """``make_config`` overrides of the ``free N=10`` condition (checked against it in main)."""
    side = math.sqrt(10)
    return {
        "n_robots": 10,
        "arena_size": (side, side),
        "camera": {"pixel_noise": 1.0, "orientation": False},
        "max_cycles": round(pictures / 0.05) + 1,
    }


def train(args: argparse.Namespace) -> tuple[Experiment, float]:
    """The trained experiment and its wall time (s)."""
    task = AnonLocTask.BELIEF.get_from_yaml()
    task.config.update(preset="default", overrides=overrides(args.pictures))
    config = evaluation_conditions(args.pictures)[CONDITION][0]
    assert settings("BELIEF", task.config).env_config() == config, "not the evaluation condition"
    run = experiment(
        task,
        "mappo",
        frames=args.frames,
        frames_per_batch=args.frames_per_batch,
        envs=args.envs,
        folder=args.folder,
        seed=args.seed,
        minibatch=args.minibatch,
        epochs=args.epochs,
        lr=args.lr,
    )
    start = time.perf_counter()
    run.run()
    return run, time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=12_000, help="belief-env steps in all")
    parser.add_argument("--frames-per-batch", type=int, default=1_200)
    parser.add_argument("--envs", type=int, default=4, help="envs stepped per batch")
    parser.add_argument("--minibatch", type=int, default=400)
    parser.add_argument("--epochs", type=int, default=10)
    parser.add_argument("--lr", type=float, default=3e-4)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--episodes", type=int, default=40)
    parser.add_argument("--pictures", type=int, default=30, help="pictures per episode")
    parser.add_argument("--first-seed", type=int, default=100_000)
    parser.add_argument("--folder", type=Path, default=Path("runs/benchmarl"))
    parser.add_argument("--json", type=Path, default=None, help="write the rows here")
    args = parser.parse_args()
    run, seconds = train(args)
    print(
        f"MAPPO: {args.frames} frames in {seconds:.0f} s; last batch's mean return "
        f"{run.mean_return:.3f}",
        flush=True,
    )
    model = load_model("bundled")
    makers: dict[str, Callable[[], Excitation]] = {
        "mappo (BenchMARL)": lambda: BenchmarlExcitation(run),
        "agent (bundled)": lambda: as_saved(model),
        "uniform": EXCITATIONS["uniform"],
    }
    config, condition, budget = evaluation_conditions(args.pictures)[CONDITION]
    seeds = range(args.first_seed, args.first_seed + args.episodes)
    rows: list[dict[str, object]] = []
    print(
        "| excitation | pictures to 99 %: censored mean | Kaplan-Meier median | reached "
        "| energy (m) | wrong |\n|---|---|---|---|---|---|"
    )
    for name, make in makers.items():
        start = time.perf_counter()
        results = play(config, condition, budget, make, seeds, args.pictures)
        row = {"excitation": name, **score(results, args.pictures)}
        row["seconds"] = time.perf_counter() - start
        row["train_seconds"], row["frames"] = seconds, args.frames
        rows.append(row)
        print(f"| {name} | {row_text(row)} |", flush=True)
    if args.json:
        write_rows(args.json, rows)


if __name__ == "__main__":
    main()
