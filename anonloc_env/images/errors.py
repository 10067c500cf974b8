"""The image path's real errors, measured, so that a config can state them (the detector's
calibration step).

A localizer builds its sensor model from the config
(:meth:`anonloc_env.identify.SensorModel.from_config`, which reads the camera section as
stated). With ``camera.source = "image"`` the config's noise fields do not describe the pictures:
the detector's errors do. They are measured here once per config (and cached): seeded pictures of
robots at random non-overlapping poses, each detection compared with the true projection.
:func:`effective_camera` returns the camera section with the measured values in place of the
nominal ones, and :func:`calibrated` the config with that section: the env takes this step when it
builds its image source (:func:`anonloc_env.detection.stated_config`).
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from anonloc_env.camera import Camera
from anonloc_env.config import CameraConfig, EnvConfig, arena_capacity
from anonloc_env.geometry import wrap_angle

MEASURE_SEED = 20170424
"""Seed of the measurement pictures (fixed: the measured model is a function of the config)."""
MEASURE_SAMPLES = 400
"""Robot views the measurement aims for."""
_MIN_ROBOTS = 20  # robots per measurement picture (when the arena holds them)


@dataclasses.dataclass(frozen=True)
class ErrorSample:
    """Per-robot detection errors over seeded pictures.

    Attributes:
        du, dv: position error of each detected robot (image units), detected minus true.
        dtheta: heading error of each detected robot (rad, wrapped).
        marker_pixels: side of each detected robot's marker in the image (pixels).
        in_view: robots whose true centre lies in the field of view.
        missed: of those, how many were not detected.
        false: detections matched to no robot.
        pictures: pictures taken.
    """

    du: np.ndarray
    dv: np.ndarray
    dtheta: np.ndarray
    marker_pixels: np.ndarray
    in_view: int
    missed: int
    false: int
    pictures: int

    @property
    def position(self) -> np.ndarray:
        """Distance between each detection and the truth (image units)."""
        return np.hypot(self.du, self.dv)

    @property
    def miss_rate(self) -> float:
        """Fraction of robots in view that were not detected."""
        return self.missed / self.in_view if self.in_view else float("nan")


@dataclasses.dataclass(frozen=True)
class ImageErrors:
    """The image path's errors in the config's terms.

    Attributes:
        pixel_noise: root mean square error of ``u`` and ``v`` (image units).
        orientation_noise_deg: root mean square heading error (deg).
        p_miss: fraction of robots in view that are missed.
        false_positives: false detections per picture.
    """

    pixel_noise: float
    orientation_noise_deg: float
    p_miss: float
    false_positives: float


def sample_errors(
    config: EnvConfig, pictures: int, seed: int, n_robots: int | None = None
) -> ErrorSample:
    """Detection errors of ``pictures`` images of ``n_robots`` (default ``config.n_robots``)
    robots at random non-overlapping poses, drawn from ``seed``."""
    from anonloc_env.images.source import ImageCamera
    from anonloc_env.world import random_poses

    if n_robots is not None:
        config = dataclasses.replace(config, n_robots=n_robots)
    camera = Camera(config)
    source = ImageCamera(config, camera)
    rng = np.random.default_rng(seed)
    u_min, v_min, u_max, v_max = camera.field_of_view
    du, dv, dth, size = [], [], [], []
    in_view = missed = false = 0
    for k in range(pictures):
        poses = random_poses(config, rng)
        picture = source.take(poses, rng, 0.0, k)
        truth = camera.project(poses[:, :2])
        view = (
            (truth[:, 0] >= u_min)
            & (truth[:, 0] <= u_max)
            & (truth[:, 1] >= v_min)
            & (truth[:, 1] <= v_max)
        )
        seen = picture.true_index >= 0
        in_view += int(view.sum())
        missed += int((view & ~seen).sum())
        false += picture.n_rows - int(seen.sum())
        rows = picture.detections[picture.true_index[seen]]
        du.append(rows[:, 0] - truth[seen, 0])
        dv.append(rows[:, 1] - truth[seen, 1])
        dth.append(wrap_angle(rows[:, 2] - camera.image_heading(poses[seen])))
        size.append(source.marker_pixels(poses[seen]))
    return ErrorSample(
        du=np.concatenate(du),
        dv=np.concatenate(dv),
        dtheta=np.concatenate(dth),
        marker_pixels=np.concatenate(size),
        in_view=in_view,
        missed=missed,
        false=false,
        pictures=pictures,
    )


def measured_errors(config: EnvConfig) -> ImageErrors:
    """The image path's errors for ``config`` (measured on seeded pictures; cached).

    The four fields the image path does not apply (``pixel_noise``, ``orientation_noise_deg``,
    ``p_miss``, ``false_positives``) do not change the measurement: a calibrated config measures
    as the config it came from.
    """
    return _measured(_unstated(config))


def _unstated(config: EnvConfig) -> EnvConfig:
    """``config`` with the four error fields at their defaults (the image path ignores them)."""
    blank = CameraConfig()
    return dataclasses.replace(
        config,
        camera=dataclasses.replace(
            config.camera,
            pixel_noise=blank.pixel_noise,
            orientation_noise_deg=blank.orientation_noise_deg,
            p_miss=blank.p_miss,
            false_positives=blank.false_positives,
        ),
    )


@functools.lru_cache(maxsize=64)
def _measured(config: EnvConfig) -> ImageErrors:
    """:func:`measured_errors`, computed."""
    n = min(max(config.n_robots, _MIN_ROBOTS), arena_capacity(config.arena_size, config.robot))
    n = max(n, config.n_robots)
    sample = sample_errors(config, math.ceil(MEASURE_SAMPLES / n), MEASURE_SEED, n_robots=n)
    if len(sample.du) == 0:
        return ImageErrors(0.0, 0.0, 0.99, 0.0)
    return ImageErrors(
        pixel_noise=float(np.sqrt(np.mean(np.concatenate([sample.du, sample.dv]) ** 2))),
        orientation_noise_deg=float(np.degrees(np.sqrt(np.mean(sample.dtheta**2)))),
        p_miss=min(sample.miss_rate, 0.99),
        false_positives=min(sample.false / sample.pictures, 1000.0),
    )


def effective_camera(config: EnvConfig) -> CameraConfig:
    """The camera section that describes the pictures ``config`` produces.

    ``config.camera`` itself for the geometric source; for the image source, the same section
    with ``pixel_noise``, ``orientation_noise_deg``, ``p_miss`` and ``false_positives`` replaced
    by the measured ones (:func:`measured_errors`).
    """
    cam = config.camera
    if cam.source != "image":
        return cam
    errors = measured_errors(config)
    return dataclasses.replace(
        cam,
        pixel_noise=errors.pixel_noise,
        orientation_noise_deg=errors.orientation_noise_deg,
        p_miss=errors.p_miss,
        false_positives=errors.false_positives,
    )


def calibrated(config: EnvConfig) -> EnvConfig:
    """``config`` with :func:`effective_camera` as its camera section: for the image source, the
    errors its pictures really have, measured (renders about 400 robot views once per config).

    Calibrating twice changes nothing: ``calibrated(calibrated(c)) == calibrated(c)``.
    """
    camera = effective_camera(config)
    return config if camera is config.camera else dataclasses.replace(config, camera=camera)
