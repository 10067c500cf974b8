"""The marker every robot carries, and where it sits on the robot.

Every robot wears the same ArUco marker (``DICT_4X4_50``, id 0): the robots stay anonymous by
construction. On top of the robot's dark body lies a white square (the marker's quiet zone) and
inside it the marker, 6 cells wide (4 x 4 data bits and a one-cell black border). Counted in
marker cells, the square drawn on the robot is ``TEMPLATE_CELLS = 10`` cells wide: one cell of
dark body, one of white, six of marker, one of white, one of dark body. It fills the square
robot, or the square inscribed in the circular one.

The marker's top edge (its first two corners, in the order ArUco returns them) faces the
robot's heading, so the heading is read from the corner order.

Ground landmarks (``camera.landmarks``) are the same square lying on the floor, with marker id
``k + 1`` for the k-th landmark, its top edge facing +y (:func:`landmark_corners`).
"""

from __future__ import annotations

import numpy as np

from anonloc_env.config import MARKER_TEMPLATE_CELLS, RobotConfig
from anonloc_env.images._cv import import_cv2

DICTIONARY = "DICT_4X4_50"
"""The ArUco dictionary (a ``cv2.aruco`` constant name)."""
MARKER_ID = 0
"""The one id every robot wears."""
MARKER_CELLS = 6
"""Cells across the marker, border included."""
TEMPLATE_CELLS = MARKER_TEMPLATE_CELLS
"""Cells across the square drawn on a robot: body, quiet zone, marker, quiet zone, body (the
config's, which bounds ``camera.image_pixels_per_unit`` with it)."""

FLOOR = 150
"""Grey level of the arena floor."""
BODY = 45
"""Grey level of a robot's body."""
WHITE = 235
"""Grey level of the quiet zone and of the marker's white cells."""
BLACK = 20
"""Grey level of the marker's black cells."""


def cell_size(robot: RobotConfig) -> float:
    """Side of one marker cell on the robot (m): ``RobotConfig.marker_cell``."""
    return robot.marker_cell


def marker_size(robot: RobotConfig) -> float:
    """Side of the marker itself, black border included (m)."""
    return MARKER_CELLS * cell_size(robot)


def template(
    pixels_per_cell: int, smoothing: float = 0.0, marker_id: int = MARKER_ID
) -> np.ndarray:
    """The square drawn on a robot, ``TEMPLATE_CELLS * pixels_per_cell`` pixels wide, uint8
    (or, with another ``marker_id``, on a ground landmark: the same square with that id).

    Row 0 is the robot's front. ``smoothing`` is the standard deviation (template pixels) of the
    Gaussian applied before the template is shrunk onto the image, which keeps its edges from
    aliasing; it is capped at the template's side (a wider blur leaves it uniform grey anyway,
    and an unbounded one made OpenCV build a kernel without end).
    """
    cv2 = import_cv2()
    dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, DICTIONARY))
    marker = cv2.aruco.generateImageMarker(dictionary, marker_id, MARKER_CELLS * pixels_per_cell)
    side = TEMPLATE_CELLS * pixels_per_cell
    out = np.full((side, side), BODY, np.uint8)
    out[pixels_per_cell:-pixels_per_cell, pixels_per_cell:-pixels_per_cell] = WHITE
    lo = 2 * pixels_per_cell
    out[lo : lo + marker.shape[0], lo : lo + marker.shape[1]] = np.where(marker > 127, WHITE, BLACK)
    if smoothing > 0.0:
        sigma = min(smoothing, float(side))
        out = cv2.GaussianBlur(out, (0, 0), sigma, borderType=cv2.BORDER_REPLICATE)
    return out


def landmark_corners(robot: RobotConfig, position: tuple[float, float]) -> np.ndarray:
    """``(4, 2)`` ground points (m) of a landmark's marker corners, in ArUco's order (top-left,
    top-right, bottom-right, bottom-left): the marker lies at ``position`` facing +y."""
    half = 0.5 * marker_size(robot)
    x, y = position
    return np.array(
        [[x - half, y + half], [x + half, y + half], [x + half, y - half], [x - half, y - half]]
    )
