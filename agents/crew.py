"""The robots of one env driven by one shared learning policy: conditions, commands, rewards.

A :class:`Crew` owns one ``anonloc_env.env.AnonLocEnv`` and a ``baselines.Team``
whose localizer is every robot's own ``bayes`` identifier. The policy decides at every picture:
its action ``(v / v_max, w / omega_max)`` is held until the next picture (:class:`HeldCommands`,
which also reverses out of bumps), so one decision is one picture interval. The action becomes
the commands through the condition's excitation (:func:`condition_excitation`): in ``free``
motion the held action is the command; on ``swarm`` duty every robot follows one shared command
stream and the held action is only a deviation of at most ``budget`` of the robot's limits. The
crew returns the policy observations of :mod:`agents.observation` and the reward of
``Crew.step``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from agents.observation import BeliefObserver, information, true_rows
from anonloc_env.actions import to_actions, to_commands
from anonloc_env.env import AnonLocEnv
from anonloc_env.rewards import energy
from baselines.excitations import BackOff, DistinctSettings, Excitation, SwarmDuty
from baselines.localizers import BayesLocalizer
from baselines.observations import Step
from baselines.policies import Team

CONDITIONS = ("free", "swarm")
REWARDS = ("log_belief", "information")
#: The identity term of the ``log_belief`` reward is floored here (nats: log 1e-3 = -6.9), so that
#: one robot's bad picture cannot dominate a batch.
LOG_BELIEF_FLOOR = 1e-3


class HeldCommands(BackOff):
    """The policy's command, held from one picture to the next, with a reflex: after a bump the
    robot reverses out of it (``baselines.excitations.BackOff``) and then resumes the
    command.

    The policy decides once per picture: between two pictures nothing new is learnt about the
    robot's identity, and a command held over the interval is what makes the robot's
    displacement its own (the hand-designed ``distinct`` excitation does the same).

    Args:
        back: the reverse drive after a bump (``DistinctSettings``' ``back_speed``,
            ``back_time`` and ``turn``).
    """

    def __init__(self, back: DistinctSettings | None = None) -> None:
        super().__init__()
        self.back = back or DistinctSettings()
        self.v = np.zeros(0)
        self.w = np.zeros(0)

    def reset(self, rngs: Sequence[np.random.Generator]) -> None:
        super().reset(rngs)
        self.v = np.zeros(self.n)
        self.w = np.zeros(self.n)
        self._reset_backoff()

    def set(self, v: np.ndarray, w: np.ndarray) -> None:
        """Hold the commands ``(R,)`` (m/s, rad/s) until the next :meth:`set`."""
        self.v, self.w = v, w

    def commands(self, step: Step, dt: float) -> tuple[np.ndarray, np.ndarray]:
        self._start_backoff(step)
        return self._apply_backoff(dt, self.v, self.w)


def condition_excitation(
    condition: str, own: Excitation, budget: float, common_seed: int = 0
) -> Excitation:
    """The excitation of a condition: ``own`` itself (``free``), or ``own`` as the bounded
    deviation from a shared command stream (``swarm``, see
    ``baselines.excitations.SwarmDuty``)."""
    if condition not in CONDITIONS:
        raise ValueError(f"condition must be one of {list(CONDITIONS)}, got {condition!r}")
    if condition == "free":
        return own
    return SwarmDuty(own, budget=budget, common_seed=common_seed)


@dataclass(frozen=True)
class StepResult:
    """One decision of a crew (one picture interval): the policy observations, rewards and
    ground-truth scores."""

    observation: dict[str, np.ndarray]
    reward: np.ndarray
    truncated: bool
    correct: np.ndarray  # (R,) decided on the true row at this step's newest picture
    present: np.ndarray  # (R,) in that picture
    new_picture: bool
    energy: np.ndarray  # (R,) wheel travel in this interval (m)
    steps: int  # control steps of the env in this interval


class Crew:
    """The R robots of one env, each with its own identifier, acting through one policy.

    Args:
        env: the environment (its reward function gives the energy term: use
            ``anonloc_env.EnergyCost`` so that the identity information is not computed twice).
        condition: ``"free"`` or ``"swarm"``.
        budget: on swarm duty, the largest deviation as a fraction of ``v_max`` and
            ``omega_max``.
        information_weight: weight of the identity term of the reward (per nat).
        reward: the identity term, at each picture: ``log_belief``, the log of the belief the
            robot gives its true row (floored at ``LOG_BELIEF_FLOOR``), so that every picture
            spent unsure costs what is still unknown; or ``information``, the nats gained since
            the previous picture (the env's ``InformationGain``; it telescopes, so only the
            discount rewards being quick).
    """

    def __init__(
        self,
        env: AnonLocEnv,
        condition: str = "free",
        budget: float = 0.2,
        information_weight: float = 1.0,
        reward: str = "log_belief",
    ) -> None:
        if reward not in REWARDS:
            raise ValueError(f"reward must be one of {list(REWARDS)}, got {reward!r}")
        self.reward = reward
        self.env = env
        config = env.config
        self.config = config
        self.agents = list(env.possible_agents)
        self.n = config.n_robots
        self.condition = condition
        self.budget = budget
        self.information_weight = information_weight
        self.capacity = env.capacity
        self.localizer = BayesLocalizer(config, self.n)
        self.held = HeldCommands()
        excitation = condition_excitation(condition, self.held, budget)
        self.team = Team(config, self.localizer, excitation)
        self.observer = BeliefObserver(self.localizer, self.capacity)
        self._scale = np.array([config.robot.v_max, config.robot.omega_max])
        self._step: Step | None = None
        self._belief_true = np.zeros(self.n)

    def reset(self, seed: int | None) -> dict[str, np.ndarray]:
        """Start an episode: the env is reset with ``seed``; the robots' own random streams
        (the swarm's shared stream included) are drawn from the env's generator."""
        observations, infos = self.env.reset(seed=seed)
        entropy = self.env.rng.integers(0, 2**63, size=2)
        if isinstance(self.team.excitation, SwarmDuty):
            self.team.excitation.shared.common_seed = int(entropy[0])
        self.team.reset(np.random.SeedSequence(int(entropy[1])).spawn(self.n))
        self.observer.reset(self.team.excitation.rngs)
        step = self.team.observe([observations[a] for a in self.agents])
        self._step = step
        if step.new_picture:
            self.observer.on_picture(step)
        self._belief_true = self.observer.true_belief(true_rows(infos, self.agents))
        return self.observer.observe(step, first=True)

    def step(self, actions: np.ndarray) -> StepResult:
        """Hold the policy's actions ``(R, 2)`` (in [-1, 1]; clipped) until the next picture (or
        the episode's end); the reward adds up the steps of that interval."""
        assert self._step is not None, "reset() first"
        clipped = np.clip(np.asarray(actions, np.float64), -1.0, 1.0)
        own = clipped * self._scale
        self.held.set(own[:, 0], own[:, 1])
        self.observer.last_command[:] = clipped  # what the policy asked (before any duty)
        reward = np.zeros(self.n)
        spent = np.zeros(self.n)
        robot, dt = self.config.robot, self.config.dt
        steps = 0
        while True:
            steps += 1
            v, w = self.team.excitation.commands(self._step, dt)
            env_actions = to_actions(v, w, robot)
            self.team.commanded(env_actions)
            observations, rewards, _, truncations, infos = self.env.step(
                dict(zip(self.agents, env_actions, strict=True))
            )
            spent += energy(self.config, *to_commands(env_actions, robot))
            reward += np.fromiter(rewards.values(), np.float64, self.n)
            step = self.team.observe([observations[a] for a in self.agents])
            self._step = step
            truncated = bool(truncations[self.agents[0]])
            if step.new_picture or truncated:
                break
        truth = true_rows(infos, self.agents)
        if step.new_picture:
            self.observer.on_picture(step)
            belief = self.observer.true_belief(truth)
            if self.reward == "log_belief":
                identity = np.log(np.maximum(belief, LOG_BELIEF_FLOOR))
            else:
                identity = information(self._belief_true, belief)
            reward += self.information_weight * identity
            self._belief_true = belief
        present = truth >= 0
        return StepResult(
            observation=self.observer.observe(step),
            reward=reward,
            truncated=truncated,
            correct=present & (self.localizer.estimate == truth),
            present=present,
            new_picture=step.new_picture,
            energy=spent,
            steps=steps,
        )
