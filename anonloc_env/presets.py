"""Named scenarios and the resolution of keyword overrides on top of them.

``make_config(preset, **overrides)`` is what :func:`anonloc_env.parallel_env` calls. Overrides apply
on top of the preset; a nested dict changes only the fields it names; an unknown name is an error
that lists the valid ones.

The three ``paper-*`` presets recreate the conditions of section III of Poulet, Guerin and Guinand
(ICCAR 2017): two square robots, a control step of 0.01 s, a picture every 10 s, speeds and turn
rates as in the paper, and a camera whose scale along u varies from 20.8 to 22.07 image units per
world unit across the arena (a 4.24 degree tilt at 10 units). Their noise levels are derived from
the paper's own second row of results; ``docs/calibration.md`` gives the derivation. They differ
only in their detector noise: the motion experiment's robots move fast.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

from anonloc_env._checks import did_you_mean
from anonloc_env.config import (
    SECTIONS,
    CameraConfig,
    EnvConfig,
    RobotConfig,
    ScheduleConfig,
)

#: Shortcuts accepted at the top level, mapped to (section, field).
_SHORTCUTS = {"picture_interval": ("schedule", "picture_interval")}

_PAPER_ROBOT = RobotConfig(
    shape="square", size=0.3, v_max=0.5, omega_max=math.radians(20.0), odometry_noise=0.0
)
# 21.42 units/world unit at the centre and sin(tilt)/height = 0.0074 give 20.8 to 22.07 units
# per unit along u across the 8-unit arena, the range the paper measured.
_PAPER_CAMERA = CameraConfig(scale=21.42, tilt_deg=4.24, height=10.0, orientation=True)

# Detector noise worked back from the paper's second row of results (baselines.paper_noise,
# docs/calibration.md): a heading noise of 1.42 deg gives its 1.6 deg mean rotation error; a
# pixel noise of 0.18 its 0.823 mean ratio deviation (slow straight drives); 2.40 its 7.22 deg
# mean x/y heading disagreement (fast random motion: moving markers are detected less precisely).
PAPER_ORIENTATION_NOISE_DEG = 1.42
PAPER_STILL_PIXEL_NOISE = 0.18
PAPER_MOVING_PIXEL_NOISE = 2.40


def _paper(pixel_noise: float) -> EnvConfig:
    return EnvConfig(
        n_robots=2,
        arena_size=(8.0, 8.0),
        dt=0.01,
        max_cycles=4000,
        robot=_PAPER_ROBOT,
        camera=dataclasses.replace(
            _PAPER_CAMERA,
            pixel_noise=pixel_noise,
            orientation_noise_deg=PAPER_ORIENTATION_NOISE_DEG,
        ),
        schedule=ScheduleConfig(picture_interval=10.0),
    )


PRESETS: dict[str, EnvConfig] = {
    "default": EnvConfig(
        n_robots=4,
        arena_size=(4.0, 4.0),
        dt=0.05,
        max_cycles=600,
        camera=CameraConfig(scale=100.0, pixel_noise=1.0, orientation_noise_deg=2.0),
        schedule=ScheduleConfig(picture_interval=1.0),
    ),
    "paper-angular": _paper(PAPER_STILL_PIXEL_NOISE),
    "paper-linear": _paper(PAPER_STILL_PIXEL_NOISE),
    "paper-motion": _paper(PAPER_MOVING_PIXEL_NOISE),
}
"""The named scenarios. ``default`` is the built-in scenario of the README's main job."""

# A camera on a small drone 5 m above the default arena (docs/drone.md gives the sources): a
# calm hover with vision positioning (DJI's hover accuracy of +-0.3 m horizontally and +-0.1 m
# vertically read as three standard deviations), and gusts (three times the drift, faster).
_DEFAULT_CAMERA = PRESETS["default"].camera
PRESETS["drone-hover"] = dataclasses.replace(
    PRESETS["default"],
    camera=dataclasses.replace(
        _DEFAULT_CAMERA,
        drift=0.1,
        drift_time=5.0,
        height_wobble=0.033,
        yaw_wobble_deg=0.5,
        tilt_wobble_deg=1.0,
        wobble_time=1.0,
        gimbal_bandwidth=100.0,
    ),
)
PRESETS["drone-windy"] = dataclasses.replace(
    PRESETS["default"],
    camera=dataclasses.replace(
        _DEFAULT_CAMERA,
        drift=0.25,
        drift_time=2.0,
        height_wobble=0.1,
        yaw_wobble_deg=2.0,
        tilt_wobble_deg=5.0,
        wobble_time=0.5,
        gimbal_bandwidth=100.0,
    ),
)

