"""The camera's pose from ground landmarks: fixed markers with distinct ids at known places.

A real setup that must know where its drone's camera looks puts markers on the ground
(``camera.landmarks``: their positions, in metres; ArUco ids 1, 2, ... while every robot wears
id 0). Each picture then carries the landmarks it sees, and their known ground positions give the
picture's ground-to-image homography. The detection source maps the picture's rows through it
into the frame of the camera's set point (``rectify``), so that localizers read pictures as if
the camera had not moved: pose estimation belongs to the detection source, and nothing
downstream changes.

The geometric camera detects a landmark like a robot: the projection through the camera's pose,
plus ``pixel_noise``, missed with ``p_miss`` or when outside the field of view
(``landmark_rows``). Its homography is the camera's pose fitted to them (``fit_pose``): the
maximum a posteriori pose ``(x, y, z, yaw, pitch, roll)`` under the hover's stationary law
(``camera_motion.pose_sigma``), so that the gimbal's small left tilt is not fitted as freely as
the drift, the height and the yaw (a full homography's 8 parameters took the landmarks' noise
into 4 more directions than the camera moves in); without noise, the exact homography
(``fit_homography``). The image source finds the landmarks' markers in the rendered image and
fits a homography to their corners with OpenCV (``anonloc_env.images.pose``).

The error this leaves is the fit's, which the sensor model adds to the pixel noise
(``landmark_error``): for the pose fit, the posterior's spread of a rectified row over the arena
(about the pixel noise over ``sqrt(4)`` with 8 landmarks, where the tilt is held by its prior);
for the image source's homography, the pixel noise times ``sqrt(4 / L)`` with ``L`` landmarks.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from anonloc_env.camera_motion import pose_homography, pose_sigma, set_point
from anonloc_env.config import EnvConfig

#: Most Gauss-Newton steps of a pose fit (it converges in two or three from the set point).
POSE_STEPS = 8


def border_landmarks(
    arena_size: tuple[float, float], inset: float = 0.15
) -> tuple[tuple[float, float], ...]:
    """Eight landmark positions ``((x, y), ...)`` (m): the corners and the middles of the sides
    of the arena shrunk by ``inset`` of its size on every side (inside the view of a drifting
    camera)."""
    width, height = arena_size
    xs = (inset * width, width / 2.0, (1.0 - inset) * width)
    ys = (inset * height, height / 2.0, (1.0 - inset) * height)
    return tuple((x, y) for y in ys for x in xs if not (x == xs[1] and y == ys[1]))


def landmark_rows(
    config: EnvConfig,
    project: object,
    field_of_view: tuple[float, float, float, float],
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray]:
    """The landmarks a geometric camera detects: ``(ids, uv)``, ``(K,)`` indices into
    ``camera.landmarks`` and ``(K, 2)`` image points, with the picture's noise and misses.

    ``project`` maps ground points ``(M, 2)`` to image points (the camera at this picture's
    pose); every draw comes from ``rng``.
    """
    cam = config.camera
    world = np.asarray(cam.landmarks, dtype=np.float64).reshape(-1, 2)
    uv = project(world)  # type: ignore[operator]  # Camera.project
    u_min, v_min, u_max, v_max = field_of_view
    seen = (uv[:, 0] >= u_min) & (uv[:, 0] <= u_max) & (uv[:, 1] >= v_min) & (uv[:, 1] <= v_max)
    if cam.p_miss > 0.0:
        seen &= rng.random(len(world)) >= cam.p_miss
    if cam.pixel_noise > 0.0:
        uv = uv + rng.normal(0.0, cam.pixel_noise, uv.shape)
    ids = np.flatnonzero(seen)
    return ids, uv[ids]


def fit_pose(config: EnvConfig, ids: np.ndarray, image: np.ndarray) -> np.ndarray:
    """``(3, 3)`` the ground-to-image homography of the camera's pose fitted to the landmarks
    ``ids`` ``(M,)`` (indices into ``camera.landmarks``) seen at ``image`` ``(M, 2)`` (image
    units).

    The pose is the maximum a posteriori one: the landmarks' rows with the detector's noise
    (``camera.pixel_noise``), the pose's components about the set point with the hover's
    stationary spreads (``camera_motion.pose_sigma``; a component that does not move is held at
    the set point), fitted by Gauss-Newton steps in the components scaled by their spreads (the
    set point's derivatives first, then those at the first step's pose). With no landmark seen,
    or a camera that does not move, the set point's homography; without pixel noise, the exact
    homography (``fit_homography``) where there are 2 landmarks or more.
    """
    cam = config.camera
    ids = np.asarray(ids, np.int64)
    image = np.asarray(image, np.float64).reshape(-1, 2)
    world = np.asarray(cam.landmarks, dtype=np.float64).reshape(-1, 2)[ids]
    if cam.pixel_noise <= 0.0 and len(world) >= 2:
        exact = fit_homography(world, image)
        if exact is not None:
            return exact
    home, sigma, free, at_home = _landmark_jacobian(config)
    pose = home.copy()
    if len(world) == 0 or len(free) == 0 or cam.pixel_noise <= 0.0:
        return pose_homography(config, pose)
    rows = np.column_stack([2 * ids, 2 * ids + 1]).reshape(-1)
    jac = at_home[rows] / cam.pixel_noise
    theta = np.zeros(len(free))
    for k in range(POSE_STEPS):
        seen = _through(pose_homography(config, pose), world)
        if k == 1:  # the derivatives where the pose now is
            jac = _pose_jacobian(config, pose, world, seen, free, sigma[free]) / cam.pixel_noise
        residual = (image - seen).reshape(-1) / cam.pixel_noise
        step = np.linalg.solve(jac.T @ jac + np.eye(len(free)), jac.T @ residual - theta)
        theta = theta + step
        pose[free] = home[free] + sigma[free] * theta
        if k and float(np.abs(step).max()) < 1e-9:
            break
    return pose_homography(config, pose)


@functools.lru_cache(maxsize=64)
def _landmark_jacobian(config: EnvConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The set point's pose, the pose's spreads (``pose_sigma``), the components that move and
    ``(2 K, F)`` the derivatives of every landmark's image point at the set point in those
    components scaled by their spreads (once per config: cached; read-only)."""
    home, sigma = set_point(config), pose_sigma(config)
    free = np.flatnonzero(sigma > 0.0)
    world = np.asarray(config.camera.landmarks, dtype=np.float64).reshape(-1, 2)
    seen = _through(pose_homography(config, home), world)
    jac = _pose_jacobian(config, home, world, seen, free, sigma[free])
    for array in (home, sigma, free, jac):
        array.flags.writeable = False
    return home, sigma, free, jac


