"""Calibrate the camera as a user would: robots drive known paths, the homography is fitted.

A few robots start on a line near the arena's low-y wall, facing +y, and drive straight across
at a known speed while the image source photographs them (the detection source alone: no
environment is run, the positions at each picture are known). Their known ground positions (a user
would measure them; here they are the simulator's) and their detected image positions give the
ground-to-image homography (``cv2.findHomography``, least squares). From it come the figures the
paper reported for its camera, compared with the true camera: the scale at the arena centre, the
range of the scale along ``u`` across the arena (the paper's 20.8 to 22.07), the perspective
coefficient ``sin(tilt) / height``, and the tilt itself, read from the ratio of the scales along
``v`` and ``u`` at the centre (``cos(tilt)``; needs no height, but is ill-conditioned for tilts of
a few degrees).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from anonloc_env.camera import Camera
from anonloc_env.config import EnvConfig
from anonloc_env.images.pose import estimate_homography


@dataclasses.dataclass(frozen=True)
class CalibrationResult:
    """An estimated homography beside the true one.

    Attributes:
        estimated: ``(3, 3)`` fitted ground-to-image homography.
        true: ``(3, 3)`` the camera's own.
        points: correspondences used.
        fit_rms: root mean square distance (image units) between the detections and the fitted
            homography's projections.
        grid_error: largest distance (image units) between the two homographies' projections of
            a 9 x 9 grid over the arena.
        scale: ``(estimated, true)`` local scale at the arena centre (image units per metre).
        scale_u_range: ``((min, max) estimated, (min, max) true)`` scale along ``u`` across the
            arena (image units per metre).
        perspective: ``(estimated, true)`` ``sin(tilt) / height`` (1/m).
        tilt_deg: ``(estimated, true)`` tilt from the centre's scale ratio (deg, unsigned).
    """

    estimated: np.ndarray
    true: np.ndarray
    points: int
    fit_rms: float
    grid_error: float
    scale: tuple[float, float]
    scale_u_range: tuple[tuple[float, float], tuple[float, float]]
    perspective: tuple[float, float]
    tilt_deg: tuple[float, float]


def calibrate(
    config: EnvConfig, *, robots: int = 3, pictures: int = 20, seed: int = 0
) -> CalibrationResult:
    """Drive ``robots`` robots straight across the arena, photograph them ``pictures`` times
    through the image source, and fit the homography.

    The camera section of ``config`` is used with ``source="image"``; robots, arena and camera
    otherwise as given.
    """
    for name, value in (("robots", robots), ("pictures", pictures)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
    # The robots drive straight at a known speed, so their ground positions at each picture are
    # known (a user measures them): no simulation is needed, only the detection source.
    from anonloc_env.images.source import ImageCamera

    width, height = config.arena_size
    speed = config.robot.v_max
    travel = 0.8 * height - config.robot.size
    interval = max(config.dt, travel / speed / pictures)
    setup = dataclasses.replace(
        config, n_robots=robots, camera=dataclasses.replace(config.camera, source="image")
    )
    source = ImageCamera(setup)
    rng = np.random.default_rng(seed)
    low = 0.1 * height + config.robot.size
    xs = np.array([width * (i + 1) / (robots + 1) for i in range(robots)])
    world: list[np.ndarray] = []
    image: list[np.ndarray] = []
    for k in range(pictures):
        poses = np.column_stack(
            [xs, np.full(robots, low + speed * k * interval), np.full(robots, math.pi / 2)]
        )
        picture = source.take(poses, rng, k * interval, k)
        for i, row in enumerate(picture.true_index.tolist()):
            if row >= 0:
                world.append(poses[i, :2])
                image.append(picture.detections[row, :2])
    return compare(estimate_homography(np.array(world), np.array(image)), config, world, image)


def compare(
    estimated: np.ndarray, config: EnvConfig, world: list[np.ndarray], image: list[np.ndarray]
) -> CalibrationResult:
    """``estimated`` beside ``config``'s true camera, with the fit's residual on the points."""
    camera = Camera(config)
    width, height = config.arena_size
    grid = np.stack(
        np.meshgrid(np.linspace(0, width, 9), np.linspace(0, height, 9)), axis=-1
    ).reshape(-1, 2)
    est_camera = _with_homography(camera, estimated)
    world_xy, image_uv = np.array(world), np.array(image)
    fit = est_camera.project(world_xy) - image_uv
    centre = np.array([[width / 2.0, height / 2.0]])

    def figures(cam: Camera) -> tuple[float, tuple[float, float], float, float]:
        jac = cam.jacobian(centre)[0]
        du = np.hypot(*cam.jacobian(grid)[:, :, 0].T)  # scale along u (a step along x)
        h = cam.homography / (cam.homography[2] @ np.array([centre[0, 0], centre[0, 1], 1.0]))
        ratio = min(1.0, abs(jac[1, 1] / jac[0, 0]))
        return (
            float(cam.local_scale(centre)[0]),
            (float(du.min()), float(du.max())),
            float(h[2, 1]),
            math.degrees(math.acos(ratio)),
        )

    est, true = figures(est_camera), figures(camera)
    return CalibrationResult(
        estimated=estimated / estimated[2, 2],
        true=camera.homography / camera.homography[2, 2],
        points=len(world_xy),
        fit_rms=float(np.sqrt(np.mean(fit**2))),
        grid_error=float(np.max(np.hypot(*(est_camera.project(grid) - camera.project(grid)).T))),
        scale=(est[0], true[0]),
        scale_u_range=(est[1], true[1]),
        perspective=(est[2], true[2]),
        tilt_deg=(est[3], true[3]),
    )


def _with_homography(camera: Camera, homography: np.ndarray) -> Camera:
    """A copy of ``camera`` projecting through ``homography``."""
    other = Camera(camera.config)
    other.homography = homography
    other.inverse = np.linalg.inv(homography)
    return other
