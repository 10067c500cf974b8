"""How well the Bayesian identifier does as the number of robots grows.

Every robot localizes at once under random motion (the paper's rules) with 1 px of pixel noise,
in an arena of side ``max(4, 2 sqrt(N))`` m (constant density), with or without detected
headings. Reported per N: the share of robots whose estimate is right at pictures 4, 6 and 8
(the first picture is number 1), the mean picture of the first decision, and calibration: of all
estimates given at belief >= 0.99, how many were wrong. The corrected ``motion`` localizer runs
as a peer on the same episodes.

Usage: ``python benchmarks/quality_scaling.py [--orientation/--no-orientation] [--quick]``
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

import anonloc_env
import baselines
from baselines.localizers import MotionLocalizer
from baselines.runner import run_episode

EPISODES = {2: 200, 10: 40, 100: 5, 1000: 2}
PICTURES = 10


def run(n: int, episodes: int, orientation: bool) -> dict[str, float]:
    """Scores of ``bayes`` (and the peer) over ``episodes`` episodes of ``n`` robots."""
    side = max(4.0, 2.0 * math.sqrt(n))
    env = anonloc_env.parallel_env(
        n_robots=n,
        arena_size=(side, side),
        max_cycles=10**6,
        camera={"pixel_noise": 1.0, "orientation": orientation},
        reward_fn=anonloc_env.EnergyCost(),
    )
    team = baselines.make_team("bayes", env.config, excitation="random")
    team.listeners = {"motion": MotionLocalizer(env.config, n)}
    right = np.zeros(PICTURES)
    peer_right = np.zeros(PICTURES)
    scored = np.zeros(PICTURES)
    decided = wrong = 0
    first: list[int] = []
    for seed in range(episodes):
        result = run_episode(env, team, seed, max_pictures=PICTURES)
        for r in result.records:
            if r.localizer == "motion":
                peer_right[r.picture] += r.correct
                continue
            scored[r.picture] += 1
            right[r.picture] += r.correct
            decided += r.estimate >= 0
            wrong += r.estimate >= 0 and not r.correct
        first += [d.picture + 1 for d in result.decisions() if d.picture >= 0]
    share = right / np.maximum(scored, 1)
    return {
        "robots": scored[0],
        "at4": share[3],
        "at6": share[5],
        "at8": share[7],
        "peer_at4": (peer_right / np.maximum(scored, 1))[3],
        "first": float(np.mean(first)) if first else float("nan"),
        "decided": decided,
        "wrong": wrong,
    }


def main(argv: list[str] | None = None) -> None:
    """Print the table."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--orientation", action=argparse.BooleanOptionalAction, default=True)
    parser.add_argument("--quick", action="store_true", help="a quarter of the episodes")
    args = parser.parse_args(argv)
    print(f"orientation detected: {args.orientation}")
    print(
        "| N | robots | right at 4th | at 6th | at 8th | motion (peer) at 4th |"
        " first decision (picture) | wrong at >= 0.99 | wall (s) |"
    )
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for n, episodes in EPISODES.items():
        start = time.perf_counter()
        m = run(n, max(1, episodes // 4) if args.quick else episodes, args.orientation)
        share = m["wrong"] / max(m["decided"], 1)
        print(
            f"| {n} | {m['robots']:.0f} | {100 * m['at4']:.1f} % | {100 * m['at6']:.1f} % | "
            f"{100 * m['at8']:.1f} % | {100 * m['peer_at4']:.1f} % | {m['first']:.2f} | "
            f"{m['wrong']:.0f} / {m['decided']:.0f} ({100 * share:.2f} %) | "
            f"{time.perf_counter() - start:.0f} |"
        )


if __name__ == "__main__":
    main()
