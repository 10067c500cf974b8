"""The image path: rendered markers are found where the robots are, with the env's handedness."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("cv2", reason="the image source needs the images extra (OpenCV)")

import anonloc_env
from anonloc_env.camera import Camera
from anonloc_env.config import CameraConfig
from anonloc_env.detection import stated_config
from anonloc_env.geometry import wrap_angle
from anonloc_env.identify import SensorModel
from anonloc_env.images import (
    ImageCamera,
    calibrate,
    calibrated,
    effective_camera,
    measured_errors,
    pixel_frame,
)
from tests.helpers import rollout


def _config(
    preset: str = "default", n: int | None = None, **camera: object
) -> anonloc_env.EnvConfig:
    """``preset`` with the image source (and ``n`` robots in the preset's own arena: a picture
    holds at most that many)."""
    arena = anonloc_env.PRESETS[preset].arena_size
    more = {} if n is None else {"n_robots": n, "arena_size": arena}
    return anonloc_env.make_config(preset, camera={"source": "image", **camera}, **more)


def _detect(source: ImageCamera, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows of every robot (nan where missed) and the picture's rows."""
    picture = source.take(np.asarray(poses, float), np.random.default_rng(0), 0.0, 0)
    rows = np.full((len(poses), 3), np.nan)
    seen = picture.true_index >= 0
    rows[seen] = picture.detections[picture.true_index[seen]]
    return rows, picture.detections


def _grid_poses(config: anonloc_env.EnvConfig) -> np.ndarray:
    width, height = config.arena_size
    margin = config.robot.size
    xs = np.linspace(margin, width - margin, 4)
    ys = np.linspace(margin, height - margin, 4)
    x, y = np.meshgrid(xs, ys)
    theta = np.linspace(-math.pi, math.pi, x.size, endpoint=False) + 0.1
    return np.column_stack([x.ravel(), y.ravel(), theta])


@pytest.mark.parametrize(
    ("preset", "tilt"), [("default", 0.0), ("paper-angular", 4.24), ("paper-angular", 10.0)]
)
def test_markers_at_known_poses_are_found_within_tolerance(preset: str, tilt: float) -> None:
    config = _config(preset, 16, tilt_deg=tilt)
    source = ImageCamera(config)
    poses = _grid_poses(config)
    rows, _ = _detect(source, poses)
    camera = source.camera
    assert not np.isnan(rows).any(), "every robot in the arena is seen"
    error = np.hypot(*(rows[:, :2] - camera.project(poses[:, :2])).T)
    pixel = 1.0 / source.frame.pixels_per_unit
    # Stated tolerance: a tenth of a pixel in position, one degree in heading.
    assert error.max() < 0.1 * pixel
    heading = np.degrees(np.abs(wrap_angle(rows[:, 2] - camera.image_heading(poses))))
    assert heading.max() < 1.0


def test_counter_clockwise_turn_increases_detected_theta() -> None:
    source = ImageCamera(_config())
    for start in (-3.0, -1.0, 0.0, 1.5, 3.0):
        before, _ = _detect(source, [[2.0, 2.0, start]])
        after, _ = _detect(source, [[2.0, 2.0, start + 0.2]])
        turned = wrap_angle(after[0, 2] - before[0, 2])
        assert turned == pytest.approx(0.2, abs=0.01)
    # Untilted, the image heading is the world heading: 0 is +u, pi/2 is +v (up).
    rows, _ = _detect(source, [[1.0, 1.0, 0.0], [3.0, 3.0, math.pi / 2]])
    assert rows[:, 2] == pytest.approx([0.0, math.pi / 2], abs=0.01)
    # v is up: a robot higher in the arena has a larger v.
    assert rows[1, 1] > rows[0, 1]


def test_tilt_reproduces_the_scale_gradient() -> None:
    config = _config("paper-angular", 4, tilt_deg=10.0)
    source = ImageCamera(config)
    # Pairs of robots 2 m apart along x, near the camera (low y) and far from it.
    poses = np.array([[3.0, 1.0, 0.0], [5.0, 1.0, 0.0], [3.0, 7.0, 0.0], [5.0, 7.0, 0.0]])
    rows, _ = _detect(source, poses)
    near = (rows[1, 0] - rows[0, 0]) / 2.0
    far = (rows[3, 0] - rows[2, 0]) / 2.0
    camera = source.camera
    true_near = (camera.project(poses[1:2, :2]) - camera.project(poses[0:1, :2]))[0, 0] / 2.0
    true_far = (camera.project(poses[3:4, :2]) - camera.project(poses[2:3, :2]))[0, 0] / 2.0
    assert far < near  # farther robots look smaller
    assert near / far == pytest.approx(true_near / true_far, rel=1e-3)
    assert near == pytest.approx(true_near, rel=1e-3)


