"""A reward function of your own: keep clear of crowds, where robots are hard to tell apart.

A reward function is any object with ``reset(config, rng, picture)`` and ``__call__(context)``
(the :class:`anonloc_env.rewards.RewardFunction` protocol). The env calls ``reset`` at every
episode start and the function once after every step with a
:class:`anonloc_env.rewards.StepContext`; it returns one reward per robot. Ground truth (which
row is which robot) may be read here: rewards are the env's, not the robots'.

Run it: ``python examples/custom_reward.py``.
"""

from __future__ import annotations

import numpy as np

import anonloc_env
from anonloc_env.camera import Picture
from anonloc_env.config import EnvConfig
from anonloc_env.rewards import StepContext, energy


class CrowdPenalty:
    """At every picture, minus the number of other detections within ``radius`` image units of
    the robot's own (0 for a robot the camera missed); minus the energy cost at every step.

    Args:
        radius: how close (image units) another detection must be to count.
    """

    needs_statistics = False  # it reads no Interval statistics: the env may skip them

    def __init__(self, radius: float = 40.0) -> None:
        self.radius = radius

    def reset(
        self, config: EnvConfig, rng: np.random.Generator, picture: Picture | None = None
    ) -> None:
        """Nothing to remember between steps (``rng`` would be the env's, for any draw)."""

    def __call__(self, context: StepContext) -> np.ndarray:
        cfg = context.config
        reward = -cfg.reward.energy_weight * energy(cfg, context.v, context.w)  # (N,)
        picture = context.picture
        if picture is None:  # no picture at this step
            return reward
        rows = picture.detections[:, :2]  # (n, 2) image units
        close = np.linalg.norm(rows[:, None] - rows[None, :], axis=2) <= self.radius
        crowd = close.sum(axis=1) - 1  # (n,) other detections near each row
        seen = picture.true_index >= 0  # robot i is row true_index[i], or missed
        reward[seen] -= crowd[picture.true_index[seen]]
        return reward


def main(seed: int = 0) -> np.ndarray:
    """Play one episode of 20 robots under random actions: each robot's total reward."""
    env = anonloc_env.parallel_env(n_robots=20, arena_size=(3.0, 3.0), reward_fn=CrowdPenalty())
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    total = np.zeros(20)
    while env.agents:
        actions = {agent: rng.uniform(-1.0, 1.0, 2) for agent in env.agents}
        _, rewards, *_ = env.step(actions)
        total += [rewards[agent] for agent in env.possible_agents]
    print(f"mean return {total.mean():.2f}, most crowded robot {total.min():.2f}")
    return total


if __name__ == "__main__":
    main()
