"""anonloc as a BenchMARL task: the environment and the belief env, each with the global state.

BenchMARL (a MARL library on TorchRL: MAPPO, IPPO, MADDPG, QMIX, ...) trains on tasks; this
module defines two, built from the YAML files in ``agents/conf/`` (package data):

| Task | Environment | Action per robot | Observation per robot |
|---|---|---|---|
| `RAW` | `anonloc_env.AnonLocEnv` | `(2,)` in [-1, 1] | the env's dict |
| `BELIEF` | `agents.pettingzoo.BeliefParallelEnv` | one of `C` candidates | `(7 C + 10,)` |

The raw task's actions are continuous and its `detections` are flattened to `(3 M,)`; the belief
task's are discrete and its observation is the belief env's `flat` form. Both give BenchMARL the
global state: every robot's true pose, flattened to `(3 N,)`.

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

:func:`experiment` does the same on the CPU with the few settings a short run needs, and
:class:`BenchmarlExcitation` drives robots with a trained belief-task policy through
``baselines``' protocol (``agents.evaluation.play``), so that it is scored as every other
excitation is.

Needs the ``benchmarl`` extra (see ``docs/benchmarl.md``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
import yaml
from benchmarl.environments.common import Task, TaskClass
from benchmarl.experiment import Experiment, ExperimentConfig
from tensordict import TensorDict
from torchrl.data import Composite
from torchrl.envs import EnvBase, FlattenObservation, PettingZooWrapper, Transform

from agents.candidate_features import CANDIDATES
from agents.candidates import CandidateChooser
from agents.pettingzoo import BeliefParallelEnv, flatten
from agents.policy import draw
from agents.spec import AgentSpec, Reward
from anonloc_env.config import EnvConfig
from anonloc_env.env import AnonLocEnv
from anonloc_env.presets import make_config
from baselines.excitations.swarm import DUTY_BUDGET

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
    budget: float = DUTY_BUDGET
    information_weight: float = 1.0

    def __post_init__(self) -> None:
        if self.condition not in ("free", "swarm"):
            raise ValueError(f"condition must be one of ['free', 'swarm'], got {self.condition!r}")
        if not 0.0 <= self.budget <= 1.0:
            raise ValueError(f"budget must be in [0, 1], got {self.budget!r}")
        if not (self.information_weight >= 0.0 and math.isfinite(self.information_weight)):
            raise ValueError(
                f"information_weight must be finite and >= 0, got {self.information_weight!r}"
            )
        super().__post_init__()

    def spec(self) -> AgentSpec:
        """The agent these settings define (``agents.spec.AgentSpec``)."""
        reward = Reward(information_weight=self.information_weight)
        return AgentSpec(reward=reward, condition=self.condition, budget=self.budget)


def settings(name: str, config: dict[str, Any]) -> RawSettings:
    """The validated settings of task ``name`` (``RAW`` or ``BELIEF``) from its config dict.

    Raises:
        ValueError: an unknown task or key (the message lists the valid ones) or a bad value.
    """
    if name not in ("RAW", "BELIEF"):  # "belief" once gave the raw task's settings silently
        raise ValueError(f"unknown task {name!r}; valid: ['RAW', 'BELIEF']")
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
        return BeliefParallelEnv(chosen.env_config(), chosen.spec(), observation="flat")
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
        for other in [k for k in spec[group] if k != key]:
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


#: BenchMARL's algorithms by name (``benchmarl.algorithms``), the ones :func:`experiment` takes.
ALGORITHMS = ("mappo", "ippo")


def experiment(
    task: TaskClass,
    algorithm: str = "mappo",
    *,
    frames: int,
    frames_per_batch: int,
    envs: int,
    folder: Path,
    seed: int = 0,
    minibatch: int = 200,
    epochs: int = 4,
    lr: float = 3e-4,
) -> Experiment:
    """A BenchMARL experiment of ``algorithm`` on ``task``, on the CPU, BenchMARL's defaults
    (``benchmarl/conf``) otherwise, with an MLP actor and critic.

    Args:
        task: e.g. ``AnonLocTask.BELIEF.get_from_yaml()``.
        algorithm: ``mappo`` (centralised critic on the state) or ``ippo``.
        frames: env steps to collect in all (a multiple of ``frames_per_batch``).
        frames_per_batch: env steps collected per iteration (over the ``envs`` envs).
        envs: environments stepped one after the other to collect a batch.
        folder: where BenchMARL writes its CSV log and marl-eval JSON (created).
        seed: the experiment's seed (torch, and the envs' first reset).
        minibatch: env steps per minibatch; ``epochs``: passes over each batch.
        lr: Adam's learning rate.

    Raises:
        ValueError: an unknown algorithm, or ``frames`` not a positive multiple of
            ``frames_per_batch``.
    """
    from benchmarl.algorithms import IppoConfig, MappoConfig
    from benchmarl.models import MlpConfig

    configs = {"mappo": MappoConfig, "ippo": IppoConfig}
    if algorithm not in configs:
        raise ValueError(f"algorithm must be one of {list(ALGORITHMS)}, got {algorithm!r}")
    if frames_per_batch < 1 or frames < frames_per_batch or frames % frames_per_batch:
        raise ValueError(
            f"frames ({frames}) must be a positive multiple of frames_per_batch "
            f"({frames_per_batch})"
        )
    folder.mkdir(parents=True, exist_ok=True)
    config = ExperimentConfig.get_from_yaml()
    settings = {
        "sampling_device": "cpu",
        "train_device": "cpu",
        "buffer_device": "cpu",
        "max_n_frames": frames,
        "on_policy_collected_frames_per_batch": frames_per_batch,
        "on_policy_n_envs_per_worker": envs,
        "on_policy_n_minibatch_iters": epochs,
        "on_policy_minibatch_size": minibatch,
        "lr": lr,
        "evaluation": False,
        "render": False,
        "loggers": ["csv"],
        "create_json": True,
        "save_folder": str(folder),
        "checkpoint_interval": 0,
        "checkpoint_at_end": False,
    }
    for key, value in settings.items():
        setattr(config, key, value)
    model = MlpConfig.get_from_yaml()
    return Experiment(
        task=task,
        algorithm_config=configs[algorithm].get_from_yaml(),
        model_config=model,
        critic_model_config=model,
        seed=seed,
        config=config,
    )


class BenchmarlExcitation(CandidateChooser):
    """The robots' commands from a policy trained on ``AnonLocTask.BELIEF``: at every picture
    each robot's candidates are scored (as in the belief env), the policy's actor gives logits
    over them, and each robot draws one with its own generator (as ``agents.policy`` does for
    an SB3 agent); it is held until the next picture, with the back-off after a bump.

    It must be the excitation of a team whose localizer is a ``BayesLocalizer``, of as many
    robots as the policy was trained with (BenchMARL's MLP has one input row per agent).

    Args:
        experiment: a trained BenchMARL experiment on the belief task (its ``robot`` group's
            actor is used, in evaluation mode, without gradients).
        candidates: candidates per robot, as in training.
    """

    def __init__(self, experiment: Experiment, candidates: int = CANDIDATES) -> None:
        super().__init__(candidates)
        actor = experiment.group_policies[GROUP]
        self.logits = actor.module[0] if hasattr(actor, "module") else actor

    def on_scored(self) -> None:
        if self.cset is None:
            return
        observation = torch.as_tensor(flatten(self.observation), dtype=torch.float32)
        with torch.no_grad():
            out = self.logits(TensorDict({GROUP: {"observation": observation}}))
        logits = out[GROUP, "logits"].numpy().astype(np.float64)
        self.decide(draw(logits, self.rngs))
