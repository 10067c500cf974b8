"""Training with RLlib PPO: the scale-out path for users who outgrow one machine.

The crew's robots are one PettingZoo env (:class:`agents.pettingzoo.BeliefParallelEnv`) wrapped
in RLlib's ``ParallelPettingZooEnv`` and registered under :data:`ENV_NAME`. Every agent maps to
one RLModule, :data:`MODULE_ID` (parameter sharing, as with SB3: identical robots, one
controller). RLlib's new API stack (RLModule, Learner, EnvRunner) is used throughout.

Choices, checked against Ray 2.60:

* **Flat observations.** RLlib's default encoders accept a 1-D ``Box`` but reject a ``Dict``
  ("No default encoder config for obs space=Dict(...)"), so the env hands out the concatenated
  observation (``observation="flat"``: the same numbers as the SB3 dict, in the layout of
  :class:`agents.features.FlatExtractor`). Concatenating the R robots' batched arrays once per
  step is cheaper than RLlib's ``FlattenObservations`` connector, which flattens every agent's
  dict separately in Python, and the learner then sees exactly what the env runner saw.
* **Rendering.** ``ParallelPettingZooEnv.render`` calls ``render(self.render_mode)``;
  ``BeliefParallelEnv.render`` accepts that argument. Training never renders.
* **Local sampling.** ``num_env_runners=0`` samples in the driver process (one env); raise it
  to sample on that many Ray workers (one env each), on this machine or a Ray cluster.

Example::

    import ray
    from agents.rllib import make_ppo_config, train_rllib
    from anonloc_env import make_config

    ray.init(num_cpus=2, include_dashboard=False)
    metrics = train_rllib(make_ppo_config(make_config(n_robots=10)), iterations=20)

Needs the ``ray`` and ``rl`` extras (``ray[rllib]`` and torch).
"""

from __future__ import annotations

import importlib
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from anonloc_env.config import EnvConfig

#: The name under which the env is registered with ``ray.tune.registry.register_env``.
ENV_NAME = "anonloc_belief_v0"
#: The one RLModule (policy) every robot acts with.
MODULE_ID = "shared"


def _rllib() -> None:
    """Fail with the extra to install when RLlib (or one of its dependencies) is missing."""
    try:
        importlib.import_module("ray.rllib")
    except ImportError as error:  # pragma: no cover - depends on the installation
        raise ImportError(
            "RLlib training needs the ray extra: pip install 'anonloc[ray,rl]' (and 'ray[rllib]')"
        ) from error


def make_env(env_config: dict[str, Any]) -> Any:
    """The env creator registered as :data:`ENV_NAME`: a ``ParallelPettingZooEnv`` around a
    :class:`~agents.pettingzoo.BeliefParallelEnv` with flat observations.

    Args:
        env_config: ``{"config": EnvConfig, "condition", "budget", "information_weight"}``
            (RLlib's ``EnvContext``; only ``config`` is required).
    """
    _rllib()
    from ray.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv

    from agents.pettingzoo import BeliefParallelEnv

    env = BeliefParallelEnv(
        env_config["config"],
        condition=env_config.get("condition", "free"),
        budget=env_config.get("budget", 0.2),
        information_weight=env_config.get("information_weight", 1.0),
        observation="flat",
    )
    return ParallelPettingZooEnv(env)


def register() -> None:
    """Register :func:`make_env` as :data:`ENV_NAME` (idempotent)."""
    _rllib()
    from ray.tune.registry import register_env

    register_env(ENV_NAME, make_env)


def _map_to_shared(agent_id: Any, episode: Any = None, **kwargs: Any) -> str:
    """The policy mapping: every robot acts with the one shared module."""
    return MODULE_ID


