"""The camera and detector: geometry, noise, misses, false positives, field of view, shuffling."""

from __future__ import annotations

import math

import numpy as np
import pytest

import anonloc_env
from anonloc_env.camera import Camera, Picture, detection_capacity, survey
from anonloc_env.identify import SensorModel
from tests.helpers import constant_actions, python_output


def _take(config: anonloc_env.EnvConfig, poses: np.ndarray, seed: int = 0):
    return Camera(config).take(poses, np.random.default_rng(seed), 0.0, 0)


def test_untilted_noise_free_detections_are_scale_times_pose_plus_offset() -> None:
    config = anonloc_env.make_config(
        n_robots=5,
        arena_size=(4.0, 3.0),
        camera={
            "scale": 37.5,
            "principal_point": (10.0, -4.0),
            "pixel_noise": 0.0,
            "orientation_noise_deg": 0.0,
        },
    )
    poses = anonloc_env.world.random_poses(config, np.random.default_rng(1))
    picture = _take(config, poses)
    rows = picture.detections[picture.true_index]
    expected_u = 37.5 * (poses[:, 0] - 2.0) + 10.0
    expected_v = 37.5 * (poses[:, 1] - 1.5) - 4.0
    np.testing.assert_allclose(rows[:, 0], expected_u, atol=1e-9)
    np.testing.assert_allclose(rows[:, 1], expected_v, atol=1e-9)
    np.testing.assert_allclose(np.cos(rows[:, 2] - poses[:, 2]), 1.0, atol=1e-12)


def test_default_principal_point_maps_world_origin_to_image_origin() -> None:
    camera = Camera(anonloc_env.make_config(camera={"scale": 50.0}))
    np.testing.assert_allclose(
        camera.project(np.array([[0.0, 0.0], [1.0, 2.0]])), [[0, 0], [50, 100]]
    )


def test_tilt_changes_scale_as_designed() -> None:
    config = anonloc_env.make_config(
        arena_size=(8.0, 8.0), camera={"scale": 20.0, "tilt_deg": 10.0, "height": 12.0}
    )
    camera = Camera(config)
    ys = np.array([0.0, 2.0, 4.0, 6.0, 8.0])
    xy = np.column_stack([np.full(5, 4.0), ys])
    w = 1.0 + (ys - 4.0) * math.sin(math.radians(10.0)) / 12.0
    jac = camera.jacobian(xy)
    np.testing.assert_allclose(jac[:, 0, 0], 20.0 / w, rtol=1e-12)  # u scale is s / w
    np.testing.assert_allclose(jac[:, 1, 1], 20.0 * math.cos(math.radians(10.0)) / w**2, rtol=1e-12)
    # Finite differences agree with the Jacobian.
    eps = 1e-6
    step = np.array([eps, 0.0])
    du = (camera.project(xy + step) - camera.project(xy - step)) / (2 * eps)
    np.testing.assert_allclose(du[:, 0], jac[:, 0, 0], rtol=1e-6)
    # Unprojection inverts projection.
    np.testing.assert_allclose(camera.unproject(camera.project(xy)), xy, atol=1e-9)


def test_paper_preset_scale_spans_the_papers_range() -> None:
    config = anonloc_env.make_config("paper-motion")
    camera = Camera(config)
    grid = np.array([[x, y] for x in np.linspace(0, 8, 9) for y in np.linspace(0, 8, 9)])
    scales = camera.jacobian(grid)[:, 0, 0]  # image units per unit along u
    assert scales.min() == pytest.approx(20.8, abs=0.03)
    assert scales.max() == pytest.approx(22.07, abs=0.03)


def test_counter_clockwise_turn_increases_detected_theta() -> None:
    for tilt in (0.0, 20.0):
        env = anonloc_env.parallel_env(
            n_robots=1,
            dt=0.1,
            picture_interval=0.1,
            camera={"tilt_deg": tilt, "height": 6.0, "orientation_noise_deg": 0.0},
        )
        env.reset(seed=0, options={"poses": [[2.0, 2.0, 0.5]]})
        before = env.picture.detections[0, 2]
        env.step(constant_actions(env, (0.0, 0.5)))  # turn CCW by 0.05 rad
        after = env.picture.detections[0, 2]
        assert 0.0 < after - before < 0.1


