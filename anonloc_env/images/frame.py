"""How image units become pixels: the rendered image's resolution, extent and row flip.

The camera model (:class:`anonloc_env.camera.Camera`) maps the ground to *image units*, in a
right-handed frame with ``v`` up. The rendered image is an array whose rows go *down*, at
``pixels_per_unit`` pixels per image unit. Pixel ``(col, row)`` (its centre, OpenCV's
convention) sits at

``u = u_min + (col + 0.5) / pixels_per_unit``, ``v = v_max - (row + 0.5) / pixels_per_unit``,

so the image's top-left corner is ``(u_min, v_max)``. The flip is here and nowhere else.

The paper's camera saw about 21 image units per metre, so its 0.3 m robots were 6.4 units wide:
far too few pixels for a marker at one pixel per unit. Rather than change the units the localizers
work in, the image is rendered at ``pixels_per_unit`` (``camera.image_pixels_per_unit``, by default
chosen so that a marker cell spans :data:`AUTO_CELL_PIXELS` pixels) and detections are converted
back to image units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from anonloc_env.camera import Camera
from anonloc_env.config import EnvConfig
from anonloc_env.images.marker import cell_size

AUTO_CELL_PIXELS = 5.0
"""Pixels per marker cell when ``camera.image_pixels_per_unit`` is ``None``."""
MAX_PIXELS = 50_000_000
"""Largest image the source renders (pixels)."""


@dataclass(frozen=True)
class PixelFrame:
    """The rendered image's grid in image units.

    Attributes:
        pixels_per_unit: pixels per image unit, > 0.
        u_min: ``u`` of the image's left edge (image units).
        v_max: ``v`` of the image's top edge (image units).
        width: image width (pixels).
        height: image height (pixels).
    """

    pixels_per_unit: float
    u_min: float
    v_max: float
    width: int
    height: int

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)`` of the image array."""
        return (self.height, self.width)

    @property
    def matrix(self) -> np.ndarray:
        """``(3, 3)`` map from homogeneous image units to homogeneous pixels ``(col, row, 1)``."""
        p = self.pixels_per_unit
        return np.array(
            [[p, 0.0, -self.u_min * p - 0.5], [0.0, -p, self.v_max * p - 0.5], [0.0, 0.0, 1.0]]
        )

    def to_pixels(self, uv: np.ndarray) -> np.ndarray:
        """Pixel coordinates ``(M, 2)`` ``(col, row)`` of image points ``uv`` ``(M, 2)``."""
        p = self.pixels_per_unit
        out = np.empty_like(uv, dtype=np.float64)
        out[:, 0] = (uv[:, 0] - self.u_min) * p - 0.5
        out[:, 1] = (self.v_max - uv[:, 1]) * p - 0.5
        return out

    def to_units(self, pixels: np.ndarray) -> np.ndarray:
        """Image points ``(M, 2)`` ``(u, v)`` of pixel coordinates ``(M, 2)`` ``(col, row)``."""
        p = self.pixels_per_unit
        out = np.empty_like(pixels, dtype=np.float64)
        out[:, 0] = self.u_min + (pixels[:, 0] + 0.5) / p
        out[:, 1] = self.v_max - (pixels[:, 1] + 0.5) / p
        return out


def pixels_per_unit(config: EnvConfig) -> float:
    """``camera.image_pixels_per_unit``, or the one that gives a marker cell
    :data:`AUTO_CELL_PIXELS` pixels at the arena centre."""
    cam = config.camera
    if cam.image_pixels_per_unit is not None:
        return cam.image_pixels_per_unit
    return AUTO_CELL_PIXELS / (cell_size(config.robot) * cam.scale)


def pixel_frame(config: EnvConfig, camera: Camera | None = None) -> PixelFrame:
    """The image grid of ``config``'s camera.

    With ``camera.image_size`` set the image is exactly that field of view (a robot near its edge
    is cut, and missed). Without it the image is the arena's projection plus half a robot on
    every side, so that a robot at a wall keeps its marker clear of the image border.

    Raises:
        ValueError: the image would exceed :data:`MAX_PIXELS`.
    """
    camera = camera if camera is not None else Camera(config)
    p = pixels_per_unit(config)
    u_min, v_min, u_max, v_max = camera.field_of_view
    if config.camera.image_size is None:
        margin = 0.5 * config.robot.size * config.camera.scale
        u_min, v_min, u_max, v_max = u_min - margin, v_min - margin, u_max + margin, v_max + margin
    width = max(1, math.ceil((u_max - u_min) * p))
    height = max(1, math.ceil((v_max - v_min) * p))
    if width * height > MAX_PIXELS:
        raise ValueError(
            f"camera.image_pixels_per_unit={p:.4g} gives a {width} x {height} image, more than "
            f"{MAX_PIXELS} pixels; choose a value in (0, "
            f"{p * math.sqrt(MAX_PIXELS / (width * height)):.4g}]"
        )
    return PixelFrame(p, u_min, v_max, width, height)


def marker_cell_pixels(config: EnvConfig) -> float:
    """Pixels per marker cell at the arena centre."""
    return cell_size(config.robot) * config.camera.scale * pixels_per_unit(config)
