"""The evaluation conditions of the learned agents (issues 17 and 24), defined once.

Every condition is :func:`benchmarks.excitations.scenario`'s: N robots, one per square metre
(arena side sqrt(N) m), the default camera (100 image units per metre) with 1 px of pixel noise
and no detected headings, a picture every second, the default robot; each condition changes
only what its name says. The evaluation script and :mod:`benchmarks.plot_agents` import them
from here.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from anonloc_env.config import EnvConfig
from baselines.excitations.swarm import DUTY_BUDGET
from benchmarks.excitations import scenario

#: The swarm deviation budget of the ``swarm`` conditions (a fraction of the robot's limits).
#: Misses and false positives (per picture) of the ``clutter`` conditions.
CLUTTER = {"p_miss": 0.1, "false_positives": 3.0}


def _camera(config: EnvConfig, **changes: Any) -> EnvConfig:
    return dataclasses.replace(config, camera=dataclasses.replace(config.camera, **changes))


def evaluation_conditions(pictures: int = 30) -> dict[str, tuple[EnvConfig, str, float]]:
    """The conditions by name: ``(config, condition, budget)`` with ``condition`` ``"free"`` or
    ``"swarm"`` (:class:`baselines.excitations.SwarmDuty` with deviation ``budget``).

    Args:
        pictures: episode length in pictures (sets ``max_cycles``), >= 1.

    Raises:
        ValueError: ``pictures`` < 1.
    """
    if not (isinstance(pictures, int) and pictures >= 1):
        raise ValueError(f"pictures must be an integer >= 1, got {pictures!r}")
    out: dict[str, tuple[EnvConfig, str, float]] = {}
    for n in (10, 30, 100, 300, 1000):
        out[f"free N={n}"] = (scenario(n, pictures), "free", DUTY_BUDGET)
    for n in (10, 100):
        out[f"swarm N={n}"] = (scenario(n, pictures), "swarm", DUTY_BUDGET)
    for n in (20, 50):
        out[f"clutter N={n}"] = (_camera(scenario(n, pictures), **CLUTTER), "free", DUTY_BUDGET)
    headings = _camera(scenario(100, pictures), orientation=True)
    out["headings N=100"] = (headings, "free", DUTY_BUDGET)
    return out


#: Robots per square metre of the crowded conditions (docs/crowds.md).
CROWD_DENSITY = 4.0


def crowded_conditions(pictures: int = 30) -> dict[str, tuple[EnvConfig, str, float]]:
    """The crowded conditions (issue 23), by name, as :func:`evaluation_conditions` gives its
    own: N = 20 and 100 (never drawn in training) at :data:`CROWD_DENSITY` robots per m², free
    motion, otherwise the same.
    ``benchmarks.agent_eval`` runs them when named (``--conditions "crowd N=20"``), beside the
    eight of issue 17.

    Raises:
        ValueError: ``pictures`` < 1.
    """
    if not (isinstance(pictures, int) and pictures >= 1):
        raise ValueError(f"pictures must be an integer >= 1, got {pictures!r}")
    return {
        f"crowd N={n}": (scenario(n, pictures, CROWD_DENSITY), "free", DUTY_BUDGET)
        for n in (20, 100)
    }


#: The robots' odometry noise of the ``odometry N=30`` condition of :func:`beyond_conditions`.
BEYOND_ODOMETRY_NOISE = 0.05
#: Misses and false positives (per picture) of its ``heavy clutter N=30`` condition.
HEAVY_CLUTTER = {"p_miss": 0.25, "false_positives": 8.0}


def beyond_conditions(pictures: int = 30) -> dict[str, tuple[EnvConfig, str, float]]:
    """Conditions outside what the agents were trained, searched and selected on (issue 24:
    "conditions beyond these will be tried"), by name, as :func:`evaluation_conditions` gives
    its own. Each changes one thing of ``free N=30`` to a value beyond the training draws
    (``agents.conditions.ConditionRanges``):

    * ``free N=2``: the paper's team of two (training draws 3 to 40 robots);
    * ``sparse N=30``: 0.25 robots per m² (training: 0.5 to 6);
    * ``noise 3 px N=30``: 3 image units of pixel noise (training: 0.5 to 2);
    * ``heavy clutter N=30``: a quarter of the robots missed and 8 false positives per picture
      (training: at most 0.15 and 4);
    * ``odometry N=30``: odometry with a multiplicative error of 5 % per control step
      (training: none);
    * ``swarm N=30, budget 0.05``: swarm duty with a quarter of the evaluation's deviation
      budget (training: 0.1 to 0.4).

    ``benchmarks.agent_eval`` runs them when named.

    Raises:
        ValueError: ``pictures`` < 1.
    """
    if not (isinstance(pictures, int) and pictures >= 1):
        raise ValueError(f"pictures must be an integer >= 1, got {pictures!r}")
    base = scenario(30, pictures)
    robot = dataclasses.replace(base.robot, odometry_noise=BEYOND_ODOMETRY_NOISE)
    return {
        "free N=2": (scenario(2, pictures), "free", DUTY_BUDGET),
        "sparse N=30": (scenario(30, pictures, 0.25), "free", DUTY_BUDGET),
        "noise 3 px N=30": (_camera(base, pixel_noise=3.0), "free", DUTY_BUDGET),
        "heavy clutter N=30": (_camera(base, **HEAVY_CLUTTER), "free", DUTY_BUDGET),
        "odometry N=30": (dataclasses.replace(base, robot=robot), "free", DUTY_BUDGET),
        "swarm N=30, budget 0.05": (base, "swarm", DUTY_BUDGET / 4),
    }
