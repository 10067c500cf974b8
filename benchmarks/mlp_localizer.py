"""The learned localizer ``mlp`` beside ``bayes`` and the paper's three methods.

Two tables (Markdown, on stdout):

1. **The paper presets**, as ``anonloc reproduce`` plays them (:func:`baselines.paper.play`, the
   same seeds 0 upward, the same episodes): success per robot at its first decision, with 95 %
   Wilson intervals, for the method's faithful and corrected versions, ``bayes`` and ``mlp``
   listening to the very same pictures; and ``bayes`` and ``mlp`` at the 4th picture.
2. **Pictures to 99 %** at N = 10 and 100 (the conditions ``free N=10``, ``free N=100`` and
   ``headings N=100`` of :mod:`benchmarks.agent_conditions`: one robot per square metre, 1 px of
   noise, a picture every second; random motion): per localizer, the share of episodes in which
   99 % of the robots were identified, the censored mean (an episode that never got there counts
   at one past its last picture; 95 % bootstrap interval) and the Kaplan-Meier median (censored
   at its last picture; 95 % interval), on the same seeds from 100000.

Usage::

    python -m benchmarks.mlp_localizer                       # the paper's run counts, 20 episodes
    python -m benchmarks.mlp_localizer --runs 30 --episodes 5 --weights other.npz
    python -m benchmarks.mlp_localizer --methods motion --conditions   # one paper column only

(run from the repository's root).
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Sequence
from pathlib import Path

import anonloc_env
import baselines
from baselines.mlp import WEIGHTS, MLPLocalizer, load_weights
from baselines.paper import BAYES_PICTURE, EXPERIMENTS, Rate, play
from baselines.runner import run_episode
from baselines.scoring import summarize
from benchmarks.agent_conditions import evaluation_conditions

#: The paper's localizers and ours, as the table's rows: listener name -> label.
ROWS = {"faithful": "faithful", "": "corrected", "bayes": "bayes", "mlp": "mlp"}
#: The conditions of the second table.
CONDITIONS = ("free N=10", "free N=100", "headings N=100")


def paper_table(runs: int | None, weights: Path, methods: Sequence[str]) -> None:
    """The first table: success at the first decision on the paper presets ``methods``."""
    model = load_weights(weights)
    first: dict[str, dict[str, list[bool]]] = {}
    fourth: dict[str, dict[str, list[bool]]] = {}
    for method in methods:
        experiment = EXPERIMENTS[method]
        config = anonloc_env.make_config(experiment.preset)
        first[method] = {name: [] for name in ROWS}
        fourth[method] = {"bayes": [], "mlp": []}
        for seed in range(experiment.runs if runs is None else runs):
            mlp = MLPLocalizer(config, config.n_robots, weights=model)
            result = play(method, seed, listeners={"mlp": mlp})
            for name in ROWS:
                first[method][name] += [d.correct for d in result.decisions(name)]
            for name in fourth[method]:
                fourth[method][name] += [
                    r.correct
                    for r in result.records
                    if r.localizer == name and r.picture == BAYES_PICTURE
                ]
    print("| success, first decision | " + " | ".join(methods) + " |")
    print("|---" * (1 + len(methods)) + "|")
    for name, label in ROWS.items():
        cells = [str(Rate(sum(first[m][name]), len(first[m][name]))) for m in methods]
        print(f"| {label} | " + " | ".join(cells) + " |")
    for name in ("bayes", "mlp"):
        cells = [str(Rate(sum(fourth[m][name]), len(fourth[m][name]))) for m in methods]
        print(f"| {name} at 4th picture | " + " | ".join(cells) + " |")
    print("| paper | " + " | ".join(f"{EXPERIMENTS[m].success} %" for m in methods) + " |")


def pictures_table(
    episodes: int, pictures: int, weights: Path, first_seed: int, names: Sequence[str]
) -> None:
    """The second table: pictures to 99 % with ``bayes`` and ``mlp``, random motion, in the
    conditions ``names``."""
    model = load_weights(weights)
    conditions = evaluation_conditions(pictures)
    print(
        "\n| condition | localizer | reached 99 % | censored mean (95 % CI) "
        "| Kaplan-Meier median (95 % CI) | s |\n|---|---|---|---|---|---|"
    )
    for name in names:
        config, _, _ = conditions[name]
        env = anonloc_env.AnonLocEnv(config, reward_fn=anonloc_env.EnergyCost())
        for localizer in ("bayes", "mlp"):
            start = time.perf_counter()
            kwargs = {"weights": model} if localizer == "mlp" else {}
            results = [
                run_episode(
                    env,
                    baselines.make_team(localizer, env, excitation="random", **kwargs),
                    seed,
                    max_pictures=pictures + 1,
                )
                for seed in range(first_seed, first_seed + episodes)
            ]
            s = summarize(results)
            print(
                f"| {name} | {localizer} | {s.identified}/{s.episodes} | {s.pictures_all} "
                f"| {s.median} | {time.perf_counter() - start:.0f} |",
                flush=True,
            )
        env.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=None, help="default: the paper's counts")
    parser.add_argument("--episodes", type=int, default=20, help="per condition, table 2")
    parser.add_argument("--pictures", type=int, default=30, help="pictures per episode")
    parser.add_argument("--first-seed", type=int, default=100_000)
    parser.add_argument("--weights", type=Path, default=WEIGHTS)
    parser.add_argument("--methods", nargs="*", default=list(EXPERIMENTS), help="table 1")
    parser.add_argument("--conditions", nargs="*", default=list(CONDITIONS), help="table 2")
    args = parser.parse_args()
    if args.methods:
        paper_table(args.runs, args.weights, args.methods)
    if args.conditions:
        pictures_table(args.episodes, args.pictures, args.weights, args.first_seed, args.conditions)


if __name__ == "__main__":
    main()
