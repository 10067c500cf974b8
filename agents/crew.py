"""The robots of one env driven by one shared learning policy: conditions, choices, rewards.

A :class:`Crew` owns one ``anonloc_env.env.AnonLocEnv`` and a ``baselines.Team`` whose localizer
is every robot's own ``bayes`` identifier and whose excitation is a
:class:`agents.candidates.CandidateChooser`. The policy decides at every picture: its action is
the index of the candidate command each robot drives, held until the next picture (with the
back-off after a bump), so one decision is one picture interval. The condition's excitation
(:func:`condition_excitation`) turns it into commands: in ``free`` motion the candidate is the
command; on ``swarm`` duty every robot follows one shared command stream and the candidate is a
deviation of at most ``budget`` of the robot's limits. The crew returns the policy observations
of :mod:`agents.candidate_features` and the reward of ``Crew.step``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from agents.candidate_features import CANDIDATES, information, true_belief, true_rows
from agents.candidates import CandidateChooser
from anonloc_env.actions import to_commands
from anonloc_env.env import AnonLocEnv
from anonloc_env.rewards import energy
from baselines.excitations import Excitation, SwarmDuty
from baselines.localizers import BayesLocalizer
from baselines.policies import Team
from baselines.steps import Step

CONDITIONS = ("free", "swarm")
REWARDS = ("log_belief", "information", "team")
#: The identity term of the ``log_belief`` reward is floored here (nats: log 1e-3 = -6.9), so that
#: one robot's bad picture cannot dominate a batch.
LOG_BELIEF_FLOOR = 1e-3


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
    teacher: np.ndarray  # (R,) the candidate greedy would drive at the new picture
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
            discount rewards being quick); or ``team``, the mean over the env's robots of their
            ``log_belief`` terms, the same for every robot: a robot's motion also decides how
            well the others are told apart, which a reward of its own does not see.
        candidates: candidates per robot and picture (the policy's choices).
    """

    def __init__(
        self,
        env: AnonLocEnv,
        condition: str = "free",
        budget: float = 0.2,
        information_weight: float = 1.0,
        reward: str = "log_belief",
        candidates: int = CANDIDATES,
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
        self.chooser = CandidateChooser(candidates)
        excitation = condition_excitation(condition, self.chooser, budget)
        self.team = Team(config, self.localizer, excitation)
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
        step = self.team.observe([observations[a] for a in self.agents])
        self._step = step
        self._belief_true = true_belief(self.localizer.belief, true_rows(infos, self.agents))
        return self.chooser.observation

    def step(self, actions: np.ndarray) -> StepResult:
        """Drive each robot's chosen candidate (``(R,)`` indices) until the next picture (or the
        episode's end); the reward adds up the steps of that interval."""
        assert self._step is not None, "reset() first"
        self.chooser.decide(np.asarray(actions).reshape(-1))
        reward = np.zeros(self.n)
        spent = np.zeros(self.n)
        robot, dt = self.config.robot, self.config.dt
        steps = 0
        while True:  # the env's arrays, never its per-agent dicts (the same bits)
            steps += 1
            v, w = self.team.excitation.commands(self._step, dt)
            env_actions = self.team.command(v, w)
            result = self.env.step_arrays(env_actions)
            spent += energy(self.config, *to_commands(env_actions, robot))
            reward += result.rewards
            step = self.team.take(result.seen)
            self._step = step
            truncated = result.truncated
            if step.new_picture or truncated:
                break
        truth = result.true_index
        if step.new_picture:
            belief = true_belief(self.localizer.belief, truth)
            if self.reward == "information":
                identity = information(self._belief_true, belief)
            else:
                identity = np.log(np.maximum(belief, LOG_BELIEF_FLOOR))
                if self.reward == "team":
                    identity = np.full(self.n, identity.mean())
            reward += self.information_weight * identity
            self._belief_true = belief
        present = truth >= 0
        return StepResult(
            observation=self.chooser.observation,
            teacher=self.chooser.teacher(),
            reward=reward,
            truncated=truncated,
            correct=present & (self.localizer.estimate == truth),
            present=present,
            new_picture=step.new_picture,
            energy=spent,
            steps=steps,
        )
