"""The camera on a drone: its seeded hover, the truth in infos only, refused configs."""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest
from test_identify_paths import _Recorder

import anonloc_env
from anonloc_env.camera import Camera
from anonloc_env.camera_motion import CameraMotion, pose_homography, set_point
from anonloc_env.identify import Identifier, SensorModel
from anonloc_env.identify.camera_pose import Registration, apply
from anonloc_env.identify.out_of_view import claimed_elsewhere
from anonloc_env.identify.pose_guess import Anchors
from anonloc_env.identify.pose_prior import registration_prior
from anonloc_env.identify.tracks import Tracks
from anonloc_env.landmarks import (
    _through,
    border_landmarks,
    fit_homography,
    fit_pose,
    landmark_error,
)
from anonloc_env.odometry import Interval
from anonloc_env.rewards import EnergyCost


def _camera_path(preset: str, seed: int, steps: int = 120) -> list[np.ndarray]:
    env = anonloc_env.parallel_env(preset, n_robots=6)
    _, infos = env.reset(seed=seed)
    path = [infos["robot_0"]["camera_pose"]]
    still = {agent: np.zeros(2, np.float32) for agent in env.agents}
    for _ in range(steps):
        _, _, _, _, infos = env.step(still)
        path.append(infos["robot_0"]["camera_pose"])
    return path


def test_same_seed_same_camera_path_and_another_seed_another() -> None:
    first, again = _camera_path("drone-windy", 3), _camera_path("drone-windy", 3)
    assert all(np.array_equal(a, b) for a, b in zip(first, again, strict=True))
    other = _camera_path("drone-windy", 4)
    assert not np.array_equal(first[-1], other[-1])


def test_fixed_camera_stays_at_its_set_point() -> None:
    config = anonloc_env.make_config("default", n_robots=6)
    path = _camera_path("default", 0, steps=30)
    assert all(np.array_equal(p, set_point(config)) for p in path)


def test_the_set_point_is_the_fixed_camera() -> None:
    config = anonloc_env.make_config(camera={"tilt_deg": 12.0, "height": 6.0})
    np.testing.assert_allclose(
        pose_homography(config, set_point(config)), Camera(config).homography, atol=1e-9
    )


def test_camera_pose_is_in_infos_never_in_observations() -> None:
    moving = anonloc_env.parallel_env("drone-windy", n_robots=5)
    fixed = anonloc_env.parallel_env("default", n_robots=5)
    obs, infos = moving.reset(seed=1)
    assert moving.observation_space("robot_0") == fixed.observation_space("robot_0")
    pose = infos["robot_2"]["camera_pose"]
    assert pose.shape == (6,)
    assert not pose.flags.writeable
    for agent in moving.agents:
        for value in obs[agent].values():
            for component in pose:
                assert not np.isclose(np.asarray(value, np.float64), component, rtol=1e-6).any()


def test_the_picture_moves_with_the_camera_and_robots_leave_the_view() -> None:
    env = anonloc_env.parallel_env("drone-windy", n_robots=16, camera={"drift": 0.5})
    env.reset(seed=2)
    still = {agent: np.zeros(2, np.float32) for agent in env.agents}
    rows, missing = [], 0
    for _ in range(400):
        env.step(still)
        if env.steps % 20 == 0:
            rows.append(np.sort(env.picture.detections[:, 0]))
            missing += int((env.picture.true_index < 0).sum())
    # Robots stand still, yet the picture moves (and with p_miss = 0 only leaving the view misses).
    assert missing > 0
    spread = np.std([r[0] for r in rows])
    assert spread > 5.0


def test_gimbal_leaves_the_fast_part_of_the_tilt() -> None:
    config = anonloc_env.make_config(
        camera={"tilt_wobble_deg": 4.0, "wobble_time": 0.5, "gimbal_bandwidth": 2.0}
    )
    motion = CameraMotion(config)
    rng = np.random.default_rng(0)
    motion.reset(rng)
    rolls = [motion.advance(0.7 * k, rng)[5] for k in range(1, 4000)]
    tau_g = 1.0 / (2.0 * math.pi * 2.0)
    expected = math.radians(4.0) * math.sqrt(tau_g / (0.5 + tau_g))
    assert np.std(rolls) == pytest.approx(expected, rel=0.08)


