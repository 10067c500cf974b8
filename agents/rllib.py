"""Training with RLlib PPO: the scale-out path for users who outgrow one machine.

The crew's robots are one PettingZoo env (:class:`agents.pettingzoo.BeliefParallelEnv`) wrapped
in RLlib's ``ParallelPettingZooEnv`` and registered under :data:`ENV_NAME`. Every agent maps to
one RLModule, :data:`MODULE_ID` (parameter sharing, as with SB3: identical robots, one
controller). RLlib's new API stack (RLModule, Learner, EnvRunner) is used throughout.

Choices, checked against Ray 2.60:

* **The same agent as SB3's.** The module is :class:`agents.rllib_module.CandidateRLModule`,
  whose network is :class:`agents.features.CandidateScorer`, the one of the SB3 policy
  :class:`agents.features.CandidatePolicy`: each robot scores its ``C`` candidate commands and
  draws one (``Discrete(C)``); the weights depend on neither N nor the camera.
  :func:`export_agent` turns a trained module into an SB3 agent zip that
  ``baselines.make("agent", env, path=...)`` and ``anonloc eval --agent`` load.
* **Flat observations.** RLlib's connectors batch a 1-D ``Box`` without Python work per agent,
  so the env hands out the concatenated observation (``observation="flat"``: the same numbers
  as the SB3 dict), which the module splits back with :func:`agents.pettingzoo.unflatten`.
  Concatenating the R robots' batched arrays once per step is cheaper than RLlib's
  ``FlattenObservations`` connector, which flattens every agent's dict separately in Python.
* **Rendering.** ``ParallelPettingZooEnv.render`` calls ``render(self.render_mode)``;
  ``BeliefParallelEnv.render`` accepts that argument. Training never renders.
* **Local sampling.** ``num_env_runners=0`` samples in the driver process (one env); raise it
  to sample on that many Ray workers (one env each), on this machine or a Ray cluster.

Example::

    import ray
    from agents.rllib import export_agent, make_ppo_config, train_rllib
    from anonloc_env import make_config

    ray.init(num_cpus=2, include_dashboard=False)
    metrics = train_rllib(make_ppo_config(make_config(n_robots=10)), 20, "runs/rllib")
    export_agent("runs/rllib", "runs/rllib/agent.zip")  # baselines.make("agent", path=...)

Needs the ``ray`` and ``rl`` extras (``ray[rllib]`` and torch).
"""

from __future__ import annotations

