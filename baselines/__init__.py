"""Baselines: the paper's three localizers (faithful and corrected) and a Bayesian identifier.

>>> import anonloc_env, baselines
>>> env = anonloc_env.parallel_env("paper-motion")
>>> policy = baselines.make("bayes", env.config, excitation="motion")
>>> team = baselines.make_team("motion", env.config, n=2, mode="faithful")

Names: ``angular``, ``linear``, ``motion``, ``motion3`` (scale unknown) and ``bayes``. See
:mod:`baselines.localizers` for the maths and :mod:`baselines.excitations` for the motions.
"""

from __future__ import annotations

from typing import Any

import numpy as np

import anonloc_env
from anonloc_env.actions import to_commands
from anonloc_env.config import EnvConfig
from baselines.excitations import EXCITATIONS, Excitation
from baselines.localizers import (
    AngularLocalizer,
    BayesLocalizer,
    LinearLocalizer,
    Localizer,
    Motion3Localizer,
    MotionLocalizer,
)
from baselines.observations import Step
from baselines.policies import BaselinePolicy, Policy, Team

__all__ = ["POLICIES", "BaselinePolicy", "Policy", "Team", "make", "make_team", "policy_names"]

#: name -> (localizer class, name of the excitation its method prescribes)
POLICIES: dict[str, tuple[type[Localizer], str]] = {
    "angular": (AngularLocalizer, "angular"),
    "linear": (LinearLocalizer, "linear"),
    "motion": (MotionLocalizer, "motion"),
    "motion3": (Motion3Localizer, "motion"),
    "bayes": (BayesLocalizer, "random"),
}


def policy_names() -> list[str]:
    """The valid policy names."""
    return list(POLICIES)


class PolicyExcitation(Excitation):
    """Any policy (e.g. a learned one) used as the motion of a localizing robot."""

    def __init__(self, policy: Policy, config: EnvConfig) -> None:
        super().__init__()
        self.policy = policy
        self.config = config
        self.observations: list[Any] = []

    def commands(self, step: Step, dt: float) -> tuple[np.ndarray, np.ndarray]:
        batch = {
            key: np.stack([np.asarray(o[key]) for o in self.observations])
            for key in self.observations[0]
        }
        actions, _ = self.policy.predict(batch, deterministic=True)
        return to_commands(np.asarray(actions).reshape(self.n, 2), self.config.robot)


def _config(config: EnvConfig | str | None, env: Any) -> EnvConfig:
    if env is not None:
        return env.unwrapped.config if hasattr(env, "unwrapped") else env.config
    if config is None or isinstance(config, str):
        return anonloc_env.make_config(config)
    if not isinstance(config, EnvConfig):
        raise TypeError(
            f"config must be an EnvConfig or a preset name, got {type(config).__name__}"
        )
    return config


def _excitation(spec: str | Excitation | Policy, config: EnvConfig) -> Excitation:
    if isinstance(spec, Excitation):
        return spec
    if isinstance(spec, str):
        if spec not in EXCITATIONS:
            raise ValueError(f"unknown excitation {spec!r}; valid: {list(EXCITATIONS)}")
        return EXCITATIONS[spec]()
    if isinstance(spec, Policy) or hasattr(spec, "predict"):
        return PolicyExcitation(spec, config)
    raise TypeError(f"excitation must be a name, an Excitation or a policy, got {spec!r}")


def make_team(
    name: str,
    config: EnvConfig | str | None = None,
    n: int | None = None,
    *,
    env: Any = None,
    mode: str = "corrected",
    excitation: str | Excitation | Policy | None = None,
    **kwargs: Any,
) -> Team:
    """A team of ``n`` robots (default: all of the config's robots) running policy ``name``.

    Args:
        name: a name from :func:`policy_names`.
        config: what the robots know: an ``EnvConfig``, a preset name, or None (``"default"``).
        n: number of robots in the team.
        env: take the config from this env instead.
        mode: ``"corrected"`` (default) or ``"faithful"`` (the paper as printed).
        excitation: the motion between pictures: a name (``still``, ``angular``, ``linear``,
            ``motion``/``random``), an ``Excitation``, or any policy object. Default: the
            method's own (``random`` for ``bayes``).
        **kwargs: passed to the localizer (``bayes``: ``threshold``, ``scale_known``).
    """
    if name not in POLICIES:
        raise ValueError(f"unknown policy {name!r}; valid: {policy_names()}")
    cfg = _config(config, env)
    count = cfg.n_robots if n is None else n
    localizer_class, own = POLICIES[name]
    localizer = localizer_class(cfg, count, mode, **kwargs)
    return Team(cfg, localizer, _excitation(own if excitation is None else excitation, cfg))


def make(
    name: str,
    config: EnvConfig | str | None = None,
    *,
    env: Any = None,
    mode: str = "corrected",
    excitation: str | Excitation | Policy | None = None,
    **kwargs: Any,
) -> BaselinePolicy:
    """One robot's policy ``name`` (see :func:`make_team` for the arguments)."""
    make_team(name, config, 1, env=env, mode=mode, excitation=excitation, **kwargs)  # validate
    return BaselinePolicy(
        name,
        lambda: make_team(name, config, 1, env=env, mode=mode, excitation=excitation, **kwargs),
    )
