"""Robots out of view: each registered picture's footprint in the identifier's counting model."""

from __future__ import annotations

import math

import numpy as np
import pytest

import anonloc_env
from anonloc_env.identify import Identifier, SensorModel
from anonloc_env.identify.arrays import is_shared, shared
from anonloc_env.identify.camera_pose import Registration
from anonloc_env.identify.footprint import NDTR_ONE, Footprint, View, ndtr
from anonloc_env.landmarks import border_landmarks
from anonloc_env.odometry import Interval
from anonloc_env.rewards import EnergyCost

SQUARE = ((0.0, 0.0), (100.0, 0.0), (100.0, 100.0), (0.0, 100.0))


def _shifted(du: float, sigma: float = 1e-3) -> Footprint:
    """A 100 x 100 arena seen by a view of its size shifted ``du`` along u."""
    view = View((0.0, 0.0, 100.0, 100.0), SQUARE, offset_sigma=sigma)
    return Footprint.of(view, view.corners() + np.array([du, 0.0]), sigma)


def _config(preset: str, landmarks: bool = False) -> anonloc_env.EnvConfig:
    side = math.sqrt(10)
    camera: dict[str, object] = {"pixel_noise": 1.0, "orientation": False}
    if landmarks:
        camera["landmarks"] = border_landmarks((side, side))
    return anonloc_env.make_config(
        preset, n_robots=10, arena_size=(side, side), camera=camera, max_cycles=1200
    )


def test_only_a_moving_camera_has_a_view() -> None:
    """The fixed camera's identifier is the one it was (no footprint: every robot in view),
    with landmarks or without; a moving camera has one, registered or (round 9) rectified by
    its landmarks, whose footprint the robots observe with the picture (its edges placed to
    the landmarks' fit, the walls where the set point sees them)."""
    assert SensorModel.from_config(_config("default")).view is None
    assert SensorModel.from_config(_config("default", landmarks=True)).view is None
    assert SensorModel.from_config(_config("drone-hover")).view is not None
    rectified = SensorModel.from_config(_config("drone-hover", landmarks=True)).view
    assert rectified is not None
    assert rectified.offset_sigma < 1e-3
    assert 0.3 < rectified.fit_spreads[1] < 0.7


def test_a_shifted_view_leaves_its_strip_out_and_nothing_else() -> None:
    """A view shifted 10 units right of a 100-unit arena: a tenth of the arena out of view, on
    the left; a point inside is in view, one in the strip is not, and beyond the right wall the
    view's own edge is all that counts (the walls' place is not trusted)."""
    fp = _shifted(10.0)
    assert math.isclose(fp.share, 0.9, abs_tol=1e-3)
    p = fp.p_in(np.array([[50.0, 50.0], [5.0, 50.0], [105.0, 50.0]]), np.full(3, 1.0))
    np.testing.assert_allclose(p, [1.0, 0.0, 1.0], atol=1e-6)
    # Uncertain edges: a point on the edge is in view half the time.
    soft = _shifted(10.0, sigma=3.0)
    assert math.isclose(
        float(soft.p_in(np.array([[10.0, 50.0]]), np.zeros(1))[0]), 0.5, abs_tol=1e-6
    )


def test_p_in_skips_only_edges_where_ndtr_is_one_to_the_bit() -> None:
    """``p_in`` multiplies by ``ndtr`` only where a point is less than ``NDTR_ONE`` spreads
    inside an edge: beyond it ``ndtr`` is 1.0 to the bit, so ``p_in`` is the full product's
    floats (NaN included)."""
    beyond = np.concatenate([np.linspace(NDTR_ONE, 40.0, 2001), [1e3, 1e150, np.inf]])
    with np.errstate(over="ignore"):
        assert np.all(ndtr(beyond) == 1.0)
    fp = _shifted(10.0, sigma=3.0)
    rng = np.random.default_rng(5)
    centre = rng.uniform(-20.0, 120.0, (5000, 2))
    var = rng.uniform(0.0, 400.0, 5000)
    var[:3] = np.nan
    full = np.ones(len(centre))
    for normal, edge in zip(fp.normals, fp.edges, strict=True):
        full *= ndtr((edge - centre @ normal) / np.sqrt(var + fp.edge_var))
    np.testing.assert_array_equal(fp.p_in(centre, var), full)


def test_reentry_density_sums_to_the_share_that_comes_back() -> None:
    """A robot spread over the strip out of view, moving 5 units per component, comes back at
    the edge: its density over the arena inside the edge integrates to the stated return, and
    falls off within a few motions of the edge."""
    fp = _shifted(10.0)
    grid = np.stack(np.meshgrid(np.arange(10.05, 100.0, 0.1), np.arange(0.05, 100.0, 0.5)), -1)
    points = grid.reshape(-1, 2)
    density, back = fp.reentry(points, 5.0)
    assert math.isclose(float(density.sum()) * 0.1 * 0.5, back, rel_tol=1e-3)
    assert 0.1 < back < 0.5
    deep = fp.reentry(np.array([[60.0, 50.0], [12.0, 50.0]]), 5.0)[0]
    assert deep[0] < 1e-9 < deep[1]


