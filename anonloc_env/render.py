"""Drawing with pygame-ce (an optional extra, imported only when rendering is asked for).

The arena is drawn in world coordinates (y up). Robots are drawn with their heading; the newest
picture's detections are mapped back to the ground through the camera and drawn as grey crosses.
A robot's guess (``env.guesses``), when set, is drawn so that right and wrong differ at a glance: a
right guess is a green ring around the robot; a wrong one is a red ring around the detection it
chose, joined to the robot by a red line; a robot whose guess is ``None`` (not decided yet) gets a
thin amber ring. A legend at the bottom says so, and the header gives the time the newest picture
was taken (the crosses are where the robots were then, not where they are now). With the image
source (``camera.source = "image"``) the camera's newest grayscale image is shown in the top-right
corner (picture-in-picture). A camera that moves (``camera.drift`` and the wobbles) has its
footprint, the ground its field of view covered at the newest picture, drawn as a blue outline.

Only the ``human`` mode opens a display; ``rgb_array`` draws off screen and never initialises SDL's
video (so no display, and no message about one, is needed).
"""

from __future__ import annotations

import colorsys
import math
import os
import sys
from typing import Any

import numpy as np

from anonloc_env.camera import Camera, Picture
from anonloc_env.config import EnvConfig

_WINDOW = 640  # pixels along the arena's longer side
_MARGIN = 20
_HEADER = 24  # pixels above the arena (the time label)
_FOOTER = 26  # pixels below the arena (the legend)
_INSET = 0.3  # side of the picture-in-picture, as a fraction of the window's width
_RIGHT = (30, 160, 60)  # a right guess
_WRONG = (210, 40, 40)  # a wrong guess
_UNDECIDED = (230, 150, 0)  # no guess yet (amber)
_DETECTION = (90, 90, 90)
_FOOTPRINT = (60, 110, 220)  # the moving camera's field of view on the ground
_TEXT = (20, 20, 20)


def _import_pygame() -> Any:
    try:
        import pygame
    except ImportError as error:  # pragma: no cover - depends on the installed extras
        raise ImportError(
            "rendering needs pygame-ce: pip install 'anonloc[render]' (or pip install pygame-ce)"
        ) from error
    return pygame


