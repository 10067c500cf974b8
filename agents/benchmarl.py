"""anonloc as a BenchMARL task: the environment and the belief env, each with the global state.

BenchMARL (a MARL library on TorchRL: MAPPO, IPPO, MADDPG, QMIX, ...) trains on tasks; this
module defines two, built from the YAML files in ``agents/conf/`` (package data):

| Task | Environment | Action per robot | Observation per robot | State |
|---|---|---|---|---|
| `AnonLocTask.RAW` | `anonloc_env.AnonLocEnv` | `(2,)` in [-1, 1] (continuous) | the env's dict, `detections` flattened to `(3 M,)` | true poses, `(3 N,)` |
| `AnonLocTask.BELIEF` | `agents.pettingzoo.BeliefParallelEnv` | one of `C` candidates (discrete) | `(7 C + 10,)` (its `flat` form) | true poses, `(3 N,)` |

All robots form one group, ``robot`` (one set of parameters when the algorithm shares them).
The state (every robot's true pose, the env's ``state()``) is what a centralised critic (MAPPO,
MADDPG, QMIX's mixer) may read; the robots' own observations never hold it.

>>> from benchmarl.algorithms import MappoConfig
>>> from benchmarl.experiment import Experiment, ExperimentConfig
>>> from benchmarl.models import MlpConfig
>>> from agents.benchmarl import AnonLocTask
>>> task = AnonLocTask.BELIEF.get_from_yaml()  # agents/conf/belief.yaml
>>> task.config["overrides"]["n_robots"] = 10
>>> experiment = Experiment(
...     task=task, algorithm_config=MappoConfig.get_from_yaml(),
...     model_config=MlpConfig.get_from_yaml(), critic_model_config=MlpConfig.get_from_yaml(),
...     seed=0, config=ExperimentConfig.get_from_yaml())  # doctest: +SKIP
>>> experiment.run()  # doctest: +SKIP

Needs the ``benchmarl`` extra (see ``docs/benchmarl.md``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml
from benchmarl.environments.common import Task, TaskClass
from torchrl.data import Composite
from torchrl.envs import EnvBase, FlattenObservation, PettingZooWrapper, Transform

from agents.crew import CONDITIONS
from agents.pettingzoo import BeliefParallelEnv
from anonloc_env.config import EnvConfig
from anonloc_env.env import AnonLocEnv
from anonloc_env.presets import make_config

#: The tasks' YAML files (package data): ``raw.yaml`` and ``belief.yaml``.
CONF = Path(__file__).parent / "conf"
#: The one agent group: every robot.
GROUP = "robot"


@dataclass(frozen=True)
class RawSettings:
    """The settings of ``AnonLocTask.RAW`` (the keys of ``agents/conf/raw.yaml``).

    Attributes:
        preset: an ``anonloc_env`` preset name (``default``, ``paper-motion``, ...).
        overrides: keyword overrides of ``anonloc_env.make_config`` (``n_robots``,
            ``max_cycles`` in control steps, ``camera``, ...).
    """

    preset: str = "default"
    overrides: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.overrides, dict):
            raise TypeError(f"overrides must be a mapping, got {self.overrides!r}")
        self.env_config()  # raises, naming the field, on a bad preset or override

    def env_config(self) -> EnvConfig:
        """The environment's config: the preset with the overrides."""
        return make_config(self.preset, **self.overrides)


@dataclass(frozen=True)
class BeliefSettings(RawSettings):
    """The settings of ``AnonLocTask.BELIEF`` (the keys of ``agents/conf/belief.yaml``): those of
    :class:`RawSettings`, and the crew's (see ``agents.crew.Crew``).

    Attributes:
        condition: ``free`` or ``swarm``.
        budget: on swarm duty, the largest deviation, as a fraction of the robot's limits, in
            [0, 1].
        information_weight: weight of the identity term of the reward (per nat), >= 0.
    """

    condition: str = "free"
    budget: float = 0.2
    information_weight: float = 1.0

    def __post_init__(self) -> None:
        if self.condition not in CONDITIONS:
            raise ValueError(
                f"condition must be one of {list(CONDITIONS)}, got {self.condition!r}"
            )
        if not 0.0 <= self.budget <= 1.0:
            raise ValueError(f"budget must be in [0, 1], got {self.budget!r}")
        if not (self.information_weight >= 0.0 and math.isfinite(self.information_weight)):
            raise ValueError(
                f"information_weight must be finite and >= 0, got {self.information_weight!r}"
            )
        super().__post_init__()


