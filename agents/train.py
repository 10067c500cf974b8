"""Train one shared excitation policy with SB3 PPO, readable top to bottom (CleanRL style).

>>> from agents.train import TrainConfig, train
>>> run = train(TrainConfig(timesteps=4096, out="runs"))  # doctest: +SKIP

A run writes, under ``out/<run name>/``: ``config.json`` (this config and the scenario's full
``EnvConfig``), ``tb/`` (TensorBoard logs: PPO's losses, episode returns, and the share of
robots identified), ``checkpoints/`` (``agent_<steps>_steps.zip`` every ``checkpoint_every``
steps, and at the end or an interrupt), and ``agent.zip`` (the final policy). :func:`resume`
continues a run from its newest checkpoint, with its recorded config.

Nothing trained is lost: checkpoints and ``agent.zip`` are written to a temporary file and moved
into place; Ctrl-C (``KeyboardInterrupt``) or SIGTERM saves a checkpoint and ``agent.zip`` of the
steps done so far before :class:`Interrupted` is raised; :func:`resume` skips a damaged newest
checkpoint for the previous good one (and says so), keeps ``tb/progress.csv``'s earlier rows, and
trains up to the run's recorded total ``timesteps`` (or a new total the caller gives). A run
folder is locked while it trains: a second process on it is refused (:mod:`agents.run_folder`).
"""

from __future__ import annotations

import dataclasses
import re
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from agents.checkpoints import checkpoint_path, latest_checkpoint, save_atomic
from agents.conditions import VALIDATION_SEEDS, validation_scenario
from agents.run_folder import (
    RunLock,
    interrupt_on_sigterm,
    read_config,
    set_aside_logs,
    write_config,
)
from agents.spec import CONDITIONS, IDENTITY_TERMS, AgentSpec, Reward
from anonloc_env._checks import check_choice, check_number
from anonloc_env.config import EnvConfig
from anonloc_env.presets import make_config

#: ``condition`` values: one scenario on free motion or swarm duty, or scenarios drawn across
#: conditions (:mod:`agents.conditions`) for a general agent.
TRAIN_CONDITIONS = CONDITIONS


#: The most robot-steps a run (and so a batch or a checkpoint interval) may count: 1e10, about
#: half a year at the 700 robot-steps per second of a 2-core machine; more is a hang.
MAX_STEPS = 10_000_000_000