def test_drift_has_its_standard_deviation_and_correlation_time() -> None:
    config = anonloc_env.make_config(camera={"drift": 0.2, "drift_time": 3.0})
    motion = CameraMotion(config)
    rng = np.random.default_rng(1)
    motion.reset(rng)
    xs = np.array([motion.advance(1.0 * k, rng)[0] for k in range(1, 6000)]) - 2.0
    assert np.std(xs) == pytest.approx(0.2, rel=0.1)
    lag1 = np.corrcoef(xs[:-1], xs[1:])[0, 1]
    assert lag1 == pytest.approx(math.exp(-1.0 / 3.0), abs=0.03)


@pytest.mark.parametrize(
    ("field", "value", "range_text"),
    [
        ("drift", -0.1, "[0, 100]"),
        ("drift_time", 0.0, "(0, 1e+06]"),
        ("height_wobble", 0.6, "[0, 0.5]"),
        ("yaw_wobble_deg", 31.0, "[0, 30]"),
        ("tilt_wobble_deg", 25.0, "[0, 20]"),
        ("wobble_time", -1.0, "(0, 1e+06]"),
        ("gimbal_bandwidth", 2000.0, "[0, 1000]"),
    ],
)
def test_bad_camera_motion_is_refused_naming_field_and_range(
    field: str, value: float, range_text: str
) -> None:
    with pytest.raises(ValueError, match=re.escape(f"camera.{field} must be in {range_text}")):
        anonloc_env.make_config(camera={field: value})


def test_landmarks_outside_the_arena_are_refused() -> None:
    with pytest.raises(ValueError, match=r"camera\.landmarks\[1\] must lie in the arena"):
        anonloc_env.make_config(camera={"landmarks": ((0.5, 0.5), (9.0, 0.5))})


def _set_point_view(env: anonloc_env.AnonLocEnv) -> np.ndarray:
    """Where the camera at its set point would see the robots now (image units)."""
    xy = env.world.poses[:, :2]
    h = env.camera.set_point @ np.column_stack([xy, np.ones(len(xy))]).T
    return (h[:2] / h[2]).T


def test_landmarks_rectify_the_picture_into_the_set_points_frame() -> None:
    arena = (3.0, 3.0)
    config = anonloc_env.make_config(
        "drone-windy",
        n_robots=9,
        arena_size=arena,
        camera={"pixel_noise": 0.0, "landmarks": border_landmarks(arena)},
    )
    env = anonloc_env.AnonLocEnv(config, reward_fn=EnergyCost())
    env.reset(seed=7)
    still = {agent: np.zeros(2, np.float32) for agent in env.agents}
    for _ in range(100):
        env.step(still)
    picture = env.picture
    seen = picture.true_index >= 0
    assert picture.landmarks is not None
    assert len(picture.landmarks) >= 4
    np.testing.assert_allclose(
        picture.detections[picture.true_index[seen], :2], _set_point_view(env)[seen], atol=1e-6
    )


@pytest.mark.parametrize("preset", ["drone-hover", "drone-windy"])
def test_landmark_pose_fit_has_the_error_it_states_below_a_full_homographys(preset: str) -> None:
    """The geometric source's landmarks (8, 1 px) fitted as the camera's pose with the hover's
    prior: over the arena its rectified places are off by what ``landmark_error`` states (within
    10 %, 300 seeded pictures), and by at most 0.8 of a full homography's error (the 4 extra
    directions the camera does not move in)."""
    side = math.sqrt(40.0)
    arena = (side, side)
    config = anonloc_env.make_config(
        preset, n_robots=40, arena_size=arena, camera={"landmarks": border_landmarks(arena)}
    )
    rng = np.random.default_rng(5)
    motion = CameraMotion(config)
    motion.reset(rng)
    world = np.asarray(config.camera.landmarks)
    ids = np.arange(len(world))
    axis = np.linspace(0.0, side, 9)
    grid = np.stack(np.meshgrid(axis, axis), axis=-1).reshape(-1, 2)
    pose_err, full_err = [], []
    for k in range(300):
        truth = pose_homography(config, motion.advance(k + 1.0, rng))
        uv = _through(truth, world) + rng.normal(0.0, 1.0, world.shape)
        at = _through(truth, grid)
        pose_err.append(np.mean((_through(fit_pose(config, ids, uv), grid) - at) ** 2))
        full = fit_homography(world, uv)
        assert full is not None
        full_err.append(np.mean((_through(full, grid) - at) ** 2))
    rms, full_rms = math.sqrt(np.mean(pose_err)), math.sqrt(np.mean(full_err))
    stated = landmark_error(config, 1.0)
    assert 0.9 * stated < rms < 1.1 * stated
    assert rms < 0.8 * full_rms


