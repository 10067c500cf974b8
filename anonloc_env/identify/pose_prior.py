"""What the registration knows before it sees a picture: the camera's motion and the robots'.

``registration_prior`` turns a moving camera's config (``anonloc_env.camera_motion``) into the
standard deviations of each picture's transform, about the set point and from one picture to
the next (``RegistrationPrior``), which ``anonloc_env.identify.camera_pose.Registration`` fits
with; ``registration_error`` and ``registered_pixel_noise`` give the sensor model's nominal
figures (what the agent's candidate predictions and the corrected localizers read).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from anonloc_env.camera import survey
from anonloc_env.camera_motion import left_tilt
from anonloc_env.config import EnvConfig
from anonloc_env.landmarks import landmark_error


@dataclass(frozen=True)
class RegistrationPrior:
    """What the estimator knows of the camera's motion and of the robots' (image units, rad).

    Attributes:
        centre: the principal point ``(cu, cv)``, about which the similarity turns and scales.
        spread: standard deviation per component of a robot's displacement between two
            pictures when nothing predicts it (image units), before the fit rescales it.
        pixel_noise: the detector's standard deviation per coordinate (image units).
        radius: root mean square distance of the field of view's points from its centre
            (image units).
        change: standard deviations of the change of ``(a, b, tx, ty, g, h)`` between two
            pictures (``g``, ``h``: per image unit; 0 where the perspective is held at 0).
        absolute: standard deviations of ``(a - 1, b, tx, ty, g, h)`` about the set point.
        reach: the farthest a row moves between two pictures (image units): a robot's largest
            displacement plus four standard deviations of the camera's change.
    """

    centre: tuple[float, float]
    spread: float
    pixel_noise: float
    radius: float
    change: tuple[float, float, float, float, float, float]
    absolute: tuple[float, float, float, float, float, float]
    reach: float


def _ou_change(sigma: float, tau: float, interval: float) -> float:
    """Standard deviation of an OU process's change over ``interval``."""
    return sigma * math.sqrt(2.0 * (1.0 - math.exp(-interval / tau)))


def registration_prior(
    config: EnvConfig, pixel_noise: float | None = None
) -> RegistrationPrior | None:
    """The prior of ``config``'s camera motion, or ``None`` for a fixed camera, or one whose
    pictures its landmarks register (the detection source does it). ``pixel_noise``: the
    detector's (image units; default ``camera.pixel_noise``, the image source's measured one
    where the sensor model has it)."""
    cam = config.camera
    if not cam.moves or cam.landmarks:
        return None
    width, height = config.arena_size
    s = cam.scale
    centre = (
        cam.principal_point if cam.principal_point is not None else (s * width / 2, s * height / 2)
    )
    interval = config.schedule.picture_interval
    tilt = left_tilt(config)
    shift = s * math.hypot(cam.drift, cam.height * tilt)
    shift_change = s * math.hypot(
        _ou_change(cam.drift, cam.drift_time, interval),
        cam.height * _ou_change(tilt, cam.wobble_time, interval),
    )
    bend = tilt / (s * cam.height)  # the left tilt's perspective, per image unit
    bend_change = _ou_change(tilt, cam.wobble_time, interval) / (s * cam.height)
    noise = float(cam.pixel_noise if pixel_noise is None else pixel_noise)
    if bend * _radius(config) ** 2 < max(noise, 0.01):  # under the detector's noise: held at 0
        bend = bend_change = 0.0
    zoom = cam.height_wobble / cam.height
    yaw = math.radians(cam.yaw_wobble_deg)
    rotate = math.hypot(zoom, yaw)
    rotate_change = _ou_change(rotate, cam.wobble_time, interval)
    step = config.robot.v_max * interval * s
    floor = 1e-6  # a process set to 0 is held (almost) exactly
    return RegistrationPrior(
        centre=(float(centre[0]), float(centre[1])),
        spread=0.5 * step,
        pixel_noise=noise,
        radius=_radius(config),
        change=(
            max(rotate_change, floor),
            max(rotate_change, floor),
            max(shift_change, floor),
            max(shift_change, floor),
            bend_change,
            bend_change,
        ),
        absolute=(
            max(rotate, floor),
            max(rotate, floor),
            max(shift, floor),
            max(shift, floor),
            bend,
            bend,
        ),
        reach=1.2 * step + 4.0 * shift_change + 4.0 * rotate_change * _radius(config),
    )


def _radius(config: EnvConfig) -> float:
    """Root mean square distance of the field of view's points from its centre (image units)."""
    u_min, v_min, u_max, v_max = survey(config).field_of_view
    return math.sqrt(((u_max - u_min) ** 2 + (v_max - v_min) ** 2) / 12.0)


def registration_error(config: EnvConfig) -> float:
    """Expected error (image units, per coordinate, root mean square over the view) of a
    registered row's displacement between two pictures: the posterior spread of the transform's
    change, with every robot in view matched and unpredicted (a bound: persistence helps)."""
    prior = registration_prior(config)
    if prior is None:
        return 0.0
    cam = config.camera
    matches = max(config.n_robots * (1.0 - cam.p_miss), 1.0)
    data = matches / prior.spread**2
    radius = _radius(config)
    shift_var = 1.0 / (1.0 / prior.change[2] ** 2 + data)
    turn_var = 1.0 / (1.0 / prior.change[0] ** 2 + data * radius**2)
    return math.sqrt(shift_var + 2.0 * turn_var * radius**2 / 2.0)


def registered_pixel_noise(config: EnvConfig, pixel_noise: float) -> float:
    """The pixel noise a registered picture's rows have: ``pixel_noise`` plus half the
    registration's variance (a displacement takes two rows' noise, and one registration error),
    or, with landmarks, plus the variance of their fit (one per picture)."""
    if config.camera.landmarks:  # the detection source rectified the rows: the fit's error
        return math.sqrt(pixel_noise**2 + landmark_error(config, pixel_noise) ** 2)
    error = registration_error(config)
    return math.sqrt(pixel_noise**2 + 0.5 * error**2)


def first_error(prior: RegistrationPrior) -> float:
    """The error of a picture registered with nothing to match (the previous picture's
    transform kept): the camera's change itself, per coordinate over the view."""
    shift, turn = prior.change[2], prior.change[0]
    return math.sqrt(shift**2 + 0.5 * turn**2 * prior.radius**2)


def residual_floor(prior: RegistrationPrior) -> float:
    """The smallest spread a guess may take (image units): two rows' detector noise, or a
    hundredth of a pixel for noise-free pictures."""
    return max(math.sqrt(2.0) * prior.pixel_noise, 0.01)
