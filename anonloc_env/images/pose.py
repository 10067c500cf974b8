"""The camera's pose from what the image shows: homographies fitted with OpenCV.

:func:`estimate_homography` fits a ground-to-image homography to matched points
(``cv2.findHomography``, least squares); :func:`landmark_pose` fits one to the corners of the
ground landmarks found in a picture (``camera.landmarks``, ArUco ids 1, 2, ...; see
:mod:`anonloc_env.landmarks`). The image source rectifies every picture through it; the
calibration tool (:mod:`anonloc_env.images.calibration`) fits robots' known paths with it.
"""

from __future__ import annotations

import numpy as np

from anonloc_env.config import EnvConfig
from anonloc_env.images._cv import import_cv2
from anonloc_env.images.frame import PixelFrame
from anonloc_env.images.marker import landmark_corners


def estimate_homography(world_xy: np.ndarray, image_uv: np.ndarray) -> np.ndarray:
    """The ``(3, 3)`` homography from ground points ``(M, 2)`` (m) to their image points
    ``(M, 2)`` (image units), least squares, M >= 4."""
    if len(world_xy) < 4 or len(world_xy) != len(image_uv):
        raise ValueError(
            f"need at least 4 matching points, got {len(world_xy)} and {len(image_uv)}"
        )
    if not (np.isfinite(world_xy).all() and np.isfinite(image_uv).all()):
        raise ValueError("the points must be finite numbers (a NaN or inf gives a NaN homography)")
    cv2 = import_cv2()
    h, _ = cv2.findHomography(
        np.asarray(world_xy, np.float64).reshape(-1, 1, 2),
        np.asarray(image_uv, np.float64).reshape(-1, 1, 2),
        0,
    )
    if h is None:
        raise ValueError("the points are degenerate (collinear?): no homography fits them")
    return np.asarray(h, dtype=np.float64)


def landmark_pose(
    config: EnvConfig, frame: PixelFrame, ids: np.ndarray, corners: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """The landmarks among markers ``ids`` ``(K,)`` with pixel corners ``(K, 4, 2)``.

    Returns:
        ``(found, centres, homography)``: ``(L,)`` indices into ``camera.landmarks`` of the
        landmarks found, ``(L, 2)`` their centres (image units), and the ground-to-image
        homography their ``4 L`` corners give (``None`` with fewer than two landmarks: one
        marker's corners are too close together to fix a homography).
    """
    count = len(config.camera.landmarks)
    keep = (ids >= 1) & (ids <= count)
    found = ids[keep] - 1
    _, unique = np.unique(found, return_index=True)  # a landmark found twice: keep the first
    found, image = found[unique], corners[keep][unique]
    pixels = image.reshape(-1, 2)
    units = frame.to_units(pixels).reshape(-1, 4, 2)
    centres = units.mean(axis=1)
    if len(found) < 2:
        return found, centres, None
    world = np.concatenate(
        [landmark_corners(config.robot, config.camera.landmarks[k]) for k in found.tolist()]
    )
    return found, centres, estimate_homography(world, units.reshape(-1, 2))
