"""A saved agent as an excitation, so it runs through the same teams, runner and tables as every
baseline: ``baselines.make("agent", env, path=PATH)``.

Loading an agent unpickles parts of the file inside SB3 (``PPO.load``): load only files you trust.
Only the path the user names is ever loaded.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from agents.crew import HeldCommands, condition_excitation
from agents.observation import BeliefObserver
from anonloc_env.camera import detection_capacity
from anonloc_env.config import EnvConfig
from baselines.excitations import Excitation
from baselines.localizers import BayesLocalizer, Localizer
from baselines.observations import Step


class LearnedExcitation(HeldCommands):
    """The robots' commands from a trained SB3 policy reading its belief-annotated observations:
    at every picture the policy chooses each robot's command, held until the next picture, with
    the reverse-out-of-bumps reflex of :class:`agents.crew.HeldCommands` (as in training).

    It must be the excitation of a team whose localizer is a ``BayesLocalizer`` (the policy reads
    that localizer's beliefs, see :mod:`agents.observation`).

    Args:
        model: a trained SB3 model (``predict(observation, deterministic=True)``).
        config: the scenario.
        deterministic: act on the policy's mean action (default; the robots still differ
            through their dice), or sample the policy's Gaussian with each robot's own generator
            (reproducible too: the team's seeds decide).
        capacity: rows per picture ``D`` in the env's observations: the env's ``capacity`` (a
            custom detector's, when it has one). None: the config's
            (``anonloc_env.camera.detection_capacity``, the built-in camera's).
    """

    def __init__(
        self,
        model: Any,
        config: EnvConfig,
        deterministic: bool = True,
        capacity: int | None = None,
    ) -> None:
        super().__init__()
        self.model = model
        self.config = config
        self.deterministic = deterministic
        self.capacity = detection_capacity(config) if capacity is None else capacity
        expected = model.observation_space["mask"].shape[0]
        if expected != self.capacity:
            raise ValueError(
                f"the agent was trained on pictures of {expected} rows; this scenario's have "
                f"{self.capacity} (train it on this scenario, or one with the same n_robots and "
                "false positives)"
            )
        self._scale = np.array([config.robot.v_max, config.robot.omega_max])
        self.observer: BeliefObserver | None = None

    def reset(self, rngs: Any) -> None:
        super().reset(rngs)
        self.observer = None  # rebuilt at the first picture, on the team's localizer

    def on_picture(self, step: Step, localizer: Localizer) -> None:
        if not isinstance(localizer, BayesLocalizer):
            raise TypeError("a learned agent reads a bayes localizer's beliefs; use policy 'agent'")
        first = self.observer is None
        if self.observer is None:
            self.observer = BeliefObserver(localizer, self.capacity)
            self.observer.reset(self.rngs)
        self.observer.on_picture(step)
        observation = self.observer.observe(step, first=first)
        actions = np.clip(self._act(observation), -1.0, 1.0).reshape(self.n, 2)
        self.observer.last_command[:] = actions  # what the policy asked (before any duty)
        commands = actions * self._scale
        self.set(commands[:, 0], commands[:, 1])

    def _act(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        if self.deterministic:
            actions, _ = self.model.predict(observation, deterministic=True)
            return np.asarray(actions, np.float64)
        import torch

        policy = self.model.policy
        with torch.no_grad():
            tensors, _ = policy.obs_to_tensor(observation)
            normal = policy.get_distribution(tensors).distribution
            mean = normal.mean.cpu().numpy().astype(np.float64)
            std = normal.stddev.cpu().numpy().astype(np.float64)
        noise = np.stack([rng.standard_normal(mean.shape[-1]) for rng in self.rngs])
        return mean + std * noise


def agent_file(path: str | Path) -> Path:
    """The ``agent.zip`` that ``path`` names (the file, or its run folder)."""
    path = Path(path)
    if path.is_dir():
        path = path / "agent.zip"
    if not path.is_file():
        raise FileNotFoundError(f"no saved agent at {path}")
    return path


def load_model(path: str | Path) -> Any:
    """The SB3 model saved at ``path`` (unpickled by SB3: load only files you trust)."""
    from stable_baselines3 import PPO

    return PPO.load(agent_file(path), device="cpu")


def load_agent(path: str | Path, config: EnvConfig, capacity: int | None = None) -> Excitation:
    """The excitation of the agent saved at ``path`` (an ``agent.zip`` or its run folder), in the
    condition it was trained for (``free``, or ``swarm`` duty with its budget); ``capacity`` is
    the env's (see :class:`LearnedExcitation`)."""
    path = agent_file(path)
    model = load_model(path)
    record = path.parent / "config.json"
    train = json.loads(record.read_text())["train"] if record.is_file() else {}
    own = LearnedExcitation(model, config, capacity=capacity)
    condition = train.get("condition", "free")
    if condition == "free":
        return own
    return condition_excitation(condition, own, float(train.get("budget", 0.2)))
