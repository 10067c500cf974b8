"""``anonloc detect``: the marker detector on a folder of image files, detections to CSV/Parquet.

The camera file is a scenario file (TOML or YAML, see :mod:`anonloc_cli.scenarios`) whose config
fixes the pixel grid: ``camera.image_pixels_per_unit``, and the field of view (``image_size`` and
``principal_point``, or the arena's projection plus a margin), exactly as the image source renders
it (:func:`anonloc_env.images.pixel_frame`). Every frame must have that size. For a real camera
whose pixels are the image units, set ``image_pixels_per_unit = 1``, ``image_size = [W, H]`` and
``principal_point = [W / 2, H / 2]``: then ``u = col + 0.5`` and ``v = H - row - 0.5`` (pixel
centres; ``v`` is up).

Frames are the folder's ``.png``, ``.jpg`` and ``.jpeg`` files in name order, numbered from 0.
Columns of the output (one row per detection; a frame without detections has none):

* ``frame``: the frame's number;
* ``u``, ``v``: the marker's centre (image units, ``v`` up);
* ``theta``: its heading in the image (rad, in [-pi, pi); 0 if ``camera.orientation`` is false).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from anonloc_cli import provenance, store
from anonloc_cli.console import echo, progress
from anonloc_cli.scenarios import InputError, Scenario

FRAME_SUFFIXES = (".png", ".jpg", ".jpeg")
OUT_SUFFIXES = (".csv", ".parquet")
TYPES = {"frame": "int64", "u": "float64", "v": "float64", "theta": "float64"}
"""Columns and their types (for Parquet)."""


def check_output(out: Path) -> None:
    """Refuse an output format the command cannot write, before any work."""
    if out.suffix.lower() not in OUT_SUFFIXES:
        raise InputError(f"--out must end in one of {list(OUT_SUFFIXES)}, got {str(out)!r}")


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


def main(folder: Path, camera: Scenario, out: Path, *, quiet: bool) -> int:
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
    rows: list[dict[str, Any]] = []
    with progress(len(files), "detect", quiet=quiet, unit="frame") as bar:
        for index, path in enumerate(files):
            image = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
            if image is None:
                raise InputError(f"cannot read {str(path)!r} as an image")
            if image.shape != grid.shape:
                raise InputError(
                    f"{path.name} is {image.shape[1]} x {image.shape[0]} pixels but the camera "
                    f"file describes a {grid.width} x {grid.height} image; set "
                    f"camera.image_size and camera.image_pixels_per_unit to match the frames"
                )
            for u, v, theta in detector.detect(image).tolist():
                rows.append(
                    {
                        "frame": index,
                        "u": u,
                        "v": v,
                        "theta": theta if config.camera.orientation else 0.0,
                    }
                )
            bar.update()
    record = provenance.provenance(
        {camera.name: config_to_dict(config)},
        folder=str(folder),
        frames=[p.name for p in files],
        pixels_per_unit=grid.pixels_per_unit,
    )
    if out.suffix.lower() == ".parquet":
        store.write_parquet(out, rows, TYPES, record)
    else:
        store.write_csv(out, rows, list(TYPES))
    store.write_json(store.meta_path(out), record)
    wall = time.perf_counter() - start
    echo(f"wrote {out}: {len(rows)} detections in {len(files)} frames ({wall:.1f} s)")
    return 0