def test_a_fixed_cameras_landmarks_leave_its_rows_as_taken() -> None:
    """A camera that does not move has its pose known: its landmarks change no row and add no
    error, whatever their noise."""
    arena = (3.0, 3.0)
    config = anonloc_env.make_config(
        n_robots=9, arena_size=arena, camera={"landmarks": border_landmarks(arena)}
    )
    plain = dataclasses.replace(config, camera=dataclasses.replace(config.camera, landmarks=()))
    assert landmark_error(config, 1.0) == 0.0
    rows = []
    for cfg in (config, plain):
        env = anonloc_env.AnonLocEnv(cfg, reward_fn=EnergyCost())
        env.reset(seed=3)
        rows.append(env.picture.detections)
    np.testing.assert_array_equal(rows[0], rows[1])


def test_the_footprint_is_observed_with_landmarks_on_a_moving_camera_only() -> None:
    """Where landmarks rectify a moving camera's pictures, the robots observe where the picture
    covers the arena: its field of view through the landmarks' fit, within a pixel of the true
    one (``landmark_error`` is 0.5 px); no other camera has the key."""
    arena = (3.0, 3.0)
    config = anonloc_env.make_config(
        "drone-windy", n_robots=9, arena_size=arena, camera={"landmarks": border_landmarks(arena)}
    )
    env = anonloc_env.AnonLocEnv(config, reward_fn=EnergyCost())
    env.reset(seed=4)
    still = {agent: np.zeros(2, np.float32) for agent in env.agents}
    for _ in range(3):
        for _ in range(10):
            observations, *_ = env.step(still)
        seen = observations["robot_0"]["footprint"]
        assert seen.shape == (4, 2)
        assert seen is observations["robot_5"]["footprint"]  # one array for the team
        u_min, v_min, u_max, v_max = env.camera.field_of_view
        corners = np.array([[u_min, v_min], [u_max, v_min], [u_max, v_max], [u_min, v_max]])
        warp = env.camera.set_point @ np.linalg.inv(env.camera.homography)
        truth = _through(warp, corners)
        assert float(np.abs(seen - truth).max()) < 3.0
        assert float(np.abs(truth - corners).max()) > 5.0  # the wind moved the view
    for preset, landmarks in (("drone-windy", ()), ("default", border_landmarks(arena))):
        other = anonloc_env.make_config(
            preset, n_robots=9, arena_size=arena, camera={"landmarks": landmarks}
        )
        obs, _ = anonloc_env.AnonLocEnv(other, reward_fn=EnergyCost()).reset(seed=4)
        assert "footprint" not in obs["robot_0"]


def test_a_robot_out_of_the_landmarks_footprint_is_missed_at_no_cost() -> None:
    """Two robots standing still at rows A (near the left wall) and B; the next picture shows B
    only, and its footprint (as the landmarks tell it) leaves A's place out of view: each
    robot's hypothesis that it is at A, unseen, gains on its hypothesis at B against the same
    pictures without the footprint (1.7 nats here: a miss inside the view costs ``log(1e-6)``,
    but without the footprint the count law, one row short of the team, makes a miss cheap
    for every robot alike)."""
    config = anonloc_env.make_config(
        "drone-hover", n_robots=2, camera={"landmarks": border_landmarks((4.0, 4.0))}
    )
    camera = Camera(config)
    a, b = camera.project(np.array([[0.3, 2.0], [2.0, 2.0]]))
    u_min, v_min, u_max, v_max = camera.field_of_view
    view = np.array([[u_min, v_min], [u_max, v_min], [u_max, v_max], [u_min, v_max]])
    shifted = view + np.array([60.0, 0.0])  # the drift moved the view right by 0.6 m
    zero = np.zeros(2)
    still = Interval(np.zeros((2, 2)), zero, zero, zero, zero)
    gaps = []
    for footprint in (shifted, None):
        identifier = Identifier(SensorModel.from_config(config), 2)
        identifier.update(np.array([[*a, 0.0], [*b, 0.0]]), None, view)
        identifier.update(np.array([[*b, 0.0]]), still, footprint)
        tracks = identifier.tracks
        at_a = (tracks.row < 0) & (np.hypot(*(tracks.pos - a).T) < 5.0)
        unseen, at_b = tracks.logw[at_a], tracks.logw[tracks.row == 0]
        assert len(unseen) == len(at_b) == 2  # each robot: at A unseen, or at B
        gaps.append(unseen - at_b)
    assert np.all(gaps[0] - gaps[1] > 1.0)