# A crowd (docs/crowds.md): 100 robots at 4 per square metre (0.2 m squares cover 16 % of the
# floor), 1 px of noise and no detected headings, the hardest common case for identification;
# 30 pictures.
PRESETS["crowd"] = dataclasses.replace(
    PRESETS["default"],
    n_robots=100,
    arena_size=(5.0, 5.0),
    max_cycles=601,
    camera=dataclasses.replace(_DEFAULT_CAMERA, orientation=False),
)


def preset_names() -> list[str]:
    """The valid preset names."""
    return list(PRESETS)


def make_config(preset: str | None = None, **overrides: Any) -> EnvConfig:
    """Build an :class:`EnvConfig` from a named preset and keyword overrides.

    Args:
        preset: a name from :data:`PRESETS`; ``None`` means ``"default"``.
        **overrides: top-level fields of :class:`EnvConfig` (``n_robots``, ``arena_size``, ``dt``,
            ``max_cycles``), the shortcut ``picture_interval``, and the sections ``robot``,
            ``camera``, ``schedule``, ``observation``, ``reward``, each either a dict of the fields
            to change or a whole config object.

    When ``n_robots`` is given and ``arena_size`` is not, an arena too small for N at the preset's
    density grows by ``sqrt(n_robots / preset.n_robots)`` on each side (its aspect kept), so
    ``parallel_env(n_robots=1000)`` works; a smaller N keeps the preset's arena. An
    ``arena_size`` given explicitly is used as is, and refused if it cannot hold N robots.

    Raises:
        ValueError: an unknown preset, override or field name (the message lists the valid
            ones), or a value out of range.
        TypeError: a section given as something other than a dict or its config class.
    """
    if preset is not None and not isinstance(preset, str):
        raise TypeError(
            f"preset must be a preset name (one of {list(PRESETS)}) or None, got {preset!r}; "
            "give the number of robots as n_robots=..."
        )
    name = "default" if preset is None else preset
    if name not in PRESETS:
        raise ValueError(
            f"unknown preset {name!r}{did_you_mean(name, PRESETS)}; valid: {list(PRESETS)}"
        )
    base = PRESETS[name]
    top_fields = {f.name for f in dataclasses.fields(EnvConfig)}
    valid = sorted(top_fields | set(_SHORTCUTS))
    changes: dict[str, Any] = {}
    sections: dict[str, dict[str, Any]] = {}
    for key, value in overrides.items():
        if key in _SHORTCUTS:
            section, field_name = _SHORTCUTS[key]
            sections.setdefault(section, {})[field_name] = value
        elif key in SECTIONS:
            if isinstance(value, SECTIONS[key]):
                changes[key] = value
            elif isinstance(value, Mapping):
                merged = sections.setdefault(key, {})
                for field_name, field_value in value.items():
                    if field_name in merged and merged[field_name] != field_value:
                        raise ValueError(
                            f"{key}.{field_name} is given twice with different values "
                            f"({merged[field_name]!r} and {field_value!r})"
                        )
                    merged[field_name] = field_value
            else:
                raise TypeError(
                    f"{key} must be a dict of fields or a {SECTIONS[key].__name__}, "
                    f"got {type(value).__name__}"
                )
        elif key in top_fields:
            changes[key] = value
        else:
            raise ValueError(f"unknown override {key!r}{did_you_mean(key, valid)}; valid: {valid}")
    for section, fields in sections.items():
        current = changes.get(section, getattr(base, section))
        changes[section] = replace_fields(current, section, fields)
    if "n_robots" in changes and "arena_size" not in changes:
        scaled = _scaled_arena(base, changes["n_robots"])
        if scaled is not None:
            changes["arena_size"] = scaled
    return dataclasses.replace(base, **changes)


def _scaled_arena(base: EnvConfig, n_robots: Any) -> tuple[float, float] | None:
    """The preset's arena grown to hold ``n_robots`` at its density (None: keep it as is)."""
    try:
        ratio = float(n_robots) / base.n_robots
    except (TypeError, ValueError, OverflowError):
        return None  # not a number: the config's own check names the problem
    if not ratio > 1.0 or not math.isfinite(ratio):
        return None
    growth = math.sqrt(ratio)
    return (base.arena_size[0] * growth, base.arena_size[1] * growth)


def replace_fields(obj: Any, prefix: str, fields: Mapping[str, Any]) -> Any:
    """``dataclasses.replace`` that names the valid fields when given an unknown one."""
    valid = [f.name for f in dataclasses.fields(obj)]
    for key in fields:
        if key not in valid:
            raise ValueError(
                f"unknown field {prefix}.{key}{did_you_mean(key, valid)}; "
                f"valid {prefix} fields: {valid}"
            )
    return dataclasses.replace(obj, **fields)


def config_to_dict(config: EnvConfig) -> dict[str, Any]:
    """The config as plain nested dicts and lists, e.g. to record it next to results."""
    return dataclasses.asdict(config)
