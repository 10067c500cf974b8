"""agents.policy: a saved agent reads pictures sized as its env sizes them."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

import anonloc_env
import baselines
from agents.policy import LearnedExcitation
from agents.train import TrainConfig, build_model, make_vec_env
from anonloc_env.camera import Camera, Picture
from baselines.runner import run_episode

SMALL: dict[str, Any] = {
    "n_robots": 3,
    "arena_size": (2.0, 2.0),
    "max_cycles": 24,
    "picture_interval": 0.25,
}
CLUTTERED: dict[str, Any] = {**SMALL, "camera": {"false_positives": 5.0}}


class _Exact:
    """Sees every robot exactly, nothing else: 3 rows at most, whatever the config's clutter."""

    def __init__(self, camera: Camera) -> None:
        self.camera = camera
        self.capacity = camera.config.n_robots

    def take(self, poses: np.ndarray, rng: np.random.Generator, time: float, index: int) -> Picture:
        rows = np.column_stack(
            [self.camera.project(poses[:, :2]), self.camera.image_heading(poses)]
        )
        order = rng.permutation(len(poses))
        return Picture(rows[order], np.argsort(order), time, index, has_orientation=True)


def _saved_agent(tmp_path: Path) -> Path:
    """An untrained agent for 3-row pictures, saved as ``anonloc train`` saves one."""
    config = TrainConfig(overrides=SMALL, n_envs=1, n_steps=8, batch_size=8, out=str(tmp_path))
    model = build_model(config, make_vec_env(config))
    path = tmp_path / "agent.zip"
    model.save(path)
    return path


def test_an_agent_built_from_an_env_with_a_custom_detector_uses_the_env_capacity(
    tmp_path: Path,
) -> None:
    path = _saved_agent(tmp_path)
    config = anonloc_env.make_config(**CLUTTERED)
    assert Camera(config).capacity > 3  # the built-in camera leaves room for false positives
    env = anonloc_env.parallel_env(**CLUTTERED, detector=_Exact(Camera(config)))
    assert env.capacity == 3
    team = baselines.make_team("agent", env, path=str(path))
    assert isinstance(team.excitation, LearnedExcitation)
    assert team.excitation.capacity == 3
    outcome = run_episode(env, team, seed=2)
    assert outcome.records
    # Built from the config alone, the agent still sizes pictures as the built-in camera does.
    with pytest.raises(ValueError, match="trained on pictures of 3 rows"):
        baselines.make_team("agent", config=config, path=str(path))