def test_miss_rate_matches_setting() -> None:
    config = anonloc_env.make_config(n_robots=20, arena_size=(8.0, 8.0), camera={"p_miss": 0.3})
    camera = Camera(config)
    rng = np.random.default_rng(7)
    poses = anonloc_env.world.random_poses(config, rng)
    missed = [np.sum(camera.take(poses, rng, 0.0, 0).true_index < 0) for _ in range(500)]
    n = 500 * 20
    rate = np.sum(missed) / n
    assert abs(rate - 0.3) < 4 * math.sqrt(0.3 * 0.7 / n)  # 4 sigma


def test_false_positive_count_matches_setting_and_stays_in_view() -> None:
    config = anonloc_env.make_config(
        n_robots=2, camera={"false_positives": 2.5, "image_size": (200.0, 150.0)}
    )
    camera = Camera(config)
    rng = np.random.default_rng(3)
    poses = np.array([[2.0, 2.0, 0.0], [2.2, 2.1, 1.0]])
    counts = []
    for _ in range(2000):
        picture = camera.take(poses, rng, 0.0, 0)
        counts.append(picture.n_rows - np.sum(picture.true_index >= 0))
        u_min, v_min, u_max, v_max = camera.field_of_view
        assert np.all((picture.detections[:, 0] >= u_min) & (picture.detections[:, 0] <= u_max))
        assert np.all((picture.detections[:, 1] >= v_min) & (picture.detections[:, 1] <= v_max))
    counts_arr = np.array(counts)
    assert abs(counts_arr.mean() - 2.5) < 4 * math.sqrt(2.5 / 2000)
    assert abs(counts_arr.var() - 2.5) < 0.35  # Poisson: variance equals mean
    assert counts_arr.max() <= detection_capacity(config) - 2


def test_field_of_view_hides_robots_outside() -> None:
    config = anonloc_env.make_config(
        n_robots=2, arena_size=(4.0, 4.0), camera={"scale": 100.0, "image_size": (200.0, 200.0)}
    )
    poses = np.array([[2.0, 2.0, 0.0], [3.5, 3.5, 0.0]])  # the second is 150 px from the centre
    picture = _take(config, poses)
    assert picture.true_index[0] >= 0
    assert picture.true_index[1] == -1
    assert picture.n_rows == 1


def test_permutation_is_uniform() -> None:
    """Over many pictures, robot 0's row is spread evenly over all rows (chi-square test)."""
    n = 6
    config = anonloc_env.make_config(n_robots=n, arena_size=(4.0, 4.0))
    camera = Camera(config)
    rng = np.random.default_rng(11)
    poses = anonloc_env.world.random_poses(config, rng)
    trials = 6000
    counts = np.bincount(
        [camera.take(poses, rng, 0.0, 0).true_index[0] for _ in range(trials)], minlength=n
    )
    expected = trials / n
    chi2 = float(np.sum((counts - expected) ** 2 / expected))
    assert chi2 < 20.5  # 0.999 quantile of chi-square with 5 degrees of freedom


def test_orientation_off_gives_zero_theta() -> None:
    config = anonloc_env.make_config(n_robots=3, camera={"orientation": False})
    poses = anonloc_env.world.random_poses(config, np.random.default_rng(0))
    picture = _take(config, poses)
    assert not picture.has_orientation
    assert np.all(picture.detections[:, 2] == 0.0)


def test_pixel_and_orientation_noise_have_the_set_spread() -> None:
    config = anonloc_env.make_config(
        n_robots=1, camera={"pixel_noise": 2.0, "orientation_noise_deg": 3.0}
    )
    camera = Camera(config)
    rng = np.random.default_rng(5)
    poses = np.array([[2.0, 2.0, 0.0]])
    clean = camera.project(poses[:, :2])[0]
    rows = np.array([camera.take(poses, rng, 0.0, 0).detections[0] for _ in range(4000)])
    assert np.std(rows[:, 0] - clean[0]) == pytest.approx(2.0, rel=0.06)
    assert np.std(rows[:, 1] - clean[1]) == pytest.approx(2.0, rel=0.06)
    assert np.degrees(np.std(rows[:, 2])) == pytest.approx(3.0, rel=0.06)


class _Perfect:
    """The DetectionSource docstring's example: every robot, exactly, shuffled."""

    def __init__(self, camera: Camera, capacity: int | None = None) -> None:
        self.camera = camera
        self.capacity = camera.config.n_robots if capacity is None else capacity

    def take(self, poses: np.ndarray, rng: np.random.Generator, time: float, index: int) -> Picture:
        rows = np.column_stack(
            [self.camera.project(poses[:, :2]), self.camera.image_heading(poses)]
        )
        order = rng.permutation(len(poses))
        return Picture(rows[order], np.argsort(order), time, index, has_orientation=True)


