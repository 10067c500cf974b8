"""The crew's robots as a PettingZoo ``ParallelEnv``: what a multi-agent library (RLlib) trains on.

:class:`BeliefParallelEnv` wraps one :class:`agents.crew.Crew`, so every robot sees the
candidate observation of :mod:`agents.candidate_features` and gets the crew's reward, exactly as
in a slot of :class:`agents.vec.AnonLocVecEnv`; here each robot is a PettingZoo agent instead of
a slot. The crew computes everything for the R robots at once; this adapter only hands out row
views of its batched arrays.

| | |
|---|---|
| Agents | `robot_0` ... `robot_{N-1}`, all alive for the whole episode |
| Action | `Discrete(C)`: which candidate command to drive (see :meth:`agents.crew.Crew.step`) |
| Observation | `Dict`: `candidates (C, 7)`, `context (10,)`; or flat `(7 C + 10,)` |
| Import | `from agents.pettingzoo import BeliefParallelEnv` |
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from agents.candidate_features import (
    CANDIDATE_FEATURES,
    CANDIDATES,
    CONTEXT_FEATURES,
)
from agents.crew import Crew
from agents.spec import AgentSpec
from anonloc_env.config import EnvConfig
from anonloc_env.env import AnonLocEnv
from anonloc_env.presets import PRESETS
from anonloc_env.rewards import EnergyCost

OBSERVATION_FORMS = ("dict", "flat")


def flat_size(candidates: int = CANDIDATES) -> int:
    """Length of a flat observation with ``candidates`` candidates."""
    return candidates * CANDIDATE_FEATURES + CONTEXT_FEATURES


def flatten(observation: dict[str, np.ndarray]) -> np.ndarray:
    """``(R, 7 C + 10)`` float32: the batched ``candidates`` (row-major), then ``context``."""
    candidates = observation["candidates"]
    return np.concatenate(
        [candidates.reshape(candidates.shape[0], -1), observation["context"]], axis=1
    )


def unflatten(flat: np.ndarray, candidates: int = CANDIDATES) -> dict[str, np.ndarray]:
    """The inverse of :func:`flatten` for ``(B, 7 C + 10)`` arrays (or tensors: only slicing
    and reshaping)."""
    split = candidates * CANDIDATE_FEATURES
    return {
        "candidates": flat[:, :split].reshape(-1, candidates, CANDIDATE_FEATURES),
        "context": flat[:, split:],
    }


class BeliefParallelEnv(ParallelEnv[str, Any, np.ndarray]):
    """The robots of one env, each seeing its own identifier's belief (see the module doc).

    ## Observation Space
    With ``observation="dict"`` (the default) each agent gets the dict of
    ``agents.spec.AgentSpec.observation_space``, the same as a slot of
    :class:`agents.vec.AnonLocVecEnv`. With ``observation="flat"`` it gets those two arrays
    concatenated into one float32 vector of :func:`flat_size` entries (``candidates``
    row-major, then ``context``): the form RLlib's modules take (:func:`unflatten` undoes it).

    ## Action Space
    ``Discrete(C)``: the candidate each robot drives until the next picture.

    ## Rewards
    The crew's (:meth:`agents.crew.Crew.step`): one step here is one picture interval (the
    action is held until the next picture); the reward adds up the energy term of its control
    steps and, at the picture, the identity term of the spec's reward (``agents.spec.Reward``; by
    default the log of the belief the robot gives its true row).

    ## Episode End
    No terminations; every agent is truncated when the env's ``max_cycles`` control steps are
    spent (possibly between two pictures).

    ## Infos
    ``infos[agent]`` holds ground truth, for scoring only: ``correct`` (the robot's identifier
    decides on its true row of the newest picture) and ``present`` (the robot is in it).

    ## Arguments
    ``config`` (an ``EnvConfig``; ``None`` is the ``default`` preset), ``spec`` (the agent,
    :class:`agents.spec.AgentSpec`: candidates, reward, condition and budget), ``observation``
    (``"dict"`` or ``"flat"``) and ``render_mode`` (the environment's).
    """

    metadata: ClassVar[dict[str, Any]] = {
        "name": "anonloc_belief_v0",
        "render_modes": AnonLocEnv.metadata["render_modes"],
        "render_fps": AnonLocEnv.metadata["render_fps"],
        "is_parallelizable": True,
    }

    def __init__(
        self,
        config: EnvConfig | None = None,
        spec: AgentSpec | None = None,
        observation: str = "dict",
        render_mode: str | None = None,
    ) -> None:
        if observation not in OBSERVATION_FORMS:
            raise ValueError(
                f"observation must be one of {list(OBSERVATION_FORMS)}, got {observation!r}"
            )
        spec = spec if spec is not None else AgentSpec()
        if observation == "flat" and spec.features != AgentSpec().features:
            raise ValueError(
                "observation='flat' (RLlib's form) has layout 2's features only; this spec "
                "names the crowd features too: use observation='dict'"
            )
        config = config if config is not None else PRESETS["default"]
        env = AnonLocEnv(config, render_mode=render_mode, reward_fn=EnergyCost())
        self.spec = spec
        self.crew = Crew(env, self.spec)
        self.config = config
        self.observation_form = observation
        self.render_mode = render_mode
        self.possible_agents = list(self.crew.agents)
        self.agents: list[str] = []
        # One space object per agent, built once (seeding one agent's space leaves the others).
        self.observation_spaces: dict[str, spaces.Space[Any]] = {
            agent: self._space() for agent in self.possible_agents
        }
        self.action_spaces: dict[str, spaces.Space[Any]] = {
            agent: self.spec.action_space() for agent in self.possible_agents
        }
        self.state_space = env.state_space

    def _space(self) -> spaces.Space[Any]:
        if self.observation_form == "dict":
            return self.spec.observation_space()
        return spaces.Box(-np.inf, np.inf, (flat_size(self.spec.candidates),), np.float32)

    @property
    def max_cycles(self) -> int:
        """Steps before truncation (the environment's; may be changed between episodes)."""
        return self.crew.env.max_cycles

    @max_cycles.setter
    def max_cycles(self, value: int) -> None:
        self.crew.env.max_cycles = value

    def observation_space(self, agent: str) -> spaces.Space[Any]:
        """The observation space of ``agent`` (the same object on every call)."""
        return self.observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Space[Any]:
        """The action space of ``agent`` (the same object on every call)."""
        return self.action_spaces[agent]

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, Any], dict[str, dict[str, Any]]]:
        """Start an episode (``seed`` as in ``AnonLocEnv.reset``; ``options`` are not used)."""
        observation = self.crew.reset(seed)
        self.agents = self.possible_agents[:]
        infos: dict[str, dict[str, Any]] = {agent: {} for agent in self.agents}
        return self._split(observation), infos

    def step(
        self, actions: dict[str, Any]
    ) -> tuple[
        dict[str, Any],
        dict[str, float],
        dict[str, bool],
        dict[str, bool],
        dict[str, dict[str, Any]],
    ]:
        """One control step of every robot (each live agent needs an action)."""
        if not self.agents:
            raise RuntimeError("step() called on a finished episode; call reset() first")
        missing = [agent for agent in self.agents if agent not in actions]
        if missing:
            raise ValueError(f"actions are missing for {missing}")
        result = self.crew.step(np.asarray([actions[agent] for agent in self.agents]))
        agents = self.agents
        observations = self._split(result.observation)
        rewards = dict(zip(agents, result.reward.tolist(), strict=True))
        terminations = dict.fromkeys(agents, False)
        truncations = dict.fromkeys(agents, result.truncated)
        infos = {
            agent: {"correct": c, "present": p}
            for agent, c, p in zip(
                agents, result.correct.tolist(), result.present.tolist(), strict=True
            )
        }
        if result.truncated:
            self.agents = []
        return observations, rewards, terminations, truncations, infos

    def _split(self, observation: dict[str, np.ndarray]) -> dict[str, Any]:
        """Per-agent row views of the crew's batched arrays (fresh arrays every step)."""
        if self.observation_form == "flat":
            return dict(zip(self.possible_agents, flatten(observation), strict=True))
        candidates, context = observation["candidates"], observation["context"]
        return {
            agent: {"candidates": candidates[i], "context": context[i]}
            for i, agent in enumerate(self.possible_agents)
        }

    def state(self) -> np.ndarray:
        """Every robot's true pose ``(N, 3)`` (see ``AnonLocEnv.state``)."""
        return self.crew.env.state()

    def render(self, mode: str | None = None) -> np.ndarray | None:
        """Draw the environment (see ``AnonLocEnv.render``).

        Args:
            mode: accepted for RLlib's ``ParallelPettingZooEnv``, which passes its own
                ``render_mode``; it must be ``None`` or this env's ``render_mode``.
        """
        if mode is not None and mode != self.render_mode:
            raise ValueError(
                f"render mode {mode!r} differs from this env's render_mode {self.render_mode!r}; "
                "set render_mode when building the env"
            )
        return self.crew.env.render()

    def close(self) -> None:
        """Release the environment's rendering window, if any."""
        self.crew.env.close()
