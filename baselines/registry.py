"""One registry of the policies and the excitations: :func:`make_team`, :func:`make` and
:func:`make_excitation` build them by name, for the scenario :func:`scenario_config` gives.

The names, and where each class is defined, are in :mod:`baselines.catalog` (which lists them
without importing anything); this module loads the classes. The built-in policies are a
localizer with the excitation its method prescribes (:data:`POLICIES`). Other packages add
theirs without ``baselines`` importing them: under the entry-point group ``anonloc.policies``
(``agents`` registers ``agent`` so), or at run time with :func:`register_policy`.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import Any

import anonloc_env
from anonloc_env._checks import did_you_mean
from anonloc_env.config import EnvConfig
from anonloc_env.detection import stated_config
from baselines.catalog import (
    BUILT_IN_EXCITATIONS,
    BUILT_IN_POLICIES,
    ENTRY_POINTS,
    RENAMED,
    excitation_names,
    policy_names,
    register_policy,
    registered_factory,
)
from baselines.excitations import Excitation
from baselines.localizers import Localizer
from baselines.policies import BaselinePolicy, Policy, PolicyExcitation, Team

__all__ = [
    "EXCITATIONS",
    "POLICIES",
    "RENAMED",
    "excitation_names",
    "make",
    "make_excitation",
    "make_team",
    "policy_names",
    "register_policy",
    "scenario_config",
]

#: name -> (localizer class, name of the excitation its method prescribes), loaded from
#: :data:`baselines.catalog.BUILT_IN_POLICIES`.
POLICIES: dict[str, tuple[type[Localizer], str]] = {
    name: (entry.load(), entry.excitation) for name, entry in BUILT_IN_POLICIES.items()
}

#: Excitations by name (each value builds one), loaded from
#: :data:`baselines.catalog.BUILT_IN_EXCITATIONS` (which says what each name is).
EXCITATIONS: dict[str, Callable[[], Excitation]] = {
    name: entry.load() for name, entry in BUILT_IN_EXCITATIONS.items()
}


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
    config = stated_config(config)  # an image source's measured errors, as its env states them
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
            ``scale_known``; ``bayes``: ``share``, default True: a team of all the env's robots
            reads the identifier the env's default reward runs, see
            :class:`~baselines.localizers.BayesLocalizer`); ``agent`` also takes ``path``, a
            saved agent (default: the agent bundled with the package; a file is unpickled by
            SB3: load only files you trust), and ``condition``, ``"free"`` or ``"swarm"``
            (default: the one the agent's run recorded, else ``free``). ``mlp`` takes
            ``threshold`` and ``weights``, a weights file (default: the ones shipped,
            ``baselines/data/mlp.npz``).

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
        return registered_factory(name)(cfg, count, mode, excitation, **kwargs)
    localizer_class, own = POLICIES[name]
    localizer = localizer_class(cfg, count, mode, **kwargs)
    if env is not None and not isinstance(env, (EnvConfig, str)):
        localizer.attach(env)  # e.g. bayes reads the identifier the env's reward runs
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

    # Built for the scenario, not the env: a one-robot policy may serve any env of the scenario
    # (a batch of them from a VecEnv), so it never reads one env's reward identifier.
    scenario = scenario_config(env, config)

    def build() -> Team:
        return make_team(name, scenario, 1, mode=mode, excitation=excitation, **kwargs)

    return BaselinePolicy(name, build, build())
