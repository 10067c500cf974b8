"""RLlib PPO on the crew's env: iterations per minute and the reward curve of a short run.

Run from the repository root::

    python benchmarks/rllib_curve.py                    # N = 10, 25 iterations, a few minutes
    python benchmarks/rllib_curve.py --iterations 5     # a quick look

Starts a local Ray instance with ``--cpus`` CPUs (default 2, no dashboard) and trains
:func:`agents.rllib.make_ppo_config` (one shared module, flat observations, 64-64 tanh
networks) on the free-motion condition of ``docs/agents.md`` (N robots, one per square metre,
1 px of noise, no detected headings) for ``--iterations`` iterations of ``--batch`` env steps
(``--batch`` times N robot decisions; one decision is one picture interval: the crew holds each
action until the next picture). Prints each iteration's mean per-robot episode return, losses
and wall time, then iterations per minute and robot decisions per second, and saves the curve
as a PNG (``--plot``, default ``docs/assets/rllib_curve.png``; needs matplotlib).
"""

from __future__ import annotations

import argparse
import math
import statistics
from pathlib import Path

from agents.rllib import IterationMetrics, PPOSettings, make_ppo_config, train_rllib
from anonloc_env import make_config


def plot(metrics: list[IterationMetrics], path: Path, title: str) -> None:
    """Save the per-robot episode return against robot decisions sampled."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as error:  # pragma: no cover - depends on the installation
        raise ImportError("the plot needs matplotlib: pip install 'anonloc[cli]'") from error
    points = [(m.agent_steps, m.episode_return_mean) for m in metrics]
    points = [(x, y) for x, y in points if math.isfinite(y)]
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.plot([p[0] for p in points], [p[1] for p in points], marker="o", markersize=3)
    ax.set_xlabel("robot decisions sampled")
    ax.set_ylabel("mean episode return per robot")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, default=10, help="N")
    parser.add_argument("--iterations", type=int, default=25)
    parser.add_argument("--batch", type=int, default=200, help="env steps (pictures) per iteration")
    parser.add_argument("--minibatch", type=int, default=200, help="robot decisions per SGD step")
    parser.add_argument("--epochs", type=int, default=4)
    parser.add_argument("--max-cycles", type=int, default=400, help="control steps per episode")
    parser.add_argument("--cpus", type=int, default=2, help="CPUs of the local Ray instance")
    parser.add_argument("--env-runners", type=int, default=0, help="Ray sampling workers")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--plot", type=Path, default=Path("docs/assets/rllib_curve.png"))
    args = parser.parse_args()

    # The free-motion condition of docs/agents.md: one robot per square metre, 1 px of noise, no
    # detected headings (with headings every robot is identified at once: nothing to learn).
    side = math.sqrt(args.robots)
    config = make_config(
        n_robots=args.robots,
        arena_size=(side, side),
        camera={"pixel_noise": 1.0, "orientation": False},
        max_cycles=args.max_cycles,
    )
    settings = PPOSettings(
        train_batch_size=args.batch,
        minibatch_size=args.minibatch,
        num_epochs=args.epochs,
        num_env_runners=args.env_runners,
    )
    print(f"N={args.robots}, {settings}, episodes of {args.max_cycles} steps, {args.cpus} CPUs")
    metrics = train_rllib(
        make_ppo_config(config, settings, seed=args.seed), args.iterations, num_cpus=args.cpus
    )
    print("\n| iteration | robot decisions | return per robot | policy loss | vf loss | s |")
    print("|---:|---:|---:|---:|---:|---:|")
    for m in metrics:
        print(
            f"| {m.iteration} | {m.agent_steps:,} | {m.episode_return_mean:.3f} | "
            f"{m.policy_loss:.4f} | {m.vf_loss:.4f} | {m.seconds:.1f} |"
        )
    # The first iteration also builds the sampling and learning pipelines: leave it out.
    steady = [m.seconds for m in metrics[1:]] or [metrics[0].seconds]
    per_iteration = statistics.median(steady)
    steps_per_iteration = metrics[-1].agent_steps / len(metrics)
    print(
        f"\n{60.0 / per_iteration:.1f} iterations per minute (median {per_iteration:.1f} s, "
        f"first {metrics[0].seconds:.1f} s); {steps_per_iteration / per_iteration:,.0f} "
        "robot decisions per second"
    )
    title = f"RLlib PPO, N={args.robots}, one shared module, {args.cpus} CPUs"
    plot(metrics, args.plot, title)
    print(f"curve saved to {args.plot}")


if __name__ == "__main__":
    main()
