"""Training callbacks: what the logs show besides PPO's own figures, and a wall-clock budget."""

from __future__ import annotations

import time

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback


class WallClockBudget(BaseCallback):
    """Stops training (after the current rollout) once ``minutes`` of wall time have passed."""

    def __init__(self, minutes: float) -> None:
        super().__init__()
        self.minutes = minutes
        self._start = time.monotonic()

    def _on_training_start(self) -> None:
        self._start = time.monotonic()

    def _on_step(self) -> bool:
        return time.monotonic() - self._start < 60.0 * self.minutes


class IdentificationLogger(BaseCallback):
    """Logs ``identify/correct_at_end``: the share of the robots present in the last picture of
    an episode that were correctly identified (decided at belief 0.99 on their true row), over
    the episodes that ended since the last log (ground truth from the infos, never observed)."""

    def _init_callback(self) -> None:
        self._correct: list[float] = []

    def _on_step(self) -> bool:
        dones = self.locals["dones"]
        if dones.any():
            infos = self.locals["infos"]
            ended = np.flatnonzero(dones)
            present = [infos[i]["present"] for i in ended]
            correct = [infos[i]["correct"] for i in ended]
            if any(present):
                self._correct.append(float(np.sum(correct)) / float(np.sum(present)))
        return True

    def _on_rollout_end(self) -> None:
        if self._correct:
            self.logger.record("identify/correct_at_end", float(np.mean(self._correct)))
            self._correct = []
