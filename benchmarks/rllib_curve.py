"""RLlib PPO on the crew's env: iterations per minute and the reward curve of a short run.

Run from the repository root::

    python benchmarks/rllib_curve.py                    # N = 10, 25 iterations, a few minutes
    python benchmarks/rllib_curve.py --iterations 5     # a quick look

Starts a local Ray instance with ``--cpus`` CPUs (default 1, no dashboard) and trains
:func:`agents.rllib.make_ppo_config` (one shared :class:`agents.rllib_module.CandidateRLModule`:
each robot scores its 8 candidate commands with ``CandidateScorer`` of width ``--hidden`` and
draws one) on the free-motion condition of ``docs/agents.md`` (N robots, one per square metre,
1 px of noise, no detected headings; energy weighted as in issue 17's recipe,
``--energy-weight 0.3`` per metre) for ``--iterations`` iterations of ``--batch`` env steps
(``--batch`` times N robot decisions; one decision is one picture interval: the crew holds each
candidate until the next picture). Prints each iteration's mean per-robot episode return,
losses, entropy and wall time as a Markdown table, then iterations per minute and robot
decisions per second, and saves the curve as a PNG (``--plot``, default
``docs/assets/rllib-curve.png``; needs matplotlib). The first iteration's policy is nearly
uniform over the candidates (entropy log 8 = 2.08): the curve starts at random choice. Beside
the curve, the return of two fixed choices on ``--reference-episodes`` other seeds: a uniform
draw, and greedy's (the candidate with the smallest predicted entropy). ``--export PATH`` saves
the trained agent as an ``agent.zip`` (``agents.rllib.export_agent``) for ``anonloc eval``.
"""

from __future__ import annotations

import argparse
import math
import statistics
from pathlib import Path

import numpy as np

from agents.pettingzoo import BeliefParallelEnv
from agents.rllib import (
    IterationMetrics,
    PPOSettings,
    export_agent,
    make_ppo_config,
    train_rllib,
)
from anonloc_env import EnvConfig, make_config

#: Evaluation seeds of the reference choices start here (RLlib's env runners draw their own).
REFERENCE_SEED = 10_000


def reference_return(config: EnvConfig, rule: str, episodes: int) -> tuple[float, float]:
    """Mean per-robot episode return (and its standard error over episodes) when every robot
    picks its candidate by ``rule``: ``uniform`` (a uniform draw, what the untrained module
    does) or ``greedy`` (the smallest predicted entropy, the ``greedy`` excitation's choice)."""
    env = BeliefParallelEnv(config)
    rng = np.random.default_rng(REFERENCE_SEED)
    returns = []
    for episode in range(episodes):
        observations, _ = env.reset(seed=REFERENCE_SEED + episode)
        total = 0.0
        while env.agents:
            if rule == "uniform":
                picks = rng.integers(0, env.action_space("robot_0").n, len(env.agents))
            else:
                picks = [int(np.argmin(observations[a]["candidates"][:, 2])) for a in env.agents]
            observations, rewards, *_ = env.step(dict(zip(env.agents, picks, strict=True)))
            total += sum(rewards.values())
        returns.append(total / config.n_robots)
    return float(np.mean(returns)), float(np.std(returns, ddof=1) / math.sqrt(episodes))


def plot(
    metrics: list[IterationMetrics],
    references: dict[str, tuple[float, float]],
    path: Path,
    title: str,
) -> None:
    """Save the per-robot episode return against robot decisions sampled, with the reference
    choices' returns as horizontal bands (mean +- one standard error)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as error:  # pragma: no cover - depends on the installation
        raise ImportError("the plot needs matplotlib: pip install 'anonloc[cli]'") from error
    points = [(m.agent_steps, m.episode_return_mean) for m in metrics]
    points = [(x, y) for x, y in points if math.isfinite(y)]
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.plot([p[0] for p in points], [p[1] for p in points], marker="o", markersize=3, label="RLlib")
    for (rule, (mean, error)), colour in zip(references.items(), ["grey", "tab:red"], strict=False):
        ax.axhline(mean, color=colour, linestyle="--", linewidth=1, label=f"{rule} choice")
        ax.axhspan(mean - error, mean + error, color=colour, alpha=0.15)
    ax.legend(fontsize=8)
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
    parser.add_argument("--hidden", type=int, default=64, help="width of the scorer")
    parser.add_argument("--cpus", type=int, default=1, help="CPUs of the local Ray instance")
    parser.add_argument("--env-runners", type=int, default=0, help="Ray sampling workers")
    parser.add_argument(
        "--energy-weight", type=float, default=0.3, help="reward lost per metre (issue's recipe)"
    )
    parser.add_argument("--reference-episodes", type=int, default=12)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--plot", type=Path, default=Path("docs/assets/rllib-curve.png"))
    parser.add_argument(
        "--export", type=Path, default=None, help="save the trained agent here (an agent.zip)"
    )
    args = parser.parse_args()

    # The free-motion condition of docs/agents.md: one robot per square metre, 1 px of noise, no
    # detected headings (with headings every robot is identified at once: nothing to learn).
    side = math.sqrt(args.robots)
    config = make_config(
        n_robots=args.robots,
        arena_size=(side, side),
        camera={"pixel_noise": 1.0, "orientation": False},
        max_cycles=args.max_cycles,
        reward={"energy_weight": args.energy_weight},
    )
    settings = PPOSettings(
        train_batch_size=args.batch,
        minibatch_size=args.minibatch,
        n_epochs=args.epochs,
        num_env_runners=args.env_runners,
        hidden=args.hidden,
    )
    print(f"N={args.robots}, {settings}, episodes of {args.max_cycles} steps, {args.cpus} CPUs")
    checkpoint = None if args.export is None else str(args.export.with_suffix(".rllib"))
    metrics = train_rllib(
        make_ppo_config(config, settings, seed=args.seed),
        args.iterations,
        checkpoint_dir=checkpoint,
        num_cpus=args.cpus,
    )
    if args.export is not None and checkpoint is not None:
        print(f"agent saved to {export_agent(checkpoint, args.export)}")
    print(
        "\n| iteration | robot decisions | return per robot | policy loss | vf loss | entropy | s |"
    )
    print("|---:|---:|---:|---:|---:|---:|---:|")
    for m in metrics:
        print(
            f"| {m.iteration} | {m.agent_steps:,} | {m.episode_return_mean:.3f} | "
            f"{m.policy_loss:.4f} | {m.vf_loss:.4f} | {m.entropy:.3f} | {m.seconds:.1f} |"
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
    references = {
        rule: reference_return(config, rule, args.reference_episodes)
        for rule in ("uniform", "greedy")
    }
    for rule, (mean, error) in references.items():
        print(
            f"{rule} choice: {mean:.3f} +- {error:.3f} per robot and episode "
            f"({args.reference_episodes} episodes)"
        )
    title = f"RLlib PPO, CandidateRLModule, N={args.robots}, {args.cpus} CPU(s), seed {args.seed}"
    plot(metrics, references, args.plot, title)
    print(f"curve saved to {args.plot}")


if __name__ == "__main__":
    main()
