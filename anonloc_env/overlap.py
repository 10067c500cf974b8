"""How deep robots overlap each other and the walls, from their poses alone (numpy, no pymunk).

Used to check start poses (the shapes, not only the centres) and by the tests and
``benchmarks/robustness.py`` to measure how solid the robots are. A square is checked with the
separating axis theorem: two convex shapes overlap by the smallest overlap of their projections
on the four edge normals; a circle by the distance of the centres.
"""

from __future__ import annotations

import numpy as np

from anonloc_env.config import RobotConfig
from anonloc_env.neighbours import pairs_within


def half_extents(
    robot: RobotConfig, theta: np.ndarray, axis_angle: np.ndarray | float
) -> np.ndarray:
    """Half the length of each robot's projection on the axis at ``axis_angle`` (m)."""
    half = robot.size / 2.0
    if robot.shape == "circle":
        return np.full(np.broadcast(theta, axis_angle).shape, half)
    rel = np.asarray(theta) - np.asarray(axis_angle)
    return half * (np.abs(np.cos(rel)) + np.abs(np.sin(rel)))


def robot_overlaps(
    robot: RobotConfig, poses: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every pair of robots whose shapes overlap, and how deep.

    Args:
        robot: the robots' shape and size.
        poses: ``(N, 3)`` poses ``(x, y, theta)`` (m, rad).

    Returns:
        ``(i, j, depth)`` with ``i < j``: the penetration depth (m) of each overlapping pair,
        the distance one robot must move to clear the other.
    """
    poses = np.asarray(poses, dtype=np.float64)
    i, j, dist = pairs_within(poses[:, :2], poses[:, :2], 2.0 * robot.radius)
    keep = i < j
    i, j, dist = i[keep], j[keep], dist[keep]
    if robot.shape == "circle":
        depth = robot.size - dist
    else:
        d = poses[j, :2] - poses[i, :2]
        depth = np.full(len(i), np.inf)
        for owner in (i, j):
            for quarter in (0.0, np.pi / 2.0):
                phi = poses[owner, 2] + quarter
                gap = np.abs(d[:, 0] * np.cos(phi) + d[:, 1] * np.sin(phi))
                reach = half_extents(robot, poses[i, 2], phi)
                reach += half_extents(robot, poses[j, 2], phi)
                np.minimum(depth, reach - gap, out=depth)
    hit = depth > 0.0
    return i[hit], j[hit], depth[hit]


def wall_overlaps(
    robot: RobotConfig, arena_size: tuple[float, float], poses: np.ndarray
) -> np.ndarray:
    """``(N,)`` how deep (m) each robot's shape reaches into the walls (0 if it is clear)."""
    poses = np.asarray(poses, dtype=np.float64)
    width, height = arena_size
    ex = half_extents(robot, poses[:, 2], 0.0)
    ey = half_extents(robot, poses[:, 2], np.pi / 2.0)
    x, y = poses[:, 0], poses[:, 1]
    reach = np.maximum.reduce([ex - x, x + ex - width, ey - y, y + ey - height])
    return np.maximum(reach, 0.0)
