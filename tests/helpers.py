"""Small helpers shared by the tests."""

from __future__ import annotations

import itertools
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np

import anonloc_env
from baselines.excitations.uniform import UniformChoice
from baselines.steps import Step

#: The repository's root (needs nothing but the standard library).
ROOT = Path(__file__).resolve().parents[1]


def python_output(code: str) -> str:
    """What ``python -c code`` prints (stripped), run in a fresh interpreter from the repository
    root: for what a new process imports (a check of the import cost, not of this test's)."""
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True
    )
    return done.stdout.strip()


def constant_actions(env: Any, action: tuple[float, float]) -> dict[str, np.ndarray]:
    """The same action for every live agent."""
    return {a: np.array(action, dtype=np.float32) for a in env.agents}


def rollout(
    env: anonloc_env.AnonLocEnv, seed: int, steps: int, action_seed: int = 0
) -> list[tuple[Any, ...]]:
    """Reset with ``seed`` and play ``steps`` seeded random actions; return every step's output."""
    obs, infos = env.reset(seed=seed)
    out: list[tuple[Any, ...]] = [(obs, infos)]
    rng = np.random.default_rng(action_seed)
    for _ in range(steps):
        if not env.agents:
            break
        actions = {a: rng.uniform(-1, 1, 2).astype(np.float32) for a in env.agents}
        out.append(env.step(actions))
    return out


class RecordedUniform(UniformChoice):
    """``uniform`` that keeps every command it gives (``given``: ``(v, w)`` per step)."""

    def reset(self, rngs: list[np.random.Generator]) -> None:  # type: ignore[override]
        super().reset(rngs)
        self.given: list[tuple[np.ndarray, np.ndarray]] = []

    def commands(self, step: Step, dt: float) -> tuple[np.ndarray, np.ndarray]:
        v, w = super().commands(step, dt)
        self.given.append((v.copy(), w.copy()))
        return v, w


def lost_decisions(decisions: list[np.ndarray], true: list[np.ndarray]) -> int:
    """Right decisions at one picture that are not right at the next (``decisions``: each
    picture's ``(R,)`` decided rows, -1 undecided; ``true``: each picture's true rows)."""
    right = [(e >= 0) & (e == t) for e, t in zip(decisions, true, strict=False)]
    return sum(int((a & ~b).sum()) for a, b in itertools.pairwise(right))


def wrong_decisions(decisions: list[np.ndarray], true: list[np.ndarray]) -> int:
    """Decisions (robot-pictures) on a row that is not the robot's."""
    return sum(int(((e >= 0) & (e != t)).sum()) for e, t in zip(decisions, true, strict=False))
