"""On swarm duty, how much of ``uniform``'s energy to 99 % is the duty's own (``docs/agents.md``,
*What swarm duty leaves to save*).

Issue 24's first target asks the agent for no more pictures than ``uniform`` at no more than
0.8x its energy to 99 %. On swarm duty every robot drives the shared command plus its own
deviation (``baselines.excitations.SwarmDuty``), and the energy to 99 % counts the wheel travel of
both. This script plays, on the same seeds:

* ``uniform`` (its deviation drawn in the agent's box),
* the duty's own travel: every robot follows the shared command with no deviation at all
  (``baselines.excitations.base.Still`` as the deviation), which identifies nobody, and
* the least travel the duty allows (:class:`LeastTravel`): every robot's deviation opposes the
  shared command as far as its budget allows, which is the least wheel travel any policy on duty
  can spend up to a given picture, whatever it learned;

and prints, per condition, each one's travel at ``uniform``'s picture to 99 % as a share of
``uniform``'s energy to 99 %, and the last picture at which the least travel still stays within
``--share`` (0.8) of it. A policy meets the energy clause only if it reaches 99 % by that
picture. Where the duty's own travel is above ``--share``, only a team that falls behind its
shared command (deviations against it, on average) can meet the clause: a deviation drawn with
mean zero at each step spends on average at least the duty's own travel there (the wheel
travel is convex in the deviation: Jensen's inequality).

Usage::

    python -m benchmarks.duty_energy --conditions "swarm N=10" "swarm N=100" --episodes 30
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np

from agents.evaluation import censored, play
from baselines.excitations import Excitation
from baselines.excitations.base import Still
from baselines.excitations.uniform import UniformChoice
from baselines.runner import EpisodeResult
from baselines.steps import Step
from benchmarks.agent_conditions import evaluation_conditions

PICTURES = 30


class LeastTravel(Excitation):
    """The deviation that brings each robot's command closest to standing still: ``-shared /
    budget``, clipped to the robot's limits ``v_max`` (m/s) and ``omega_max`` (rad/s)."""

    def __init__(self, v_max: float, omega_max: float) -> None:
        super().__init__()
        self.limits = (v_max, omega_max)
        self.shared = (np.zeros(0), np.zeros(0), 1.0)

    def follow(self, v: np.ndarray, w: np.ndarray, budget: float) -> None:
        self.shared = (np.asarray(v, np.float64), np.asarray(w, np.float64), budget)

    def commands(self, step: Step, dt: float) -> tuple[np.ndarray, np.ndarray]:
        v, w, budget = self.shared
        if budget == 0.0:
            return np.zeros(self.n), np.zeros(self.n)
        v_max, omega_max = self.limits
        return np.clip(-v / budget, -v_max, v_max), np.clip(-w / budget, -omega_max, omega_max)


def energy_by_picture(result: EpisodeResult) -> dict[int, float]:
    """Mean wheel travel (m) of the robots until each picture of ``result``."""
    travel: dict[int, list[float]] = {}
    for record in result.records:
        if record.localizer == "":
            travel.setdefault(record.picture, []).append(record.energy)
    return {picture: float(np.mean(values)) for picture, values in travel.items()}


@dataclass(frozen=True)
class DutyShare:
    """What the duty leaves of ``uniform``'s energy on one condition (means over the episodes).

    Attributes:
        pictures: ``uniform``'s pictures to 99 % (censored).
        least: the least travel by then, as a share of ``uniform``'s energy to 99 %.
        last: the last picture at which the least travel stays within the asked share.
        follow: the duty's own travel (no deviation) by then, as a share of the same.
    """

    pictures: float
    least: float
    last: float
    follow: float


def duty_share(name: str, episodes: int, first: int, share: float) -> DutyShare:
    """:class:`DutyShare` of condition ``name`` on ``episodes`` seeds from ``first``, with the
    least travel's last picture within ``share`` of ``uniform``'s energy to 99 %."""
    config, condition, budget = evaluation_conditions(PICTURES)[name]
    seeds = range(first, first + episodes)
    chance = [
        censored(r, PICTURES)
        for r in play(config, condition, budget, UniformChoice, seeds, PICTURES)
    ]
    robot = config.robot
    least = play(
        config,
        condition,
        budget,
        lambda: LeastTravel(robot.v_max, robot.omega_max),
        seeds,
        PICTURES,
    )
    follow = play(config, condition, budget, Still, seeds, PICTURES)
    shares, last, own = [], [], []
    for (picture, spent), alone, plain in zip(chance, least, follow, strict=True):
        travel = energy_by_picture(alone)
        shares.append(travel[min(picture, max(travel))] / spent)
        last.append(max((p for p, e in travel.items() if e <= share * spent), default=0))
        duty = energy_by_picture(plain)
        own.append(duty[min(picture, max(duty))] / spent)
    return DutyShare(
        float(np.mean([c[0] for c in chance])),
        float(np.mean(shares)),
        float(np.mean(last)),
        float(np.mean(own)),
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--conditions", nargs="+", default=["swarm N=10", "swarm N=100"])
    parser.add_argument("--episodes", type=int, default=30)
    parser.add_argument("--first-seed", type=int, default=920_000)
    parser.add_argument("--share", type=float, default=0.8)
    args = parser.parse_args()
    for name in args.conditions:
        found = duty_share(name, args.episodes, args.first_seed, args.share)
        print(
            f"{name}: uniform {found.pictures:.2f} pictures to 99 %; by then the duty's own "
            f"travel is {found.follow:.3f} of its energy and the least travel on duty "
            f"{found.least:.3f}, which stays within {args.share} of it until picture "
            f"{found.last:.2f} on average ({found.last / found.pictures:.2f}x uniform's pictures)",
            flush=True,
        )


if __name__ == "__main__":
    main()
