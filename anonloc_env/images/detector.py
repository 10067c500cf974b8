"""Find the robots' markers in an image: OpenCV's ``ArucoDetector``, rows in image units.

A detection's position is the intersection of the marker's diagonals (the projective image of
its centre, exact under perspective, where the corners' mean is not); its heading is the
direction of the marker's two side edges, from the bottom corners to the top ones, which the
corner order fixes. Pixel coordinates go back to image units through the
:class:`~anonloc_env.images.frame.PixelFrame` (rows down become ``v`` up).

Corner refinement: ``CORNER_REFINE_SUBPIX`` with a window of about half a marker cell (see
``docs/images.md`` for the measurements behind the choice). A marker cut by the image border or
partly hidden by another robot fails ArUco's border and bit checks and is missed, not misplaced.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from anonloc_env.images._cv import import_cv2
from anonloc_env.images.frame import PixelFrame
from anonloc_env.images.marker import DICTIONARY, MARKER_CELLS, MARKER_ID

REFINEMENTS = ("none", "subpix", "contour", "apriltag")


class MarkerDetector:
    """Detects the one marker id every robot wears.

    Args:
        frame: the image's pixel grid (to convert pixels to image units).
        cell_pixels: expected pixels per marker cell (sizes the refinement window and the
            smallest marker searched for), > 0.
        refinement: ``"subpix"`` (default), ``"contour"``, ``"apriltag"`` or ``"none"``.
        window: half-size of the sub-pixel refinement window (pixels); ``None``: about half a
            marker cell, at least 2.
    """

    def __init__(
        self,
        frame: PixelFrame,
        cell_pixels: float,
        refinement: str = "subpix",
        window: int | None = None,
    ) -> None:
        if refinement not in REFINEMENTS:
            raise ValueError(f"refinement must be one of {list(REFINEMENTS)}, got {refinement!r}")
        if not cell_pixels > 0.0:
            raise ValueError(f"cell_pixels must be in (0, inf), got {cell_pixels!r}")
        cv2 = import_cv2()
        self.frame = frame
        params = cv2.aruco.DetectorParameters()
        params.cornerRefinementMethod = getattr(cv2.aruco, f"CORNER_REFINE_{refinement.upper()}")
        win = window if window is not None else max(2, round(0.5 * cell_pixels))
        params.cornerRefinementWinSize = int(win)
        if hasattr(params, "relativeCornerRefinmentWinSize"):  # OpenCV >= 4.9 (sic)
            params.relativeCornerRefinmentWinSize = 1.0  # let cornerRefinementWinSize decide
        # Look for markers down to a third of the expected perimeter (tilt, the far side).
        perimeter = 4.0 * MARKER_CELLS * cell_pixels
        params.minMarkerPerimeterRate = min(0.03, perimeter / 3.0 / max(frame.shape))
        self.params = params
        self._detector: Any = cv2.aruco.ArucoDetector(
            cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, DICTIONARY)), params
        )

    def markers(self, image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Every marker found in ``image``: ``(K,)`` ids and ``(K, 4, 2)`` pixel corners
        ``(col, row)`` in ArUco's order (the marker's top-left, top-right, bottom-right,
        bottom-left)."""
        found, ids, _ = self._detector.detectMarkers(image)
        if ids is None or len(found) == 0:
            return np.zeros(0, np.int64), np.empty((0, 4, 2))
        return (
            np.asarray(ids, dtype=np.int64).reshape(-1),
            np.asarray(found, dtype=np.float64).reshape(-1, 4, 2),
        )

    def corners(self, image: np.ndarray) -> np.ndarray:
        """``(K, 4, 2)`` pixel corners of the robots' markers (id 0) found in ``image``."""
        ids, corners = self.markers(image)
        return corners[ids == MARKER_ID]

    def detect(self, image: np.ndarray) -> np.ndarray:
        """``(K, 3)`` rows ``(u, v, theta)`` (image units, rad in [-pi, pi)) of the markers in
        ``image`` (a 2-D uint8 array)."""
        return corners_to_rows(self.corners(image), self.frame)


def corners_to_rows(corners: np.ndarray, frame: PixelFrame) -> np.ndarray:
    """``(K, 3)`` rows ``(u, v, theta)`` of markers with pixel corners ``(K, 4, 2)``."""
    if len(corners) == 0:
        return np.empty((0, 3))
    p0, p1, p2, p3 = (corners[:, i] for i in range(4))
    # Diagonals p0 + s (p2 - p0) and p1 + t (p3 - p1) meet where s solves a 2-D cross product.
    d1, d2, r = p2 - p0, p3 - p1, p1 - p0
    denom = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    s = (r[:, 0] * d2[:, 1] - r[:, 1] * d2[:, 0]) / denom
    centre = p0 + s[:, None] * d1
    up = (p0 - p3) + (p1 - p2)  # pixels, rows down
    rows = np.empty((len(corners), 3))
    rows[:, :2] = frame.to_units(centre)
    theta = np.arctan2(-up[:, 1], up[:, 0])  # v = -row
    rows[:, 2] = (theta + np.pi) % (2.0 * np.pi) - np.pi
    return rows