def test_registration_without_landmarks_follows_the_camera() -> None:
    """Robots standing still: the picture moves only with the camera (by several pixels from
    one picture to the next), and the identifier's registration holds every robot's registered
    place to within a pixel of its place in the previous picture."""
    config = anonloc_env.make_config(
        "drone-hover", n_robots=25, arena_size=(5.0, 5.0), camera={"pixel_noise": 0.0}
    )
    prior = registration_prior(config)
    assert prior is not None
    registration = Registration(prior)
    env = anonloc_env.AnonLocEnv(config, reward_fn=EnergyCost())
    env.reset(seed=3)
    still = {agent: np.zeros(2, np.float32) for agent in env.agents}
    raw_moves, registered_moves = [], []
    previous = None
    for _ in range(300):
        env.step(still)
        picture = env.picture
        if previous is not None and picture.index == previous[0]:
            continue
        registered = registration.register(picture.detections)
        place = {i: registered[r, :2] for i, r in enumerate(picture.true_index) if r >= 0}
        raw = {i: picture.detections[r, :2] for i, r in enumerate(picture.true_index) if r >= 0}
        if previous is not None:
            both = sorted(set(place) & set(previous[1]))
            registered_moves.append(max(np.abs(place[i] - previous[1][i]).max() for i in both))
            raw_moves.append(max(np.abs(raw[i] - previous[2][i]).max() for i in both))
        previous = (picture.index, place, raw)
    assert np.mean(raw_moves) > 2.0  # the camera moved the picture
    # The first interval has nothing to predict the robots' motion with: from the second on,
    # their standing still is known.
    assert max(registered_moves[1:]) < 1.0


def _registration_errors(
    config: anonloc_env.EnvConfig, seed: int, pictures: int
) -> tuple[np.ndarray, np.ndarray]:
    """Robots driving on random commands under ``config``'s moving camera, registered picture by
    picture: each picture's stated error squared and its true one (the mean square change of the
    noise-free rows' registration against the camera's change), from the second interval on."""
    prior = registration_prior(config)
    assert prior is not None
    registration = Registration(prior, orientation=False)
    env = anonloc_env.AnonLocEnv(config, reward_fn=EnergyCost())
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    fixed = Camera(config)
    stated, actual = [], []
    previous = None
    for _ in range(pictures):
        commands = rng.uniform([0.2, -0.5], [0.6, 0.5], size=(len(env.agents), 2))
        for _ in range(int(config.schedule.picture_interval / config.dt)):
            env.step({a: c.astype(np.float32) for a, c in zip(env.agents, commands, strict=True)})
        picture = env.picture
        registration.register(picture.detections)
        seen = np.flatnonzero(picture.true_index >= 0)
        raw = env.camera.project(env.world.poses[seen, :2])  # the rows as taken, noise-free
        offset = apply(registration.transform, prior.centre, raw) - fixed.project(
            env.world.poses[seen, :2]
        )
        now = dict(zip(seen.tolist(), offset, strict=True))
        if previous is not None:
            both = sorted(set(now) & set(previous))
            change = np.array([now[i] - previous[i] for i in both])
            actual.append(float(np.mean(change**2)))
            stated.append(registration.error**2)
        previous = now
    return np.array(stated[1:]), np.array(actual[1:])


def _registration_config(preset: str, n_robots: int, side: float) -> anonloc_env.EnvConfig:
    """``preset`` with ``n_robots`` in a ``side`` x ``side`` m arena, headings not detected, long
    enough for the registration tests' 60 pictures."""
    return anonloc_env.make_config(
        preset,
        n_robots=n_robots,
        arena_size=(side, side),
        camera={"orientation": False},
        max_cycles=1300,
    )


