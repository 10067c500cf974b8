"""Small planar helpers shared by the camera, the likelihood model and the localizers."""

from __future__ import annotations

import math

import numpy as np


def wrap_angle(angle: np.ndarray | float) -> np.ndarray:
    """Wrap angles (rad) to [-pi, pi)."""
    return np.mod(np.asarray(angle, dtype=np.float64) + math.pi, 2.0 * math.pi) - math.pi


def rotate(vectors: np.ndarray, angle: np.ndarray | float) -> np.ndarray:
    """Rotate 2-D ``vectors`` ``(..., 2)`` counter-clockwise by ``angle`` (rad, broadcast)."""
    c, s = np.cos(angle), np.sin(angle)
    x, y = vectors[..., 0], vectors[..., 1]
    return np.stack([c * x - s * y, s * x + c * y], axis=-1)