@dataclass(frozen=True)
class TrainConfig:
    """Everything a training run depends on. Every field is recorded in ``config.json``."""

    preset: str = "default"
    """The scenario's preset (see ``anonloc_env.preset_names()``)."""
    overrides: dict[str, Any] = field(default_factory=dict)
    """Keyword overrides of the preset (as ``anonloc_env.make_config`` takes them)."""
    condition: str = "free"
    """``free`` (the chosen candidate is the command), ``swarm`` (a bounded deviation from a
    shared command stream), or ``mixed``: every copy draws its scenario from
    :class:`agents.conditions.ConditionRanges` and draws a new one (its N kept) at the end of
    every episode (the preset and overrides are then not used)."""
    budget: float = 0.2  # = DUTY_BUDGET, spelled out: the CLI reads defaults without importing
    """On swarm duty: the largest deviation, as a fraction of ``v_max`` and ``omega_max``."""
    information_weight: float = 1.0
    """Weight of the identity term of the reward."""
    reward: str = "log_belief"
    """The identity term: ``log_belief`` (log of the belief in the true row, at every picture),
    ``information`` (nats gained since the previous picture) or ``team`` (the robots' mean
    ``log_belief``, shared); see :class:`agents.crew.Crew`."""
    energy_weight: float | None = None
    """Reward lost per metre of wheel travel; None keeps the scenario's ``reward.energy_weight``."""
    rest: float | None = None
    """The belief at which a robot holds still until the next picture, in (0.5, 1]
    (``baselines.excitations.rest.RestWhenSure``; saved in the agent's spec, so it rests where
    it runs as it did in training); None: it chooses a candidate at every picture."""
    hidden: int = 64
    """Width of the candidate scorer's encodings (:class:`agents.features.CandidateScorer`)."""
    imitation: int = 0
    """Robot-decisions of ``greedy`` to imitate before PPO (:mod:`agents.imitation`); 0: PPO
    starts from ``uniform`` (the scorer's last layer zeroed: every logit 0)."""
    imitation_epochs: int = 15
    """Passes over the demonstrations."""
    temperature: float = 10.0
    """The imitated logits are divided by this before PPO starts: ``greedy``'s choice alone
    makes identical robots too alike (measured in ``docs/agents.md``), a softer start keeps
    the robots' draws diverse."""
    eval_episodes: int = 4
    """Episodes on fixed seeds at every checkpoint (pictures to 99 % in the progress display
    and the logs) and, at the end, for the comparison against random motion; 0: none."""
    timesteps: int = 200_000
    """Total robot-decisions of experience (slots x decisions; one decision per picture)."""
    n_envs: int = 4
    """Copies of the env (slots = copies x robots)."""
    seed: int = 0
    """Seeds PPO, torch and every env copy."""
    learning_rate: float = 3e-4
    """Adam step size."""
    n_steps: int = 128
    """Decisions per slot between two updates."""
    batch_size: int = 1024
    """Minibatch size (samples; at most one rollout, ``n_steps`` x slots)."""
    n_epochs: int = 4
    """Passes over each rollout."""
    gamma: float = 0.99
    """Discount per decision (per picture interval)."""
    ent_coef: float = 0.0
    """Entropy bonus."""
    minutes: float | None = None
    """Wall-clock budget: stop (and save) after this many minutes even if ``timesteps`` are not
    reached; None: no budget."""
    checkpoint_every: int = 50_000
    """Robot-decisions between checkpoints."""
    out: str = "runs"
    """Folder of the runs."""
    name: str | None = None
    """Run name; default ``<preset>-<condition>-ppo-s<seed>-<time>``."""
    torch_threads: int = 1
    """Threads torch may use (1 is fastest for these small networks on a shared CPU)."""
    progress: bool = False
    """Show a progress bar."""

    def __post_init__(self) -> None:
        check_choice("condition", self.condition, TRAIN_CONDITIONS)
        if self.condition == "mixed" and self.overrides:
            raise ValueError("condition 'mixed' draws its scenarios: overrides would be ignored")
        check_number("hidden", self.hidden, 1, 4096, integer=True)
        check_number("imitation", self.imitation, 0, 10**9, integer=True)
        check_number("imitation_epochs", self.imitation_epochs, 1, 10_000, integer=True)
        check_number("temperature", self.temperature, 0.0, 1e6, low_open=True)
        check_number("eval_episodes", self.eval_episodes, 0, 10_000, integer=True)
        check_choice("reward", self.reward, IDENTITY_TERMS)
        if self.energy_weight is not None:
            check_number("energy_weight", self.energy_weight, 0.0)
        check_number("budget", self.budget, 0.0, 1.0)
        check_number("information_weight", self.information_weight, 0.0)
        check_number("timesteps", self.timesteps, 1, MAX_STEPS, integer=True)
        check_number("n_envs", self.n_envs, 1, 1024, integer=True)
        check_number("seed", self.seed, 0, 2**32 - 1, integer=True)
        check_number("learning_rate", self.learning_rate, 0.0, 1.0, low_open=True)
        check_number("n_steps", self.n_steps, 2, 100_000, integer=True)
        check_number("batch_size", self.batch_size, 2, MAX_STEPS, integer=True)
        check_number("n_epochs", self.n_epochs, 1, 1000, integer=True)
        check_number("gamma", self.gamma, 0.0, 1.0)
        check_number("ent_coef", self.ent_coef, 0.0)
        check_number("checkpoint_every", self.checkpoint_every, 1, MAX_STEPS, integer=True)
        if self.minutes is not None:
            check_number("minutes", self.minutes, 0.0, low_open=True)
        check_number("torch_threads", self.torch_threads, 1, 1024, integer=True)
        if self.name is not None and not re.fullmatch(r"[A-Za-z0-9._-]+", self.name):
            raise ValueError(f"name must use letters, digits, '.', '_' or '-', got {self.name!r}")
        self.spec()  # a bad rest fails here
        self.env_config()  # a bad scenario fails here, before any work

    def spec(self) -> AgentSpec:
        """The agent this run trains (:class:`agents.spec.AgentSpec`), built from this config's
        ``condition``, ``budget``, ``reward``, ``information_weight``, ``energy_weight`` and
        ``rest``;
        saved with the agent."""
        reward = Reward(self.reward, self.information_weight, self.energy_weight)
        return AgentSpec(
            reward=reward, condition=self.condition, budget=self.budget, rest=self.rest
        )

    def env_config(self) -> EnvConfig:
        """The scenario's config (with ``energy_weight`` applied)."""
        config = make_config(self.preset, **self.overrides)
        if self.energy_weight is None:
            return config
        reward = dataclasses.replace(config.reward, energy_weight=self.energy_weight)
        return dataclasses.replace(config, reward=reward)

    def run_name(self) -> str:
        """The run's folder name."""
        if self.name is not None:
            return self.name
        stamp = time.strftime("%Y%m%d-%H%M%S")
        return f"{self.preset}-{self.condition}-ppo-s{self.seed}-{stamp}"

    def to_json(self) -> dict[str, Any]:
        """The config as JSON values."""
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class TrainResult:
    """What a run produced.

    Attributes:
        directory: the run's folder.
        agent: the saved final policy (``agent.zip``).
        timesteps: robot-steps trained (a resumed run counts its earlier steps).
        seconds: wall time of this call.
        comparison: pictures to 99 % (censored mean) of the trained agent and of random motion
            on the progress display's evaluation seeds, or None (``eval_episodes`` 0).
    """

    directory: Path
    agent: Path
    timesteps: int
    seconds: float
    comparison: tuple[float, float] | None = None


