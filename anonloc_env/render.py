"""Drawing with pygame-ce (an optional extra, imported only when rendering is asked for).

The arena is drawn in world coordinates (y up). Robots are drawn with their heading; the newest
picture's detections are mapped back to the ground through the camera and drawn as crosses; a
robot's guess, when set, is a line from the robot to the detection it believes is itself, green
when right and red when wrong. With the image source (``camera.source = "image"``) the camera's
newest grayscale image is shown in the top-right corner (picture-in-picture).
"""

from __future__ import annotations

import colorsys
import math
from typing import Any

import numpy as np

from anonloc_env.camera import Camera, Picture
from anonloc_env.config import EnvConfig

_WINDOW = 640  # pixels along the arena's longer side
_MARGIN = 20
_INSET = 0.3  # side of the picture-in-picture, as a fraction of the window's width


def _import_pygame() -> Any:
    try:
        import pygame
    except ImportError as error:  # pragma: no cover - depends on the installed extras
        raise ImportError(
            "rendering needs pygame-ce: pip install 'anonloc[render]' (or pip install pygame-ce)"
        ) from error
    return pygame


class Renderer:
    """Draws frames of one env.

    Args:
        config: the task configuration.
        camera: the env's camera (to map detections back to the ground).
        mode: ``"human"`` (a window) or ``"rgb_array"`` (returns ``(H, W, 3)`` uint8 frames).
    """

    def __init__(self, config: EnvConfig, camera: Camera, mode: str) -> None:
        self.pygame = _import_pygame()
        self.config = config
        self.camera = camera
        self.mode = mode
        width, height = config.arena_size
        self.pixels_per_metre = (_WINDOW - 2 * _MARGIN) / max(width, height)
        self.size = (
            round(width * self.pixels_per_metre) + 2 * _MARGIN,
            round(height * self.pixels_per_metre) + 2 * _MARGIN + 24,
        )
        pg = self.pygame
        pg.init()
        if mode == "human":
            self.window = pg.display.set_mode(self.size)
            pg.display.set_caption("anonloc")
            self.clock = pg.time.Clock()
        self.surface = pg.Surface(self.size)
        self.font = pg.font.Font(None, 20)
        n = config.n_robots
        self.colors = [
            tuple(int(255 * c) for c in colorsys.hsv_to_rgb(i / max(n, 1), 0.65, 0.85))
            for i in range(n)
        ]

    def _to_screen(self, xy: np.ndarray) -> np.ndarray:
        height = self.config.arena_size[1]
        screen = np.empty_like(xy)
        screen[..., 0] = _MARGIN + xy[..., 0] * self.pixels_per_metre
        screen[..., 1] = _MARGIN + 24 + (height - xy[..., 1]) * self.pixels_per_metre
        return screen

    def draw(
        self,
        poses: np.ndarray,
        picture: Picture | None,
        guesses: dict[str, int | None],
        agents: list[str],
        time: float,
        image: np.ndarray | None = None,
    ) -> np.ndarray | None:
        """Draw one frame; return it for ``rgb_array``, show it for ``human``.

        ``image``, a grayscale ``(H, W)`` uint8 camera image, is drawn as a picture-in-picture.
        """
        pg, surface = self.pygame, self.surface
        surface.fill((250, 250, 250))
        width, height = self.config.arena_size
        corners = self._to_screen(
            np.array([[0.0, 0.0], [width, 0.0], [width, height], [0, height]])
        )
        pg.draw.polygon(surface, (40, 40, 40), corners.tolist(), 2)
        self._draw_robots(poses)
        if picture is not None and picture.n_rows > 0:
            ground = self.camera.unproject(picture.detections[:, :2])
            screen = self._to_screen(ground)
            for x, y in screen:
                pg.draw.line(surface, (90, 90, 90), (x - 4, y - 4), (x + 4, y + 4), 2)
                pg.draw.line(surface, (90, 90, 90), (x - 4, y + 4), (x + 4, y - 4), 2)
            self._draw_guesses(poses, picture, screen, guesses, agents)
        label = f"t = {time:7.2f} s   pictures: {0 if picture is None else picture.index + 1}"
        surface.blit(self.font.render(label, True, (20, 20, 20)), (_MARGIN, 4))
        if image is not None:
            self._draw_inset(image)
        if self.mode == "human":
            self.window.blit(surface, (0, 0))
            pg.event.pump()
            pg.display.flip()
            self.clock.tick(self.config_fps())
            return None
        return np.transpose(pg.surfarray.array3d(surface), (1, 0, 2)).copy()

    def config_fps(self) -> int:
        """Frames per second of the human window (real time, capped at 60)."""
        return int(min(60, max(1, round(1.0 / self.config.dt))))

    def _draw_robots(self, poses: np.ndarray) -> None:
        pg, robot = self.pygame, self.config.robot
        centres = self._to_screen(poses[:, :2])
        half = robot.size / 2.0 * self.pixels_per_metre
        for (cx, cy), theta, color in zip(centres, poses[:, 2], self.colors, strict=True):
            c, s = math.cos(theta), math.sin(theta)
            if robot.shape == "square":
                pts = [
                    (cx + half * (dx * c - dy * s), cy - half * (dx * s + dy * c))
                    for dx, dy in ((1, 1), (-1, 1), (-1, -1), (1, -1))
                ]
                pg.draw.polygon(self.surface, color, pts)
            else:
                pg.draw.circle(self.surface, color, (cx, cy), half)
            pg.draw.line(self.surface, (20, 20, 20), (cx, cy), (cx + half * c, cy - half * s), 2)

    def _draw_inset(self, image: np.ndarray) -> None:
        pg = self.pygame
        rows, cols = image.shape[:2]
        width = round(_INSET * self.size[0])
        height = max(1, round(width * rows / cols))
        # surfarray is indexed (x, y): transpose the (rows, cols) image, grey to RGB.
        grey = pg.surfarray.make_surface(np.repeat(image.T[:, :, None], 3, axis=2))
        inset = pg.transform.smoothscale(grey, (width, height))
        left, top = self.size[0] - width - 6, 28
        self.surface.blit(inset, (left, top))
        pg.draw.rect(self.surface, (20, 20, 20), (left - 1, top - 1, width + 2, height + 2), 1)

    def _draw_guesses(
        self,
        poses: np.ndarray,
        picture: Picture,
        screen: np.ndarray,
        guesses: dict[str, int | None],
        agents: list[str],
    ) -> None:
        centres = self._to_screen(poses[:, :2])
        for i, agent in enumerate(agents):
            row = guesses.get(agent)
            if row is None or not 0 <= row < len(screen):
                continue
            right = row == picture.true_index[i]
            color = (30, 160, 60) if right else (210, 40, 40)
            self.pygame.draw.line(self.surface, color, tuple(centres[i]), tuple(screen[row]), 2)

    def close(self) -> None:
        """Close the window (human mode)."""
        if self.mode == "human":
            self.pygame.display.quit()
