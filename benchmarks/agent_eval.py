"""The learned agent against ``uniform``, random, ``distinct``, ``greedy`` and the centralized code.

Every robot runs the ``bayes`` identifier (decisions at belief 0.99) and one excitation (``code``
is :class:`baselines.excitations.code.CentralizedCode`, a reference that knows identities); the
evaluation seeds (from ``--first-seed``, default 100000) are never used in training (a training
run seeds its env copies with 64-bit draws of ``SeedSequence(seed)`` and draws its scenarios
from their own generator). For each condition and excitation it reports, over all episodes:

* pictures to 99 %: the censored mean (an episode that never gets there counts at its last
  picture, ``--pictures``), with a 95 % bootstrap interval;
* pictures to 99 %: the Kaplan-Meier median (an episode that never gets there is censored at
  its last picture), with its 95 % interval (``inf``: the data bound it only from below);
* the share of episodes that reach 99 %;
* energy to 99 %: mean wheel travel per robot until that picture (censored the same way), m;
* confident decisions wrong: decisions (belief >= 0.99) on a row that is not the robot's, over
  all decisions of all robots at all pictures;
* the limits of :mod:`baselines.limit` for the condition;
* at the end, agent / ``uniform`` for pictures and energy, paired on the same seeds, with 95 %
  bootstrap intervals (:func:`paired_ratio`).

Usage::

    python -m benchmarks.agent_eval --agent bundled --json results/agents.json
    python -m benchmarks.agent_eval --agent runs/x/agent.zip --conditions "free N=10" --episodes 40
    python -m benchmarks.agent_eval --report results/a.json results/b.json  # the ratios only

(run from the repository's root). The conditions are
:func:`benchmarks.agent_conditions.evaluation_conditions` (one robot per square metre,
1 px of noise, no headings unless said, a picture every second); the crowds
(:func:`~benchmarks.agent_conditions.crowded_conditions`) and the conditions beyond the training
draws (:func:`~benchmarks.agent_conditions.beyond_conditions`) run when named.
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable, Sequence
from functools import partial
from pathlib import Path
from typing import Any

from agents.evaluation import censored, play
from baselines.excitations import Excitation
from baselines.excitations.code import CentralizedCode
from baselines.excitations.rest import SURE, RestWhenSure
from baselines.limit import picture_limit
from baselines.registry import EXCITATIONS
from baselines.runner import EpisodeResult
from baselines.scoring import pictures_to_identify
from baselines.statistics import SurvivalMedian, bootstrap_mean, km_median, paired_ratio
from benchmarks.agent_conditions import (
    beyond_conditions,
    crowded_conditions,
    evaluation_conditions,
)

BASELINES = ("uniform", "random", "distinct", "greedy")
#: The centralized reference (``baselines.excitations.code.CentralizedCode``: knows identities).
REFERENCE = "code"
#: Episodes per condition by default (fewer where N is large).
EPISODES = {10: 40, 20: 40, 30: 30, 50: 30, 100: 20, 300: 8, 1000: 5}


def score(results: list[EpisodeResult], pictures: int) -> dict[str, Any]:
    """The module's figures over ``results`` (censored at ``pictures``), with the per-episode
    ``firsts`` and ``energies`` (for paired comparisons on the same seeds)."""
    firsts, energies = zip(*(censored(r, pictures) for r in results), strict=True)
    decided = sum(rec.estimate >= 0 for r in results for rec in r.records)
    wrong = sum(rec.estimate >= 0 and not rec.correct for r in results for rec in r.records)
    reached = [pictures_to_identify(r)[0] is not None for r in results]
    mean = bootstrap_mean(firsts)
    spent = bootstrap_mean(energies)
    median = km_median(firsts, reached)
    return {
        "pictures": mean.mean,
        "low": mean.low,
        "high": mean.high,
        "median": median.median,
        "median_low": median.low,
        "median_high": median.high,
        "reached": sum(reached),
        "episodes": len(results),
        "energy": spent.mean,
        "energy_low": spent.low,
        "energy_high": spent.high,
        "wrong": wrong / max(decided, 1),
        "decisions": decided,
        "firsts": [float(f) for f in firsts],
        "energies": [float(e) for e in energies],
    }


def makers(
    agent: str, excitations: Sequence[str], sure: float = SURE
) -> dict[str, Callable[[], Excitation]]:
    """How to build each named excitation (the agent's model is loaded once, and runs as its
    spec says: at rest once sure if it was searched or trained so). A name ending in ``-rest``
    that the registry does not know (``agent-rest``, ``greedy-rest``), or any ``-rest`` name
    when ``sure`` is not the default, is the named one inside
    :class:`baselines.excitations.rest.RestWhenSure` at ``sure``."""
    out: dict[str, Callable[[], Excitation]] = {
        k: EXCITATIONS[k] for k in excitations if k in EXCITATIONS
    }
    out[REFERENCE] = CentralizedCode
    if "agent" in excitations or "agent-rest" in excitations:
        from agents.policy import as_saved, load_model

        model = load_model(agent)
        out["agent"] = lambda: as_saved(model)
    for name in excitations:
        inner = out.get(name.removesuffix("-rest")) or EXCITATIONS.get(name.removesuffix("-rest"))
        if name.endswith("-rest") and inner is not None and (name not in out or sure != SURE):
            out[name] = partial(_at_rest, inner, sure)
    return out


def _at_rest(make: Callable[[], Excitation], sure: float) -> Excitation:
    return RestWhenSure(make(), sure)


def median_text(row: dict[str, Any]) -> str:
    """A row's Kaplan-Meier median and interval, as the tables print them."""
    median = SurvivalMedian(
        row["median"], row["median_low"], row["median_high"], int(row["episodes"]), 0
    )
    return str(median)


