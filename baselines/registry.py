"""One registry of the policies and the excitations: the names that :func:`make_team`,
:func:`make` and :func:`make_excitation` build, and the scenario a policy is built for.

The built-in policies are a localizer with the excitation its method prescribes
(:data:`POLICIES`). Other packages add theirs without ``baselines`` importing them: a policy is
registered under the entry-point group ``anonloc.policies`` (``name = "module:factory"`` in the
package's ``pyproject.toml``; ``agents`` registers ``agent`` so), or at run time with
:func:`register_policy`. A factory is called as ``factory(config, n, mode, excitation,
**kwargs)`` and returns a :class:`~baselines.policies.Team`; it is imported only when its name is
built.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from importlib import metadata
from typing import Any

import anonloc_env
from anonloc_env._checks import did_you_mean
from anonloc_env.config import EnvConfig
from baselines.active import GreedyIdentification
from baselines.excitations import (
    Angular,
    DistinctMotion,
    Excitation,
    Linear,
    RandomMotion,
    Still,
    SwarmMotion,
)
from baselines.localizers import (
    AngularLocalizer,
    BayesLocalizer,
    LinearLocalizer,
    Localizer,
    Motion3Localizer,
    MotionLocalizer,
)
from baselines.policies import BaselinePolicy, Policy, PolicyExcitation, Team

#: name -> (localizer class, name of the excitation its method prescribes)
POLICIES: dict[str, tuple[type[Localizer], str]] = {
    "angular": (AngularLocalizer, "angular"),
    "linear": (LinearLocalizer, "linear"),
    "motion": (MotionLocalizer, "random"),
    "motion3": (Motion3Localizer, "random"),
    "bayes": (BayesLocalizer, "random"),
}

EXCITATIONS: dict[str, Callable[[], Excitation]] = {
    "still": Still,
    "angular": Angular,
    "linear": Linear,
    "random": RandomMotion,
    "swarm": SwarmMotion,
    "distinct": DistinctMotion,
    "greedy": GreedyIdentification,
}
"""Excitations by name (each value builds one). ``random`` is the paper's random motion
(:class:`~baselines.excitations.RandomMotion`, the excitation of the ``motion`` localizer);
``swarm`` is :class:`~baselines.excitations.SwarmMotion` with its defaults (jitter
``SWARM_JITTER``, common seed 0); ``distinct`` is :class:`~baselines.excitations.DistinctMotion`;
``greedy`` is :class:`baselines.active.GreedyIdentification`."""

RENAMED = {"motion": "random"}
"""Old excitation names, still accepted with a ``DeprecationWarning``: old name -> new name.
``motion`` named both a localizer and this excitation; the excitation is now only ``random``."""

#: The entry-point group other packages register policies under.
ENTRY_POINTS = "anonloc.policies"

#: ``factory(config, n, mode, excitation, **kwargs) -> Team``.
PolicyFactory = Callable[..., Team]

_registered: dict[str, PolicyFactory] = {}


def register_policy(name: str, factory: PolicyFactory) -> None:
    """Make ``name`` a policy built by ``factory`` (see the module documentation).

    Raises:
        ValueError: ``name`` is a built-in policy's.
    """
    if name in POLICIES:
        raise ValueError(f"{name!r} is a built-in policy; valid new names are any others")
    _registered[name] = factory


def _entry_points() -> dict[str, metadata.EntryPoint]:
    return {ep.name: ep for ep in metadata.entry_points(group=ENTRY_POINTS)}


def policy_names() -> list[str]:
    """The valid policy names: the built-in ones, then those registered (entry points and
    :func:`register_policy`). Nothing is imported to list them."""
    names = [*POLICIES]
    for name in [*_entry_points(), *_registered]:
        if name not in names:
            names.append(name)
    return names


def excitation_names() -> list[str]:
    """The valid excitation names (:data:`EXCITATIONS`)."""
    return list(EXCITATIONS)


def make_excitation(name: str) -> Excitation:
    """A new excitation by name (a key of :data:`EXCITATIONS`, or an old one of :data:`RENAMED`).

    Raises:
        ValueError: an unknown name (the message lists the valid ones).
    """
    if name in RENAMED:
        warnings.warn(
            f"excitation {name!r} is renamed {RENAMED[name]!r}; the old name will be removed",
            DeprecationWarning,
            stacklevel=2,
        )
        name = RENAMED[name]
    if name not in EXCITATIONS:
        raise ValueError(
            f"unknown excitation {name!r}{did_you_mean(name, EXCITATIONS)}; "
            f"valid: {list(EXCITATIONS)}"
        )
    return EXCITATIONS[name]()


def _factory(name: str) -> PolicyFactory:
    """The registered factory of ``name`` (an entry point is imported now)."""
    if name in _registered:
        return _registered[name]
    entry = _entry_points()[name]
    try:
        factory: PolicyFactory = entry.load()
    except ImportError as error:
        raise ImportError(
            f"policy {name!r} comes from {entry.value!r}, which could not be imported ({error}); "
            "for 'agent': pip install 'anonloc[rl]'"
        ) from error
    return factory


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
            :data:`EXCITATIONS`, an ``Excitation``, or any policy object.
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
    names = policy_names()
    if name not in names:
        raise ValueError(
            f"unknown policy {name!r}; valid: {names} (a package registers more under the "
            f"entry-point group {ENTRY_POINTS!r}: an editable install sees a new one after "
            "`pip install -e .`)"
        )
    cfg = scenario_config(env, config)
    count = cfg.n_robots if n is None else n
    if name not in POLICIES:
        return _factory(name)(cfg, count, mode, excitation, **kwargs)
    localizer_class, own = POLICIES[name]
    localizer = localizer_class(cfg, count, mode, **kwargs)
    return Team(cfg, localizer, _excitation(own if excitation is None else excitation, cfg))


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