@dataclass(frozen=True)
class PPOSettings:
    """PPO's hyperparameters (the defaults are SB3's ``PPO`` defaults, so the two compare; an SB3
    ``n_steps`` per slot is ``n_steps`` env steps here).

    Attributes:
        train_batch_size: env steps sampled per training iteration, >= 1 (RLlib counts a step
            of the whole env once, a picture interval: the module trains on N robot decisions
            for each).
        minibatch_size: robot decisions per gradient step of the shared module, in
            [1, train_batch_size] (RLlib's bound).
        num_epochs: passes over each train batch, >= 1.
        lr: Adam learning rate, > 0.
        gamma: discount per control step, in [0, 1].
        lambda_: GAE lambda, in [0, 1].
        clip_param: PPO ratio clip, > 0.
        entropy_coeff: entropy bonus, >= 0.
        hidden: sizes of the hidden layers of the policy and of the (separate) value network.
        num_env_runners: Ray workers that sample (0: the driver samples), >= 0.
        rollout_fragment_length: env steps per env-runner sample call (``"auto"`` or >= 1).
    """

    train_batch_size: int = 2048
    minibatch_size: int = 64
    num_epochs: int = 10
    lr: float = 3e-4
    gamma: float = 0.99
    lambda_: float = 0.95
    clip_param: float = 0.2
    entropy_coeff: float = 0.0
    hidden: tuple[int, ...] = (64, 64)
    num_env_runners: int = 0
    rollout_fragment_length: int | str = "auto"

    def __post_init__(self) -> None:
        _check_int("train_batch_size", self.train_batch_size, 1)
        _check_int("minibatch_size", self.minibatch_size, 1)
        if self.minibatch_size > self.train_batch_size:
            raise ValueError(
                f"minibatch_size must be in [1, train_batch_size={self.train_batch_size}], "
                f"got {self.minibatch_size}"
            )
        _check_int("num_epochs", self.num_epochs, 1)
        _check_int("num_env_runners", self.num_env_runners, 0)
        for name, value, low, high in (
            ("lr", self.lr, 0.0, math.inf),
            ("clip_param", self.clip_param, 0.0, math.inf),
        ):
            if not (isinstance(value, (int, float)) and low < value < high):
                raise ValueError(f"{name} must be > 0 and finite, got {value!r}")
        for name, value in (("gamma", self.gamma), ("lambda_", self.lambda_)):
            if not (isinstance(value, (int, float)) and 0.0 <= value <= 1.0):
                raise ValueError(f"{name} must be in [0, 1], got {value!r}")
        if not (isinstance(self.entropy_coeff, (int, float)) and 0 <= self.entropy_coeff < 1e9):
            raise ValueError(f"entropy_coeff must be >= 0 and finite, got {self.entropy_coeff!r}")
        if not self.hidden or any(
            not isinstance(h, int) or isinstance(h, bool) or h < 1 for h in self.hidden
        ):
            raise ValueError(
                f"hidden must be a non-empty tuple of integers >= 1, got {self.hidden!r}"
            )
        if self.rollout_fragment_length != "auto":
            _check_int("rollout_fragment_length", self.rollout_fragment_length, 1)


def _check_int(name: str, value: Any, low: int) -> None:
    if not isinstance(value, int) or isinstance(value, bool) or value < low:
        raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")


def make_ppo_config(
    config: EnvConfig,
    settings: PPOSettings | None = None,
    *,
    condition: str = "free",
    budget: float = 0.2,
    information_weight: float = 1.0,
    seed: int | None = 0,
) -> Any:
    """An RLlib ``PPOConfig`` (new API stack) training one shared module for every robot.

    Args:
        config: the scenario.
        settings: PPO's hyperparameters (default :class:`PPOSettings`).
        condition: ``"free"`` or ``"swarm"`` (see :mod:`agents.crew`).
        budget: on swarm duty, the largest deviation as a fraction of the robot's limits.
        information_weight: reward per nat of information about the robot's identity.
        seed: seeds RLlib (module weights, sampling) and its envs; ``None``: fresh entropy.
    """
    if not isinstance(config, EnvConfig):
        raise TypeError(f"config must be an EnvConfig, got {type(config).__name__}")
    from agents.crew import CONDITIONS

    if condition not in CONDITIONS:
        raise ValueError(f"condition must be one of {list(CONDITIONS)}, got {condition!r}")
    settings = settings if settings is not None else PPOSettings()
    _rllib()
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig
    from ray.rllib.core.rl_module.multi_rl_module import MultiRLModuleSpec
    from ray.rllib.core.rl_module.rl_module import RLModuleSpec

    register()
    model = DefaultModelConfig(fcnet_hiddens=list(settings.hidden), fcnet_activation="tanh")
    ppo = (
        PPOConfig()
        .api_stack(enable_rl_module_and_learner=True, enable_env_runner_and_connector_v2=True)
        .environment(
            ENV_NAME,
            env_config={
                "config": config,
                "condition": condition,
                "budget": budget,
                "information_weight": information_weight,
            },
        )
        .framework("torch")
        .env_runners(
            num_env_runners=settings.num_env_runners,
            num_envs_per_env_runner=1,
            rollout_fragment_length=settings.rollout_fragment_length,
        )
        .multi_agent(policies={MODULE_ID}, policy_mapping_fn=_map_to_shared)
        .rl_module(
            rl_module_spec=MultiRLModuleSpec(
                rl_module_specs={MODULE_ID: RLModuleSpec(model_config=model)}
            )
        )
        .training(
            train_batch_size_per_learner=settings.train_batch_size,
            minibatch_size=settings.minibatch_size,
            num_epochs=settings.num_epochs,
            lr=settings.lr,
            gamma=settings.gamma,
            lambda_=settings.lambda_,
            clip_param=settings.clip_param,
            entropy_coeff=settings.entropy_coeff,
        )
        .learners(num_learners=0)
    )
    if seed is not None:
        ppo = ppo.debugging(seed=seed)
    return ppo


