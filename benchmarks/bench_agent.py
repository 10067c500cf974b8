"""A saved agent's robots against another agent's, per decision, alternated in one run: what a
change of the bundled agent (its terms, its weights) costs where it runs, in evaluation.

Each measurement is a fresh interpreter on this checkout that loads the agent, plays one untimed
episode, then ``--episodes`` episodes (seeds 1, 2, ...) of ``--pictures`` pictures in free
motion, N robots at one per square metre, 1 px of noise, no headings (``agents.evaluation.play``,
every robot running ``bayes`` and the agent), and prints the robot-decisions per second (per
second of its own CPU time with ``--clock cpu``). The two agents run one after the other, in an
order that alternates between rounds; the ratio is the median of the per-round ratios.

Usage::

    git show ec78ad0:agents/data/agent.zip > /tmp/old.zip
    python benchmarks/bench_agent.py --old /tmp/old.zip --new bundled --robots 30 100 --rounds 4
"""

from __future__ import annotations

import argparse
import statistics
from pathlib import Path

from benchmarks.bench_belief import rate

WORKER = """
import sys, time
from anonloc_env import make_config
from agents.evaluation import play
from agents.policy import as_saved, load_model
path, n, pictures, episodes = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
clock = time.process_time if sys.argv[5] == "cpu" else time.perf_counter
side = n ** 0.5
config = make_config(
    n_robots=n, arena_size=(side, side), camera={"orientation": False},
    max_cycles=round(pictures / 0.05) + 1,
)
model = load_model(path)
make = lambda: as_saved(model)
play(config, "free", 0.2, make, [0], 2)
start = clock()
results = play(config, "free", 0.2, make, range(1, 1 + episodes), pictures)
print(sum(len(r.records) for r in results) / (clock() - start))
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--old", required=True, help="an agent.zip (or 'bundled')")
    parser.add_argument("--new", default="bundled", help="an agent.zip (or 'bundled')")
    parser.add_argument("--robots", type=int, nargs="+", default=[30, 100])
    parser.add_argument("--pictures", type=int, default=10)
    parser.add_argument("--episodes", type=int, default=2)
    parser.add_argument("--rounds", type=int, default=3, help="alternations (medians)")
    parser.add_argument("--clock", choices=("cpu", "wall"), default="cpu")
    args = parser.parse_args()
    here = Path.cwd()
    print("| N | old decisions/s | new decisions/s | new / old |")
    print("|---:|---:|---:|---:|")
    for n in args.robots:
        olds: list[float] = []
        news: list[float] = []
        ratios: list[float] = []
        for k in range(args.rounds):
            pair = [(args.old, olds), (args.new, news)]
            for agent, into in pair if k % 2 == 0 else pair[::-1]:
                extra = [str(n), str(args.pictures), str(args.episodes), args.clock]
                into.append(rate(here, WORKER, [agent, *extra]))
            ratios.append(news[-1] / olds[-1])
        print(
            f"| {n} | {statistics.median(olds):,.0f} | {statistics.median(news):,.0f} | "
            f"{statistics.median(ratios):.3f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
