"""Baselines: the paper's three localizers (faithful and corrected) and a Bayesian identifier.

>>> import anonloc_env, baselines
>>> env = anonloc_env.parallel_env("paper-motion")
>>> policy = baselines.make("bayes", env, excitation="random")
>>> team = baselines.make_team("motion", env, n=2, mode="faithful")

Every policy is built for the scenario it runs in (``env``, or ``config=`` an ``EnvConfig`` or a
preset name): the localizers' sensor model comes from it. Without one, ``make`` raises.

Names: ``angular``, ``linear``, ``motion``, ``motion3`` (scale unknown) and ``bayes``. See
:mod:`baselines.localizers` for the maths and :mod:`baselines.excitations` for the motions.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

import anonloc_env
from anonloc_env.actions import to_commands
from anonloc_env.config import EnvConfig
from baselines.excitations import Excitation, make_excitation
from baselines.localizers import (
    AngularLocalizer,
    BayesLocalizer,
    LinearLocalizer,
    Localizer,
    Motion3Localizer,
    MotionLocalizer,
)
from baselines.policies import BaselinePolicy, Policy, Team
from baselines.steps import Step

__all__ = [
    "POLICIES",
    "BaselinePolicy",
    "Policy",
    "Team",
    "make",
    "make_team",
    "policy_names",
    "scenario_config",
]

#: name -> (localizer class, name of the excitation its method prescribes)
POLICIES: dict[str, tuple[type[Localizer], str]] = {
    "angular": (AngularLocalizer, "angular"),
    "linear": (LinearLocalizer, "linear"),
    "motion": (MotionLocalizer, "random"),
    "motion3": (Motion3Localizer, "random"),
    "bayes": (BayesLocalizer, "random"),
}


#: A learned agent (``agents``, the ``rl`` extra): the ``bayes`` localizer with the agent's
#: motion; the bundled agent, or ``path=`` a saved one.
AGENT = "agent"


def policy_names() -> list[str]:
    """The valid policy names."""
    return [*POLICIES, AGENT]


class PolicyExcitation(Excitation):
    """Any policy (e.g. a learned one) used as the motion of a localizing robot."""

    def __init__(self, policy: Policy, config: EnvConfig) -> None:
        super().__init__()
        self.policy = policy
        self.config = config
        self.observations: list[Any] = []

    def on_observations(self, observations: Sequence[Mapping[str, Any]]) -> None:
        self.observations = list(observations)

    def commands(self, step: Step, dt: float) -> tuple[np.ndarray, np.ndarray]:
        batch = {
            key: np.stack([np.asarray(o[key]) for o in self.observations])
            for key in self.observations[0]
        }
        actions, _ = self.policy.predict(batch, deterministic=True)
        return to_commands(np.asarray(actions).reshape(self.n, 2), self.config.robot)


def scenario_config(env: Any = None, config: EnvConfig | str | None = None) -> EnvConfig:
    """The scenario a policy is built for: ``env``'s config, or ``config`` (an ``EnvConfig`` or a
    preset name). A localizer's sensor model comes from it, so it is never guessed.

    Raises:
        ValueError: neither is given, or both are and they differ.
        TypeError: ``config`` is neither an ``EnvConfig`` nor a preset name.
    """
    if isinstance(env, (EnvConfig, str)) and config is None:
        env, config = None, env  # a config given where the env goes (the positional slot)
    from_env = None
    if env is not None:
        unwrapped = getattr(env, "unwrapped", env)
        from_env = getattr(unwrapped, "config", None)
        if not isinstance(from_env, EnvConfig):
            raise TypeError(
                f"env must be an anonloc env (with a .config), got {type(env).__name__}"
            )
    if config is None:
        if from_env is None:
            raise ValueError(
                "a policy needs the scenario it will run in, to build its sensor model: pass "
                "env=<the env> (or config=<its EnvConfig or preset name>)"
            )
        return from_env
    if isinstance(config, str):
        config = anonloc_env.make_config(config)
    if not isinstance(config, EnvConfig):
        raise TypeError(
            f"config must be an EnvConfig or a preset name, got {type(config).__name__}"
        )
    if from_env is not None and from_env != config:
        raise ValueError("env and config describe different scenarios: pass one of them")
    return config


def _excitation(spec: str | Excitation | Policy, config: EnvConfig) -> Excitation:
    if isinstance(spec, Excitation):
        return spec
    if isinstance(spec, str):
        return make_excitation(spec)
    if isinstance(spec, Policy) or hasattr(spec, "predict"):
        return PolicyExcitation(spec, config)
    raise TypeError(f"excitation must be a name, an Excitation or a policy, got {spec!r}")


def make_team(
    name: str,
    env: Any = None,
    n: int | None = None,
    *,
    config: EnvConfig | str | None = None,
    mode: str = "corrected",
    excitation: str | Excitation | Policy | None = None,
    **kwargs: Any,
) -> Team:
    """A team of ``n`` robots (default: all of the scenario's robots) running policy ``name``.

    Like SB3's ``PPO(policy, env)``, a policy is built from the env it will run in: its sensor
    model (camera scale and tilt, noise, misses) comes from that env's config, never from a
    default.

    Args:
        name: a name from :func:`policy_names`.
        env: the env the robots run in (an ``EnvConfig`` or a preset name is also accepted here).
        n: number of robots in the team.
        config: the scenario, when there is no env: an ``EnvConfig`` or a preset name.
        mode: ``"corrected"`` (default) or ``"faithful"`` (the paper as printed).
        excitation: the motion between pictures: a name from
            :data:`baselines.excitations.EXCITATIONS`, an ``Excitation``, or any policy object.
            Default: the method's own (``random`` for ``bayes``).
        **kwargs: passed to the localizer (``bayes`` and ``agent``: ``threshold``,
            ``scale_known``); ``agent`` also takes ``path``, a saved agent (default: the agent
            bundled with the package; a file is unpickled by SB3: load only files you trust),
            and ``condition``, ``"free"`` or ``"swarm"`` (default: the one the agent's run
            recorded, else ``free``).

    Raises:
        ValueError: an unknown name, mode or excitation, or no scenario given (neither ``env``
            nor ``config``).
    """
    if name not in policy_names():
        raise ValueError(f"unknown policy {name!r}; valid: {policy_names()}")
    cfg = scenario_config(env, config)
    count = cfg.n_robots if n is None else n
    if name == AGENT:
        return _agent_team(cfg, count, mode, excitation, **kwargs)
    localizer_class, own = POLICIES[name]
    localizer = localizer_class(cfg, count, mode, **kwargs)
    return Team(cfg, localizer, _excitation(own if excitation is None else excitation, cfg))


def _agent_team(
    config: EnvConfig,
    n: int,
    mode: str,
    excitation: Any,
    path: str | None = None,
    condition: str | None = None,
    **kwargs: Any,
) -> Team:
    """A team driven by the saved agent at ``path`` (None: the bundled agent), loaded lazily
    (``agents`` needs torch); ``condition``: ``free`` or ``swarm`` (None: the run's own)."""
    if excitation is not None:
        raise ValueError("policy 'agent' moves as it learned: it takes no excitation")
    try:
        from agents.policy import BUNDLED_NAME, load_agent
    except ImportError as error:
        raise ImportError(
            f"policy 'agent' needs the rl extra: pip install 'anonloc[rl]' ({error})"
        ) from error
    localizer = BayesLocalizer(config, n, mode, **kwargs)
    return Team(config, localizer, load_agent(path or BUNDLED_NAME, condition))


def make(
    name: str,
    env: Any = None,
    *,
    config: EnvConfig | str | None = None,
    mode: str = "corrected",
    excitation: str | Excitation | Policy | None = None,
    **kwargs: Any,
) -> BaselinePolicy:
    """One robot's policy ``name``, built for ``env`` (see :func:`make_team` for the arguments).

    >>> env = anonloc_env.parallel_env("paper-motion")
    >>> policy = make("bayes", env)
    >>> make("bayes")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: a policy needs the scenario it will run in, ...: pass env=<the env> (or config=...)
    """

    def build() -> Team:
        return make_team(name, env, 1, config=config, mode=mode, excitation=excitation, **kwargs)

    return BaselinePolicy(name, build, build())