def test_registration_follows_robots_that_back_off_along_their_axis() -> None:
    """Seeded: 40 robots at 1 per m^2 under ``drone-hover``, a ``bayes`` team with ``distinct``
    motion (a new command each picture, a reverse drive after each bump: about half the robots
    go back along the line they came on). Each robot is predicted on or back along its axis, so
    the registration's true error over 20 pictures (2 episodes) is under 2.3 px (1.68 measured
    on these seeds; 3.33 when each robot was predicted ahead along its heading only, the same
    spread in every direction)."""
    import baselines

    config = _registration_config("drone-hover", 40, math.sqrt(40))
    config = dataclasses.replace(config, camera=dataclasses.replace(config.camera, pixel_noise=1.0))
    fixed = Camera(config)
    actual = []
    for seed in (0, 1):
        env = anonloc_env.AnonLocEnv(config, reward_fn=EnergyCost())
        team = baselines.make_team("bayes", env, excitation="distinct")
        registration = team.localizer.identifier.registration
        observations, _ = env.reset(seed=seed)
        team.reset(np.random.SeedSequence(seed).spawn(config.n_robots))
        previous, pictures = None, 0
        while pictures < 20:
            actions = team.act([observations[a] for a in env.possible_agents])
            if observations[env.possible_agents[0]]["new_picture"][0] > 0.5:
                pictures += 1
                seen = np.flatnonzero(env.picture.true_index >= 0)
                raw = env.camera.project(env.world.poses[seen, :2])
                offset = apply(registration.transform, registration.prior.centre, raw)
                now = dict(
                    zip(
                        seen.tolist(),
                        offset - fixed.project(env.world.poses[seen, :2]),
                        strict=True,
                    )
                )
                if previous is not None and pictures > 2:  # from the second interval on
                    both = sorted(set(now) & set(previous))
                    actual.append(np.mean([(now[i] - previous[i]) ** 2 for i in both]))
                previous = now
            observations, _, _, _, _ = env.step(
                dict(zip(env.possible_agents, actions, strict=True))
            )
    true_rms = math.sqrt(float(np.mean(actual)))
    assert true_rms < 2.3, true_rms


def test_registration_fits_the_tilts_perspective_where_it_bends_the_picture() -> None:
    """Seeded: 100 robots driving on random commands under ``drone-windy`` (a 10 m view from
    5 m: the 0.28 deg the gimbal leaves bends its edges by about 1.6 px). The registration fits
    the perspective there, and its estimate follows the camera's true one (correlation over 30
    pictures above 0.4; 0.63 measured, about 0 where it is not fitted); under ``drone-hover``
    (0.2 px) it is held at 0."""
    hover = registration_prior(_registration_config("drone-hover", 100, 10.0))
    assert hover is not None
    assert hover.absolute[4] == hover.absolute[5] == 0.0
    config = _registration_config("drone-windy", 100, 10.0)
    prior = registration_prior(config)
    assert prior is not None
    assert prior.absolute[4] > 0.0
    registration = Registration(prior, orientation=False)
    env = anonloc_env.AnonLocEnv(config, reward_fn=EnergyCost())
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    estimated, true = [], []
    for _ in range(30):
        commands = rng.uniform([0.2, -0.5], [0.6, 0.5], size=(len(env.agents), 2))
        for _ in range(int(config.schedule.picture_interval / config.dt)):
            env.step({a: c.astype(np.float32) for a, c in zip(env.agents, commands, strict=True)})
        registration.register(env.picture.detections)
        to_set_point = env.camera.set_point @ np.linalg.inv(env.camera.homography)
        p, q, r = to_set_point[2]
        norm = r + p * prior.centre[0] + q * prior.centre[1]
        estimated.extend(registration.transform[4:6])
        true.extend((p / norm, q / norm))
    correlation = float(np.corrcoef(estimated, true)[0, 1])
    assert correlation > 0.4, correlation


def test_registration_error_says_how_far_off_each_picture_is() -> None:
    """Seeded: 25 robots driving (random commands, 1 px of noise) under the hovering camera.
    The registration's own error, which the identifier adds to each picture's pixel noise, is
    of the right size: over 60 pictures the root mean square of the registered displacements'
    true error (noise-free rows: the change of the registration against the camera's change)
    within 0.7 to 1.4 times that of the stated errors (1.06 measured with ``ERROR_FACTOR`` at
    1.3, 0.88 at 1.6; 0.97 before the stated error took the two guesses' disagreement)."""
    config = _registration_config("drone-hover", 25, 5.0)
    stated, actual = _registration_errors(config, 5, 60)
    ratio = math.sqrt(np.mean(actual) / np.mean(stated))
    assert 0.7 < ratio < 1.4, ratio


def test_registration_error_has_no_heavy_tail_in_wind() -> None:
    """Seeded: 10 robots at 1 per m^2 driving on random commands under ``drone-windy``, 4
    episodes of 30 pictures. A picture's true error is more than 2.15 times the stated one (a
    calibrated Gaussian's 99th percentile for this measure) in at most 6 of them (6 of 112
    measured with the least-cost matching of round 15, 5 with mutual nearest neighbours before
    it; over 40 seeds 5.45 % of 1,120 pictures with either; 5 of 112, 2.7 times at the 99th
    percentile, with ``ERROR_FACTOR`` at 1.3, calibrated on ``drone-hover``, whose stated error
    it left too large; 3 of 112 and 2.4 times at 1.6, the bound then 3 %; 5 of 112, and 5.7
    times at the 99th percentile, before the stated error took the disagreement between the
    registrations under the two guesses of the robots' motion)."""
    config = _registration_config("drone-windy", 10, math.sqrt(10))
    runs = [_registration_errors(config, seed, 30) for seed in range(4)]
    stated = np.concatenate([r[0] for r in runs])
    actual = np.concatenate([r[1] for r in runs])
    assert len(stated) == 112
    assert int(np.sum(actual > 2.15**2 * stated)) <= 6