@dataclass(frozen=True)
class IterationMetrics:
    """What one RLlib training iteration did.

    Attributes:
        iteration: 1 for the first.
        agent_steps: robot decisions sampled so far (all robots count).
        env_steps: env steps sampled so far (one per control step of the whole env).
        episode_return_mean: mean return of one robot over the episodes that ended in the
            reporting window (NaN before any ended).
        policy_loss: the shared module's PPO policy loss.
        vf_loss: its value-function loss.
        entropy: its action-distribution entropy.
        seconds: wall time of the iteration (s).
    """

    iteration: int
    agent_steps: int
    env_steps: int
    episode_return_mean: float
    policy_loss: float
    vf_loss: float
    entropy: float
    seconds: float


def _number(mapping: Any, *keys: str) -> float:
    value = mapping
    for key in keys:
        if not isinstance(value, dict) or key not in value:
            return math.nan
        value = value[key]
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def iteration_metrics(result: dict[str, Any], n_robots: int, seconds: float) -> IterationMetrics:
    """The :class:`IterationMetrics` of one ``Algorithm.train()`` result (new API stack)."""
    runners = result.get("env_runners", {})
    # RLlib reports the module's return summed over the robots mapped to it, per episode.
    module_return = _number(runners, "module_episode_returns_mean", MODULE_ID)
    return IterationMetrics(
        iteration=int(result.get("training_iteration", 0)),
        agent_steps=int(sum(runners.get("num_agent_steps_sampled_lifetime", {}).values())),
        env_steps=int(runners.get("num_env_steps_sampled_lifetime", 0)),
        episode_return_mean=module_return / n_robots,
        policy_loss=_number(result, "learners", MODULE_ID, "policy_loss"),
        vf_loss=_number(result, "learners", MODULE_ID, "vf_loss"),
        entropy=_number(result, "learners", MODULE_ID, "entropy"),
        seconds=seconds,
    )


def train_iterations(algorithm: Any, iterations: int, n_robots: int) -> list[IterationMetrics]:
    """Run ``iterations`` training iterations of a built RLlib algorithm."""
    _check_int("iterations", iterations, 1)
    metrics = []
    for _ in range(iterations):
        start = time.perf_counter()
        result = algorithm.train()
        metrics.append(iteration_metrics(result, n_robots, time.perf_counter() - start))
    return metrics


def train_rllib(
    ppo_config: Any,
    iterations: int,
    checkpoint_dir: str | None = None,
    num_cpus: int | None = None,
    torch_threads: int | None = 1,
) -> list[IterationMetrics]:
    """Train with RLlib PPO for ``iterations`` iterations; return each iteration's metrics.

    Starts a local Ray instance (``num_cpus`` CPUs, no dashboard) unless Ray is already
    initialised (``ray.init(address=...)`` first to use a cluster).

    Args:
        ppo_config: from :func:`make_ppo_config` (or a ``PPOConfig`` built on it).
        iterations: training iterations, >= 1.
        checkpoint_dir: if given, the trained algorithm is saved there (``Algorithm.save_to_path``;
            a relative path is taken from the working folder).
        num_cpus: CPUs of the local Ray instance (default: all).
        torch_threads: torch threads of this process, which samples (with
            ``num_env_runners=0``) and learns (``num_learners=0``); ``None`` leaves torch's
            setting. One thread is about 4 times faster than torch's default on a busy 2-core
            machine: the networks are small and every step runs one.
    """
    _check_int("iterations", iterations, 1)
    if torch_threads is not None:
        _check_int("torch_threads", torch_threads, 1)
    env_config = ppo_config.env_config.get("config")
    if not isinstance(env_config, EnvConfig):
        raise ValueError("ppo_config must come from make_ppo_config (its env_config has no config)")
    import ray
    import torch

    if torch_threads is not None:
        torch.set_num_threads(torch_threads)
    if not ray.is_initialized():
        ray.init(num_cpus=num_cpus, include_dashboard=False)
    algorithm = ppo_config.build_algo()
    try:
        metrics = train_iterations(algorithm, iterations, env_config.n_robots)
        if checkpoint_dir is not None:  # pyarrow refuses a relative path ("empty scheme")
            algorithm.save_to_path(str(Path(checkpoint_dir).resolve()))
    finally:
        algorithm.stop()
    return metrics