def build_model(config: TrainConfig, vec_env: Any) -> Any:
    """A fresh PPO on ``vec_env`` with the candidate scorer and the config's hyperparameters."""
    from stable_baselines3 import PPO

    from agents.features import CandidatePolicy

    return PPO(
        CandidatePolicy,
        vec_env,
        learning_rate=config.learning_rate,
        n_steps=config.n_steps,
        batch_size=min(config.batch_size, config.n_steps * vec_env.num_envs),
        n_epochs=config.n_epochs,
        gamma=config.gamma,
        ent_coef=config.ent_coef,
        seed=config.seed,
        device="cpu",
        policy_kwargs={"hidden": config.hidden, "spec": config.spec().to_json()},
        verbose=0,
    )


def make_vec_env(config: TrainConfig) -> Any:
    """The config's vectorized env (copies x robots slots)."""
    from agents.conditions import ConditionRanges, training_scenarios
    from agents.vec import AnonLocVecEnv

    spec = config.spec()
    if config.condition == "mixed":
        ranges = ConditionRanges()
        if config.energy_weight is not None:
            ranges = dataclasses.replace(ranges, energy_weight=config.energy_weight)
        scenarios = training_scenarios(config.n_envs, config.seed, ranges)
        return AnonLocVecEnv(scenarios[0].config, spec=spec, scenarios=scenarios, redraw=ranges)
    return AnonLocVecEnv(config.env_config(), n_envs=config.n_envs, spec=spec)


def evaluation_scenario(config: TrainConfig) -> tuple[EnvConfig, str, float]:
    """What the progress display evaluates on: the run's scenario, or for ``mixed`` 14 robots
    (a training N, none of the evaluation conditions') at one per square metre, 1 px of noise,
    no headings, free motion, 20 pictures."""
    if config.condition != "mixed":
        return config.env_config(), config.condition, config.budget
    return validation_scenario("free", config.budget).config, "free", config.budget


