"""Synthetic aerial images and marker detection: the camera as pixels (OpenCV, ``images`` extra).

The paper's robots were photographed by a webcam and found by ARToolKit, all wearing the same
pattern. This package recreates that platform with OpenCV's ArUco markers:

* :class:`ImageRenderer`: a grayscale top-down image of the arena through the camera's
  homography, every robot wearing marker 0 of ``DICT_4X4_50`` (anonymous by construction), with
  optional blur, sensor noise and an illumination gradient;
* :class:`MarkerDetector`: ``cv2.aruco.ArucoDetector`` with sub-pixel corners, rows
  ``(u, v, theta)`` in image units;
* :class:`ImageCamera`: both behind the :class:`~anonloc_env.camera.DetectionSource` interface
  (the env uses it with ``camera={"source": "image"}``);
* :func:`effective_camera`: the camera section with the image path's measured errors, and
  :func:`calibrated`, the config with it (the env takes this step for its image source, so that
  the sensor model localizers build from ``env.config`` describes the pictures);
* :func:`landmark_pose`: a picture's homography from the ground landmarks it shows;
* :func:`calibrate`: the camera homography estimated from robots driving known paths.

Importing this package does not import OpenCV; building any of the classes does.
"""

from __future__ import annotations

from anonloc_env.images.calibration import CalibrationResult, calibrate
from anonloc_env.images.detector import MarkerDetector
from anonloc_env.images.errors import (
    ErrorSample,
    ImageErrors,
    calibrated,
    effective_camera,
    measured_errors,
    sample_errors,
)
from anonloc_env.images.frame import PixelFrame, pixel_frame
from anonloc_env.images.pose import estimate_homography, landmark_pose
from anonloc_env.images.renderer import ImageRenderer
from anonloc_env.images.source import ImageCamera

__all__ = [
    "CalibrationResult",
    "ErrorSample",
    "ImageCamera",
    "ImageErrors",
    "ImageRenderer",
    "MarkerDetector",
    "PixelFrame",
    "calibrate",
    "calibrated",
    "effective_camera",
    "estimate_homography",
    "landmark_pose",
    "measured_errors",
    "pixel_frame",
    "sample_errors",
]
