"""anonloc_env: self-localization of anonymous robots from aerial images, as a PettingZoo env.

>>> import anonloc_env
>>> env = anonloc_env.parallel_env()              # the "default" preset
>>> observations, infos = env.reset(seed=0)
>>> env = anonloc_env.parallel_env("paper-motion", n_robots=10, camera={"pixel_noise": 1.0})

Registered with PettingZoo's registry as ``anonloc/AnonLoc-v0`` (both ``"parallel"`` and ``"aec"``).
"""

from __future__ import annotations

from typing import Any

import pettingzoo
from pettingzoo.utils import BaseWrapper
from pettingzoo.utils.conversions import parallel_to_aec

from anonloc_env.actions import stack_actions, to_actions, to_commands
from anonloc_env.camera import Camera, DetectionSource, Picture
from anonloc_env.config import (
    CameraConfig,
    EnvConfig,
    ObservationConfig,
    RewardConfig,
    RobotConfig,
    ScheduleConfig,
)
from anonloc_env.env import AnonLocEnv
from anonloc_env.presets import PRESETS, make_config, preset_names
from anonloc_env.rewards import EnergyCost, InformationGain, RewardFunction, StepContext

__version__ = "0.1.0"
ENV_ID = "anonloc/AnonLoc-v0"

__all__ = [
    "ENV_ID",
    "PRESETS",
    "AnonLocEnv",
    "Camera",
    "CameraConfig",
    "DetectionSource",
    "EnergyCost",
    "EnvConfig",
    "InformationGain",
    "ObservationConfig",
    "Picture",
    "RewardConfig",
    "RewardFunction",
    "RobotConfig",
    "ScheduleConfig",
    "StepContext",
    "env",
    "make_config",
    "parallel_env",
    "preset_names",
    "raw_env",
    "to_actions",
    "to_commands",
]


def parallel_env(
    preset: str | None = None,
    *,
    render_mode: str | None = None,
    reward_fn: RewardFunction | None = None,
    detector: DetectionSource | None = None,
    **overrides: Any,
) -> AnonLocEnv:
    """The environment in PettingZoo's parallel API.

    Args:
        preset: ``"default"`` (when None), ``"paper-angular"``, ``"paper-linear"`` or
            ``"paper-motion"``.
        render_mode: None, ``"human"`` or ``"rgb_array"``.
        reward_fn: a reward function (see :mod:`anonloc_env.rewards`); default
            :class:`InformationGain`.
        detector: replaces the built-in geometric camera (see :class:`DetectionSource`).
        **overrides: ``n_robots``, ``arena_size``, ``dt``, ``picture_interval``, ``max_cycles``,
            and the sections ``robot``, ``camera``, ``schedule``, ``observation``, ``reward`` as
            dicts (only the named fields change) or config objects. See :func:`make_config`.
    """
    config = make_config(preset, **overrides)
    return AnonLocEnv(config, render_mode=render_mode, reward_fn=reward_fn, detector=detector)


def raw_env(preset: str | None = None, **kwargs: Any) -> AnonLocEnv:
    """The unwrapped parallel environment (the same as :func:`parallel_env`)."""
    return parallel_env(preset, **kwargs)


def env(preset: str | None = None, **kwargs: Any) -> pettingzoo.AECEnv:
    """The environment in PettingZoo's AEC API (``parallel_to_aec`` with order enforcing).

    Takes the same arguments as :func:`parallel_env`. The AEC form steps physics once after every
    agent has acted, so time runs the same in both forms. Each action is checked at its agent's
    turn: a bad one raises ``ValueError`` naming the agent and is not kept, so the agent can act
    again.
    """
    return _CheckedActions(parallel_to_aec(parallel_env(preset, **kwargs)))


class _CheckedActions(BaseWrapper):
    """Refuses a malformed action at its agent's turn, before ``parallel_to_aec`` buffers it."""

    def step(self, action: Any) -> None:
        agent = self.env.agent_selection
        live = not (self.env.terminations.get(agent) or self.env.truncations.get(agent))
        if live:
            stack_actions({agent: action}, [agent])
        self.env.step(action)


def _register() -> None:
    for kind, entry in (("parallel", parallel_env), ("aec", env)):
        registry = pettingzoo.parallel_registry if kind == "parallel" else pettingzoo.aec_registry
        if ENV_ID not in registry:
            pettingzoo.register(kind, ENV_ID, entry_point=entry)


_register()
