"""The one place the commands turn a policy name into a team of robots.

Every command resolves names through :func:`policy_names` and builds teams through
:func:`build_team`; both come from :mod:`baselines.registry` (where other packages, such as
``agents``, register their policies). Excitations are resolved here too: the registry's names,
where ``swarm`` (:class:`baselines.excitations.SwarmMotion`) shares its stream through the episode
seed.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from anonloc_cli.console import echo
from anonloc_cli.scenarios import InputError
from anonloc_env._checks import did_you_mean
from anonloc_env.config import EnvConfig


def policy_names() -> list[str]:
    """The valid policy names."""
    from baselines.registry import policy_names as names

    return names()


def excitation_names() -> list[str]:
    """The valid excitation names."""
    from baselines.registry import excitation_names as names

    return names()


def check_policy(name: str) -> str:
    """``name`` if it is a policy, else an :class:`InputError` listing the valid ones. Where
    plug-ins claim the name twice (or a built-in's), a note on stderr says which one is used."""
    from baselines.catalog import plugin_notes

    checked = _check("policy", name, policy_names())
    for note in plugin_notes([name]):
        echo(f"note: {note}", err=True)
    return checked


def check_excitation(name: str | None) -> str | None:
    """``name`` if it is an excitation (or None), else an :class:`InputError`. An old name
    (:data:`baselines.registry.RENAMED`) still works, with a note on stderr."""
    from baselines.registry import RENAMED

    if name in RENAMED:
        echo(f"note: excitation {name!r} is renamed {RENAMED[name]!r}", err=True)
        return name
    return None if name is None else _check("excitation", name, excitation_names())


def check_mode(mode: str) -> str:
    """``mode`` if it is one of :data:`baselines.localizers.MODES`, else an :class:`InputError`."""
    from baselines.localizers import MODES

    return _check("mode", mode, MODES)


def _check(what: str, name: str, valid: Sequence[str]) -> str:
    if name in valid:
        return name
    raise InputError(f"unknown {what} {name!r}{did_you_mean(name, valid)}; valid: {list(valid)}")


def excitation(spec: Any, seed: int) -> Any:
    """An excitation from a name, ``{"swarm": jitter}``, or None (the policy's own)."""
    from baselines.excitations import SwarmMotion

    if isinstance(spec, dict) and "swarm" in spec:
        return SwarmMotion(float(spec["swarm"]), common_seed=seed)
    if spec == "swarm":
        return SwarmMotion(common_seed=seed)
    return spec


def build_team(
    policy: str,
    scenario: Any,
    *,
    mode: str = "corrected",
    excitation_spec: Any = None,
    seed: int = 0,
    **kwargs: Any,
) -> Any:
    """A team of all the scenario's robots running ``policy`` (see :func:`baselines.make_team`).

    Args:
        policy: a name from :func:`policy_names`.
        scenario: the env the team will run in (a ``bayes`` team then reads the identifier of
            its default reward), or its ``EnvConfig``.
        mode: ``corrected`` or ``faithful``.
        excitation_spec: None (the policy's own), a name, or ``{"swarm": jitter}``.
        seed: the episode seed (the swarm's shared commands are drawn from it).
        **kwargs: passed to the localizer (``bayes``: ``threshold``, ``scale_known``).
    """
    import baselines

    return baselines.make_team(
        policy, scenario, mode=mode, excitation=excitation(excitation_spec, seed), **kwargs
    )


def check_team(
    policy: str, config: EnvConfig, *, mode: str, excitation_spec: Any = None, **kwargs: Any
) -> None:
    """Build the team once to surface a bad combination (a localizer's settings, a mode it
    lacks, a scenario it cannot run in) before any work."""
    try:
        build_team(policy, config, mode=mode, excitation_spec=excitation_spec, **kwargs)
    except (TypeError, ValueError, ImportError) as error:  # ImportError: a plug-in's
        text = str(error).removeprefix("Error: ")  # SB3's own messages start with "Error: "
        raise InputError(f"policy {policy!r}: {text}") from error


def play(unit: Any) -> Any:
    """Play the episode a bench or study unit (:class:`anonloc_cli.jobs.Unit`) describes: its
    scenario, a team of all its robots running its policy (with the unit's ``mode``,
    ``excitation`` and localizer ``kwargs``), its seed, up to its ``pictures``. Returns the
    :class:`baselines.runner.EpisodeResult`."""
    import anonloc_env
    from baselines.runner import run_episode

    p = unit.params
    # The commands read pictures and energy, never rewards: the cheapest reward (the default one
    # would run an identifier for nothing, beside any team's own).
    env = anonloc_env.parallel_env(**unit.scenario, reward_fn=anonloc_env.EnergyCost())
    team = build_team(
        unit.policy,
        env.config,
        mode=p.get("mode", "corrected"),
        excitation_spec=p["excitation"],
        seed=unit.seed,
        **p.get("kwargs", {}),
    )
    return run_episode(env, team, unit.seed, max_pictures=p["pictures"])
