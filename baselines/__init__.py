"""Baselines: the paper's three localizers (faithful and corrected) and a Bayesian identifier.

>>> import anonloc_env, baselines
>>> env = anonloc_env.parallel_env("paper-motion")
>>> policy = baselines.make("bayes", env, excitation="random")
>>> team = baselines.make_team("motion", env, n=2, mode="faithful")

Every policy is built for the scenario it runs in (``env``, or ``config=`` an ``EnvConfig`` or a
preset name): the localizers' sensor model comes from it. Without one, ``make`` raises.

Names: ``angular``, ``linear``, ``motion``, ``motion3`` (scale unknown) and ``bayes``, and those
other packages register (``agent``, from ``agents``): :mod:`baselines.registry`. See
:mod:`baselines.localizers` for the maths and :mod:`baselines.excitations` for the motions.
"""

from __future__ import annotations

from baselines.policies import BaselinePolicy, Policy, Team
from baselines.registry import (
    POLICIES,
    make,
    make_team,
    policy_names,
    register_policy,
    scenario_config,
)

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
