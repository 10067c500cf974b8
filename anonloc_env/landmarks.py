"""The camera's pose from ground landmarks: fixed markers with distinct ids at known places.

A real setup that must know where its drone's camera looks puts markers on the ground
(``camera.landmarks``: their positions, in metres; ArUco ids 1, 2, ... while every robot wears
id 0). Each picture then carries the landmarks it sees, and their known ground positions give the
picture's ground-to-image homography (least squares, :func:`fit_homography`; a similarity from
2 or 3 landmarks, the previous picture's transform from fewer). The detection source maps the
picture's rows through it into the frame of the camera's set point (:func:`rectify`), so that
localizers read pictures as if the camera had not moved: pose estimation belongs to the detection
source, and nothing downstream changes.

The geometric camera detects a landmark like a robot: the projection through the camera's pose,
plus ``pixel_noise``, missed with ``p_miss`` or when outside the field of view
(:func:`landmark_rows`). The image source finds the landmarks' markers in the rendered image and
fits their corners with OpenCV (``anonloc_env.images.pose``).

The error this leaves is the fit's: about the pixel noise times ``sqrt(4 / L)`` per coordinate
with ``L`` landmarks seen (:func:`landmark_error`), which the sensor model adds to the pixel noise.
"""

from __future__ import annotations

import math

import numpy as np

from anonloc_env.config import EnvConfig


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
    """Expected error (image units per coordinate) of a rectified row's place from the fit: the
    noise of ``L`` landmarks spread over 8 parameters (``pixel_noise * sqrt(4 / L)``, the mean
    variance of a least-squares fit over its ``2 L`` equations), 0 without landmarks."""
    count = len(config.camera.landmarks) * (1.0 - config.camera.p_miss)
    if count <= 0.0:
        return 0.0
    params = 8.0 if count >= 4 else 4.0
    return pixel_noise * math.sqrt(params / (2.0 * count))
