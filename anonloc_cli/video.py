"""Frames written as they are drawn: a GIF (Pillow) or an MP4 (imageio's ffmpeg plugin), never
all of them in memory.

A frame of the default arena is about 1.3 MB of RGB; keeping an episode's frames to write them at
the end (and stacking them again for the writer) took 4.4 MB per frame, so ``render --steps 1500
--set max_cycles=1500`` failed under a 3.5 GB cap after the whole simulation. :func:`open_video`
returns a writer that takes one frame at a time, so memory stays that of one frame however long
the episode.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, BinaryIO, Protocol

import numpy as np


class Video(Protocol):
    """A video being written: :meth:`add` one frame at a time, then :meth:`close`."""

    frames: int

    def add(self, frame: np.ndarray) -> None: ...

    def close(self) -> None: ...


def gif_duration(fps: float) -> int:
    """A GIF frame's duration in ms for ``fps`` (GIF counts in hundredths: at least 20 ms)."""
    return max(20, 10 * math.ceil(100.0 / fps))


class GifVideo:
    """A looping GIF written frame by frame: each ``(H, W, 3)`` uint8 frame gets its own
    adaptive palette (a local colour table), the first one's is the global table."""

    def __init__(self, path: Path, fps: float) -> None:
        self.file: BinaryIO = open(path, "wb")  # noqa: SIM115 - closed by close()
        self.duration = gif_duration(fps)
        self.frames = 0

    def add(self, frame: np.ndarray) -> None:
        from PIL import GifImagePlugin, Image

        image = Image.fromarray(np.ascontiguousarray(frame[..., :3]), "RGB").quantize(256)
        if self.frames == 0:
            header, _ = GifImagePlugin.getheader(image, info={"loop": 0, "duration": 1})
            self.file.write(b"".join(header))
        data = GifImagePlugin.getdata(image, duration=self.duration, include_color_table=True)
        self.file.write(b"".join(data))
        self.frames += 1

    def close(self) -> None:
        if not self.file.closed:
            if self.frames:
                self.file.write(b";")  # the GIF trailer
            self.file.close()


class Mp4Video:
    """An MP4 written frame by frame through imageio's ffmpeg writer (a pipe to ffmpeg)."""

    def __init__(self, path: Path, fps: float) -> None:
        import imageio.v2 as imageio

        self.writer: Any = imageio.get_writer(path, format="FFMPEG", mode="I", fps=fps)
        self.frames = 0

    def add(self, frame: np.ndarray) -> None:
        self.writer.append_data(frame)
        self.frames += 1

    def close(self) -> None:
        self.writer.close()


def open_video(path: Path, fps: float) -> Video:
    """A writer for ``path`` (``.gif``, else ``.mp4``) at ``fps`` frames per second."""
    return GifVideo(path, fps) if path.suffix.lower() == ".gif" else Mp4Video(path, fps)
