"""Baselines: the paper's three localizers (faithful and corrected) and a Bayesian identifier.

>>> import anonloc_env, baselines
>>> env = anonloc_env.parallel_env("paper-motion")
>>> policy = baselines.make("bayes", env, excitation="random")
>>> team = baselines.make_team("motion", env, n=2, mode="faithful")

Every policy is built for the scenario it runs in (``env``, or ``config=`` an ``EnvConfig`` or a
preset name): the localizers' sensor model comes from it. Without one, ``make`` raises.

Names: ``angular``, ``linear``, ``motion``, ``motion3`` (scale unknown), ``bayes`` and ``mlp``
(learned, :mod:`baselines.mlp`), and those
other packages register (``agent``, from ``agents``): :mod:`baselines.registry`. See
:mod:`baselines.localizers` for the maths and :mod:`baselines.excitations` for the motions.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

from baselines._distribution import check as _check_distribution
from baselines.catalog import policy_names, register_policy

if TYPE_CHECKING:
    from baselines.policies import BaselinePolicy, Policy, Team
    from baselines.registry import POLICIES, make, make_team, scenario_config

# OpenAI's `baselines` on the package index has this top-level name too (docs/design.md).
_check_distribution("baselines")

#: The package face, imported on first use (``import baselines`` stays cheap: listing the names
#: needs only :mod:`baselines.catalog`).
_LAZY = {
    "POLICIES": "baselines.registry",
    "BaselinePolicy": "baselines.policies",
    "Policy": "baselines.policies",
    "Team": "baselines.policies",
    "make": "baselines.registry",
    "make_team": "baselines.registry",
    "scenario_config": "baselines.registry",
}

__all__ = [
    "POLICIES",
    "BaselinePolicy",
    "Policy",
    "Team",
    "make",
    "make_team",
    "policy_names",
    "register_policy",
    "scenario_config",
]


def __getattr__(name: str) -> Any:
    """Import the package face's names, and its submodules, on first use."""
    if name in _LAZY:
        value = getattr(import_module(_LAZY[name]), name)
    else:
        try:
            value = import_module(f"baselines.{name}")
        except ModuleNotFoundError as missing:
            if missing.name != f"baselines.{name}":
                raise
            raise AttributeError(f"module 'baselines' has no attribute {name!r}") from None
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
