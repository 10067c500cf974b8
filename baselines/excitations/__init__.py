"""Excitations: what a robot does between pictures so that it can be recognised.

Each excitation drives R robots at once, every robot with its own random generator (a robot's
choices never depend on another's). ``commands(step, dt)`` returns physical commands ``v`` (m/s) and
``w`` (rad/s), clipped by the env to the robot's limits.

Defaults follow section III of the paper: turn in place counter-clockwise at up to 9 deg/s
(angular), drive straight at up to 0.1 units/s (linear), or random motion with speeds in
[0.1, 0.5] units/s and turn rates in [-20, 20] deg/s changed at random times every 0 to 3 s, turning
in place at a random rate after a bump (random). ``swarm`` shares one random command stream
between all robots, each blending in a fraction ``jitter`` of its own draw.

Layout, one family a module (every name is importable from here):
:mod:`~baselines.excitations.base` (the :class:`Excitation` base class, :class:`Still`),
:mod:`~baselines.excitations.paper` (the paper's :class:`Angular` and :class:`Linear`),
:mod:`~baselines.excitations.random_motion` (the paper's :class:`RandomMotion` and the
:class:`BumpEscape` it shares with the swarm),
:mod:`~baselines.excitations.swarm` (:class:`SwarmMotion`, :class:`SwarmDuty`),
:mod:`~baselines.excitations.backoff` (the :class:`BackOff` out of bumps and its settings),
:mod:`~baselines.excitations.distinct` (:class:`DistinctMotion`),
:mod:`~baselines.excitations.gaps` (:class:`GapSeeking`, the crowd-aware one: it reads the
beliefs and the picture to keep out of contact) and :mod:`~baselines.excitations.reflex`
(:class:`BumpReflex`: the back-off of the candidate excitations, which escapes as ``gaps`` does
when a robot is pressed). The other active ones, which read the robots'
beliefs, are in :mod:`baselines.active`.
"""

from baselines.excitations.base import Excitation, Still
from baselines.excitations.distinct import (
    BackOff,
    DistinctMotion,
    DistinctSettings,
    check_command_box,
)
from baselines.excitations.gaps import GapSeeking, GapSettings
from baselines.excitations.paper import Angular, AngularSettings, Linear, LinearSettings
from baselines.excitations.random_motion import BumpEscape, RandomMotion, RandomSettings
from baselines.excitations.reflex import BumpReflex
from baselines.excitations.swarm import SWARM_JITTER, SwarmDuty, SwarmMotion

__all__ = [
    "SWARM_JITTER",
    "Angular",
    "AngularSettings",
    "BackOff",
    "BumpEscape",
    "BumpReflex",
    "DistinctMotion",
    "DistinctSettings",
    "Excitation",
    "GapSeeking",
    "GapSettings",
    "Linear",
    "LinearSettings",
    "RandomMotion",
    "RandomSettings",
    "Still",
    "SwarmDuty",
    "SwarmMotion",
    "check_command_box",
]
