"""Which detection source a config names: the geometric :class:`~anonloc_env.camera.Camera`,
or the image path of :mod:`anonloc_env.images` (imported here only when the config asks for it,
so that the camera and the image path do not import each other)."""

from __future__ import annotations

from anonloc_env.camera import Camera, DetectionSource
from anonloc_env.config import EnvConfig


def detection_source(config: EnvConfig, camera: Camera) -> DetectionSource:
    """The detection source ``config.camera.source`` names: ``camera`` itself for
    ``"geometric"``, an :class:`anonloc_env.images.ImageCamera` sharing its geometry for
    ``"image"`` (imports OpenCV)."""
    if config.camera.source == "image":
        from anonloc_env.images.source import ImageCamera  # OpenCV: the optional images extra

        return ImageCamera(config, camera)
    return camera
