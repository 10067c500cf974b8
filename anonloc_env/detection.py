"""Which detection source a config names: the geometric :class:`~anonloc_env.camera.Camera`,
or the image path of :mod:`anonloc_env.images` (imported here only when the config asks for it,
so that the camera and the image path do not import each other), and the config that states the
errors of the pictures it takes (:func:`stated_config`, the image path's calibration step)."""

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


def stated_config(config: EnvConfig) -> EnvConfig:
    """``config`` with a camera section that states the errors of the pictures its source takes.

    ``config`` itself for the geometric source, whose ``pixel_noise``, ``orientation_noise_deg``,
    ``p_miss`` and ``false_positives`` are the noise it applies. For the image source those four
    fields are not applied (the detector's own errors are the errors): they are replaced by the
    errors measured on seeded rendered pictures (:func:`anonloc_env.images.calibrated`, which
    renders and detects about 400 robot views once per config; imports OpenCV). This is the
    calibration step: the env takes it when it builds its own image source, and a localizer built
    for a scenario rather than an env (``baselines.make_team(name, config)``) takes it too. The
    sensor model (:meth:`anonloc_env.identify.SensorModel.from_config`) reads the section as
    stated and never renders.
    """
    if config.camera.source == "image":
        from anonloc_env.images.errors import calibrated  # OpenCV: the optional images extra

        return calibrated(config)
    return config