def _open_window(pg: Any, size: tuple[int, int]) -> Any:
    """A window, or a ``RuntimeError`` where there is no display to show it on.

    A video driver chosen explicitly (``SDL_VIDEODRIVER``, e.g. ``dummy`` in tests) is honoured.
    """
    chosen = bool(os.environ.get("SDL_VIDEODRIVER"))
    headless = (
        not chosen
        and sys.platform.startswith("linux")
        and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    )
    if not headless:
        pg.display.init()
    if headless or (not chosen and pg.display.get_driver() in ("offscreen", "dummy")):
        pg.display.quit()
        raise RuntimeError(
            "render_mode='human' needs a display, and none was found (no DISPLAY or "
            "WAYLAND_DISPLAY); use render_mode='rgb_array' to get frames as arrays"
        )
    window = pg.display.set_mode(size)
    pg.display.set_caption("anonloc")
    return window


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
            round(height * self.pixels_per_metre) + 2 * _MARGIN + _HEADER + _FOOTER,
        )
        pg = self.pygame
        pg.font.init()  # not pg.init(): rgb_array frames need no display, audio or events
        if mode == "human":
            self.window = _open_window(pg, self.size)
            self.clock = pg.time.Clock()
        self.surface = pg.Surface(self.size)
        self.font = pg.font.Font(None, 20)
        n = config.n_robots
        self.colors = [
            tuple(int(255 * c) for c in colorsys.hsv_to_rgb(i / max(n, 1), 0.45, 0.9))
            for i in range(n)
        ]

    def _to_screen(self, xy: np.ndarray) -> np.ndarray:
        height = self.config.arena_size[1]
        screen = np.empty_like(xy)
        screen[..., 0] = _MARGIN + xy[..., 0] * self.pixels_per_metre
        screen[..., 1] = _MARGIN + _HEADER + (height - xy[..., 1]) * self.pixels_per_metre
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
        if self.config.camera.moves:  # the ground the moving camera saw at the newest picture
            footprint = self._to_screen(self.camera.footprint())
            pg.draw.polygon(surface, _FOOTPRINT, footprint.tolist(), 2)
        self._draw_robots(poses)
        if picture is not None and picture.n_rows > 0:
            ground = self._ground(picture)
            screen = self._to_screen(ground)
            for x, y in screen:
                self._cross(x, y)
            self._draw_guesses(poses, picture, screen, guesses, agents)
        label = f"t = {time:.2f} s   pictures: {0 if picture is None else picture.index + 1}"
        if picture is not None:
            label += f" (crosses: the newest, taken at t = {picture.time:.2f} s)"
        surface.blit(self.font.render(label, True, _TEXT), (_MARGIN, 4))
        self._draw_legend()
        if image is not None:
            self._draw_inset(image)
        if self.mode == "human":
            self.window.blit(surface, (0, 0))
            pg.event.pump()
            pg.display.flip()
            self.clock.tick(self.config_fps())
            return None
        return np.transpose(pg.surfarray.array3d(surface), (1, 0, 2)).copy()

    def _ground(self, picture: Picture) -> np.ndarray:
        """The ground points of a picture's rows: through the camera's pose when it was taken,
        or through its set point where ground landmarks rectified the rows into that frame."""
        uv = picture.detections[:, :2]
        if picture.homography is None:
            return self.camera.unproject(uv)
        h = np.column_stack([uv, np.ones(len(uv))]) @ np.linalg.inv(self.camera.set_point).T
        return h[:, :2] / h[:, 2:3]

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

    def _cross(self, x: float, y: float) -> None:
        line = self.pygame.draw.line
        line(self.surface, _DETECTION, (x - 4, y - 4), (x + 4, y + 4), 2)
        line(self.surface, _DETECTION, (x - 4, y + 4), (x + 4, y - 4), 2)

    def _ring_radius(self) -> float:
        return self.config.robot.size / 2.0 * self.pixels_per_metre + 5

    def _draw_legend(self) -> None:
        """One line under the arena: what a cross, a green ring and a red ring mean."""
        pg, surface = self.pygame, self.surface
        y = self.size[1] - _FOOTER / 2
        x = float(_MARGIN)
        rings = {"right": (_RIGHT, 3), "wrong": (_WRONG, 3), "undecided": (_UNDECIDED, 2)}
        for kind, text in (
            ("cross", "detection"),
            ("right", "guess right"),
            ("wrong", "wrong (ring on the row it chose)"),
            ("undecided", "undecided"),
        ):
            if kind == "cross":
                self._cross(x + 6, y)
            else:
                color, width = rings[kind]
                pg.draw.circle(surface, color, (x + 6, y), 7, width)
            label = self.font.render(text, True, _TEXT)
            surface.blit(label, (x + 18, y - label.get_height() / 2))
            x += 18 + label.get_width() + 16

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
        pg, surface = self.pygame, self.surface
        centres = self._to_screen(poses[:, :2])
        radius = self._ring_radius()
        for i, agent in enumerate(agents):
            row = guesses.get(agent)
            if row is None and agent in guesses:  # told, and not decided yet
                pg.draw.circle(surface, _UNDECIDED, tuple(centres[i]), radius, 2)
                continue
            if row is None or not 0 <= row < len(screen):
                continue
            if row == picture.true_index[i]:
                pg.draw.circle(surface, _RIGHT, tuple(centres[i]), radius, 3)
            else:
                pg.draw.line(surface, _WRONG, tuple(centres[i]), tuple(screen[row]), 2)
                # wider than a right ring, so that both show where they meet on one robot
                pg.draw.circle(surface, _WRONG, tuple(screen[row]), radius + 4, 3)

    def close(self) -> None:
        """Close the window (human mode)."""
        if self.mode == "human":
            self.pygame.display.quit()
