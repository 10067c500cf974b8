"""The belief env (``agents.vec.AnonLocVecEnv``, what ``anonloc train`` learns on) against an
older checkout of anonloc, alternated in one run.

Run from the repository root, with an older commit checked out elsewhere::

    git worktree add /work/old-main 9b13f2a
    python benchmarks/bench_belief.py --old /work/old-main             # about 10 minutes
    python benchmarks/bench_belief.py --old /work/old-main --robots 30 --copies 4 --rounds 5

Each measurement is a fresh interpreter (``PYTHONPATH`` set to one checkout or the other) that
builds the env (``--copies`` copies of the ``default`` scenario with N robots, the ``team``
reward; at N = 30 with clutter: 8 % misses and 2 false positives per picture), resets it with
seed 0, takes one untimed step, then steps it with uniform random candidate choices until
``--seconds`` have passed, and prints the decisions per second (slots x steps / s). The two
checkouts run one after the other, in an order that alternates between rounds; the figures are
medians over the rounds and the ratio is the median of the per-round ratios, so that a slow spell
of the shared machine weighs on both sides.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

WORKER = """
import sys, time
import numpy as np
from anonloc_env import make_config
from agents.vec import AnonLocVecEnv
n, copies, seconds = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[4])
clutter = sys.argv[3] == "1"
camera = {"p_miss": 0.08, "false_positives": 2.0} if clutter else {}
vec = AnonLocVecEnv(make_config(n_robots=n, camera=camera), n_envs=copies, reward="team")
vec.seed(0)
vec.reset()
rng = np.random.default_rng(0)
def step():
    vec.step_async(rng.integers(0, 8, vec.num_envs))
    vec.step_wait()
step()
steps, start = 0, time.perf_counter()
while time.perf_counter() - start < seconds or steps < 2:
    step()
    steps += 1
print(steps * vec.num_envs / (time.perf_counter() - start))
"""


def rate(checkout: Path, n: int, copies: int, clutter: bool, seconds: float) -> float:
    """Decisions per second of one fresh interpreter on ``checkout``."""
    env = {**os.environ, "PYTHONPATH": str(checkout)}
    args = [str(n), str(copies), "1" if clutter else "0", str(seconds)]
    out = subprocess.run(
        [sys.executable, "-c", WORKER, *args],
        env=env,
        cwd=checkout,
        capture_output=True,
        text=True,
        check=True,
    )
    return float(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--old", type=Path, required=True, help="the older checkout")
    parser.add_argument("--new", type=Path, default=Path.cwd(), help="this checkout (default)")
    parser.add_argument("--robots", type=int, nargs="+", default=[10, 30, 100, 300])
    parser.add_argument("--copies", type=int, nargs="+", default=[4, 12])
    parser.add_argument("--rounds", type=int, default=3, help="alternations (medians)")
    parser.add_argument("--seconds", type=float, default=4.0, help="timed stepping per run")
    args = parser.parse_args()
    print("| N | copies | clutter | old decisions/s | new decisions/s | new / old |")
    print("|---:|---:|---|---:|---:|---:|")
    sides = {"old": args.old.resolve(), "new": args.new.resolve()}
    for n in args.robots:
        for copies in args.copies:
            clutter = n == 30
            rates: dict[str, list[float]] = {"old": [], "new": []}
            for r in range(args.rounds):
                for side in ("old", "new") if r % 2 == 0 else ("new", "old"):
                    rates[side].append(rate(sides[side], n, copies, clutter, args.seconds))
            ratio = statistics.median(
                b / a for a, b in zip(rates["old"], rates["new"], strict=True)
            )
            old, new = (statistics.median(rates[side]) for side in ("old", "new"))
            print(
                f"| {n} | {copies} | {'8 % misses, 2 FP' if clutter else 'none'} "
                f"| {old:,.0f} | {new:,.0f} | {ratio:.2f}x |",
                flush=True,
            )


if __name__ == "__main__":
    main()
