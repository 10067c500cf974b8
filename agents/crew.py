"""The robots of one env driven by one shared learning policy: conditions, choices, rewards.

A :class:`Crew` owns one ``anonloc_env.env.AnonLocEnv`` and a ``baselines.Team`` whose localizer
is every robot's own ``bayes`` identifier and whose excitation is a
:class:`agents.candidates.CandidateChooser`. The policy decides at every picture: its action is
the index of the candidate command each robot drives, held until the next picture (with the
back-off after a bump), so one decision is one picture interval. The condition's excitation
(``agents.spec.AgentSpec.excitation``) turns it into commands: in ``free`` motion the candidate
is the command; on ``swarm`` duty every robot follows one shared command stream and the
candidate is a deviation of at most ``budget`` of the robot's limits. The crew returns the
policy observations of :mod:`agents.candidate_features` and the reward of the spec
(``agents.spec.Reward``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from agents.candidate_features import true_belief, true_rows
from agents.candidates import CandidateChooser
from agents.spec import AgentSpec
from anonloc_env.actions import to_commands
from anonloc_env.env import AnonLocEnv, ArrayStep
from anonloc_env.rewards import EnergyCost, energy
from baselines.active import ScoringJob
from baselines.excitations import SwarmDuty
from baselines.localizers import BayesLocalizer
from baselines.policies import Team
from baselines.steps import Step


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
        spec: the agent (:class:`agents.spec.AgentSpec`): its candidates, its reward's identity
            term (``spec.reward``) and its condition (``free`` or ``swarm``) and budget.
    """

    def __init__(self, env: AnonLocEnv, spec: AgentSpec | None = None) -> None:
        spec = spec if spec is not None else AgentSpec()
        if spec.condition == "mixed":
            raise ValueError("a crew acts in one condition: 'free' or 'swarm', not 'mixed'")
        self.spec = spec
        self.env = env
        config = env.config
        self.config = config
        self.agents = list(env.possible_agents)
        self.n = config.n_robots
        self.capacity = env.capacity
        self.localizer = BayesLocalizer(config, self.n)
        self.chooser = CandidateChooser(spec.candidates, features=spec.features)
        self.team = Team(config, self.localizer, spec.excitation(self.chooser))
        self._step: Step | None = None
        self._advanced: tuple[ArrayStep, np.ndarray, np.ndarray, int] | None = None
        self._belief_true = np.zeros(self.n)
        # An EnergyCost reward is computed here, once per decision from the commands of all
        # its control steps (the same bits as the env's step by step), not by the env.
        self._energy_reward = type(env.reward_fn) is EnergyCost

    def reset(self, seed: int | None) -> dict[str, np.ndarray]:
        """Start an episode: the env is reset with ``seed``; the robots' own random streams
        (the swarm's shared stream included) are drawn from the env's generator."""
        job = self.start(seed)
        return self.started(None if job is None else job.entropy())

    def start(self, seed: int | None) -> ScoringJob | None:
        """``reset`` with the candidates of the first picture prepared but not scored: the
        returned job's expected entropy goes to ``started`` (``agents.vec.AnonLocVecEnv``
        scores the copies it resets together); None when nothing is to be scored."""
        observations, infos = self.env.reset(seed=seed)
        entropy = self.env.rng.integers(0, 2**63, size=2)
        if isinstance(self.team.excitation, SwarmDuty):  # the swarm's stream, of this episode
            self.team.excitation.shared.common_seed = int(entropy[0])
        self.team.reset(np.random.SeedSequence(int(entropy[1])).spawn(self.n))
        self.chooser.defer = True
        try:
            step = self.team.observe([observations[a] for a in self.agents])
        finally:
            self.chooser.defer = False
        self._step = step
        self._belief_true = true_belief(self.localizer.belief, true_rows(infos, self.agents))
        return self.chooser.job

    def started(self, entropy: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """The first observation of the episode begun by ``start``, its picture scored with
        ``entropy`` (the expected entropy of the job ``start`` returned; None when it returned
        None)."""
        if self.chooser.waiting:
            self.chooser.scored(entropy)
        return self.chooser.observation

    def step(self, actions: np.ndarray) -> StepResult:
        """Drive each robot's chosen candidate (``(R,)`` indices) until the next picture (or the
        episode's end); the reward adds up the steps of that interval."""
        job = self.advance(actions, defer=True)
        return self.finish(None if job is None else job.entropy())

    def advance(self, actions: np.ndarray, defer: bool = False) -> ScoringJob | None:
        """``step`` up to the picture. With ``defer`` the candidates of a new picture are
        prepared but not scored: the returned job's expected entropy goes to ``finish``
        (``agents.vec.AnonLocVecEnv`` scores all its copies in one call); None when nothing
        is to be scored."""
        assert self._step is not None, "reset() first"
        self.chooser.decide(np.asarray(actions).reshape(-1))
        reward = np.zeros(self.n)
        spent = np.zeros(self.n)
        dt = self.config.dt
        sent: list[np.ndarray] = []
        env_rewards = not self._energy_reward
        self.chooser.defer = defer
        try:
            while True:  # the env's arrays, never its per-agent dicts (the same bits)
                v, w = self.team.excitation.commands(self._step, dt)
                env_actions = self.team.command(v, w)
                sent.append(env_actions)
                result = self.env.step_arrays(env_actions, rewards=env_rewards)
                if env_rewards:
                    reward += result.rewards
                step = self.team.take(result.seen)
                self._step = step
                if step.new_picture or result.truncated:
                    break
        finally:
            self.chooser.defer = False
        # Each step's wheel travel, computed for all steps at once, added up step by step; so
        # is the EnergyCost reward (EnergyCost.__call__: minus the weighted travel).
        travels = energy(self.config, *to_commands(np.stack(sent), self.config.robot))
        for travel in travels:
            spent += travel
        if self._energy_reward:
            travels *= -self.config.reward.energy_weight
            for cost in travels:
                reward += cost
        self._advanced = (result, reward, spent, len(sent))
        return self.chooser.job

    def finish(self, entropy: np.ndarray | None = None) -> StepResult:
        """The decision begun by ``advance``: its picture scored with ``entropy`` (the
        expected entropy of the job ``advance`` returned; None when it returned None)."""
        assert self._advanced is not None, "advance() first"
        result, reward, spent, steps = self._advanced
        self._advanced = None
        if self.chooser.waiting:
            self.chooser.scored(entropy)
        truth = result.true_index
        step = self._step
        assert step is not None
        if step.new_picture:
            belief = true_belief(self.localizer.belief, truth)
            reward += self.spec.reward.term(self._belief_true, belief)
            self._belief_true = belief
        present = truth >= 0
        return StepResult(
            observation=self.chooser.observation,
            teacher=self.chooser.teacher(),
            reward=reward,
            truncated=result.truncated,
            correct=present & (self.localizer.estimate == truth),
            present=present,
            new_picture=step.new_picture,
            energy=spent,
            steps=steps,
        )
