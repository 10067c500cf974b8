"""``anonloc detect`` on frames the tests generate gives back the poses they were drawn from."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

import anonloc_env
from anonloc_env.geometry import wrap_angle
from anonloc_env.images import ImageRenderer
from anonloc_env.world import random_poses
from tests.cli_helpers import invoke, read_csv

cv2 = pytest.importorskip("cv2", reason="anonloc detect needs the images extra (OpenCV)")

CAMERA_TOML = """\
preset = "paper-angular"
n_robots = 6
[camera]
source = "image"
tilt_deg = 10.0
image_noise = 4.0
"""


def _frames(folder: Path, count: int) -> list[np.ndarray]:
    """Write ``count`` frames of seeded random poses; return the true rows of each."""
    config = anonloc_env.make_config(
        "paper-angular",
        n_robots=6,
        camera={"source": "image", "tilt_deg": 10.0, "image_noise": 4.0},
    )
    renderer = ImageRenderer(config)
    rng = np.random.default_rng(5)
    truth = []
    for k in range(count):
        poses = random_poses(config, rng)
        cv2.imwrite(str(folder / f"frame_{k:03d}.png"), renderer.render(poses, rng))
        rows = np.column_stack(
            [renderer.camera.project(poses[:, :2]), renderer.camera.image_heading(poses)]
        )
        truth.append(rows)
    return truth


def _check(rows: list[dict[str, Any]], truth: list[np.ndarray]) -> None:
    frames = np.array([int(r["frame"]) for r in rows])
    found = np.array([[float(r[c]) for c in ("u", "v", "theta")] for r in rows])
    assert sorted(set(frames.tolist())) == list(range(len(truth)))
    for k, true_rows in enumerate(truth):
        mine = found[frames == k]
        assert len(mine) == len(true_rows)
        for u, v, theta in true_rows:
            distance = np.hypot(mine[:, 0] - u, mine[:, 1] - v)
            nearest = mine[np.argmin(distance)]
            assert distance.min() < 0.05  # image units (about 0.4 pixel at 7.8 pixels per unit)
            assert abs(wrap_angle(np.array([nearest[2] - theta]))[0]) < np.radians(2.0)


def test_detect_gives_back_the_drawn_poses(tmp_path: Path) -> None:
    folder = tmp_path / "frames"
    folder.mkdir()
    truth = _frames(folder, 3)
    camera = tmp_path / "camera.toml"
    camera.write_text(CAMERA_TOML)
    out = tmp_path / "detections.csv"
    result = invoke("detect", folder, "--camera", camera, "--out", out, "-q")
    assert result.exit_code == 0, result.output
    rows = read_csv(out)
    assert list(rows[0]) == ["frame", "u", "v", "theta"]
    _check(rows, truth)


def test_detect_writes_parquet(tmp_path: Path) -> None:
    pq = pytest.importorskip("pyarrow.parquet", reason="Parquet output needs pyarrow")
    folder = tmp_path / "frames"
    folder.mkdir()
    truth = _frames(folder, 2)
    camera = tmp_path / "camera.toml"
    camera.write_text(CAMERA_TOML)
    out = tmp_path / "detections.parquet"
    assert invoke("detect", folder, "--camera", camera, "--out", out, "-q").exit_code == 0
    _check(pq.read_table(out).to_pylist(), truth)


def test_detect_refuses_bad_input(tmp_path: Path) -> None:
    camera = tmp_path / "camera.toml"
    camera.write_text(CAMERA_TOML)
    empty = tmp_path / "empty"
    empty.mkdir()
    result = invoke("detect", empty, "--camera", camera, "--out", tmp_path / "d.csv")
    assert result.exit_code == 2
    assert "holds no image files" in result.output
    result = invoke("detect", empty, "--camera", camera, "--out", tmp_path / "d.txt")
    assert result.exit_code == 2
    assert "tables are written as .csv (CSV) or .parquet (Parquet)" in result.output
    cv2.imwrite(str(empty / "small.png"), np.zeros((10, 20), np.uint8))
    result = invoke("detect", empty, "--camera", camera, "--out", tmp_path / "d.csv")
    assert result.exit_code == 2
    assert "small.png is 20 x 10 pixels" in result.output
    assert not (tmp_path / "d.csv").exists()


DRONE_TOML = """\
preset = "drone-windy"
n_robots = 6
arena_size = [3.0, 3.0]
[camera]
source = "image"
landmarks = [[0.45, 0.45], [1.5, 0.45], [2.55, 0.45], [0.45, 1.5], [2.55, 1.5], [0.45, 2.55],
  [1.5, 2.55], [2.55, 2.55]]
"""


def test_detect_locates_a_moving_camera_by_its_landmarks(tmp_path: Path) -> None:
    """Frames from a drone off its set point: the robots' rows come back where the camera at its
    set point would have seen them, and the landmarks in view are listed."""
    import math

    from anonloc_env.camera_motion import set_point
    from anonloc_env.landmarks import border_landmarks

    config = anonloc_env.make_config(
        "drone-windy",
        n_robots=6,
        arena_size=(3.0, 3.0),
        camera={"source": "image", "landmarks": border_landmarks((3.0, 3.0))},
    )
    folder = tmp_path / "frames"
    folder.mkdir()
    renderer = ImageRenderer(config)
    rng = np.random.default_rng(2)
    truth = []
    for k in range(2):
        poses = random_poses(config, rng)
        shift = np.array([0.15 * (k + 1), -0.1, 0.08, math.radians(2.0 + k), 0.004, -0.003])
        renderer.camera.move_to(set_point(config) + shift)
        cv2.imwrite(str(folder / f"frame_{k:03d}.png"), renderer.render(poses, rng))
        renderer.camera.move_to(None)
        truth.append(renderer.camera.project(poses[:, :2]))
    camera = tmp_path / "drone.toml"
    camera.write_text(DRONE_TOML)
    out = tmp_path / "detections.csv"
    result = invoke("detect", folder, "--camera", camera, "--out", out, "-q")
    assert result.exit_code == 0, result.output
    rows = read_csv(out)
    assert list(rows[0]) == ["frame", "u", "v", "theta", "landmark"]
    for k, true_uv in enumerate(truth):
        robots = np.array(
            [
                [float(r["u"]), float(r["v"])]
                for r in rows
                if int(r["frame"]) == k and int(r["landmark"]) < 0
            ]
        )
        marks = [r for r in rows if int(r["frame"]) == k and int(r["landmark"]) >= 0]
        assert len(marks) >= 6  # a robot may stand on a landmark and hide it
        assert len(robots) >= len(true_uv) - 1  # one may have drifted out of the picture
        for u, v in robots:
            assert np.hypot(true_uv[:, 0] - u, true_uv[:, 1] - v).min() < 0.1
