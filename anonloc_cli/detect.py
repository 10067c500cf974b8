"""``anonloc detect``: the marker detector on a folder of image files, detections to CSV/Parquet.

The camera file is a scenario file (TOML or YAML, see :mod:`anonloc_cli.scenarios`) whose config
fixes the pixel grid: ``camera.image_pixels_per_unit``, and the field of view (``image_size`` and
``principal_point``, or the arena's projection plus a margin), exactly as the image source renders
it (:func:`anonloc_env.images.pixel_frame`). Every frame must have that size. For a real camera
whose pixels are the image units, set ``image_pixels_per_unit = 1``, ``image_size = [W, H]`` and
``principal_point = [W / 2, H / 2]``: then ``u = col + 0.5`` and ``v = H - row - 0.5`` (pixel
centres; ``v`` is up).

Frames are the folder's ``.png``, ``.jpg`` and ``.jpeg`` files in name order, numbered from 0;
the other files are skipped, and the command says how many. Each frame's size is read from its
file header before it is decoded: a frame of the wrong size (or a header claiming 30000 x 30000
pixels) is refused without decoding it. An unreadable frame stops the command, or with
``--skip-bad`` is skipped and named in the summary (the frame numbers of the others stay).
Columns of the output (one row per detection; a frame without detections has none):

* ``frame``: the frame's number;
* ``u``, ``v``: the marker's centre (image units, ``v`` up);
* ``theta``: its heading in the image (rad, in [-pi, pi); 0 if ``camera.orientation`` is false).

With ground landmarks in the camera file (``camera.landmarks``: their ground positions, ArUco ids
1, 2, ... while the robots wear id 0; see ``docs/drone.md``), a camera that moves (on a drone)
is located in every frame: the landmarks' corners give the frame's homography
(``cv2.findHomography``), the robots' rows are rectified into the frame of the camera's set
point (the camera file's own pose), and one more column says which row is what:

* ``landmark``: -1 for a robot; ``k`` for the k-th landmark (``u``, ``v`` its centre as seen,
  ``theta`` 0). A frame with fewer than two landmarks keeps its robots' rows as seen.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from anonloc_cli import provenance, store
from anonloc_cli.console import echo, progress
from anonloc_cli.scenarios import InputError, Scenario

FRAME_SUFFIXES = (".png", ".jpg", ".jpeg")
TYPES = {"frame": "int64", "u": "float64", "v": "float64", "theta": "float64"}
"""Columns and their types (for Parquet)."""


def check_output(out: Path) -> None:
    """Refuse an output format the command cannot write, before any work (the same rule as
    ``bench`` and ``eval``: :func:`anonloc_cli.options.check_table_suffix`)."""
    from anonloc_cli.options import check_table_suffix

    check_table_suffix(out)


def frame_files(folder: Path) -> list[Path]:
    """The image files of ``folder`` in name order, or an :class:`InputError`."""
    if not folder.is_dir():
        raise InputError(f"DIR must be a folder of image files, got {str(folder)!r}")
    files = sorted(p for p in folder.iterdir() if p.suffix.lower() in FRAME_SUFFIXES)
    if not files:
        raise InputError(
            f"{str(folder)!r} holds no image files (looked for {', '.join(FRAME_SUFFIXES)})"
        )
    return files


class BadFrameError(ValueError):
    """A frame that cannot be used: unreadable, or not the camera's size."""


def header_size(path: Path) -> tuple[int, int]:
    """``(width, height)`` from a PNG or JPEG file's header, without decoding the pixels."""
    with open(path, "rb") as file:
        head = file.read(24)
        if head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR":
            return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")
        if head[:2] == b"\xff\xd8":
            file.seek(2)
            return _jpeg_size(file)
    raise BadFrameError("not a PNG or JPEG file")


def _jpeg_size(file: Any) -> tuple[int, int]:
    """The size in a JPEG's first start-of-frame segment (``file`` just after its SOI)."""
    while True:
        marker = file.read(2)
        if len(marker) < 2 or marker[0] != 0xFF:
            raise BadFrameError("a JPEG without a readable frame header")
        kind = marker[1]
        if kind == 0xFF:  # fill byte
            file.seek(-1, 1)
            continue
        length = int.from_bytes(file.read(2), "big")
        if 0xC0 <= kind <= 0xCF and kind not in (0xC4, 0xC8, 0xCC):
            segment = file.read(5)
            if len(segment) < 5:
                raise BadFrameError("a truncated JPEG frame header")
            return int.from_bytes(segment[3:5], "big"), int.from_bytes(segment[1:3], "big")
        if length < 2:
            raise BadFrameError("a JPEG segment of impossible length")
        file.seek(length - 2, 1)