def test_a_marker_cut_by_the_border_is_missed_not_misplaced() -> None:
    # The image is a 100 x 100 unit window around the arena centre (scale 100, 4 m arena).
    config = _config(image_size=(100.0, 100.0))
    source = ImageCamera(config)
    camera = source.camera
    u_max = camera.field_of_view[2]
    # Robot 0 inside; robot 1 with its centre just inside the right edge, marker cut.
    x_edge = camera.unproject(np.array([[u_max - 3.0, 200.0]]))[0, 0]
    poses = np.array([[2.0, 2.0, 0.3], [x_edge, 2.0, 0.0]])
    rows, detections = _detect(source, poses)
    assert not np.isnan(rows[0]).any()
    assert np.isnan(rows[1]).all()
    assert len(detections) == 1


def test_an_overlapped_marker_is_missed_and_the_top_one_found() -> None:
    source = ImageCamera(_config())
    # Robot 1 (drawn last) covers half of robot 0.
    poses = np.array([[2.0, 2.0, 0.0], [2.1, 2.0, 0.5]])
    rows, detections = _detect(source, poses)
    assert np.isnan(rows[0]).all()
    assert len(detections) == 1
    true_uv = source.camera.project(poses[1:, :2])[0]
    assert np.hypot(*(detections[0, :2] - true_uv)) < 0.05


@pytest.mark.parametrize("shape", ["square", "circle"])
def test_touching_robots_are_two_detections_at_the_right_places(shape: str) -> None:
    config = anonloc_env.make_config(
        "default", n_robots=3, robot={"shape": shape}, camera={"source": "image"}
    )
    source = ImageCamera(config)
    size = config.robot.size
    poses = np.array(
        [[2.0, 2.0, 0.0], [2.0 + size, 2.0, 0.0], [2.0, 2.0 + size, math.pi / 2]]
    )  # side by side, edges touching
    rows, detections = _detect(source, poses)
    assert len(detections) == 3
    assert not np.isnan(rows).any()
    error = np.hypot(*(rows[:, :2] - source.camera.project(poses[:, :2])).T)
    assert error.max() < 0.1


def test_image_path_is_deterministic_given_the_seed() -> None:
    spec = {"n_robots": 6, "camera": {"source": "image", "image_noise": 8.0, "image_blur": 0.8}}
    first = rollout(anonloc_env.parallel_env(**spec), seed=3, steps=60)
    second = rollout(anonloc_env.parallel_env(**spec), seed=3, steps=60)
    for a, b in zip(first, second, strict=True):
        obs_a, obs_b = a[0], b[0]
        for agent in obs_a:
            for key in obs_a[agent]:
                np.testing.assert_array_equal(obs_a[agent][key], obs_b[agent][key])
    other = rollout(anonloc_env.parallel_env(**spec), seed=4, steps=0)
    assert not np.array_equal(
        other[0][0]["robot_0"]["detections"], first[0][0]["robot_0"]["detections"]
    )


def test_noise_blur_and_gradient_keep_detections_close() -> None:
    config = _config(n=16, image_noise=10.0, image_blur=1.0, image_gradient=0.5)
    source = ImageCamera(config)
    poses = _grid_poses(config)
    rows, _ = _detect(source, poses)
    seen = ~np.isnan(rows[:, 0])
    assert seen.mean() >= 0.9
    error = np.hypot(*(rows[seen, :2] - source.camera.project(poses[seen, :2])).T)
    assert error.max() < 0.5  # half a pixel at 2.5 pixels per unit


def test_env_option_takes_pictures_through_the_image_path() -> None:
    env = anonloc_env.parallel_env("default", camera={"source": "image"})
    observations, infos = env.reset(seed=0)
    assert isinstance(env.detector, ImageCamera)
    picture = env.picture
    assert picture is not None
    assert picture.n_rows == env.config.n_robots
    truth = env.camera.project(env.world.poses[:, :2])
    for i, agent in enumerate(env.possible_agents):
        row = infos[agent]["true_index"]
        assert row >= 0
        assert np.hypot(*(picture.detections[row, :2] - truth[i])) < 0.1
    obs = observations["robot_0"]
    assert obs["detections"].shape == (env.camera.capacity, 3)
    assert obs["mask"].sum() == env.config.n_robots
    geometric = anonloc_env.parallel_env("default")
    assert env.observation_space("robot_0") == geometric.observation_space("robot_0")