#: The progress display's evaluation seeds start here (never a training or benchmark seed).
PROGRESS_SEEDS = VALIDATION_SEEDS


def train(config: TrainConfig) -> TrainResult:
    """Train a new run as ``config`` describes (see the module doc).

    Raises:
        FileExistsError: the run folder exists already.
    """
    directory = Path(config.out) / config.run_name()
    if directory.exists():
        raise FileExistsError(
            f"run folder {directory} exists: choose another name, or continue it with resume"
        )
    directory.mkdir(parents=True)
    with RunLock(directory):
        write_config(directory, config.to_json(), config.env_config())
        return _learn(config, directory, None)


class Interrupted(KeyboardInterrupt):
    """Training was stopped by Ctrl-C or SIGTERM after saving what it had.

    Attributes:
        directory: the run folder (continue it with :func:`resume`).
        checkpoint: the checkpoint just saved.
        timesteps: robot-steps trained when it stopped.
    """

    def __init__(self, directory: Path, checkpoint: Path, timesteps: int) -> None:
        super().__init__(f"training stopped at {timesteps} robot-steps; saved {checkpoint}")
        self.directory = directory
        self.checkpoint = checkpoint
        self.timesteps = timesteps


def resume(
    directory: Path | str,
    timesteps: int | None = None,
    minutes: float | None = None,
    *,
    progress: bool | None = None,
    notify: Callable[[str], None] | None = None,
) -> TrainResult:
    """Continue the run in ``directory`` from its newest good checkpoint, with its recorded config.

    The budget rule: the run trains up to its recorded total ``timesteps`` unless ``timesteps``
    gives a new total; ``minutes`` bounds this call's wall time (default: the recorded
    ``minutes``, itself per call). A run already at its total trains no more. A run killed
    before its first checkpoint (nothing saved) trains again from step 0.

    Args:
        directory: the run folder.
        timesteps: new total robot-steps (default: the recorded total).
        minutes: this call's wall-clock budget (default: the recorded one).
        progress: show a progress bar (default: as recorded).
        notify: where to say that a checkpoint was skipped or missing (default: a warning).

    Raises:
        FileNotFoundError: no run there, or only damaged checkpoints.
        ValueError: a bad new budget, or a config.json that is not a run's.
        agents.run_folder.RunBusyError: another process trains this run.
    """
    directory = Path(directory)
    recorded = read_config(directory)
    if timesteps is not None:
        recorded["timesteps"] = timesteps
    if minutes is not None:
        recorded["minutes"] = minutes
    if progress is not None:
        recorded["progress"] = progress
    try:
        config = TrainConfig(**recorded)
    except TypeError as error:
        raise ValueError(f"{directory / 'config.json'} is not a run's config: {error}") from None
    say = notify if notify is not None else _warn
    with RunLock(directory):
        if not list((directory / "checkpoints").glob("agent_*_steps.zip")):
            # Killed (kill -9, a power cut) before its first checkpoint: nothing was saved, so
            # the run starts again from step 0 rather than being a dead end.
            kept = set_aside_logs(directory)
            moved = "" if kept is None else f" (the earlier logs are kept in {kept})"
            where = directory / "checkpoints"
            say(f"no checkpoint in {where}: training the run from step 0{moved}")
            return _learn(config, directory, None)
        return _learn(config, directory, latest_checkpoint(directory, notify=notify))


def _warn(message: str) -> None:
    warnings.warn(message, stacklevel=3)