def read_frame(cv2: Any, path: Path, shape: tuple[int, int]) -> Any:
    """The grayscale frame at ``path``, checked against the camera's ``(height, width)`` from
    its header first (no decoding of a wrong or hostile size)."""
    try:
        width, height = header_size(path)
    except OSError as error:
        raise BadFrameError(f"cannot read {path.name} ({error.strerror})") from None
    except BadFrameError as error:
        raise BadFrameError(f"{path.name}: {error}") from None
    if (height, width) != shape:
        raise BadFrameError(
            f"{path.name} is {width} x {height} pixels but the camera file describes a "
            f"{shape[1]} x {shape[0]} image; set camera.image_size and "
            "camera.image_pixels_per_unit to match the frames"
        )
    image = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if image is None or image.shape != shape:
        raise BadFrameError(f"cannot read {path.name} as an image")
    return image


def frame_rows(config: Any, detector: Any, image: Any, index: int) -> list[dict[str, Any]]:
    """One frame's output rows: its robots (rectified by its landmarks, if the camera has
    some), then its landmarks."""
    import numpy as np

    from anonloc_env.camera import Camera, Picture, rectified
    from anonloc_env.images.detector import corners_to_rows
    from anonloc_env.images.marker import MARKER_ID
    from anonloc_env.images.pose import landmark_pose

    ids, corners = detector.markers(image)
    found = corners_to_rows(corners[ids == MARKER_ID], detector.frame)
    if not config.camera.orientation:
        found[:, 2] = 0.0
    landmarks = config.camera.landmarks
    out = [{"frame": index, "u": u, "v": v, "theta": t} for u, v, t in found.tolist()]
    if not landmarks:
        return out
    which, centres, estimated = landmark_pose(config, detector.frame, ids, corners)
    if estimated is not None:
        picture = Picture(found, np.zeros(0, np.int64), 0.0, index, config.camera.orientation)
        fixed = rectified(config, picture, which, centres, Camera(config).set_point, estimated)
        out = [
            {"frame": index, "u": u, "v": v, "theta": t} for u, v, t in fixed.detections.tolist()
        ]
    for row in out:
        row["landmark"] = -1
    for k, (u, v) in zip(which.tolist(), centres.tolist(), strict=True):
        out.append({"frame": index, "u": u, "v": v, "theta": 0.0, "landmark": k})
    return out


def main(folder: Path, camera: Scenario, out: Path, *, quiet: bool, skip_bad: bool = False) -> int:
    """Detect the markers in every frame of ``folder``; write the rows to ``out``."""
    from anonloc_env.images import MarkerDetector, pixel_frame
    from anonloc_env.images._cv import import_cv2
    from anonloc_env.images.frame import marker_cell_pixels
    from anonloc_env.presets import config_to_dict

    start = time.perf_counter()
    cv2 = import_cv2()
    files = frame_files(folder)
    config = camera.config
    try:
        grid = pixel_frame(config)
    except ValueError as error:
        raise InputError(str(error)) from None
    detector = MarkerDetector(grid, marker_cell_pixels(config))
    others = sorted(p.name for p in folder.iterdir() if p.is_file() and p not in files)
    rows: list[dict[str, Any]] = []
    skipped: list[str] = []
    with progress(len(files), "detect", quiet=quiet, unit="frame") as bar:
        for index, path in enumerate(files):
            try:
                image = read_frame(cv2, path, grid.shape)
            except BadFrameError as error:
                if not skip_bad:
                    raise InputError(f"{error} (--skip-bad skips such frames)") from None
                skipped.append(str(error))
                bar.update()
                continue
            rows.extend(frame_rows(config, detector, image, index))
            bar.update()
    record = provenance.provenance(
        {camera.name: config_to_dict(config)},
        folder=str(folder),
        frames=[p.name for p in files],
        skipped_frames=skipped,
        pixels_per_unit=grid.pixels_per_unit,
    )
    types = {**TYPES, "landmark": "int64"} if config.camera.landmarks else TYPES
    if out.suffix.lower() == ".parquet":
        store.write_parquet(out, rows, types, record)
    else:
        store.write_csv(out, rows, list(types))
    store.write_json(store.meta_path(out), record)
    wall = time.perf_counter() - start
    used = len(files) - len(skipped)
    echo(f"wrote {out}: {len(rows)} detections in {used} frames ({wall:.1f} s)")
    if others:
        shown = ", ".join(others[:5]) + (", ..." if len(others) > 5 else "")
        echo(f"skipped {len(others)} files that are not .png/.jpg/.jpeg: {shown}", err=True)
    for problem in skipped:
        echo(f"skipped frame: {problem}", err=True)
    return 0
