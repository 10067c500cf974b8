"""A localizer of your own: each robot is the detection that moved as far as it did.

Subclass :class:`baselines.localizers.Localizer` and implement ``decide``: it reads the last
pictures and each robot's own motion between them, and sets ``estimate`` and ``belief``. Then
pair it with an excitation in a :class:`baselines.policies.Team` and play an episode.

Run it: ``python examples/custom_localizer.py``.
"""

from __future__ import annotations

import numpy as np

import anonloc_env
from baselines.excitations import RandomMotion
from baselines.localizers import Localizer
from baselines.policies import Team
from baselines.runner import run_episode


class DistanceLocalizer(Localizer):
    """Robot i is the detection whose distance from the previous picture's nearest detection
    matches how far robot i's own odometry says it moved. Blind to direction, so weaker than the
    paper's methods; it decides only when exactly one row fits."""

    needs = 2  # pictures kept before the first decide()

    def decide(self) -> None:
        before = self.pictures[-2][:, :2]  # (n0, 2) image units
        now = self.pictures[-1][:, :2]  # (n, 2) image units
        interval = self.intervals[-1]  # each robot's own motion between the two
        moved = self.scale * np.hypot(interval.d[:, 0], interval.d[:, 1])  # (R,) image units
        if len(before) == 0:
            shift = np.full(len(now), np.inf)
        else:  # how far each row of `now` lies from the nearest row of `before`
            shift = np.linalg.norm(now[:, None, :] - before[None, :, :], axis=2).min(axis=1)
        tolerance = 2.0 * self._sigma(interval)[:, None]  # (R, 1) image units
        chi2 = ((shift[None, :] - moved[:, None]) / tolerance) ** 2  # (R, n)
        fits = chi2 <= 9.0  # within three tolerances
        weights = np.exp(-0.5 * np.minimum(chi2, 700.0)) * fits
        total = weights.sum(axis=1, keepdims=True)
        self.belief = np.divide(weights, total, out=np.zeros_like(weights), where=total > 0)
        self.estimate = np.where(fits.sum(axis=1) == 1, np.argmax(fits, axis=1), -1)


def main(seed: int = 0) -> tuple[int, int]:
    """Play one episode of 8 robots: (decisions taken, decisions right) over its pictures."""
    env = anonloc_env.parallel_env(n_robots=8, arena_size=(8.0, 8.0), max_cycles=200)
    team = Team(env.config, DistanceLocalizer(env.config, n=8), RandomMotion())
    result = run_episode(env, team, seed=seed)
    decided = [r for r in result.records if r.estimate >= 0]
    right = sum(r.correct for r in decided)
    print(f"{len(decided)} decisions over {len(result.records)} robot-pictures, {right} right")
    return len(decided), right


if __name__ == "__main__":
    main()
