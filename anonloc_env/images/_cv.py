"""The one place OpenCV is imported (lazily: it is the optional ``images`` extra)."""

from __future__ import annotations

from typing import Any


def import_cv2() -> Any:
    """The ``cv2`` module, or an ``ImportError`` that says which extra installs it."""
    try:
        import cv2
    except ImportError as error:  # pragma: no cover - depends on the installed extras
        raise ImportError(
            "the image source needs OpenCV: pip install 'anonloc[images]' "
            "(or pip install opencv-python-headless)"
        ) from error
    if not hasattr(cv2, "aruco") or not hasattr(cv2.aruco, "ArucoDetector"):
        raise ImportError(  # pragma: no cover - depends on the installed OpenCV
            f"the image source needs OpenCV >= 4.7 with cv2.aruco.ArucoDetector; "
            f"found OpenCV {cv2.__version__}: pip install -U 'anonloc[images]'"
        )
    return cv2