def _pose_jacobian(
    config: EnvConfig,
    pose: np.ndarray,
    world: np.ndarray,
    seen: np.ndarray,
    free: np.ndarray,
    scale: np.ndarray,
) -> np.ndarray:
    """``(2 M, F)`` derivatives of the image points ``seen`` of ``world`` at ``pose`` in the
    components ``free`` scaled by ``scale`` (forward differences of a thousandth of a
    spread)."""
    out = np.empty((2 * len(world), len(free)))
    for k, (index, spread) in enumerate(zip(free.tolist(), scale.tolist(), strict=True)):
        moved = pose.copy()
        moved[index] += 1e-3 * spread
        out[:, k] = (_through(pose_homography(config, moved), world) - seen).reshape(-1) / 1e-3
    return out


def fit_homography(world: np.ndarray, image: np.ndarray) -> np.ndarray | None:
    """``(3, 3)`` ground-to-image homography fitted to ``(M, 2)`` pairs: the normalised direct
    linear transform for M >= 4, a similarity for M of 2 or 3, ``None`` for fewer."""
    world, image = np.asarray(world, np.float64), np.asarray(image, np.float64)
    if len(world) < 2:
        return None
    if len(world) < 4:
        return _similarity(world, image)
    tw, ti = _normaliser(world), _normaliser(image)
    w = _through(tw, world)
    p = _through(ti, image)
    rows = []
    for (x, y), (u, v) in zip(w, p, strict=True):
        rows.append([-x, -y, -1.0, 0.0, 0.0, 0.0, u * x, u * y, u])
        rows.append([0.0, 0.0, 0.0, -x, -y, -1.0, v * x, v * y, v])
    _, singular, vt = np.linalg.svd(np.array(rows))
    if singular[-2] < 1e-12 * singular[0]:  # degenerate (collinear points): fall back
        return _similarity(world, image)
    h = np.linalg.inv(ti) @ vt[-1].reshape(3, 3) @ tw
    return h / h[2, 2]