def test_registration_matches_again_until_a_turn_of_the_camera_is_followed() -> None:
    """Seeded: 100 robots at 1 per m^2 driving on random commands under ``drone-windy`` (its
    yaw and zoom move the rows at the view's edge by 20 px and more a picture). Matched and
    fitted until the matches hold, the registration's true error over 30 pictures is under
    3.3 px (2.1 and 2.6 measured on these seeds; 4.6 to 4.9 with two rounds of matching), and
    the stated error stays within 0.7 to 1.4 times it (1.03 and 0.90 measured)."""
    config = _registration_config("drone-windy", 100, 10.0)
    for seed in (0, 1):
        stated, actual = _registration_errors(config, seed, 30)
        true_rms = math.sqrt(np.mean(actual))
        assert true_rms < 3.3, (seed, true_rms)
        assert 0.7 < math.sqrt(np.mean(stated)) / true_rms < 1.4


def test_a_few_robots_that_agree_by_chance_do_not_make_the_registration_sure() -> None:
    """Seeded: 30 robots driving (12 px per component between pictures) under a still camera,
    then a picture where only 8 robots are in view, each exactly where the registration
    predicted it. Their residuals say nothing of the robots' spread: the stated error must not
    fall below that of the 30-robot pictures before (the running scale holds it up: 4.2 px
    against 3.4 measured; from the 8 residuals alone it was 1.2)."""
    config = anonloc_env.make_config(
        "drone-hover", n_robots=30, arena_size=(5.0, 5.0), camera={"orientation": False}
    )
    prior = registration_prior(config)
    assert prior is not None
    registration = Registration(prior, orientation=False)
    rng = np.random.default_rng(3)
    places = rng.uniform(50.0, 450.0, size=(30, 2))
    for _ in range(8):
        places = places + rng.normal(0.0, 12.0, size=places.shape)
        registration.register(np.column_stack([places, np.zeros(30)]))
    crowded = registration.error
    target = registration._predicted()[0]  # where each robot of the last picture should be
    registration.register(np.column_stack([target[:8], np.zeros(8)]))
    assert registration.error > crowded


def _drift_of_registration(anchored: int, seed: int = 5) -> tuple[float, float]:
    """A still camera over 30 robots driving 12 px per component between pictures (seeded),
    ``anchored`` of them predicted by their own tracks to the pixel noise (1 px), the others
    guessed: the registration's true error (RMS of the registered rows' common offset from the
    truth over the pictures) and its mean stated error."""
    config = anonloc_env.make_config(
        "drone-hover", n_robots=30, arena_size=(5.0, 5.0), camera={"orientation": False}
    )
    prior = registration_prior(config)
    assert prior is not None
    registration = Registration(prior, orientation=False)
    rng = np.random.default_rng(seed)
    places = rng.uniform(100.0, 400.0, size=(30, 2))
    offsets, stated = [], []
    for picture in range(12):
        moved = places + rng.normal(0.0, 12.0, size=places.shape)
        sure = None
        if picture and anchored:
            k = np.arange(anchored)
            sure = Anchors(
                k, moved[k] + rng.normal(0.0, 1.0, (anchored, 2)), np.full(anchored, 1.5)
            )
        rows = moved + rng.normal(0.0, 1.0, size=moved.shape)
        registered = registration.register(np.column_stack([rows, np.zeros(30)]), sure)
        if picture >= 2:
            offsets.append(np.mean(registered[:, :2] - moved, axis=0))
            stated.append(registration.error)
        places = moved
    return float(np.sqrt(np.mean(np.square(offsets)))), float(np.mean(stated))


def test_robots_the_identifier_is_sure_of_anchor_the_registration() -> None:
    """Seeded: with 20 of 30 robots predicted by their own tracks (``anchors.sure_moves``)
    the registration follows the truth several times closer than from its guess of the robots'
    motion (0.3 against 2.7 px, per component; 0.2 against 3.9 to 6.9 px on three other
    seeds), and it says so (its stated error falls from 4.3 to 0.7 px); the anchors do not
    make it overconfident (true under stated)."""
    guessed, guessed_stated = _drift_of_registration(0)
    sure, sure_stated = _drift_of_registration(20)
    assert sure < 0.4 * guessed
    assert sure_stated < 0.5 * guessed_stated
    assert sure < sure_stated


