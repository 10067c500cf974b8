"""The position correction on its own: which pairs it looks at, and that it leaves none out."""

from __future__ import annotations

import numpy as np
import pytest

from anonloc_env.config import RobotConfig
from anonloc_env.overlap import robot_overlaps
from anonloc_env.separation import SKIN, STOP_OVERLAP, Separator, pairs_within_self


def _separate(separator: Separator, poses: np.ndarray) -> None:
    """One correction of ``poses`` ``(N, 3)`` in place, with no walls."""
    xy = np.ascontiguousarray(poses[:, :2])
    separator.separate(xy, np.exp(1j * poses[:, 2]), lambda: None)
    poses[:, :2] = xy


def _worst_overlap(robot: RobotConfig, poses: np.ndarray) -> float:
    return float(robot_overlaps(robot, poses)[2].max(initial=0.0))


@pytest.mark.parametrize("shape", ["square", "circle"])
def test_a_robot_that_moved_past_the_skin_is_looked_up_again(shape: str) -> None:
    """The neighbour list is built for positions far apart; then one robot lands on another,
    further than half the skin from where it was: the list is rebuilt and the pair separated."""
    robot = RobotConfig(shape=shape)
    separator = Separator(robot, 3)
    poses = np.array([[0.0, 0.0, 0.3], [5.0, 0.0, 0.0], [0.0, 5.0, 1.0]])
    _separate(separator, poses)
    assert separator.rebuilds == 1
    np.testing.assert_array_equal(poses[:, :2], [[0.0, 0.0], [5.0, 0.0], [0.0, 5.0]])
    poses[2, :2] = [0.05 * robot.size, 0.0]  # onto robot 0: 5 m away from where it was
    assert _worst_overlap(robot, poses) > 0.5 * robot.size
    _separate(separator, poses)
    assert separator.rebuilds > 1
    assert _worst_overlap(robot, poses) <= STOP_OVERLAP * robot.size


def test_the_list_is_kept_until_a_robot_moved_half_the_skin() -> None:
    robot = RobotConfig()
    separator = Separator(robot, 2)
    poses = np.array([[0.0, 0.0, 0.0], [5.0, 0.0, 0.0]])
    _separate(separator, poses)
    poses[1, 0] += 0.3 * SKIN * robot.size
    _separate(separator, poses)
    assert separator.rebuilds == 1
    poses[1, 0] += 0.3 * SKIN * robot.size  # 0.6 of the skin from where the list was built
    _separate(separator, poses)
    assert separator.rebuilds == 2


@pytest.mark.parametrize("shape", ["square", "circle"])
def test_a_push_into_a_robot_that_was_not_close_is_corrected(shape: str) -> None:
    """Robots 0 and 1 overlap by 90 % of the size; robot 2 is clear of robot 1, too far to be
    among the pairs projected at first. Pushing 1 out of 0 drives it into 2; that pair must be
    found and separated too (it is left overlapping by about 15 % otherwise)."""
    robot = RobotConfig(shape=shape)
    size = robot.size
    poses = np.array([[1.0, 1.0, 0.0], [1.0 + 0.1 * size, 1.0, 0.0], [1.0 + 1.4 * size, 1.0, 0.0]])
    assert len(robot_overlaps(robot, poses)[0]) == 1  # only 0 and 1
    _separate(Separator(robot, 3), poses)
    assert _worst_overlap(robot, poses) <= STOP_OVERLAP * size
    assert poses[2, 0] > 1.0 + 1.4 * size  # robot 2 was pushed, not left alone
    assert np.all(np.diff(poses[:, 0]) > 0.0)  # nobody passed through anybody


def test_a_pile_is_separated_to_the_stop_overlap() -> None:
    """60 squares dropped at random headings into a 2.4 m box (many of them overlapping
    deeply) come out with no pair overlapping by more than the stop."""
    robot = RobotConfig()
    rng = np.random.default_rng(4)
    poses = np.column_stack([rng.uniform(0, 2.4, (60, 2)), rng.uniform(-np.pi, np.pi, 60)])
    assert _worst_overlap(robot, poses) > 0.5 * robot.size
    _separate(Separator(robot, 60), poses)
    assert _worst_overlap(robot, poses) <= STOP_OVERLAP * robot.size


@pytest.mark.parametrize("seed", range(4))
def test_pairs_within_self_finds_every_close_pair_once(seed: int) -> None:
    """Against all pairs by brute force: points on cell edges, repeated points, one column."""
    rng = np.random.default_rng(seed)
    radius = 0.5
    points = rng.uniform(-3.0, 3.0, (300, 2))
    points[:20] = np.round(points[:20] / radius) * radius  # on the grid's edges
    points[20:30] = points[30]  # ten copies of one point
    points[40:60, 0] = 1.0  # a column
    z = points[:, 0] + 1j * points[:, 1]
    found = pairs_within_self(z, radius)
    assert np.all(found[:, 0] < found[:, 1])
    i, j = np.triu_indices(len(z), k=1)
    close = np.abs(z[j] - z[i]) <= radius
    expected = set(zip(i[close].tolist(), j[close].tolist(), strict=True))
    assert len(found) == len(expected)
    assert set(map(tuple, found.tolist())) == expected
    assert len(pairs_within_self(z[:1], radius)) == 0