def test_a_custom_detector_sizes_the_observations_and_is_scored_by_its_truth() -> None:
    config = anonloc_env.make_config(n_robots=3, camera={"false_positives": 5.0})
    env = anonloc_env.parallel_env(
        n_robots=3, camera={"false_positives": 5.0}, detector=_Perfect(Camera(config))
    )
    assert env.capacity == 3  # the detector's, not the config's (which leaves room for clutter)
    assert Camera(config).capacity > 3
    observations, infos = env.reset(seed=4)
    first = observations["robot_0"]
    assert first["detections"].shape == (3, 3)
    assert env.observation_space("robot_0").contains(first)
    state = env.state()
    for i, agent in enumerate(env.agents):
        row = first["detections"][infos[agent]["true_index"]]
        np.testing.assert_allclose(row[:2], env.camera.project(state[i : i + 1, :2])[0], rtol=1e-6)


def test_a_detector_that_overflows_its_capacity_is_an_error() -> None:
    config = anonloc_env.make_config(n_robots=3)
    with pytest.raises(ValueError, match="more than its capacity 2"):
        anonloc_env.parallel_env(n_robots=3, detector=_Perfect(Camera(config), 2)).reset(seed=0)
    with pytest.raises(ValueError, match=r"detector\.capacity must be an integer"):
        anonloc_env.parallel_env(n_robots=3, detector=_Perfect(Camera(config), 0))


def test_survey_of_an_untilted_camera_is_its_scale_everywhere() -> None:
    config = anonloc_env.make_config(arena_size=(6.0, 4.0), camera={"scale": 37.5})
    found = survey(config)
    assert found.scale == pytest.approx(37.5, rel=1e-12)
    assert found.scale_spread == pytest.approx(0.0, abs=1e-12)
    assert found.scale_gradient == pytest.approx(0.0, abs=1e-9)
    assert found.field_of_view == Camera(config).field_of_view


def test_survey_of_a_tilted_camera_has_the_gradient_of_its_local_scale() -> None:
    """With a tilt about x the local scale ``s sqrt(cos(tilt)) / w^(3/2)`` changes along y
    only; its largest relative change per metre is at the near edge (smallest w):
    ``1.5 sin(tilt) / (height w)``, up to the survey's finite difference."""
    tilt, height = math.radians(10.0), 12.0
    config = anonloc_env.make_config(
        arena_size=(8.0, 8.0), camera={"scale": 20.0, "tilt_deg": 10.0, "height": height}
    )
    found = survey(config)
    w_near = 1.0 - 4.0 * math.sin(tilt) / height
    assert found.scale_gradient == pytest.approx(1.5 * math.sin(tilt) / (height * w_near), rel=1e-2)
    ys = np.linspace(0.0, 8.0, 9)
    local = 20.0 * math.sqrt(math.cos(tilt)) / (1.0 + (ys - 4.0) * math.sin(tilt) / height) ** 1.5
    assert found.scale == pytest.approx(local.mean(), rel=1e-12)
    assert found.scale_spread == pytest.approx(local.std() / local.mean(), rel=1e-9)


def test_the_camera_is_surveyed_and_the_sensor_model_derived_once_per_config() -> None:
    config = anonloc_env.make_config("paper-motion", n_robots=7)
    again = anonloc_env.make_config("paper-motion", n_robots=7)  # equal, not the same object
    assert survey(config) is survey(again)
    model = SensorModel.from_config(config)
    assert SensorModel.from_config(again) is model
    assert model.scale == survey(config).scale
    assert model.scale_spread == survey(config).scale_spread
    unknown = SensorModel.from_config(config, scale_known=False)
    assert unknown.scale is None
    assert unknown.scale_range == (0.5 * model.scale, 2.0 * model.scale)


def test_the_geometric_camera_never_imports_the_image_path() -> None:
    """An env on the geometric camera, its reward's identifier and a sensor model run without
    :mod:`anonloc_env.images` (it imports only when ``camera.source == "image"``)."""
    script = (
        "import sys, anonloc_env\n"
        "from anonloc_env.identify import SensorModel\n"
        "env = anonloc_env.parallel_env(n_robots=4)\n"
        "env.reset(seed=0)\n"
        "env.step({a: env.action_space(a).sample() for a in env.agents})\n"
        "SensorModel.from_config(env.config)\n"
        "print(sorted(m for m in sys.modules if m.startswith('anonloc_env.images')))\n"
    )
    assert python_output(script) == "[]"