def _learn(config: TrainConfig, directory: Path, checkpoint: Path | None) -> TrainResult:
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import CallbackList

    from agents.callbacks import (
        AtomicCheckpoint,
        IdentificationLogger,
        ProgressEvaluation,
        StepProgress,
        WallClockBudget,
        resumable_logger,
    )

    start = time.perf_counter()
    torch.set_num_threads(config.torch_threads)
    vec_env = make_vec_env(config)
    try:
        if checkpoint is None:
            model = build_model(config, vec_env)
            if config.imitation:
                start_from_greedy(model, vec_env, config)
            else:
                start_from_uniform(model)
        else:
            model = PPO.load(checkpoint, env=vec_env, device="cpu")
        checkpoints = AtomicCheckpoint(
            save_freq=max(config.checkpoint_every // vec_env.num_envs, 1),
            save_path=str(directory / "checkpoints"),
            name_prefix="agent",
        )
        model.set_logger(resumable_logger(directory / "tb", keep=checkpoint is not None))
        already = int(model.num_timesteps)
        callbacks = [checkpoints, IdentificationLogger()]
        if config.minutes is not None:
            callbacks.append(WallClockBudget(config.minutes))
        progress = None
        if config.progress:
            progress = StepProgress(config.timesteps, already, config.minutes)
            callbacks.append(progress)
        evaluation = None
        if config.eval_episodes:
            evaluation = ProgressEvaluation(
                evaluation_scenario(config),
                range(PROGRESS_SEEDS, PROGRESS_SEEDS + config.eval_episodes),
                every=max(config.checkpoint_every // vec_env.num_envs, 1),
                progress=progress,
            )
            callbacks.append(evaluation)
        try:
            with interrupt_on_sigterm():
                model.learn(
                    total_timesteps=max(config.timesteps - already, 0),
                    callback=CallbackList(callbacks),
                    reset_num_timesteps=checkpoint is None,
                )
        except (KeyboardInterrupt, SystemError) as error:
            if not _is_interrupt(error):
                raise
            saved = save_atomic(model, checkpoint_path(directory, int(model.num_timesteps)))
            save_atomic(model, directory / "agent.zip")
            raise Interrupted(directory, saved, int(model.num_timesteps)) from None
        finally:
            model.logger.close()
        # The end is a checkpoint too: any finished run can be extended with resume.
        save_atomic(model, checkpoint_path(directory, int(model.num_timesteps)))
        agent = save_atomic(model, directory / "agent.zip")
        comparison = None if evaluation is None else evaluation.against_random(model)
    finally:
        vec_env.close()
    return TrainResult(
        directory, agent, int(model.num_timesteps), time.perf_counter() - start, comparison
    )


def _is_interrupt(error: BaseException) -> bool:
    """Whether ``error`` is Ctrl-C or SIGTERM: a ``KeyboardInterrupt``, or the ``SystemError``
    a compiled function (numba's dispatcher, the ``fast`` extra) raises when the signal's
    handler raised inside it ("returned a result with an exception set", the interrupt
    chained as its cause)."""
    seen: BaseException | None = error
    while seen is not None:
        if isinstance(seen, KeyboardInterrupt):
            return True
        seen = seen.__cause__ or seen.__context__
    return False


def start_from_uniform(model: Any) -> None:
    """Zero the scorer's last layer: every logit is 0, so PPO starts from ``uniform`` exactly (a
    fair draw among the candidates, the policy's no-learning ablation) and whatever it gains
    over its start is learned; the value head and the encodings keep their random start."""
    import torch

    last = model.policy.scorer.score[-1]
    with torch.no_grad():
        last.weight.zero_()
        last.bias.zero_()


def start_from_greedy(model: Any, vec_env: Any, config: TrainConfig) -> list[float]:
    """Imitate ``config.imitation`` robot-decisions of ``greedy`` (:mod:`agents.imitation`),
    then soften the logits by ``config.temperature``; returns the agreement after each epoch."""
    import torch

    from agents.imitation import collect_demonstrations, imitate

    demos = collect_demonstrations(vec_env, config.imitation, config.seed, config.gamma)
    agreement = imitate(model.policy, demos, epochs=config.imitation_epochs, seed=config.seed)
    last = model.policy.scorer.score[-1]
    with torch.no_grad():
        last.weight /= config.temperature
        last.bias /= config.temperature
    vec_env.seed(config.seed)  # PPO's own episodes start from the run's seed again
    return agreement