def test_robot_leaving_and_reentering_the_view_is_right_or_undecided() -> None:
    """Seeded (drone-hover, 10 robots at 1 per m^2, no landmarks, distinct motion, 4 episodes of
    30 pictures): robots the drift carries out of the picture and back are never confidently
    wrong after they come back, and mostly right: 73 of their 106 pictures after a return
    (57 without the footprint, which kept fewer of their tracks through the misses)."""
    import baselines
    from baselines.runner import run_episode

    config = _config("drone-hover")
    returns = right = wrong = 0
    for seed in range(4):
        env = anonloc_env.AnonLocEnv(config, reward_fn=EnergyCost())
        team = baselines.make_team("bayes", env, excitation="distinct")
        result = run_episode(env, team, seed=3000 + seed, max_pictures=30)
        by_robot: dict[int, list[tuple[int, int]]] = {}
        for record in result.records:
            by_robot.setdefault(record.robot, []).append((record.true_index, record.estimate))
        for history in by_robot.values():
            left = False
            for truth, estimate in history:
                if truth < 0:
                    left = True
                elif left:
                    returns += 1
                    right += estimate == truth
                    wrong += estimate >= 0 and estimate != truth
    assert returns >= 20
    assert wrong == 0
    assert right >= 0.6 * returns


def _missed_tracks(config: anonloc_env.EnvConfig) -> tuple[np.ndarray, float]:
    """Position variances of one robot's tracks continued through a miss (its row left out of
    the third picture), and the third picture's registration error."""
    identifier = Identifier(SensorModel.from_config(config), 1)
    rng = np.random.default_rng(7)
    rows = np.column_stack([rng.uniform(30.0, 290.0, (10, 2)), np.zeros(10)])
    rows[0, :2] = (1.0, 150.0)  # at the view's edge: it may leave
    step = Interval.exact(np.array([[0.02, 0.0]]), np.zeros(1))
    identifier.update(rows)
    identifier.update(rows + np.array([2.0, -1.0, 0.0]), step)  # the camera shifted
    identifier.update(rows[1:] + np.array([3.0, 1.0, 0.0]), step)  # and row 0 is not seen
    assert identifier.registration is not None
    tracks = identifier.tracks
    return np.asarray(tracks.pos_var[tracks.row < 0]), identifier.registration.error


def test_a_robot_unseen_carries_the_frames_change(monkeypatch: pytest.MonkeyPatch) -> None:
    """A robot missed in a picture is compared, when seen again, across every registration in
    between: its predicted place's variance grows by each registration's error squared."""
    config = _config("drone-windy")
    widened, error = _missed_tracks(config)
    monkeypatch.setattr(Registration, "unseen", lambda self, pos_var: pos_var)
    plain, _ = _missed_tracks(config)
    assert len(widened) >= 1
    assert error > 0.0
    np.testing.assert_allclose(widened - plain, error**2)


def test_unseen_keeps_a_shared_field_shared() -> None:
    registration = Registration(SensorModel.from_config(_config("drone-hover")).registration)
    registration.error = 3.0
    out = registration.unseen(shared(2.0, 5))
    assert is_shared(out)
    np.testing.assert_allclose(out, 11.0)
    np.testing.assert_allclose(registration.unseen(np.array([1.0, 2.0])), [10.0, 11.0])


def test_a_robot_carried_out_before_it_is_known_keeps_its_place() -> None:
    """40 robots (more rows than ``MISSED_PER_ROBOT``), a view rectified by its landmarks that
    shifts 60 units right at the second picture: the rows left of the new edge are not seen.
    Each robot, unsure of its row, keeps a missed track at each of those rows (they are likely
    out of view now), at most ``LEAVING_ROWS`` of them, and none at a row deep in view; the
    rest of the uniform weight's miss returns to "position unknown" as before."""
    from anonloc_env.identify.out_of_view import LEAVING_ROWS

    side = math.sqrt(40)
    camera: dict[str, object] = {
        "pixel_noise": 1.0,
        "orientation": False,
        "landmarks": border_landmarks((side, side)),
    }
    config = anonloc_env.make_config(
        "drone-hover", n_robots=40, arena_size=(side, side), camera=camera, max_cycles=1200
    )
    model = SensorModel.from_config(config)
    assert model.view is not None
    assert model.registration is None
    identifier = Identifier(model, 40)
    grid = np.stack(np.meshgrid(np.arange(8), np.arange(5)), -1).reshape(-1, 2)
    rows = np.column_stack([40.0 + 78.0 * grid[:, 0], 40.0 + 130.0 * grid[:, 1], np.zeros(40)])
    still = Interval.exact(np.zeros((40, 2)), np.zeros(40))
    corners = model.view.corners()
    identifier.update(rows, footprint=corners)
    out = rows[:, 0] < 60.0  # the first column, carried out of view
    identifier.update(rows[~out], still, footprint=corners + np.array([60.0, 0.0]))
    tracks = identifier.tracks
    missed = tracks.row < 0
    assert 0 < int(out.sum()) <= LEAVING_ROWS
    for robot in range(40):
        places = tracks.pos[missed & (tracks.slot == robot)]
        # A missed track at every row carried out, and at no other.
        np.testing.assert_allclose(np.sort(places[:, 1]), np.sort(rows[out, 1]))
        np.testing.assert_allclose(places[:, 0], rows[out, 0][0])
