"""The sweeps of ``anonloc study``: what varies, how, and which policies are compared.

Each sweep answers one of the paper's future-work questions: the Bayesian identifier (``bayes``),
and the corrected ``motion`` method where it applies, against one quantity. The base scenario is
the ``default`` preset (a picture every second, a control step of 0.05 s, 1 image unit of pixel
noise at 100 units/m) with :data:`ROBOTS` robots, all localizing at once, in a square arena of
side ``max(4, 1.5 sqrt(N))`` m (the ``robots`` sweep scales it the same way).

A sweep is pure data: :func:`overrides` turns a point into the scenario's overrides, which travel
in the work unit (so its key changes when the sweep does).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

#: Episodes per point and policy by default: ``anonloc study`` runs in a few minutes on 2 cores.
DEFAULT_SEEDS = 6
#: Most seeds a command takes (``--seeds``): its units are built before any runs, and ten
#: million of them would not fit in memory.
MAX_SEEDS = 100_000
#: Robots in every sweep but ``robots`` (the default preset's 4 make most questions too easy).
ROBOTS = 10
#: Pictures per episode (the ``blackout`` sweep adds its own).
PICTURES = 8
#: Belief in the true row that counts as "identified again" after a blackout.
REID_BELIEF = 0.9
#: Pictures after a blackout within which a robot must be identified again.
REID_PICTURES = 5
#: The blackout starts here (s), when every robot has long been identified.
BLACKOUT_START = 5.0
#: Robots in the ``density`` sweep (enough that most are away from the walls at 6 per m^2).
CROWD_ROBOTS = 30


#: The ``drift`` sweep's camera besides its drift: the ``drone-hover`` preset's wobbles and gimbal
#: (plain data here: the CLI's help must not import the env).
DRONE_WOBBLES = {
    "drift_time": 5.0,
    "height_wobble": 0.033,
    "yaw_wobble_deg": 0.5,
    "tilt_wobble_deg": 1.0,
    "wobble_time": 1.0,
    "gimbal_bandwidth": 100.0,
}


@dataclass(frozen=True)
class Variant:
    """A policy as a sweep plots it.

    Attributes:
        label: the legend's name.
        policy: the policy's name.
        kwargs: passed to the localizer (e.g. ``scale_known=False``).
    """

    label: str
    policy: str
    kwargs: dict[str, Any] = field(default_factory=dict)


BAYES = Variant("bayes", "bayes")
MOTION = Variant("motion (corrected)", "motion")


@dataclass(frozen=True)
class Sweep:
    """One quantity varied over ``xs``.

    Attributes:
        name: the ``--sweep`` name (and the files' stem).
        title: the plot's title.
        xlabel: the x axis, with its unit.
        xs: the values.
        variants: the policies compared.
        log_x: a logarithmic x axis (linear between 0 and the smallest positive x).
        measure: ``"decision"`` (success and pictures at each robot's first decision) or
            ``"reid"`` (identified again after a blackout, and how many pictures it took).
    """

    name: str
    title: str
    xlabel: str
    xs: tuple[float, ...]
    variants: tuple[Variant, ...] = (BAYES, MOTION)
    log_x: bool = False
    measure: str = "decision"


SWEEPS: dict[str, Sweep] = {
    s.name: s
    for s in (
        Sweep(
            "robots",
            "Number of robots (arena side max(4, 1.5 sqrt(N)) m)",
            "number of robots N",
            (2, 10, 100, 1000),
            log_x=True,
        ),
        Sweep(
            "interval", "Picture interval", "picture interval (s)", (0.25, 0.5, 1, 2, 4), log_x=True
        ),
        Sweep(
            "dt",
            "Control step",
            "control step dt (s)",
            (0.01, 0.02, 0.05, 0.1, 0.2, 0.5),
            log_x=True,
        ),
        Sweep(
            "noise",
            "Pixel noise",
            "pixel noise std (image units; 100 units = 1 m)",
            (0, 1, 2, 4, 8, 16, 32, 64),
            log_x=True,
        ),
        Sweep(
            "tilt",
            "Camera tilt (scale varies across the image)",
            "camera tilt (deg)",
            (0, 10, 20, 30, 40),
            variants=(
                BAYES,
                Variant("bayes (scale unknown)", "bayes", {"scale_known": False}),
                MOTION,
                Variant("motion3 (scale unknown)", "motion3"),
            ),
        ),
        Sweep(
            "miss",
            "Missed detections",
            "probability that a robot is missed",
            (0, 0.05, 0.1, 0.2, 0.4),
        ),
        Sweep(
            "false-positives",
            "False detections",
            "false detections per picture (mean)",
            (0, 1, 2, 4, 8),
        ),
        Sweep(
            "swarm",
            "Swarm-like motion (shared commands, per-robot jitter)",
            "per-robot command jitter (0: identical, 1: independent)",
            (0, 0.05, 0.1, 0.2, 0.5, 1),
            log_x=True,
        ),
        Sweep(
            "drift",
            "A camera on a hovering drone: horizontal drift (drone-hover's wobbles, no landmarks)",
            "camera drift std (m, per axis; correlation time 5 s)",
            (0, 0.025, 0.05, 0.1, 0.2, 0.4),
        ),
        Sweep(
            "density",
            f"Crowding: {CROWD_ROBOTS} robots, no detected headings (docs/crowds.md)",
            "robots per square metre (0.2 m robots)",
            (0.25, 0.5, 1, 2, 4, 6),
            log_x=True,
        ),
        Sweep(
            "blackout",
            f"Identified again after a blackout from t = {BLACKOUT_START:g} s (5 % odometry noise)",
            "blackout duration (s)",
            (0, 2, 5, 10, 20),
            measure="reid",
        ),
    )
}


def overrides(sweep: Sweep, x: float) -> dict[str, Any]:
    """The overrides of the ``default`` preset at point ``x`` of ``sweep`` (the episode is made
    long enough for its pictures)."""
    interval, dt, extra_time = 1.0, 0.05, 0.0
    out: dict[str, Any] = arena(int(x) if sweep.name == "robots" else ROBOTS)
    if sweep.name == "interval":
        interval = float(x)
        out["picture_interval"] = interval
    elif sweep.name == "dt":
        dt = float(x)
        out["dt"] = dt
    elif sweep.name == "noise":
        out["camera"] = {"pixel_noise": float(x)}
    elif sweep.name == "tilt":
        out["camera"] = {"tilt_deg": float(x)}
    elif sweep.name == "miss":
        out["camera"] = {"p_miss": float(x)}
    elif sweep.name == "false-positives":
        out["camera"] = {"false_positives": float(x)}
    elif sweep.name == "drift":
        out["camera"] = {**DRONE_WOBBLES, "drift": float(x)} if x > 0 else {}
    elif sweep.name == "density":
        side = round(math.sqrt(CROWD_ROBOTS / float(x)), 3)
        out = {"n_robots": CROWD_ROBOTS, "arena_size": [side, side]}
        out["camera"] = {"orientation": False}
    elif sweep.name == "blackout":
        extra_time = float(x)
        out["robot"] = {"odometry_noise": 0.05}
        if x > 0:
            out["schedule"] = {"blackouts": [[BLACKOUT_START, BLACKOUT_START + float(x)]]}
    out["max_cycles"] = math.ceil(((pictures(sweep) + 1) * interval + extra_time) / dt)
    return out


def arena(n: int) -> dict[str, Any]:
    """``n`` robots in a square arena of side ``max(4, 1.5 sqrt(n))`` m."""
    side = round(max(4.0, 1.5 * math.sqrt(n)), 3)
    return {"n_robots": n, "arena_size": [side, side]}


def excitation(sweep: Sweep, x: float) -> Any:
    """The excitation at point ``x`` (None: each policy's own)."""
    return {"swarm": float(x)} if sweep.name == "swarm" else None


def pictures(sweep: Sweep) -> int:
    """Pictures scored per episode."""
    if sweep.measure == "reid":
        return math.ceil(BLACKOUT_START) + REID_PICTURES  # one picture a second
    return PICTURES


def after(sweep: Sweep, x: float) -> float | None:
    """For ``reid``: the time (s) from which pictures count as "after the blackout"."""
    return BLACKOUT_START + float(x) if sweep.measure == "reid" else None
