"""The overhead camera and its detector: world poses in, an anonymous shuffled picture out.

Geometry (see :class:`anonloc_env.config.CameraConfig`): the camera looks at the arena centre
``(xc, yc)`` from a distance ``height``, turned by ``tilt`` about the world x axis. A ground point
maps to the image through the homography

``G = P @ K @ C`` with ``C = [[1, 0, -xc], [0, 1, -yc], [0, 0, 1]]`` (centre the arena),
``K = [[s, 0, 0], [0, s cos(tilt), 0], [0, sin(tilt) / height, 1]]`` (perspective) and
``P = [[1, 0, cu], [0, 1, cv], [0, 0, 1]]`` (principal point),

so ``w = 1 + (y - yc) sin(tilt) / height`` is the relative depth of the point and the local scale
is ``s / w`` along u and ``s cos(tilt) / w**2`` along v. Untilted, ``G`` is the affine map
``u = s (x - xc) + cu``. A robot's detected heading is the image direction of its heading vector
through the Jacobian of ``G`` at its position.

Anything that yields :class:`Picture` objects from poses can stand in for :class:`Camera` (the
:class:`DetectionSource` protocol): nothing downstream knows how a picture was made. With
``camera.source = "image"``, :func:`anonloc_env.detection.detection_source` picks
:mod:`anonloc_env.images`' rendered and detected pictures instead.

:func:`survey` surveys the camera once per config: its local scale's mean, spread and largest
gradient over the arena, and its field of view, what the sensor model and the localizers read.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from anonloc_env.camera_motion import pose_homography
from anonloc_env.config import EnvConfig
from anonloc_env.geometry import wrap_angle
from anonloc_env.landmarks import fit_pose, landmark_rows, rectify


@dataclass(frozen=True, eq=False)
class Picture:
    """One picture: the shuffled detections every robot receives, and the ground truth.

    Attributes:
        detections: ``(M, 3)`` rows ``(u, v, theta)`` in image units and radians, theta in
            [-pi, pi) (0 where the detector gives no orientation). Row order is random.
        true_index: ``(N,)`` row of robot i in ``detections``, or -1 if it was not detected.
            Ground truth: it reaches infos, never observations.
        time: time the picture was taken (s since reset).
        index: 0 for the first picture of an episode, then 1, 2, ...
        has_orientation: whether ``theta`` was measured.
        landmarks: ``(K, 3)`` rows ``(id, u, v)`` of the ground landmarks seen (``id`` indexes
            ``camera.landmarks``; image units as taken, before rectification), or ``None``
            without landmarks.
        homography: ``(3, 3)`` the ground-to-image homography the landmarks gave, through which
            ``detections`` were rectified into the set point's frame (see
            :mod:`anonloc_env.landmarks`), or ``None`` without landmarks.
        footprint: ``(4, 2)`` the field of view's corners in the frame of ``detections`` (the
            set point's, through ``homography``), round it, or ``None`` without landmarks:
            where a moving camera's picture covers the arena, as its landmarks tell.
    """

    detections: np.ndarray
    true_index: np.ndarray
    time: float
    index: int
    has_orientation: bool
    landmarks: np.ndarray | None = None
    homography: np.ndarray | None = None
    footprint: np.ndarray | None = None

    @property
    def n_rows(self) -> int:
        """Number of detections (robots seen plus false positives)."""
        return int(self.detections.shape[0])


class DetectionSource(Protocol):
    """Anything that turns the robots' true poses into a :class:`Picture` (the env's camera).

    The contract:

    * ``take(poses, rng, time, index)`` returns the picture of robots at ``poses`` ``(N, 3)``;
      every random draw comes from ``rng`` (the env's generator), so episodes replay;
    * ``capacity`` (optional attribute, int): the most rows a picture may hold. The env sizes the
      observations' ``(D, 3)`` arrays from it; without it, the env uses the capacity of its
      config (:func:`detection_capacity`). A picture with more rows is an error.

    Example, a detector that sees every robot exactly and nothing else::

        class Perfect:
            def __init__(self, camera):
                self.camera = camera
                self.capacity = camera.config.n_robots

            def take(self, poses, rng, time, index):
                rows = np.column_stack(
                    [self.camera.project(poses[:, :2]), self.camera.image_heading(poses)]
                )
                order = rng.permutation(len(poses))  # shuffled, as a real detector's output
                true_index = np.argsort(order)
                return Picture(rows[order], true_index, time, index, has_orientation=True)

        env = anonloc_env.parallel_env(detector=Perfect(anonloc_env.Camera(config)))
    """

    def take(
        self, poses: np.ndarray, rng: np.random.Generator, time: float, index: int
    ) -> Picture: ...


def detection_capacity(config: EnvConfig) -> int:
    """Rows a picture may hold: every robot plus the false positives of all but one picture in a
    million (unless ``observation.max_detections`` fixes it).

    The Poisson probabilities are summed in log space: ``exp(-mean)`` underflows for a mean
    above about 745 (the config allows up to 1000).
    """
    if config.observation.max_detections is not None:
        return config.observation.max_detections
    mean = config.camera.false_positives
    extra = 0
    if mean > 0.0:
        top = math.ceil(mean + 20.0 * math.sqrt(mean) + 30.0)  # the tail beyond is < 1e-20
        k = np.arange(top + 1)
        log_factorial = np.concatenate([[0.0], np.cumsum(np.log(k[1:]))])
        tail = 1.0 - np.cumsum(np.exp(k * math.log(mean) - mean - log_factorial))
        extra = int(np.argmax(tail <= 1e-6))
    return config.n_robots + extra


class Camera:
    """Pinhole camera above the arena plus a noisy, anonymous detector.

    Args:
        config: the task configuration (camera section, arena and robot count).
    """

    def __init__(self, config: EnvConfig) -> None:
        cam = config.camera
        self.config = config
        width, height = config.arena_size
        xc, yc = width / 2.0, height / 2.0
        s = cam.scale
        cu, cv = cam.principal_point if cam.principal_point is not None else (s * xc, s * yc)
        tilt = math.radians(cam.tilt_deg)
        center = np.array([[1.0, 0.0, -xc], [0.0, 1.0, -yc], [0.0, 0.0, 1.0]])
        perspective = np.array(
            [[s, 0.0, 0.0], [0.0, s * math.cos(tilt), 0.0], [0.0, math.sin(tilt) / cam.height, 1.0]]
        )
        principal = np.array([[1.0, 0.0, cu], [0.0, 1.0, cv], [0.0, 0.0, 1.0]])
        self.homography = principal @ perspective @ center
        """``(3, 3)`` map from ``(x, y, 1)`` on the ground to homogeneous image coordinates (of
        the newest picture's pose: see :meth:`move_to`)."""
        self.inverse = np.linalg.inv(self.homography)
        self.set_point = self.homography
        """``(3, 3)`` the homography of the camera at its set point (the fixed camera's)."""
        self.moved = False
        """Whether the camera is away from its set point (:meth:`move_to`)."""
        self.principal_point = (cu, cv)
        self.capacity = detection_capacity(config)
        self.field_of_view = self._field_of_view()
        """``(u_min, v_min, u_max, v_max)`` of the region where detections can appear."""

    def move_to(self, pose: np.ndarray | None) -> None:
        """Put the camera at ``pose`` ``(6,)`` ``(x, y, z, yaw, pitch, roll)`` (m, rad; see
        :mod:`anonloc_env.camera_motion`) for the pictures to come, or back at its set point
        (``None``). The field of view stays the image's own: as the camera moves, its footprint
        on the ground moves, and robots near the edge leave the picture."""
        if pose is None:
            self.homography, self.moved = self.set_point, False
        else:
            self.homography, self.moved = pose_homography(self.config, pose), True
        self.inverse = np.linalg.inv(self.homography)

    def footprint(self) -> np.ndarray:
        """``(4, 2)`` the ground points (m) at the corners of the field of view, as the camera
        stands now (the quadrilateral it sees)."""
        u_min, v_min, u_max, v_max = self.field_of_view
        corners = np.array([[u_min, v_min], [u_max, v_min], [u_max, v_max], [u_min, v_max]])
        return self.unproject(corners)

    def _field_of_view(self) -> tuple[float, float, float, float]:
        cam = self.config.camera
        if cam.image_size is not None:
            (cu, cv), (w, h) = self.principal_point, cam.image_size
            return (cu - w / 2.0, cv - h / 2.0, cu + w / 2.0, cv + h / 2.0)
        width, height = self.config.arena_size
        corners = self.project(np.array([[0.0, 0.0], [width, 0.0], [width, height], [0.0, height]]))
        lo, hi = corners.min(axis=0), corners.max(axis=0)
        return (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))

    def project(self, xy: np.ndarray) -> np.ndarray:
        """Image coordinates ``(M, 2)`` of ground points ``xy`` ``(M, 2)`` (no noise)."""
        g = self.homography
        x, y = xy[:, 0], xy[:, 1]
        w = g[2, 0] * x + g[2, 1] * y + g[2, 2]
        uv = np.empty((len(xy), 2))
        np.divide(g[0, 0] * x + g[0, 1] * y + g[0, 2], w, out=uv[:, 0])
        np.divide(g[1, 0] * x + g[1, 1] * y + g[1, 2], w, out=uv[:, 1])
        return uv

    def unproject(self, uv: np.ndarray) -> np.ndarray:
        """Ground points ``(M, 2)`` seen at image coordinates ``uv`` ``(M, 2)``."""
        h = np.column_stack([uv, np.ones(len(uv))]) @ self.inverse.T
        return h[:, :2] / h[:, 2:3]

    def jacobian(self, xy: np.ndarray) -> np.ndarray:
        """``(M, 2, 2)`` derivative of image coordinates with respect to ground coordinates."""
        g = self.homography
        w = g[2, 0] * xy[:, 0] + g[2, 1] * xy[:, 1] + g[2, 2]
        uv = self.project(xy)
        jac = g[None, :2, :2] - uv[:, :, None] * g[None, 2:3, :2]
        return jac / w[:, None, None]

    def local_scale(self, xy: np.ndarray) -> np.ndarray:
        """Image units per metre at ground points ``xy`` (square root of the Jacobian's area)."""
        return np.sqrt(np.abs(np.linalg.det(self.jacobian(xy))))

    def image_heading(self, poses: np.ndarray) -> np.ndarray:
        """Detected heading (rad, in [-pi, pi)) of robots at ``poses`` ``(M, 3)`` (no noise)."""
        if self.config.camera.tilt_deg == 0.0 and not self.moved:
            return wrap_angle(poses[:, 2])
        jac = self.jacobian(poses[:, :2])
        heading = np.column_stack([np.cos(poses[:, 2]), np.sin(poses[:, 2])])
        image_dir = np.einsum("mij,mj->mi", jac, heading)
        return np.arctan2(image_dir[:, 1], image_dir[:, 0])

    def take(self, poses: np.ndarray, rng: np.random.Generator, time: float, index: int) -> Picture:
        """Photograph robots at ``poses`` ``(N, 3)``: project, add noise, drop misses and robots
        outside the field of view, add false positives, shuffle."""
        cam = self.config.camera
        n = len(poses)
        rows = np.empty((n, 3))  # (u, v, theta) of every robot, seen or not
        rows[:, :2] = self.project(poses[:, :2])
        u, v = rows[:, 0], rows[:, 1]
        u_min, v_min, u_max, v_max = self.field_of_view
        seen = (u >= u_min) & (u <= u_max) & (v >= v_min) & (v <= v_max)
        if cam.p_miss > 0.0:
            seen &= rng.random(n) >= cam.p_miss
        if cam.pixel_noise > 0.0:
            rows[:, :2] += rng.normal(0.0, cam.pixel_noise, (n, 2))
        if cam.orientation:
            rows[:, 2] = self.image_heading(poses)
            if cam.orientation_noise_deg > 0.0:
                rows[:, 2] += rng.normal(0.0, math.radians(cam.orientation_noise_deg), n)
        else:
            rows[:, 2] = 0.0
        true_rows = rows[seen]
        n_true = len(true_rows)
        n_false = 0
        if cam.false_positives > 0.0:
            n_false = min(int(rng.poisson(cam.false_positives)), self.capacity - n_true)
        if n_false > 0:
            false_rows = np.empty((n_false, 3))
            false_rows[:, 0] = rng.uniform(u_min, u_max, n_false)
            false_rows[:, 1] = rng.uniform(v_min, v_max, n_false)
            false_rows[:, 2] = rng.uniform(-math.pi, math.pi, n_false) if cam.orientation else 0.0
            rows = np.concatenate([true_rows, false_rows])
        else:
            rows = true_rows
        order = rng.permutation(len(rows))
        detections = rows[order]
        if cam.orientation:
            detections[:, 2] = wrap_angle(detections[:, 2])
        # Row of each robot after the shuffle: invert the permutation for the first rows.
        row_of = np.empty(len(rows), dtype=np.int64)
        row_of[order] = np.arange(len(rows))
        true_index = np.full(n, -1, dtype=np.int64)
        true_index[seen] = row_of[:n_true]
        picture = Picture(
            detections=detections,
            true_index=true_index,
            time=time,
            index=index,
            has_orientation=cam.orientation,
        )
        return self.register(picture, rng) if cam.landmarks else picture

    def register(self, picture: Picture, rng: np.random.Generator) -> Picture:
        """``picture`` rectified into the set point's frame by the ground landmarks this camera
        sees now (noise and misses drawn from ``rng``; see :mod:`anonloc_env.landmarks`)."""
        ids, uv = landmark_rows(self.config, self.project, self.field_of_view, rng)
        return rectified(self.config, picture, ids, uv, self.set_point)


def rectified(
    config: EnvConfig,
    picture: Picture,
    ids: np.ndarray,
    uv: np.ndarray,
    set_point: np.ndarray,
    estimated: np.ndarray | None = None,
) -> Picture:
    """``picture`` with its rows mapped into the set point's frame through the homography
    ``estimated`` or, if ``None``, the camera's pose the landmarks ``ids`` seen at ``uv`` give
    (``landmarks.fit_pose``; the set point if none is seen)."""
    if estimated is None:
        estimated = fit_pose(config, ids, uv)
    rows = rectify(picture.detections, estimated, set_point)
    rows[:, 2] = wrap_angle(rows[:, 2]) if picture.has_orientation else 0.0
    u_min, v_min, u_max, v_max = survey(config).field_of_view
    corners = np.array([[u_min, v_min, 0.0], [u_max, v_min, 0.0], [u_max, v_max, 0.0]])
    corners = np.concatenate([corners, [[u_min, v_max, 0.0]]])
    return dataclasses.replace(
        picture,
        detections=rows,
        landmarks=np.column_stack([ids, uv]) if len(ids) else np.zeros((0, 3)),
        homography=estimated,
        footprint=rectify(corners, estimated, set_point)[:, :2],
    )


@dataclass(frozen=True)
class CameraSurvey:
    """What a robot knows of the camera from its specs: the local scale (image units per metre)
    over the arena, sampled on a grid, and the field of view.

    Attributes:
        scale: the mean local scale (what the paper did with its 20.8 to 22.07 range).
        scale_spread: its standard deviation over the grid relative to the mean (0 for a camera
            looking straight down).
        scale_gradient: the largest relative change of the local scale per metre (1/m; 0 for a
            camera looking straight down), from finite differences at the grid points.
        field_of_view: ``(u_min, v_min, u_max, v_max)`` where detections can appear.
    """

    scale: float
    scale_spread: float
    scale_gradient: float
    field_of_view: tuple[float, float, float, float]


#: Points per side of the grid :func:`survey` samples the local scale on.
SURVEY_POINTS = 9


@functools.lru_cache(maxsize=64)
def survey(config: EnvConfig) -> CameraSurvey:
    """Survey ``config``'s camera over its arena (once per config: cached)."""
    camera = Camera(config)
    width, height = config.arena_size
    axes = (np.linspace(0, width, SURVEY_POINTS), np.linspace(0, height, SURVEY_POINTS))
    grid = np.stack(np.meshgrid(*axes), axis=-1).reshape(-1, 2)
    local = camera.local_scale(grid)
    mean = float(local.mean())
    step = 1e-3 * max(width, height)
    along_x = camera.local_scale(grid + np.array([step, 0.0])) - local
    along_y = camera.local_scale(grid + np.array([0.0, step])) - local
    return CameraSurvey(
        scale=mean,
        scale_spread=float(local.std() / mean),
        scale_gradient=float(np.max(np.hypot(along_x, along_y) / (local * step))),
        field_of_view=camera.field_of_view,
    )
