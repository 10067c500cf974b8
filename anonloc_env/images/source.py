"""The image path behind the :class:`~anonloc_env.camera.DetectionSource` interface.

:class:`ImageCamera` renders the arena (:class:`~anonloc_env.images.renderer.ImageRenderer`),
detects the markers (:class:`~anonloc_env.images.detector.MarkerDetector`) and returns the rows as
a :class:`~anonloc_env.camera.Picture`, shuffled; with ground landmarks, rectified into the set
point's frame through the homography their corners give
(:func:`~anonloc_env.images.pose.landmark_pose`). Robots whose marker is cut by the image
border, hidden by another robot or not decoded are missing; a detection that lies near no robot is a
false positive. The ground truth ``true_index`` matches each robot to the detection nearest its
projected centre, within a quarter of a marker.
"""

from __future__ import annotations

import numpy as np

from anonloc_env.camera import Camera, Picture, rectified
from anonloc_env.config import EnvConfig
from anonloc_env.images.detector import MarkerDetector, corners_to_rows
from anonloc_env.images.marker import MARKER_ID, marker_size
from anonloc_env.images.pose import landmark_pose
from anonloc_env.images.renderer import ImageRenderer


class ImageCamera:
    """A camera that photographs the marked robots and detects them with OpenCV.

    Args:
        config: the task configuration; ``camera.source`` need not be ``"image"``.
        camera: the geometric camera whose homography, field of view and row capacity it shares
            (built if ``None``).
    """

    def __init__(self, config: EnvConfig, camera: Camera | None = None) -> None:
        self.config = config
        self.camera = camera if camera is not None else Camera(config)
        self.renderer = ImageRenderer(config, self.camera)
        self.frame = self.renderer.frame
        self.detector = MarkerDetector(self.frame, self.renderer.cell_pixels)
        self.gate = 0.25 * marker_size(config.robot) * config.camera.scale
        """Largest distance (image units) between a robot and the detection matched to it."""
        self.last_image: np.ndarray | None = None
        """The newest rendered image (``(H, W)`` uint8), or ``None`` before the first picture."""

    def marker_pixels(self, poses: np.ndarray) -> np.ndarray:
        """``(N,)`` side (pixels) of the marker of robots at ``poses`` in the image."""
        local = self.camera.local_scale(np.asarray(poses)[:, :2])
        return local * marker_size(self.config.robot) * self.frame.pixels_per_unit

    def take(self, poses: np.ndarray, rng: np.random.Generator, time: float, index: int) -> Picture:
        """Photograph robots at ``poses`` ``(N, 3)``: render, detect, match, shuffle."""
        image = self.renderer.render(poses, rng)
        self.last_image = image
        ids, corners = self.detector.markers(image)
        rows = corners_to_rows(corners[ids == MARKER_ID], self.frame)
        robot_row = match(self.camera.project(np.asarray(poses)[:, :2]), rows, self.gate)
        capacity = self.camera.capacity
        if len(rows) > capacity:  # keep every true detection, drop extra false ones
            matched = np.zeros(len(rows), bool)
            matched[robot_row[robot_row >= 0]] = True
            keep = np.concatenate([np.flatnonzero(matched), np.flatnonzero(~matched)])[:capacity]
            new_index = np.full(len(rows), -1, np.int64)
            new_index[keep] = np.arange(len(keep))
            rows = rows[keep]
            robot_row = _reindex(robot_row, new_index)
        order = rng.permutation(len(rows))
        detections = rows[order]
        if not self.config.camera.orientation:
            detections[:, 2] = 0.0
        row_of = np.empty(len(rows), dtype=np.int64)
        row_of[order] = np.arange(len(rows))
        picture = Picture(
            detections=detections,
            true_index=_reindex(robot_row, row_of),
            time=time,
            index=index,
            has_orientation=self.config.camera.orientation,
        )
        if not self.config.camera.landmarks:
            return picture
        found, centres, estimated = landmark_pose(self.config, self.frame, ids, corners)
        return rectified(self.config, picture, found, centres, self.camera.set_point, estimated)


def _reindex(robot_row: np.ndarray, new_row: np.ndarray) -> np.ndarray:
    """``new_row[robot_row]`` where ``robot_row >= 0``, else -1."""
    out = np.full(len(robot_row), -1, np.int64)
    seen = robot_row >= 0
    out[seen] = new_row[robot_row[seen]]
    return out


def match(truth: np.ndarray, rows: np.ndarray, gate: float) -> np.ndarray:
    """``(N,)`` row of ``rows`` ``(K, >=2)`` matched to each true point ``truth`` ``(N, 2)``, or -1.

    Pairs are taken nearest first, each row and each point at most once, up to ``gate``.
    """
    n = len(truth)
    out = np.full(n, -1, np.int64)
    if n == 0 or len(rows) == 0:
        return out
    dist = np.hypot(
        truth[:, None, 0] - rows[None, :, 0], truth[:, None, 1] - rows[None, :, 1]
    )  # (N, K)
    robots, found = np.nonzero(dist <= gate)
    order = np.argsort(dist[robots, found], kind="stable")
    used = np.zeros(len(rows), bool)
    for i, k in zip(robots[order].tolist(), found[order].tolist(), strict=True):
        if out[i] < 0 and not used[k]:
            out[i] = k
            used[k] = True
    return out
