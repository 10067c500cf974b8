"""K copies of the env as one SB3 ``VecEnv`` in which every robot is a slot.

The slots of copy ``k`` follow those of copy ``k - 1`` (with one scenario, slot ``k * N + i`` is
robot ``i`` of copy ``k``); one policy acts for every slot (parameter sharing: identical robots,
one controller). The copies may hold different scenarios (``configs``: training across
conditions), with different numbers of robots. Observations are the belief-annotated dicts of
:mod:`agents.candidate_features`, batched as ``(K * N, ...)`` arrays.

What it guarantees (each is tested):

* **Truncation is reported as truncation.** The env never terminates; when its ``max_cycles``
  run out, every slot of that copy is ``done`` with ``infos[slot]["TimeLimit.truncated"] = True``
  and ``infos[slot]["terminal_observation"]``, so PPO bootstraps from the value of the last
  observation instead of treating the time limit as the end of the task. The copy is reset at
  once and the returned observation is the new episode's first, as SB3 expects.
* **Seeding goes through reset.** ``seed(s)`` (which ``PPO(seed=s)`` calls) gives copy ``k`` the
  ``k``-th child of ``SeedSequence(s)`` at its next reset; afterwards each copy continues its own
  env generator, so two runs with one seed are identical and copies never share random state.
* **Batched arrays.** Each copy's robots are updated by one vectorised identifier; the
  candidates of every robot of every copy are scored in one call
  (``baselines.active.entropies_together``: the same bits as copy by copy).

Each slot's ``infos`` also carry ``"episode": {"r", "l"}`` at the end of an episode (the format
of SB3's ``Monitor``, so training logs show returns), and the per-step ground-truth scores
``"correct"`` and ``"present"`` for evaluation, and ``"teacher"``, the candidate the ``greedy``
excitation would drive at the new picture (the target of :mod:`agents.imitation`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices, VecEnvStepReturn

from agents.conditions import ConditionRanges, Scenario, draw_scenario
from agents.crew import Crew
from agents.spec import AgentSpec
from anonloc_env.config import EnvConfig
from anonloc_env.env import AnonLocEnv
from anonloc_env.memory import keep_freed_memory
from anonloc_env.rewards import EnergyCost
from baselines.active import ScoringJob, entropies_together


class AnonLocVecEnv(VecEnv):
    """The robots of ``n_envs`` copies of one scenario as one ``VecEnv`` (see the module doc).

    Args:
        config: the scenario.
        n_envs: number K of env copies (each with the config's N robots).
        spec: the agent (:class:`agents.spec.AgentSpec`: candidates, reward, condition and
            budget; the energy term's weight is the config's ``reward.energy_weight``).
        make_env: builds one copy from the config (default: ``AnonLocEnv`` with the
            ``EnergyCost`` reward; the information term is computed by the crew).
        scenarios: one scenario (config, condition and budget) per copy instead of ``config``
            for all (training across conditions, :mod:`agents.conditions`); the number of
            robots may differ between copies. ``n_envs`` is then ignored.
        redraw: with ``scenarios``: at the end of every episode of a copy, draw its next
            scenario from these ranges (its number of robots kept), with a seed drawn from the
            copy's env generator, so runs stay reproducible.
    """

    def __init__(
        self,
        config: EnvConfig,
        n_envs: int = 1,
        spec: AgentSpec | None = None,
        make_env: Callable[[EnvConfig], AnonLocEnv] | None = None,
        scenarios: Sequence[Scenario] | None = None,
        redraw: ConditionRanges | None = None,
    ) -> None:
        if not isinstance(n_envs, (int, np.integer)) or isinstance(n_envs, bool) or n_envs < 1:
            raise ValueError(f"n_envs must be an integer >= 1, got {n_envs!r}")
        keep_freed_memory()  # the scoring's and identifier's temporaries reuse memory
        build = make_env or (lambda cfg: AnonLocEnv(cfg, reward_fn=EnergyCost()))
        self.config = config
        self.spec = spec = spec if spec is not None else AgentSpec()
        drawn = list(scenarios or [Scenario(config, spec.condition, spec.budget)] * int(n_envs))

        def crew(scenario: Scenario) -> Crew:
            return Crew(
                build(scenario.config), spec.in_scenario(scenario.condition, scenario.budget)
            )

        self._crew = crew
        self._redraw = redraw
        self.crews = [crew(s) for s in drawn]
        sizes = [crew.n for crew in self.crews]
        self.starts = np.concatenate([[0], np.cumsum(sizes)]).astype(int)
        self.n_robots = config.n_robots
        self.n_envs = len(self.crews)
        self.render_mode = None
        super().__init__(
            int(self.starts[-1]),
            spec.observation_space(),
            spec.action_space(),
        )
        self._copy_seeds: list[int | None] = [None] * self.n_envs
        self._actions: np.ndarray | None = None
        self.control_steps = 0
        """Env control steps simulated so far, all copies together (one decision is one picture
        interval: several control steps)."""
        self._returns = np.zeros(self.num_envs)
        self._lengths = np.zeros(self.num_envs, np.int64)

    # -- seeding and reset ------------------------------------------------------------------------
    def seed(self, seed: int | None = None) -> Sequence[int | None]:
        """Seed every copy at its next reset: copy k gets the k-th child of
        ``SeedSequence(seed)`` (fresh entropy if None). Returns one entry per slot."""
        children = np.random.SeedSequence(seed).spawn(self.n_envs)
        self._copy_seeds = [int(c.generate_state(1, np.uint64)[0]) for c in children]
        pairs = zip(self._copy_seeds, self.crews, strict=True)
        return [s for s, crew in pairs for _ in range(crew.n)]

    def reset(self) -> dict[str, np.ndarray]:
        seeds = zip(self.crews, self._copy_seeds, strict=True)
        parts = self._started({k: crew.start(seed) for k, (crew, seed) in enumerate(seeds)})
        self._copy_seeds = [None] * self.n_envs
        self._reset_seeds()
        self._returns[:] = 0.0
        self._lengths[:] = 0
        return _stack(parts)

    # -- stepping ---------------------------------------------------------------------------------
    def step_async(self, actions: np.ndarray) -> None:
        actions = np.asarray(actions).reshape(-1)
        space = self.action_space
        assert isinstance(space, spaces.Discrete)
        if actions.shape != (self.num_envs,) or not np.issubdtype(actions.dtype, np.integer):
            raise ValueError(f"actions must be {self.num_envs} integers (one per slot)")
        outside = (actions < 0) | (actions >= space.n)
        if outside.any():
            bad = int(np.flatnonzero(outside)[0])
            raise ValueError(f"actions must be in [0, {space.n}); slot {bad} got {actions[bad]}")
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        assert self._actions is not None, "step_async() first"
        parts: list[dict[str, np.ndarray]] = []
        begun: dict[int, ScoringJob | None] = {}  # copies that start a new episode
        rewards = np.empty(self.num_envs, np.float32)
        dones = np.zeros(self.num_envs, bool)
        infos: list[dict[str, Any]] = []
        # Every copy up to its picture, then all their candidates scored in one call.
        jobs = [
            crew.advance(self._actions[self.starts[k] : self.starts[k + 1]], defer=True)
            for k, crew in enumerate(self.crews)
        ]
        scored = [job for job in jobs if job is not None]
        entropies = iter(entropies_together(scored))
        for k, crew in enumerate(self.crews):
            first = int(self.starts[k])
            slots = slice(first, int(self.starts[k + 1]))
            result = crew.finish(None if jobs[k] is None else next(entropies))
            self.control_steps += result.steps
            rewards[slots] = result.reward
            self._returns[slots] += result.reward
            self._lengths[slots] += 1
            copy_infos: list[dict[str, Any]] = [
                {"correct": bool(c), "present": bool(p), "teacher": int(t)}
                for c, p, t in zip(result.correct, result.present, result.teacher, strict=True)
            ]
            observation = result.observation
            if result.truncated:
                dones[slots] = True
                terminal = result.observation
                for i, info in enumerate(copy_infos):
                    info["TimeLimit.truncated"] = True
                    info["terminal_observation"] = {key: v[i] for key, v in terminal.items()}
                    info["episode"] = {
                        "r": float(self._returns[first + i]),
                        "l": int(self._lengths[first + i]),
                    }
                self._returns[slots] = 0.0
                self._lengths[slots] = 0
                begun[k] = self._next_episode(k)
            parts.append(observation)
            infos.extend(copy_infos)
        for k, started in zip(begun, self._started(begun), strict=True):
            parts[k] = started
        self._actions = None
        return _stack(parts), rewards, dones, infos

    def _next_episode(self, k: int) -> ScoringJob | None:
        """Start copy ``k``'s next episode (``Crew.start``): the same scenario, or a new one
        drawn (``redraw``)."""
        crew = self.crews[k]
        if self._redraw is None:
            return crew.start(None)
        rng = np.random.default_rng(crew.env.rng.integers(0, 2**63))
        ranges = dataclasses.replace(self._redraw, robots=(crew.n,))
        crew.env.close()
        self.crews[k] = self._crew(draw_scenario(rng, ranges))
        return self.crews[k].start(int(rng.integers(0, 2**63)))

    def _started(self, jobs: dict[int, ScoringJob | None]) -> list[dict[str, np.ndarray]]:
        """The first observations of the copies ``Crew.start`` began (copy -> its job), their
        first pictures scored together in one call (the same bits as one by one)."""
        entropies = iter(entropies_together([job for job in jobs.values() if job is not None]))
        return [
            self.crews[k].started(None if job is None else next(entropies))
            for k, job in jobs.items()
        ]

    def close(self) -> None:
        for crew in self.crews:
            crew.env.close()

    # -- attribute access (the VecEnv interface); slots of one copy share its env ---------------
    def _copies(self, indices: VecEnvIndices) -> list[int]:
        if indices is None:
            slots: Sequence[int] = range(self.num_envs)
        elif isinstance(indices, int):
            slots = [indices]
        else:
            slots = list(indices)
        return [int(np.searchsorted(self.starts, slot, side="right")) - 1 for slot in slots]

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        return [getattr(self.crews[k].env, attr_name) for k in self._copies(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        for k in sorted(set(self._copies(indices))):
            setattr(self.crews[k].env, attr_name, value)

    def env_method(
        self,
        method_name: str,
        *method_args: Any,
        indices: VecEnvIndices = None,
        **method_kwargs: Any,
    ) -> list[Any]:
        return [
            getattr(self.crews[k].env, method_name)(*method_args, **method_kwargs)
            for k in self._copies(indices)
        ]

    def env_is_wrapped(self, wrapper_class: type, indices: VecEnvIndices = None) -> list[bool]:
        return [False for _ in self._copies(indices)]


def _stack(parts: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    if len(parts) == 1:
        return parts[0]
    return {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
