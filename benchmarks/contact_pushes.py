"""How far contacts move robots where their wheels cannot see, against the bound the robots use.

Run from the repository root::

    python benchmarks/contact_pushes.py                      # clutter scenario, 20 episodes
    python benchmarks/contact_pushes.py --scenario dense --episodes 4

Each episode of an ``identify_quality.py`` scenario is played under the ``random`` excitation, and
the true poses at every picture are kept (``infos[agent]["pose"]``: ground truth, read only here).
For every robot and interval between pictures, the unseen displacement is the true displacement
(in the robot's frame at the first picture) minus what its odometry says (``Interval.d``). Over the
intervals in which a contact happened (``Interval.push > 0``) it is printed against the bound
``Interval.push`` (the sum of :func:`anonloc_env.odometry.push_bound` over the contact steps):
percentiles of the ratio. The identifier models the unseen push as Gaussian with
``SensorModel.push_share`` of the bound's covariance; a ratio above 1 is a push the bound does not
cover. Intervals without a contact show the odometry's own error (zero without odometry noise).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import identify_quality as quality  # a sibling script, found through sys.path

from anonloc_env.geometry import rotate


class PoseLog:
    """Wraps an env's ``reset`` and ``step`` to keep the true poses at every new picture."""

    def __init__(self, env: Any) -> None:
        self.poses: list[np.ndarray] = []
        self._picture: Any = None
        self._env = env
        self._reset, self._step = env.reset, env.step
        env.reset, env.step = self.reset, self.step

    def _keep(self, infos: dict[str, Any]) -> None:
        agents = self._env.possible_agents
        picture = infos[agents[0]]["picture"]
        if picture != self._picture:  # a new picture was taken at this step
            self._picture = picture
            self.poses.append(np.array([infos[a]["pose"] for a in agents]))

    def reset(self, *args: Any, **kwargs: Any) -> Any:
        observations, infos = self._reset(*args, **kwargs)
        self.poses, self._picture = [], None
        self._keep(infos)
        return observations, infos

    def step(self, *args: Any, **kwargs: Any) -> Any:
        result = self._step(*args, **kwargs)
        self._keep(result[4])
        return result


def measure(name: str, episodes: int) -> dict[str, np.ndarray]:
    """Unseen displacement (m) and its ratio to the bound, over the pushed and unpushed legs."""
    scenario = quality.SCENARIOS[name]
    env = quality.make_env(scenario)
    log = PoseLog(env)
    pushed_error, ratio, free_error = [], [], []
    for seed in range(episodes):
        episode = quality.record(scenario, seed, env)
        for k in range(1, min(len(episode.observed), len(log.poses))):
            interval = episode.observed[k][1]
            assert interval is not None
            before, after = log.poses[k - 1], log.poses[k]
            moved = rotate(after[:, :2] - before[:, :2], -before[:, 2])
            error = np.hypot(*(moved - interval.d).T)
            push = np.zeros(len(error)) if interval.push is None else interval.push
            hit = push > 0
            pushed_error.append(error[hit])
            ratio.append(error[hit] / push[hit])
            free_error.append(error[~hit])
    return {
        "pushed": np.concatenate(pushed_error),
        "ratio": np.concatenate(ratio),
        "free": np.concatenate(free_error),
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="clutter", choices=sorted(quality.SCENARIOS))
    parser.add_argument("--episodes", type=int, default=20)
    args = parser.parse_args(argv)
    result = measure(args.scenario, args.episodes)
    legs = len(result["pushed"]) + len(result["free"])
    levels = [50, 90, 99, 99.9, 100]
    share = 100 * len(result["pushed"]) / legs
    print(f"{args.scenario}, {args.episodes} episodes: {legs} robot-intervals, ", end="")
    print(f"{len(result['pushed'])} with a contact ({share:.1f} %)\n")
    print("| percentile | " + " | ".join(f"{p:g}" for p in levels) + " |")
    print("|---|" + "---:|" * len(levels))
    rows = {
        "unseen move with a contact (m)": result["pushed"],
        "... against the bound": result["ratio"],
        "odometry error without a contact (m)": result["free"],
    }
    for label, values in rows.items():
        cells = np.percentile(values, levels) if len(values) else [np.nan] * len(levels)
        print(f"| {label} | " + " | ".join(f"{v:.3g}" for v in cells) + " |")
    beyond = float(np.mean(result["ratio"] > 1.0)) if len(result["ratio"]) else float("nan")
    print(f"\ncontact intervals whose unseen move exceeds the bound: {100 * beyond:.2f} %")


if __name__ == "__main__":
    main()
