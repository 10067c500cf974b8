"""Which excitation gets a team recognised fastest, at what energy: random, distinct, greedy.

Every robot runs the ``bayes`` identifier (decisions at belief 0.99) and one excitation; the
measure is :func:`baselines.scoring.pictures_to_identify`: the first picture at which 99 % of the
robots present are correctly identified, and the mean wheel travel per robot until then, over
seeded episodes (mean and 95 % bootstrap interval). Scenario: N robots in an arena of side
sqrt(N) m (one robot per square metre), the default camera (100 image units per metre) with
1 px of pixel noise and no detected headings, a picture every second.

Conditions:

* ``free``: the excitation drives the robots.
* ``swarm``: :class:`baselines.excitations.SwarmDuty`: one shared command stream (seeded by the
  episode seed), and the excitation as a deviation of at most ``budget`` of the robot's limits
  (``random`` there means the paper's random motion as the deviation).

Usage::

    python benchmarks/excitations.py --robots 10 100 --conditions free swarm --episodes 30
    python benchmarks/excitations.py --robots 10 --conditions free --agent runs/free-10/agent.zip

``--agent PATH`` adds a saved learned agent (``agents``, the ``rl`` extra; ``bundled`` for the
agent shipped with the package) as the excitation ``agent``; on swarm duty it is the deviation.
To compare another excitation, pass it to :func:`run` in ``extra`` (name -> a function of the
episode seed returning the ``Excitation``).
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable, Mapping, Sequence

import anonloc_env
import baselines
from anonloc_env.config import EnvConfig
from baselines.excitations import Excitation, SwarmDuty
from baselines.excitations.swarm import DUTY_BUDGET
from baselines.registry import EXCITATIONS
from baselines.runner import run_episode
from baselines.scoring import IdentificationSummary, summarize

NAMES = ("random", "distinct", "greedy")
CONDITIONS = ("free", "swarm")


def scenario(n: int, pictures: int, density: float = 1.0) -> EnvConfig:
    """N robots, ``density`` per square metre (one by default), 1 px of noise, no headings,
    ``pictures`` seconds long."""
    side = math.sqrt(n / density)
    return anonloc_env.make_config(
        n_robots=n,
        arena_size=(side, side),
        camera={"pixel_noise": 1.0, "orientation": False},
        max_cycles=round(pictures / 0.05) + 1,
    )


def excitation(
    name: str,
    condition: str,
    seed: int,
    budget: float,
    extra: Mapping[str, Callable[[int], Excitation]],
) -> Excitation:
    """The named excitation, as a deviation from the shared stream on ``swarm`` duty."""
    own = extra[name](seed) if name in extra else EXCITATIONS[name]()
    if condition == "free":
        return own
    return SwarmDuty(own, budget=budget, common_seed=seed)


def run(
    n: int,
    condition: str,
    names: Sequence[str],
    episodes: int,
    pictures: int,
    budget: float = DUTY_BUDGET,
    extra: Mapping[str, Callable[[int], Excitation]] | None = None,
    first_seed: int = 0,
) -> dict[str, tuple[IdentificationSummary, float]]:
    """Each excitation's summary (and wall time, s) on the same ``episodes`` seeds (from
    ``first_seed``)."""
    config = scenario(n, pictures)
    env = anonloc_env.AnonLocEnv(config, reward_fn=anonloc_env.EnergyCost())
    out = {}
    for name in names:
        start = time.perf_counter()
        results = []
        for seed in range(first_seed, first_seed + episodes):
            team = baselines.make_team(
                "bayes", env, excitation=excitation(name, condition, seed, budget, extra or {})
            )
            results.append(run_episode(env, team, seed, max_pictures=pictures))
        out[name] = (summarize(results), time.perf_counter() - start)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, nargs="+", default=[10, 100])
    parser.add_argument("--conditions", nargs="+", choices=CONDITIONS, default=list(CONDITIONS))
    parser.add_argument("--excitations", nargs="+", default=list(NAMES))
    parser.add_argument("--episodes", type=int, default=30)
    parser.add_argument("--pictures", type=int, default=40, help="episode length (pictures)")
    parser.add_argument("--budget", type=float, default=DUTY_BUDGET, help="swarm deviation budget")
    parser.add_argument("--agent", help="a saved agent (agent.zip) to add as 'agent'")
    parser.add_argument("--first-seed", type=int, default=0, help="seeds first..first+episodes")
    args = parser.parse_args()
    names = list(args.excitations)
    extra: dict[str, Callable[[int], Excitation]] = {}
    if args.agent:
        from agents.policy import as_saved, load_model

        model = load_model(args.agent)
        names[:0] = ["agent"]
        extra["agent"] = lambda seed: as_saved(model)
    print(
        "| N | condition | excitation | identified | pictures to 99 % | energy per robot (m) "
        "| pictures, all episodes | Kaplan-Meier median | s |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for n in args.robots:
        for condition in args.conditions:
            table = run(
                n, condition, names, args.episodes, args.pictures, args.budget, extra,
                args.first_seed,
            )  # fmt: skip
            for name, (s, seconds) in table.items():
                print(
                    f"| {n} | {condition} | {name} | {s.identified}/{s.episodes} | {s.pictures} "
                    f"| {s.energy} | {s.pictures_all} | {s.median} | {seconds:.0f} |",
                    flush=True,
                )


if __name__ == "__main__":
    main()