def test_a_row_another_robot_is_sure_of_is_taken_from_the_rest() -> None:
    """Robot 0 is sure of row 3 (0.995); robot 1 holds row 3 at 0.6, row 5 at 0.3 and "position
    unknown" at 0.1: its row 3 is weighed by 1 - 0.995, its weights normalised again and its
    tracks sorted heaviest first; robot 0 is untouched."""
    logw = np.log([0.995, 0.6, 0.3])
    tracks = Tracks.fresh(
        np.array([0, 1, 1]),
        np.array([3, 3, 5]),
        np.zeros((3, 2)),
        logw,
        pos_var=1.0,
        theta=np.nan,
        p_tt=np.inf,
        log_s=0.0,
    )
    uniform = np.full(2, -np.inf)
    unanchored = np.log([0.005, 0.1])
    out, uniform_out, unanchored_out = claimed_elsewhere(tracks, uniform, unanchored, 0.0)
    total = 0.6 * 0.005 + 0.3 + 0.1
    np.testing.assert_array_equal(out.slot, [0, 1, 1])
    np.testing.assert_array_equal(out.row, [3, 5, 3])
    np.testing.assert_allclose(np.exp(out.logw), [0.995, 0.3 / total, 0.003 / total])
    np.testing.assert_allclose(np.exp(unanchored_out), [0.005, 0.1 / total])
    assert np.all(uniform_out == -np.inf)


def _belief_of_robot_0(pooled: bool, others_reversed: bool) -> list[np.ndarray]:
    """Robot 0's belief and miss after each of 12 pictures of a seeded ``drone-hover`` episode
    (8 robots driving on random commands, no headings), the other robots' motions as they were
    or turned back (each one's displacement and turn reversed)."""
    recorder = _Recorder()
    camera = {"orientation": False, "pixel_noise": 1.0, "pooled_motion": pooled}
    env = anonloc_env.parallel_env(
        "drone-hover", n_robots=8, arena_size=(3.0, 3.0), camera=camera, reward_fn=recorder
    )
    env.reset(seed=4)
    rng = np.random.default_rng(4)
    while len(recorder.log) < 12:
        env.step({a: rng.uniform(-1, 1, 2).astype(np.float32) for a in env.agents})
    identifier = Identifier(SensorModel.from_config(env.config), 8)
    out = []
    for rows, interval in recorder.log[:12]:
        if interval is not None and others_reversed:
            d, dphi = interval.d.copy(), interval.dphi.copy()
            d[1:], dphi[1:] = -d[1:], -dphi[1:]
            interval = dataclasses.replace(interval, d=d, dphi=dphi)
        identifier.update(rows, interval)
        out.append(np.append(identifier.belief()[0], identifier.missing()[0]))
    return out


@pytest.mark.parametrize("pooled", [False, True])
def test_a_robots_belief_reads_the_others_motions_only_when_they_are_pooled(pooled: bool) -> None:
    """Under a moving camera without landmarks robot 0's belief depends on the pictures and its
    own motion only (the others' motions reversed change it by not a bit), unless
    ``camera.pooled_motion`` lets the robots the identifier is sure of anchor the registration
    (a communication): then it reads them."""
    own = _belief_of_robot_0(pooled, others_reversed=False)
    reversed_ = _belief_of_robot_0(pooled, others_reversed=True)
    same = all(np.array_equal(a, b) for a, b in zip(own, reversed_, strict=True))
    assert same != pooled


