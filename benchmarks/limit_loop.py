"""The speed limit of anonloc's design: the same pymunk bodies, with nothing but the essentials.

Each step, with the space settings and the solve-then-move order of ``anonloc_env.world``: compute
the forces that ask for the commanded velocities from an ``(N, 2)`` command array and write them
with ``pymunk.batch``, step the space once, read the poses and solved velocities back, move the
robots by those velocities, push apart the robots that overlap (the world's own
:class:`anonloc_env.separation.Separator`: solid robots are part of the design) and write the
poses back (velocities zeroed), shuffle a picture every ``steps_per_picture`` steps, and build
every agent's observation dict (the same keys as the env's) from views of shared arrays. No
validation, odometry, rewards, infos, schedule or wall clamp.

The env cannot be faster than this; ``bench_env.py`` reports the env's speed as a fraction of it.
"""

from __future__ import annotations

import math

import numpy as np
import pymunk
import pymunk.batch as pmb

from anonloc_env.config import RobotConfig
from anonloc_env.separation import SOLID, Separator


class LimitLoop:
    """A bare pymunk loop over ``n`` square robots in an arena of side ``side`` (m)."""

    def __init__(self, n: int, side: float, dt: float, steps_per_picture: int, seed: int) -> None:
        self.n, self.dt, self.steps_per_picture = n, dt, steps_per_picture
        self.rng = np.random.default_rng(seed)
        self.space = pymunk.Space(threaded=False)
        self.space.damping = 0.0  # as in anonloc_env.world: velocity before the solve = force * dt
        robot = RobotConfig()  # the default robot, as in the benchmark's env
        self.space.collision_slop = robot.size * 1e-3
        self.space.collision_bias = 1.0  # pymunk's position correction off: the Separator's job
        grid = math.ceil(math.sqrt(n))
        bodies = []
        for i in range(n):
            body = pymunk.Body(1.0, math.inf)
            body.position = ((i % grid + 0.5) * side / grid, (i // grid + 0.5) * side / grid)
            box = pymunk.Poly.create_box(body, (robot.size, robot.size))
            box.filter = SOLID
            self.space.add(body, box)
            bodies.append(body)
        r = robot.size / 2.0
        corners = [(-r, -r), (side + r, -r), (side + r, side + r), (-r, side + r)]
        for a, b in zip(corners, corners[1:] + corners[:1], strict=True):
            wall = pymunk.Segment(self.space.static_body, a, b, r)
            wall.filter = SOLID
            self.space.add(wall)
        self.separator = Separator(robot, n)
        buf = pmb.Buffer()
        pmb.get_space_bodies(self.space, pmb.BodyFields.BODY_ID, buf)
        ids = np.frombuffer(buf.int_buf(), dtype=np.uintp)
        assert ids[-1] == self.space.static_body.id, "batch order: the static body comes last"
        self.force = np.zeros((n + 1, 2))
        self.set_buf = pmb.Buffer()
        self.set_buf.set_float_buf(self.force.reshape(-1))
        self.state = np.zeros((n + 1, 5))
        self.state_buf = pmb.Buffer()
        self.state_buf.set_float_buf(self.state.reshape(-1))
        self.get_buf = pmb.Buffer()
        self.poses = np.zeros((n, 3))
        self.observations = BareObservations(n, steps_per_picture, self.rng)

    def step(self, commands: np.ndarray) -> dict[str, dict[str, np.ndarray]]:
        """One step with ``commands`` ``(N, 2)`` = (v, w)."""
        n = self.n
        theta = self.poses[:, 2]
        self.force[:n, 0] = commands[:, 0] * np.cos(theta) / self.dt
        self.force[:n, 1] = commands[:, 0] * np.sin(theta) / self.dt
        pmb.set_space_bodies(self.space, pmb.BodyFields.FORCE, self.set_buf)
        self.space.step(self.dt)
        self.get_buf.clear()
        fields = pmb.BodyFields.POSITION | pmb.BodyFields.ANGLE | pmb.BodyFields.VELOCITY
        pmb.get_space_bodies(self.space, fields, self.get_buf)
        state = np.frombuffer(self.get_buf.float_buf()).reshape(-1, 5)[:n]
        self.state[:n, :2] = state[:, :2] + state[:, 3:] * self.dt
        self.state[:n, 2] = state[:, 2] + commands[:, 1] * self.dt
        heading = np.exp(1j * self.state[:n, 2])
        self.separator.separate(self.state[:n, :2], heading, _no_clamp)
        pmb.set_space_bodies(self.space, fields, self.state_buf)
        self.poses = self.state[:n, :3].copy()
        return self.observations.build(self.poses)


class BareObservations:
    """What a bare loop must hand back each step: a shuffled picture every ``steps_per_picture``
    steps and every agent's observation dict (the env's keys) from views of shared arrays.

    Args:
        n: the number of agents.
        steps_per_picture: steps between two pictures.
        rng: shuffles the pictures.
    """

    def __init__(self, n: int, steps_per_picture: int, rng: np.random.Generator) -> None:
        self.n, self.steps_per_picture, self.rng = n, steps_per_picture, rng
        self.agents = [f"robot_{i}" for i in range(n)]
        self.picture = np.zeros((n, 3), np.float32)
        self.mask = np.ones(n, np.float32)
        self.flag = np.zeros(1, np.float32)
        self.interval = np.zeros(1, np.float32)
        self.between_rows = list(np.zeros((n, 3), np.float32))
        self.steps = 0

    def build(self, poses: np.ndarray) -> dict[str, dict[str, np.ndarray]]:
        """The observation dicts after a step that left the robots at ``poses`` ``(N, 3)``."""
        n = self.n
        self.steps += 1
        if self.steps % self.steps_per_picture == 0:
            self.picture = poses[self.rng.permutation(n)].astype(np.float32)
            self.between_rows = list(poses.astype(np.float32))  # changes at pictures only
        odometry = poses.astype(np.float32)
        bumper = np.zeros((n, 1), np.float32)
        since = np.zeros(1, np.float32)
        picture, mask, flag, interval = self.picture, self.mask, self.flag, self.interval
        return {
            agent: {
                "detections": picture,
                "mask": mask,
                "new_picture": flag,
                "since_picture": since,
                "odometry": odo,
                "bumper": bump,
                "odometry_between": between,
                "interval": interval,
            }
            for agent, odo, bump, between in zip(
                self.agents, list(odometry), list(bumper), self.between_rows, strict=True
            )
        }


def _no_clamp() -> None:
    """The limit loop keeps robots in the arena by pymunk's walls alone."""
