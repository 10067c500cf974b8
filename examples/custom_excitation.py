"""An excitation of your own: each robot zigzags at a speed of its own.

Subclass :class:`baselines.excitations.Excitation` and implement ``commands``: every control step
it returns the forward speed (m/s) and turn rate (rad/s) of every robot it drives. ``reset`` hands
it one random generator per robot at each episode start: draw from those, so that episodes replay
and a robot's choices never depend on another's. Then give it to any localizer's team.

Run it: ``python examples/custom_excitation.py``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

import anonloc_env
import baselines
from baselines.excitations import Excitation
from baselines.runner import run_episode
from baselines.steps import Step


class Zigzag(Excitation):
    """Drive at a speed drawn once per episode, and swap the sign of the turn at every picture;
    reverse while the bumper is pressed.

    Args:
        speed: range of the robots' speeds (m/s).
        turn: turn rate (rad/s).
    """

    def __init__(self, speed: tuple[float, float] = (0.1, 0.4), turn: float = 0.6) -> None:
        super().__init__()
        self.speed = speed
        self.turn = turn

    def reset(self, rngs: Sequence[np.random.Generator]) -> None:
        super().reset(rngs)  # keeps the generators: self.rngs, and self.n robots
        self.v = np.array([rng.uniform(*self.speed) for rng in self.rngs])  # (R,) m/s
        self.w = np.array([rng.choice([-1.0, 1.0]) * self.turn for rng in self.rngs])  # rad/s

    def commands(self, step: Step, dt: float) -> tuple[np.ndarray, np.ndarray]:
        if step.new_picture:
            self.w = -self.w
        v = np.where(step.bumper, -self.v, self.v)  # back off while in contact
        return v, self.w.copy()  # the env clips them to the robots' limits


def main(seed: int = 0, excitation: Excitation | str | None = None) -> tuple[int, int]:
    """Play one episode of 10 robots localizing with ``bayes`` while they zigzag (or move as
    ``excitation``, e.g. ``"still"``, to compare): (robots right at the last picture, robots)."""
    env = anonloc_env.parallel_env(n_robots=10, arena_size=(5.0, 5.0), max_cycles=200)
    team = baselines.make_team("bayes", env, excitation=excitation or Zigzag())
    result = run_episode(env, team, seed=seed)
    last = [r for r in result.records if r.picture == result.records[-1].picture]
    right = sum(r.correct for r in last)
    print(f"at the last picture {right} of {len(last)} robots know their row")
    return right, len(last)


if __name__ == "__main__":
    main()