def test_landmark_path_recovers_a_known_pose_from_a_rendered_image() -> None:
    """A rendered picture from a known (windy) pose: the landmarks' corners give the camera's
    homography to a few hundredths of a pixel over the arena, and the robots' rows land where the
    camera at its set point would have seen them."""
    pytest.importorskip("cv2")
    from anonloc_env.images import ImageCamera, landmark_pose

    arena = (3.0, 3.0)
    config = anonloc_env.make_config(
        "drone-windy",
        n_robots=9,
        arena_size=arena,
        camera={"source": "image", "landmarks": border_landmarks(arena)},
    )
    camera = Camera(config)
    pose = set_point(config) + np.array([0.2, -0.15, 0.1, math.radians(3.0), 0.01, -0.01])
    camera.move_to(pose)
    source = ImageCamera(config, camera)
    rng = np.random.default_rng(0)
    poses = np.array([[0.7 + 0.8 * (i % 3), 0.7 + 0.8 * (i // 3), 0.3 * i] for i in range(9)])
    picture = source.take(poses, rng, 0.0, 0)
    found, _, estimated = landmark_pose(
        config, source.frame, *source.detector.markers(source.last_image)
    )
    assert len(found) == len(config.camera.landmarks)
    grid = np.stack(np.meshgrid(np.linspace(0, 3, 7), np.linspace(0, 3, 7)), -1).reshape(-1, 2)
    truth = Camera(config)
    truth.move_to(pose)
    fitted = Camera(config)
    fitted.homography, fitted.inverse = estimated, np.linalg.inv(estimated)
    assert np.abs(fitted.project(grid) - truth.project(grid)).max() < 0.1
    seen = picture.true_index >= 0
    assert seen.all()
    at_set_point = Camera(config).project(poses[:, :2])
    np.testing.assert_allclose(picture.detections[picture.true_index, :2], at_set_point, atol=0.1)


def test_calibration_tool_runs_no_environment() -> None:
    """The calibration tool drives the detection source alone (no env, no import cycle)."""
    import ast
    import inspect

    from anonloc_env.images import calibration

    tree = ast.parse(inspect.getsource(calibration))
    imported = {
        node.module
        for node in ast.walk(tree)
        if isinstance(node, ast.ImportFrom) and node.module is not None
    }
    assert "anonloc_env.env" not in imported
    assert "anonloc_env.rewards" not in imported


@pytest.mark.slow
def test_identifier_reaches_99_percent_under_drone_hover_without_landmarks() -> None:
    """Seeded: 10 robots at 1 per m^2, 1 px, no headings, distinct motion, the camera on a
    hovering drone and no landmarks: at least 10 of 12 episodes reach 99 % within 30 pictures
    (12 do, 6.4 pictures on average, 4 of 2976 confident decisions wrong, with the least-cost
    matching of round 15; 6.5 and 5 of 2951 with mutual nearest neighbours and
    ``ERROR_FACTOR`` at 1.3; 7.7 and 3 of 2848 at 1.6; 11 and 12.3 before the robots' axes in
    the registration, round 8), and at most 0.5 % of the confident decisions are wrong."""
    import baselines
    from baselines.runner import run_episode
    from baselines.scoring import pictures_to_identify

    config = anonloc_env.make_config(
        "drone-hover",
        n_robots=10,
        arena_size=(math.sqrt(10), math.sqrt(10)),
        camera={"pixel_noise": 1.0, "orientation": False},
        max_cycles=1200,
    )
    decided = wrong = reached = 0
    for seed in range(12):
        env = anonloc_env.AnonLocEnv(config, reward_fn=EnergyCost())
        team = baselines.make_team("bayes", env, excitation="distinct")
        result = run_episode(env, team, seed=2000 + seed, max_pictures=30)
        first, _ = pictures_to_identify(result)
        reached += first is not None
        for record in result.records:
            if record.estimate >= 0:
                decided += 1
                wrong += record.estimate != record.true_index
    assert reached >= 10
    assert wrong <= 0.005 * decided


def test_drift_sweep_matches_the_hover_preset() -> None:
    """The study's drift sweep moves only the drift away from the drone-hover preset."""
    from anonloc_cli.sweeps import SWEEPS, overrides

    hover = anonloc_env.make_config("drone-hover").camera
    point = overrides(SWEEPS["drift"], hover.drift)["camera"]
    assert {k: getattr(hover, k) for k in point} == point
    assert overrides(SWEEPS["drift"], 0.0).get("camera") == {}


def test_faithful_motion_survives_a_picture_the_robots_drifted_out_of() -> None:
    """Under a windy drone a picture may hold no robot; the faithful method (as published)
    must decide nothing from it rather than fail."""
    import baselines
    from baselines.runner import run_episode

    env = anonloc_env.AnonLocEnv(anonloc_env.make_config("drone-windy"), reward_fn=EnergyCost())
    team = baselines.make_team("motion", env, mode="faithful")
    result = run_episode(env, team, seed=19, max_pictures=10)
    assert len(result.records) == 40


@pytest.mark.parametrize("preset", ["drone-hover", "drone-windy"])
def test_drone_presets_pass_pettingzoos_checks(preset: str) -> None:
    from pettingzoo.test import parallel_api_test, parallel_seed_test

    def make() -> anonloc_env.AnonLocEnv:
        return anonloc_env.parallel_env(preset, camera={"landmarks": border_landmarks((4, 4))})

    parallel_api_test(make(), num_cycles=200)
    parallel_seed_test(make)
