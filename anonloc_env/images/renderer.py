"""Render what the overhead camera sees: a grayscale image of the arena and its marked robots.

Each robot is drawn by warping one small marker template into its bounding box
(``cv2.warpPerspective`` on the box alone, so the cost grows with the robots' area, not the
arena's), through the same homography as the geometric camera. Robots are drawn in index order:
where two overlap, the later one hides the earlier. Optional effects, in the order a camera
applies them: Gaussian blur (optics), an illumination gradient, Gaussian sensor noise. The only
randomness is the sensor noise, drawn from the generator passed in.
"""

from __future__ import annotations

import math

import numpy as np

from anonloc_env.camera import Camera
from anonloc_env.config import EnvConfig
from anonloc_env.images._cv import import_cv2
from anonloc_env.images.frame import PixelFrame, marker_cell_pixels, pixel_frame
from anonloc_env.images.marker import BODY, FLOOR, TEMPLATE_CELLS, cell_size, template

_TEMPLATE_CELL_PIXELS = 16  # template resolution: 16 pixels per marker cell
_CIRCLE_SIDES = 32  # polygon approximating a circular robot's outline


class ImageRenderer:
    """Draws the robots of one config as the camera sees them.

    Args:
        config: the task configuration (camera, robots, arena).
        camera: the geometric camera whose homography the image follows (built if ``None``).
    """

    def __init__(self, config: EnvConfig, camera: Camera | None = None) -> None:
        self.cv2 = import_cv2()
        self.config = config
        self.camera = camera if camera is not None else Camera(config)
        self.frame: PixelFrame = pixel_frame(config, self.camera)
        cam, robot = config.camera, config.robot
        cell = cell_size(robot)
        cell_pixels = marker_cell_pixels(config)
        shrink = _TEMPLATE_CELL_PIXELS / cell_pixels  # template pixels per image pixel
        self.cell_pixels = cell_pixels
        """Pixels per marker cell at the arena centre."""
        self._smoothing = 0.5 * shrink if shrink > 1.0 else 0.0
        self.template = template(_TEMPLATE_CELL_PIXELS, self._smoothing)
        self._landmarks: dict[int, np.ndarray] = {}
        # Template pixel (col, row) -> robot frame (forward, left) in metres: row 0 is the front.
        metres = cell / _TEMPLATE_CELL_PIXELS
        centre = (TEMPLATE_CELLS * _TEMPLATE_CELL_PIXELS - 1) / 2.0
        self._template_to_robot = np.array(
            [[0.0, -metres, metres * centre], [-metres, 0.0, metres * centre], [0.0, 0.0, 1.0]]
        )
        self._background = np.full(self.frame.shape, FLOOR, np.uint8)
        self._gradient: np.ndarray | None = None
        if cam.image_gradient > 0.0:
            rows, cols = self.frame.shape
            ramp = (np.arange(cols)[None, :] / max(cols - 1, 1)) + (
                np.arange(rows)[:, None] / max(rows - 1, 1)
            )
            self._gradient = (1.0 - 0.5 * cam.image_gradient * ramp).astype(np.float32)
        angles = np.linspace(0.0, 2.0 * math.pi, _CIRCLE_SIDES, endpoint=False)
        self._outline = (
            0.5 * robot.size * np.column_stack([np.cos(angles), np.sin(angles)])
            if robot.shape == "circle"
            else None
        )
        half = 0.5 * robot.size
        self._box = np.array([[half, half], [-half, half], [-half, -half], [half, -half]])

    def render(self, poses: np.ndarray, rng: np.random.Generator | None = None) -> np.ndarray:
        """The camera's image of robots at ``poses`` ``(N, 3)`` (m, rad): ``(H, W)`` uint8.

        The ground landmarks (``camera.landmarks``) are drawn first, under the robots. ``rng``
        draws the sensor noise (needed only if ``camera.image_noise > 0``).
        """
        cv2 = self.cv2
        cam = self.config.camera
        image = self._background.copy()
        m = self.frame.matrix @ self.camera.homography  # the pose of this picture
        for k, (x, y) in enumerate(cam.landmarks):
            self._draw(image, m, (x, y, 0.5 * math.pi), self._landmark_template(k), None)
        for pose in np.asarray(poses, dtype=np.float64):
            self._draw(image, m, pose, self.template, self._outline)
        if cam.image_blur == 0.0 and cam.image_noise == 0.0 and self._gradient is None:
            return image
        out = image.astype(np.float32)
        if cam.image_blur > 0.0:
            out = cv2.GaussianBlur(out, (0, 0), cam.image_blur, borderType=cv2.BORDER_REPLICATE)
        if self._gradient is not None:
            out *= self._gradient
        if cam.image_noise > 0.0:
            if rng is None:
                raise ValueError("camera.image_noise > 0 needs a random generator (rng)")
            out += cam.image_noise * rng.standard_normal(out.shape, dtype=np.float32)
        return np.clip(np.rint(out), 0, 255).astype(np.uint8)

    def _landmark_template(self, k: int) -> np.ndarray:
        """The template of landmark ``k`` (marker id ``k + 1``), built once."""
        if k not in self._landmarks:
            self._landmarks[k] = template(_TEMPLATE_CELL_PIXELS, self._smoothing, marker_id=k + 1)
        return self._landmarks[k]

    def _draw(
        self,
        image: np.ndarray,
        world_to_pixels: np.ndarray,
        pose: tuple[float, float, float] | np.ndarray,
        square: np.ndarray,
        outline: np.ndarray | None,
    ) -> None:
        """Draw ``square`` (a template) at ``pose`` ``(x, y, theta)`` into ``image``, in place:
        a warp of the template into the pose's bounding box only."""
        cv2 = self.cv2
        rows, cols = image.shape
        x, y, theta = (float(value) for value in pose)
        c, s = math.cos(theta), math.sin(theta)
        robot_to_pixels = world_to_pixels @ np.array([[c, -s, x], [s, c, y], [0.0, 0.0, 1.0]])
        box = _apply(robot_to_pixels, self._box)
        c0, r0 = np.floor(box.min(axis=0)).astype(int) - 1
        c1, r1 = np.ceil(box.max(axis=0)).astype(int) + 2
        c0, r0, c1, r1 = max(c0, 0), max(r0, 0), min(c1, cols), min(r1, rows)
        if c0 >= c1 or r0 >= r1:
            return  # entirely outside the image
        shift = np.array([[1.0, 0.0, -c0], [0.0, 1.0, -r0], [0.0, 0.0, 1.0]])
        roi = image[r0:r1, c0:c1].copy()
        if outline is not None:
            points = _apply(shift @ robot_to_pixels, outline)
            cv2.fillConvexPoly(roi, np.round(points * 16).astype(np.int32), BODY, cv2.LINE_AA, 4)
        cv2.warpPerspective(
            square,
            shift @ robot_to_pixels @ self._template_to_robot,
            (c1 - c0, r1 - r0),
            dst=roi,
            flags=cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_TRANSPARENT,
        )
        image[r0:r1, c0:c1] = roi


def _apply(h: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Points ``xy`` ``(M, 2)`` through the homography ``h``."""
    p = xy @ h[:2, :2].T + h[:2, 2]
    w = xy @ h[2, :2] + h[2, 2]
    return p / w[:, None]
