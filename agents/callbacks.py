"""Training callbacks: what the logs show besides PPO's own figures."""

from __future__ import annotations

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback


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