import dataclasses
import importlib
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from agents.checkpoints import save_atomic
from anonloc_env._checks import check_number
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
        env_config: ``{"config": EnvConfig, "spec": AgentSpec.to_json()}`` (RLlib's
            ``EnvContext``; only ``config`` is required; the spec travels as JSON to the env
            runners).
    """
    _rllib()
    from ray.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv

    from agents.pettingzoo import BeliefParallelEnv
    from agents.spec import AgentSpec

    spec = AgentSpec.from_json(env_config.get("spec", {}))
    env = BeliefParallelEnv(env_config["config"], spec, observation="flat")
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
    """PPO's hyperparameters, named as :class:`agents.train.TrainConfig` (SB3) names them; the
    defaults are SB3's ``PPO`` defaults, so the two compare (an SB3 ``n_steps`` per slot is
    ``n_steps`` env steps here). :func:`make_ppo_config` maps them to RLlib's names.

    Attributes:
        train_batch_size: env steps sampled per training iteration, >= 1 (RLlib counts a step
            of the whole env once, a picture interval: the module trains on N robot decisions
            for each).
        minibatch_size: robot decisions per gradient step of the shared module, in
            [1, train_batch_size] (RLlib's bound).
        n_epochs: passes over each train batch, >= 1 (RLlib's ``num_epochs``).
        learning_rate: Adam step size, in (0, 1] (RLlib's ``lr``).
        gamma: discount per decision, in [0, 1].
        gae_lambda: GAE lambda, in [0, 1] (RLlib's ``lambda_``).
        clip_range: PPO ratio clip, in (0, 10] (RLlib's ``clip_param``).
        ent_coef: entropy bonus, in [0, 1e6] (RLlib's ``entropy_coeff``).
        hidden: width of the scorer's encodings (``CandidateScorer(hidden)``), in [1, 4096].
        num_env_runners: Ray workers that sample (0: the driver samples), >= 0.
        rollout_fragment_length: env steps per env-runner sample call (``"auto"`` or >= 1).
    """

    train_batch_size: int = 2048
    minibatch_size: int = 64
    n_epochs: int = 10
    learning_rate: float = 3e-4
    gamma: float = 0.99
    gae_lambda: float = 0.95
    clip_range: float = 0.2
    ent_coef: float = 0.0
    hidden: int = 64
    num_env_runners: int = 0
    rollout_fragment_length: int | str = "auto"

    def __post_init__(self) -> None:
        check_number("train_batch_size", self.train_batch_size, 1, 10**9, integer=True)
        check_number("minibatch_size", self.minibatch_size, 1, self.train_batch_size, integer=True)
        check_number("n_epochs", self.n_epochs, 1, 1000, integer=True)
        check_number("learning_rate", self.learning_rate, 0.0, 1.0, low_open=True)
        check_number("gamma", self.gamma, 0.0, 1.0)
        check_number("gae_lambda", self.gae_lambda, 0.0, 1.0)
        check_number("clip_range", self.clip_range, 0.0, 10.0, low_open=True)
        check_number("ent_coef", self.ent_coef, 0.0, 1e6)
        check_number("hidden", self.hidden, 1, 4096, integer=True)
        check_number("num_env_runners", self.num_env_runners, 0, 1024, integer=True)
        if self.rollout_fragment_length != "auto":
            check_number(
                "rollout_fragment_length", self.rollout_fragment_length, 1, 10**9, integer=True
            )


def make_ppo_config(
    config: EnvConfig,
    settings: PPOSettings | None = None,
    *,
    spec: Any = None,
    seed: int | None = 0,
) -> Any:
    """An RLlib ``PPOConfig`` (new API stack) training one shared
    :class:`~agents.rllib_module.CandidateRLModule` for every robot.

    Args:
        config: the scenario.
        settings: PPO's hyperparameters (default :class:`PPOSettings`).
        spec: the agent (``agents.spec.AgentSpec``: candidates, reward, condition ``free`` or
            ``swarm``, budget); default ``AgentSpec()``.
        seed: seeds RLlib (module weights, sampling) and its envs; ``None``: fresh entropy.
    """
    if not isinstance(config, EnvConfig):
        raise TypeError(f"config must be an EnvConfig, got {type(config).__name__}")
    from agents.spec import AgentSpec

    spec = spec if spec is not None else AgentSpec()
    if not isinstance(spec, AgentSpec) or spec.condition == "mixed":
        raise ValueError(f"spec must be an AgentSpec of condition 'free' or 'swarm', got {spec!r}")
    settings = settings if settings is not None else PPOSettings()
    _rllib()
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.multi_rl_module import MultiRLModuleSpec
    from ray.rllib.core.rl_module.rl_module import RLModuleSpec

    register()
    from agents.rllib_module import CandidateRLModule

    ppo = (
        PPOConfig()
        .api_stack(enable_rl_module_and_learner=True, enable_env_runner_and_connector_v2=True)
        .environment(
            ENV_NAME,
            env_config={"config": config, "spec": spec.to_json()},
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
                rl_module_specs={
                    MODULE_ID: RLModuleSpec(
                        module_class=CandidateRLModule, model_config={"hidden": settings.hidden}
                    )
                }
            )
        )
        .training(
            train_batch_size_per_learner=settings.train_batch_size,
            minibatch_size=settings.minibatch_size,
            num_epochs=settings.n_epochs,
            lr=settings.learning_rate,
            gamma=settings.gamma,
            lambda_=settings.gae_lambda,
            clip_param=settings.clip_range,
            entropy_coeff=settings.ent_coef,
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
    check_number("iterations", iterations, 1, 10**9, integer=True)
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
            a relative path is taken from the working directory). :func:`export_agent` reads it.
        num_cpus: CPUs of the local Ray instance (default: all).
        torch_threads: torch threads of this process, which samples (with
            ``num_env_runners=0``) and learns (``num_learners=0``); ``None`` leaves torch's
            setting. One thread is about 4 times faster than torch's default on a busy 2-core
            machine: the networks are small and every step runs one.
    """
    check_number("iterations", iterations, 1, 10**9, integer=True)
    if torch_threads is not None:
        check_number("torch_threads", torch_threads, 1, 1024, integer=True)
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
        if checkpoint_dir is not None:
            # Ray reads a relative path as a URI without a scheme and fails: make it absolute.
            algorithm.save_to_path(str(Path(checkpoint_dir).resolve()))
    finally:
        algorithm.stop()
    return metrics


def trained_module(source: Any) -> Any:
    """The shared :class:`~agents.rllib_module.CandidateRLModule` of ``source``: an RLlib
    ``Algorithm`` from :func:`make_ppo_config`, such a module itself, or the folder
    :func:`train_rllib` saved the algorithm to (``checkpoint_dir``).

    Raises:
        FileNotFoundError: ``source`` is a path without a saved module.
        TypeError: ``source`` is none of these, or its module is not a ``CandidateRLModule``.
    """
    _rllib()
    from agents.rllib_module import CandidateRLModule

    module = source
    if isinstance(source, (str, Path)):
        from ray.rllib.core.rl_module.rl_module import RLModule

        folder = Path(source).resolve() / "learner_group" / "learner" / "rl_module" / MODULE_ID
        if not folder.is_dir():
            raise FileNotFoundError(
                f"no RLlib module {MODULE_ID!r} saved under {source} (expected {folder}): pass "
                "the checkpoint_dir of train_rllib"
            )
        module = RLModule.from_checkpoint(str(folder))
    elif hasattr(source, "get_module"):
        module = source.get_module(MODULE_ID)
    if not isinstance(module, CandidateRLModule):
        raise TypeError(
            "source must be an RLlib Algorithm from make_ppo_config, its CandidateRLModule, or "
            f"the checkpoint_dir of train_rllib; got {type(module).__name__}"
        )
    return module


def export_agent(source: Any, path: str | Path, spec: Any = None) -> Path:
    """Save the trained RLlib module of ``source`` as an SB3 agent zip, loadable by
    ``agents.policy.load_model``, ``baselines.make("agent", env, path=path)`` and
    ``anonloc eval --agent path``, with the agent's ``spec`` (the one the module was trained
    with, given to :func:`make_ppo_config`; default ``AgentSpec()``), so that it runs in the
    spec's condition and budget.

    The zip holds an SB3 ``PPO`` whose policy is :class:`agents.features.CandidatePolicy` with
    the module's scorer weights copied unchanged (both are ``CandidateScorer``), so it scores
    every observation exactly as the RLlib module does. Only the weights carry over: PPO's
    hyperparameters in the zip are SB3's defaults.

    Args:
        source: see :func:`trained_module` (an Algorithm, its module, or a checkpoint folder).
        path: the zip to write (must end in ``.zip``; its folder is created). Written to a
            temporary file first, then moved into place.

    Returns:
        The path written.
    """
    target = Path(path)
    if target.suffix != ".zip":
        raise ValueError(f"path must name a .zip file, got {str(path)!r}")
    module = trained_module(source)
    from stable_baselines3 import PPO

    from agents.features import CandidatePolicy
    from agents.spec import AgentSpec
    from agents.vec import AnonLocVecEnv
    from anonloc_env.presets import make_config

    spec = spec if spec is not None else AgentSpec()
    spec = dataclasses.replace(spec, candidates=module.candidates)
    # The spaces depend on the spec only: any small scenario builds the policy.
    env = AnonLocVecEnv(make_config(n_robots=2), spec=spec.in_scenario("free", spec.budget))
    try:
        model = PPO(
            CandidatePolicy,
            env,
            policy_kwargs={"hidden": module.hidden, "spec": spec.to_json()},
            device="cpu",
        )
        policy = model.policy
        assert isinstance(policy, CandidatePolicy)
        policy.scorer.load_state_dict(module.scorer.state_dict())
        save_atomic(model, target)
    finally:
        env.close()
    return target