def settings(name: str, config: dict[str, Any]) -> RawSettings:
    """The validated settings of task ``name`` (``RAW`` or ``BELIEF``) from its config dict.

    Raises:
        ValueError: an unknown key (the message lists the valid ones) or a bad value.
    """
    kind = BeliefSettings if name == "BELIEF" else RawSettings
    known = set(kind.__dataclass_fields__)
    unknown = sorted(set(config) - known)
    if unknown:
        raise ValueError(f"unknown {name} task setting(s) {unknown}; valid: {sorted(known)}")
    return kind(**config)


def pettingzoo_env(name: str, config: dict[str, Any]) -> AnonLocEnv | BeliefParallelEnv:
    """The PettingZoo env of task ``name`` with ``config`` (the task's dict)."""
    chosen = settings(name, config)
    if isinstance(chosen, BeliefSettings):
        return BeliefParallelEnv(
            chosen.env_config(),
            chosen.condition,
            chosen.budget,
            chosen.information_weight,
            observation="flat",
        )
    return AnonLocEnv(chosen.env_config())


class AnonLocTaskClass(TaskClass):
    """How BenchMARL builds, reads and batches an anonloc task (see the module doc)."""

    def get_env_fun(
        self, num_envs: int, continuous_actions: bool, seed: int | None, device: Any
    ) -> Callable[[], EnvBase]:
        """A function building the task's TorchRL env (``num_envs`` is ignored: BenchMARL
        batches the unbatched env itself). Checks the settings now, before any env exists."""
        settings(self.name, self.config)
        name, config = self.name, dict(self.config)
        return lambda: PettingZooWrapper(
            env=pettingzoo_env(name, config),
            return_state=True,
            categorical_actions=True,
            seed=seed,
            device=device,
        )

    def supports_continuous_actions(self) -> bool:
        return self.name == "RAW"

    def supports_discrete_actions(self) -> bool:
        return self.name == "BELIEF"

    def has_render(self, env: EnvBase) -> bool:
        """No frames during BenchMARL's evaluation (``anonloc render`` draws episodes)."""
        return False

    def max_steps(self, env: EnvBase) -> int:
        """An episode's length bound: ``max_cycles`` control steps (the belief env's steps are
        picture intervals, fewer)."""
        return int(settings(self.name, self.config).env_config().max_cycles)

    def group_map(self, env: EnvBase) -> dict[str, list[str]]:
        return dict(env.group_map)

    def get_env_transforms(self, env: EnvBase) -> list[Transform]:
        """Flatten what an MLP cannot take as it is: the state ``(N, 3)`` and, in the raw task,
        the detections ``(M, 3)`` of each robot."""
        flatten = [FlattenObservation(-2, -1, in_keys=["state"])]
        if self.name == "RAW":
            key = (GROUP, "observation", "detections")
            flatten.append(FlattenObservation(-2, -1, in_keys=[key]))
        return flatten

    def observation_spec(self, env: EnvBase) -> Composite:
        return _only(env, "observation")

    def info_spec(self, env: EnvBase) -> Composite | None:
        return None

    def state_spec(self, env: EnvBase) -> Composite | None:
        return Composite({"state": env.observation_spec["state"].clone()})

    def action_spec(self, env: EnvBase) -> Composite:
        return env.full_action_spec

    def action_mask_spec(self, env: EnvBase) -> Composite | None:
        return None

    @staticmethod
    def env_name() -> str:
        return "anonloc"


def _only(env: EnvBase, key: str) -> Composite:
    """The env's observation spec reduced to each group's ``key`` entry."""
    spec = env.observation_spec.clone()
    del spec["state"]
    for group in env.group_map:
        for other in [k for k in spec[group].keys() if k != key]:
            del spec[group][other]
    return spec


class AnonLocTask(Task):
    """The anonloc tasks: ``RAW`` (the environment) and ``BELIEF`` (the belief env)."""

    RAW = None
    BELIEF = None

    @staticmethod
    def associated_class() -> type[TaskClass]:
        return AnonLocTaskClass

    def get_from_yaml(self, path: str | None = None) -> TaskClass:
        """The task with the settings of ``path`` (default: ``agents/conf/<name>.yaml``),
        validated.

        Raises:
            ValueError: an unknown key or a bad value in the file.
        """
        file = Path(path) if path is not None else CONF / f"{self.name.lower()}.yaml"
        config = yaml.safe_load(file.read_text()) or {}
        settings(self.name, config)
        return self.get_task(config=config)