def _normaliser(points: np.ndarray) -> np.ndarray:
    """Hartley's normalisation: centroid to the origin, mean distance sqrt(2)."""
    centre = points.mean(axis=0)
    spread = float(np.mean(np.hypot(*(points - centre).T)))
    k = math.sqrt(2.0) / spread if spread > 0.0 else 1.0
    return np.array([[k, 0.0, -k * centre[0]], [0.0, k, -k * centre[1]], [0.0, 0.0, 1.0]])


def _through(h: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Points ``(M, 2)`` through the homography ``h``."""
    out = np.column_stack([points, np.ones(len(points))]) @ h.T
    return out[:, :2] / out[:, 2:3]


def _similarity(world: np.ndarray, image: np.ndarray) -> np.ndarray | None:
    """The similarity (turn, scale, shift) that best maps ``world`` onto ``image``, as a
    homography (least squares, Umeyama without reflection); ``None`` if the points coincide."""
    cw, ci = world.mean(axis=0), image.mean(axis=0)
    a, b = world - cw, image - ci
    spread = float((a**2).sum())
    if spread <= 0.0:
        return None
    # Complex form: image = z * world + t with z = sum(conj(a) b) / sum(|a|^2).
    za, zb = a[:, 0] + 1j * a[:, 1], b[:, 0] + 1j * b[:, 1]
    z = complex((np.conj(za) * zb).sum() / spread)
    linear = np.array([[z.real, -z.imag], [z.imag, z.real]])
    shift = ci - linear @ cw
    return np.array([[*linear[0], shift[0]], [*linear[1], shift[1]], [0.0, 0.0, 1.0]])


def rectify(rows: np.ndarray, estimated: np.ndarray, set_point: np.ndarray) -> np.ndarray:
    """``rows`` ``(M, 3)`` ``(u, v, theta)`` seen through the homography ``estimated``, as the
    camera at its set point (homography ``set_point``) would have seen them; headings through
    the map's Jacobian."""
    warp = set_point @ np.linalg.inv(estimated)
    warp = warp / warp[2, 2]
    out = np.array(rows, dtype=np.float64, copy=True)
    if len(out) == 0:
        return out
    uv = out[:, :2]
    homogeneous = np.column_stack([uv, np.ones(len(uv))]) @ warp.T
    w = homogeneous[:, 2]
    moved = homogeneous[:, :2] / w[:, None]
    # Jacobian of the warp at each point, applied to the heading's direction.
    jac = (warp[None, :2, :2] - moved[:, :, None] * warp[None, 2:3, :2]) / w[:, None, None]
    direction = np.column_stack([np.cos(out[:, 2]), np.sin(out[:, 2])])
    turned = np.einsum("mij,mj->mi", jac, direction)
    out[:, :2] = moved
    out[:, 2] = np.arctan2(turned[:, 1], turned[:, 0])
    return out


def landmark_error(config: EnvConfig, pixel_noise: float) -> float:
    """Expected error (image units per coordinate, root mean square over the arena) of a
    rectified row's place from the landmarks' fit, 0 without landmarks.

    The geometric source's pose fit (``fit_pose``): the linearised posterior of the pose at the
    set point, every landmark seen with probability ``1 - p_miss`` with ``pixel_noise``, carried
    to the rectified places of a grid over the arena. The image source's homography
    (``images.pose.landmark_pose``): its 8 parameters over ``2 L`` equations,
    ``pixel_noise * sqrt(4 / L)`` (``L`` the landmarks expected in view).
    """
    cam = config.camera
    count = len(cam.landmarks) * (1.0 - cam.p_miss)
    if count <= 0.0 or pixel_noise <= 0.0:
        return 0.0
    if cam.source != "geometric":
        params = 8.0 if count >= 4 else 4.0
        return pixel_noise * math.sqrt(params / (2.0 * count))
    home, sigma, free, at_home = _landmark_jacobian(config)
    if len(free) == 0:
        return 0.0
    jac = at_home / pixel_noise
    information = (1.0 - cam.p_miss) * (jac.T @ jac) + np.eye(len(free))
    width, height = config.arena_size
    axes = (np.linspace(0.0, width, 9), np.linspace(0.0, height, 9))
    grid = np.stack(np.meshgrid(*axes), axis=-1).reshape(-1, 2)
    at_grid = _through(pose_homography(config, home), grid)
    moves = _pose_jacobian(config, home, grid, at_grid, free, sigma[free])
    variance = np.einsum("ij,jk,ik->i", moves, np.linalg.inv(information), moves)
    return float(math.sqrt(max(float(variance.mean()), 0.0)))