def test_sensor_model_describes_the_measured_errors() -> None:
    """The env states the image path's measured errors in its config, and the localizers built
    for it, or for the scenario alone, model those."""
    import baselines

    config = _config("paper-motion", image_noise=6.0, image_blur=1.0)
    errors = measured_errors(config)
    env = anonloc_env.AnonLocEnv(config)
    assert env.config == stated_config(config)
    model = SensorModel.from_config(env.config)
    assert model.pixel_noise == pytest.approx(errors.pixel_noise)
    assert model.orientation_noise == pytest.approx(math.radians(errors.orientation_noise_deg))
    assert model.p_detect == pytest.approx(1.0 - errors.p_miss)
    # The paper-motion preset's nominal 2.4 units are not what the image path gives.
    assert config.camera.pixel_noise == 2.40
    assert 0.0 < errors.pixel_noise < 0.5
    assert 0.0 < errors.orientation_noise_deg < 5.0
    for scenario in (baselines.scenario_config(env), baselines.scenario_config(config=config)):
        assert SensorModel.from_config(scenario) == model
    geometric = anonloc_env.make_config("paper-motion")
    assert effective_camera(geometric) is geometric.camera
    assert stated_config(geometric) is geometric


def test_calibrating_twice_changes_nothing() -> None:
    config = _config("default", 12, image_noise=3.0)
    once = calibrated(config)
    assert once != config
    assert calibrated(once) == once
    assert measured_errors(once) == measured_errors(config)


def test_sensor_model_renders_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    """The sensor model reads the camera section as stated: building it from an image config
    takes no picture (the calibration is the env's explicit step)."""

    def refuse(*args: object, **kwargs: object) -> None:
        raise AssertionError("SensorModel.from_config took a picture")

    monkeypatch.setattr(ImageCamera, "take", refuse)
    config = _config("default", 7, pixel_noise=1.25, p_miss=0.1)
    model = SensorModel.from_config(config)
    assert model.pixel_noise == pytest.approx(1.25)
    assert model.p_detect == pytest.approx(0.9)


def test_calibration_recovers_scale_and_tilt() -> None:
    result = calibrate(_config("paper-angular", tilt_deg=10.0), robots=3, pictures=12)
    assert result.points >= 30
    est, true = result.scale_u_range
    assert est == pytest.approx(true, rel=2e-3)
    assert result.tilt_deg[0] == pytest.approx(10.0, abs=0.5)
    assert result.perspective[0] == pytest.approx(result.perspective[1], rel=0.02)
    assert result.grid_error < 0.1


def test_config_checks_the_image_fields() -> None:
    with pytest.raises(ValueError, match=r"camera.source must be one of \['geometric', 'image'\]"):
        CameraConfig(source="video")
    with pytest.raises(ValueError, match=r"camera.image_gradient must be in \[0, 1\)"):
        CameraConfig(image_gradient=1.0)
    with pytest.raises(ValueError, match=r"camera.image_pixels_per_unit must be in \(0, 1000\]"):
        CameraConfig(image_pixels_per_unit=0.0)
    with pytest.raises(ValueError, match="more than 50000000 pixels"):
        pixel_frame(_config(image_pixels_per_unit=500.0))


def test_geometric_source_is_the_camera_itself() -> None:
    env = anonloc_env.parallel_env("default")
    assert env.detector is env.camera
    assert isinstance(env.camera, Camera)


def test_render_shows_the_camera_image_as_picture_in_picture() -> None:
    pytest.importorskip("pygame", reason="rendering needs the render extra (pygame-ce)")
    frames = []
    for source in ("geometric", "image"):
        env = anonloc_env.parallel_env(
            "default", camera={"source": source}, render_mode="rgb_array"
        )
        env.reset(seed=0)
        frames.append(env.render())
        env.close()
    geometric, image = frames
    assert geometric.shape == image.shape
    width = geometric.shape[1]
    inset = (slice(30, 60), slice(width - 60, width - 30))  # inside the top-right inset
    assert not np.array_equal(geometric[inset], image[inset])
    # The inset is grey (the floor), the same in all three channels.
    patch = image[inset].astype(int)
    assert np.all(patch[..., 0] == patch[..., 1])
