"""Time per picture for all N robots to update their localizer, N in {10, 100, 1000}.

Every robot runs the Bayesian identifier (``bayes``) under random motion with 1 px pixel noise,
orientation detected (the default camera), in an arena of side ``2 sqrt(N)`` m. In the same
process and on the same pictures, the corrected two-picture ``motion`` localizer runs as a peer
(a listener of the same team), and the ratio of the two is printed. The first interval is the
expensive one (every robot starts with every row possible), so both the median and the worst
picture are reported; the worst picture also in CPU time (the process's own, which other
processes on shared cores do not inflate). The first picture is not counted (nothing to
update yet; building the identifier, and loading its compiled kernels, happens there).

Usage: ``python benchmarks/bench_identify.py [--pictures K] [--sizes 10,100,1000] [--seeds 0,1]``
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

import anonloc_env
import baselines
from baselines.localizers import Localizer, MotionLocalizer
from baselines.runner import run_episode


def timed(localizer: Localizer, times: list[float], cpu: list[float] | None = None) -> None:
    """Record how long each ``on_picture`` of ``localizer`` takes (wall clock), and in ``cpu``
    the process's CPU time it took (blind to other processes sharing the cores)."""
    original: Callable[..., Any] = localizer.on_picture

    def wrapper(*args: Any, **kwargs: Any) -> None:
        start, start_cpu = time.perf_counter(), time.process_time()
        original(*args, **kwargs)
        times.append(time.perf_counter() - start)
        if cpu is not None:
            cpu.append(time.process_time() - start_cpu)

    localizer.on_picture = wrapper  # type: ignore[method-assign]  # instrumentation only


def measure(n: int, pictures: int, seed: int = 0) -> dict[str, float]:
    """Median and worst update time (s) per picture of bayes and motion for ``n`` robots."""
    side = max(4.0, 2.0 * math.sqrt(n))
    env = anonloc_env.parallel_env(
        n_robots=n,
        arena_size=(side, side),
        max_cycles=10**6,
        camera={"pixel_noise": 1.0},
        reward_fn=anonloc_env.EnergyCost(),
    )
    team = baselines.make_team("bayes", env.config, excitation="random")
    team.listeners = {"motion": MotionLocalizer(env.config, n)}
    bayes_times: list[float] = []
    bayes_cpu: list[float] = []
    motion_times: list[float] = []
    timed(team.localizer, bayes_times, bayes_cpu)
    timed(team.listeners["motion"], motion_times)
    result = run_episode(env, team, seed, max_pictures=pictures)
    last = [r for r in result.records if r.localizer == "" and r.picture == pictures - 1]
    return {
        "bayes_median": float(np.median(bayes_times[1:])),
        "bayes_max": float(np.max(bayes_times[1:])),
        "bayes_max_cpu": float(np.max(bayes_cpu[1:])),
        "motion_median": float(np.median(motion_times[1:])),
        "correct_last": float(np.mean([r.correct for r in last])),
    }


def main(argv: list[str] | None = None) -> None:
    """Print the table."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--pictures", type=int, default=10)
    parser.add_argument("--sizes", default="10,100,1000")
    parser.add_argument("--seeds", default="0", help="episodes, one row each (e.g. 0,1,2,3)")
    args = parser.parse_args(argv)
    print(
        "| N | seed | bayes median (ms) | bayes worst (ms) | bayes worst, CPU time (ms) |"
        " motion median (ms) | bayes / motion | correct at last picture |"
    )
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    seeds = [int(x) for x in args.seeds.split(",")]
    for n, seed in ((int(x), seed) for x in args.sizes.split(",") for seed in seeds):
        m = measure(n, args.pictures, seed)
        print(
            f"| {n} | {seed} | {1e3 * m['bayes_median']:.1f} | {1e3 * m['bayes_max']:.1f} | "
            f"{1e3 * m['bayes_max_cpu']:.1f} | "
            f"{1e3 * m['motion_median']:.2f} | {m['bayes_median'] / m['motion_median']:.1f} | "
            f"{100 * m['correct_last']:.1f} % |"
        )


if __name__ == "__main__":
    main()