def row_text(row: dict[str, Any]) -> str:
    """A row's pictures, median, episodes reached, energy and wrong share, as table cells."""
    return (
        f"{row['pictures']:.2f} [{row['low']:.2f}, {row['high']:.2f}] | {median_text(row)} | "
        f"{row['reached']}/{row['episodes']} | {row['energy']:.2f} | "
        f"{100 * row['wrong']:.2f} %"
    )


def write_rows(path: Path, rows: Sequence[dict[str, Any]]) -> None:
    """The rows as JSON at ``path``, written atomically."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(list(rows), indent=1))
    tmp.replace(path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--agent", default="bundled", help="a saved agent, or 'bundled'")
    parser.add_argument("--conditions", nargs="+", default=None, help="default: all")
    parser.add_argument("--excitations", nargs="+", default=["agent", *BASELINES, REFERENCE])
    parser.add_argument("--episodes", type=int, default=None, help="default: by N (EPISODES)")
    parser.add_argument("--pictures", type=int, default=30, help="pictures per episode")
    parser.add_argument("--first-seed", type=int, default=100_000)
    parser.add_argument("--json", type=Path, default=None, help="write the rows here")
    parser.add_argument("--scale", type=float, default=1.0, help="times the default episodes")
    parser.add_argument("--report", type=Path, nargs="+", default=None, help="rows to compare")
    parser.add_argument("--rest", type=float, default=SURE, help="belief at which -rest rests")
    args = parser.parse_args()
    if args.report:
        print_ratios([row for path in args.report for row in json.loads(path.read_text())])
        return
    built = makers(args.agent, args.excitations, args.rest)
    conditions = evaluation_conditions()
    names = args.conditions or list(conditions)
    conditions |= crowded_conditions() | beyond_conditions()  # run when named
    rows = []
    print(
        "| condition | excitation | pictures to 99 % | KM median | reached | energy (m) | wrong "
        "| limit |\n|---|---|---|---|---|---|---|---|"
    )
    for name in names:
        config, condition, budget = conditions[name]
        limit = picture_limit(config, condition, budget)
        episodes = args.episodes or max(2, round(args.scale * EPISODES.get(config.n_robots, 20)))
        seeds = range(args.first_seed, args.first_seed + episodes)
        for excitation in args.excitations:
            start = time.perf_counter()
            results = play(config, condition, budget, built[excitation], seeds, args.pictures)
            row = {
                "condition": name,
                "excitation": excitation,
                **score(results, args.pictures),
                "limit_information": limit.information,
                "limit_union": limit.union,
                "seconds": time.perf_counter() - start,
            }
            rows.append(row)
            limits = f"{limit.information:.2f} / {limit.union:.2f}"
            print(f"| {name} | {excitation} | {row_text(row)} | {limits} |", flush=True)
            if args.json:
                write_rows(args.json, rows)
    print_ratios(rows)


def print_ratios(rows: Sequence[dict[str, Any]], base: str = "uniform") -> None:
    """Agent / ``base`` per condition, pictures and energy, paired on the same seeds."""
    found = {(r["condition"], r["excitation"]): r for r in rows}
    print(f"\n| condition | agent / {base}, pictures [95 %] | energy [95 %] |\n|---|---|---|")
    for (condition, excitation), row in found.items():
        other = found.get((condition, base))
        if excitation != "agent" or other is None:
            continue
        n = min(len(row["firsts"]), len(other["firsts"]))  # the seeds both played
        pictures = paired_ratio(row["firsts"][:n], other["firsts"][:n])
        energy = paired_ratio(row["energies"][:n], other["energies"][:n])
        print(f"| {condition} | {pictures} | {energy} |", flush=True)


if __name__ == "__main__":
    main()
