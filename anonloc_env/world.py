"""The physical layer: a walled pymunk arena with N identical unicycle robots.

Each control step the world takes every robot's command ``(v, w)`` at once, advances the physics
once (in ``substeps`` equal sub-steps so that nothing tunnels), and returns, per sub-step, how far
each robot rolled forward and how much it turned, plus which robots a contact pushed or blocked.

Design notes:

* Bodies are dynamic with infinite moment: collisions push robots (a robot can shove another) but
  never spin them; headings change only by the commanded turn rate.
* Velocities are written and poses read for all bodies at once with ``pymunk.batch``'s C
  iterators (no per-body Python loop on the step path; see :class:`BodyBatch`).
  ``cpSpaceEachBody`` visits the robots in the order they were added and the space's static body
  last; the order is checked once when the world is built.
* pymunk integrates positions before it resolves contacts, so a wall is enforced through the
  contact bias: overlap is halved at every sub-step, and a sub-step is short enough that a robot
  moves at most a tenth of its size. A robot held against a wall at full speed overlaps it by at
  most about a fifth of its size and never passes through.
"""

from __future__ import annotations

import math
import warnings
from typing import NamedTuple

import numpy as np
import pymunk
import pymunk.batch as pmb

from anonloc_env.config import EnvConfig, placement_spacing
from anonloc_env.neighbours import pairs_within

#: Fraction of the robot size a robot (corner included) may move in one physics sub-step.
_MAX_MOVE_PER_SUBSTEP = 0.1
#: A robot whose sub-step displacement differs from its command by more than this fraction of
#: its size was pushed or blocked by a contact: its bumper fires.
_BUMP_TOLERANCE = 1e-9
# Flag unions built once: combining enum flags costs microseconds per call.
_SET_FIELDS = pmb.BodyFields.VELOCITY | pmb.BodyFields.ANGULAR_VELOCITY
_GET_FIELDS = pmb.BodyFields.POSITION | pmb.BodyFields.ANGLE
#: One ``(x, y, theta)`` row: ``np.frombuffer`` with it gives ``(N, 3)`` arrays directly.
_POSE = np.dtype((np.float64, 3))
#: Fraction of the overlap of two shapes removed at every sub-step.
_OVERLAP_CORRECTION = 0.5


class Motion(NamedTuple):
    """What the wheels did during one control step.

    Attributes:
        forward: one ``(N,)`` array per sub-step: the distance each robot moved along its heading
            (m). Sideways motion (being pushed) is not seen by wheel encoders and is left out.
        turned: one ``(N,)`` array per sub-step: each robot's heading change (rad).
        contact: ``(N,)`` True where a contact moved the robot off its commanded path (it was
            blocked by a wall or a robot, or pushed): what a bumper switch reports.
    """

    forward: list[np.ndarray]
    turned: list[np.ndarray]
    contact: np.ndarray


def substeps_for(config: EnvConfig) -> int:
    """Number of physics sub-steps per control step that keeps every move short (see module)."""
    robot = config.robot
    fastest = robot.v_max + robot.omega_max * robot.radius
    return max(1, math.ceil(fastest * config.dt / (_MAX_MOVE_PER_SUBSTEP * robot.size)))


def random_poses(config: EnvConfig, rng: np.random.Generator) -> np.ndarray:
    """Draw ``(N, 3)`` non-overlapping poses ``(x, y, theta)`` from ``rng``.

    The arena is cut into a grid of cells at least ``placement_spacing`` wide (larger when the
    arena is roomy, so poses spread out); N distinct cells are drawn, each robot is placed
    uniformly where it fits inside its cell, with a uniform heading. This cannot loop forever: a
    config whose arena is too small is refused when it is built.
    """
    n = config.n_robots
    width, height = config.arena_size
    spacing = placement_spacing(config.robot)
    cell = max(spacing, math.sqrt(width * height / (4.0 * n)))
    nx, ny = int(width // cell), int(height // cell)
    if nx * ny < n:
        cell = spacing
        nx, ny = int(width // cell), int(height // cell)
    cells = rng.choice(nx * ny, size=n, replace=False)
    cell_w, cell_h = width / nx, height / ny
    slack_x = max(cell_w - spacing, 0.0)
    slack_y = max(cell_h - spacing, 0.0)
    x = (cells % nx) * cell_w + (cell_w - slack_x) / 2.0 + rng.uniform(0.0, 1.0, n) * slack_x
    y = (cells // nx) * cell_h + (cell_h - slack_y) / 2.0 + rng.uniform(0.0, 1.0, n) * slack_y
    theta = rng.uniform(-math.pi, math.pi, n)
    return np.column_stack([x, y, theta])


def check_poses(config: EnvConfig, poses: object) -> np.ndarray:
    """Validate user-given initial poses: shape ``(N, 3)``, finite, inside the arena."""
    arr = np.asarray(poses, dtype=np.float64)
    n = config.n_robots
    if arr.shape != (n, 3):
        raise ValueError(
            f"options['poses'] must have shape (n_robots, 3) = ({n}, 3) rows of (x, y, theta), "
            f"got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise ValueError("options['poses'] must be finite")
    i, j, _ = pairs_within(arr[:, :2], arr[:, :2], config.robot.size)
    clash = i < j
    if clash.any():
        a, b = int(i[clash][0]), int(j[clash][0])
        raise ValueError(
            f"options['poses'][{a}] and [{b}] overlap: robots' centres must be at least the "
            f"robot size ({config.robot.size:g} m) apart"
        )
    margin = config.robot.size / 2.0
    width, height = config.arena_size
    outside = (
        (arr[:, 0] < margin)
        | (arr[:, 0] > width - margin)
        | (arr[:, 1] < margin)
        | (arr[:, 1] > height - margin)
    )
    if outside.any():
        k = int(np.flatnonzero(outside)[0])
        raise ValueError(
            f"options['poses'][{k}] = {arr[k].tolist()} puts the robot outside the arena: x must "
            f"be in [{margin:g}, {width - margin:g}] and y in [{margin:g}, {height - margin:g}] m"
        )
    return arr.copy()


class World:
    """pymunk arena, walls and robots. Built afresh (a new single-threaded space) on every reset.

    Args:
        config: the task configuration.
        poses: ``(N, 3)`` initial poses ``(x, y, theta)`` in metres and radians.
    """

    def __init__(self, config: EnvConfig, poses: np.ndarray) -> None:
        self.config = config
        self.n = config.n_robots
        self.substeps = substeps_for(config)
        self.substep_dt = config.dt / self.substeps
        robot = config.robot

        space = pymunk.Space(threaded=False)
        space.damping = 1.0
        space.collision_slop = robot.size * 1e-3
        space.collision_bias = (1.0 - _OVERLAP_CORRECTION) ** (1.0 / self.substep_dt)
        self.space = space

        bodies = []
        for x, y, theta in poses:
            body = pymunk.Body(mass=1.0, moment=math.inf)
            body.position = (float(x), float(y))
            body.angle = float(theta)
            if robot.shape == "square":
                shape: pymunk.Shape = pymunk.Poly.create_box(body, (robot.size, robot.size))
            else:
                shape = pymunk.Circle(body, robot.size / 2.0)
            shape.friction = 0.0
            shape.elasticity = 0.0
            space.add(body, shape)
            bodies.append(body)
        self._add_walls()
        self._bodies = bodies  # keeps the Python wrappers alive next to the C bodies
        self._check_body_order(bodies)

        # (N + 1, 3) velocities: robots first, the static body last (kept at rest).
        self._velocity = np.zeros((self.n + 1, 3), dtype=np.float64)
        self.batch = BodyBatch(space, self._velocity, self.n)
        # Views of the robots' rows and columns, made once; ufuncs write into them.
        self._robot_velocity = self._velocity[: self.n]
        self._vx, self._vy, self._w = self._robot_velocity.T
        # A numpy scalar: comparing an array with a Python float costs a conversion per call.
        self._bump_tolerance = np.float64(_BUMP_TOLERANCE * robot.size)
        self.poses = np.asarray(poses, dtype=np.float64).copy()
        """``(N, 3)`` current poses ``(x, y, theta)``; theta is not wrapped."""

    def _add_walls(self) -> None:
        width, height = self.config.arena_size
        r = max(self.config.robot.size / 2.0, 0.05)  # thick walls: their inner faces are the arena
        corners = [(-r, -r), (width + r, -r), (width + r, height + r), (-r, height + r)]
        for a, b in zip(corners, corners[1:] + corners[:1], strict=True):
            wall = pymunk.Segment(self.space.static_body, a, b, r)
            wall.friction = 0.0
            wall.elasticity = 0.0
            self.space.add(wall)

    def _check_body_order(self, bodies: list[pymunk.Body]) -> None:
        buf = pmb.Buffer()
        pmb.get_space_bodies(self.space, pmb.BodyFields.BODY_ID, buf)
        ids = np.frombuffer(buf.int_buf(), dtype=np.uintp).copy()
        expected = [b.id for b in bodies] + [self.space.static_body.id]
        if ids.tolist() != expected:
            raise RuntimeError(
                "pymunk.batch visits bodies in an unexpected order; this pymunk version is not "
                "supported (anonloc needs pymunk>=7,<8)"
            )

    def step(self, v: np.ndarray, w: np.ndarray) -> Motion:
        """Hold commands ``v`` (m/s) and ``w`` (rad/s), arrays of shape ``(N,)``, for one ``dt``.

        The arithmetic works on 1-D columns: numpy is slower on 2-D strided blocks and
        broadcasts than on a few more 1-D calls.
        """
        h = self.substep_dt
        vx, vy = self._vx, self._vy
        forward, turned = [], []
        worst = None  # per robot, largest gap between its displacement and its command
        np.copyto(self._w, w)
        for _ in range(self.substeps):
            poses = self.poses
            cos, sin = np.cos(poses[:, 2]), np.sin(poses[:, 2])
            np.multiply(v, cos, out=vx)
            np.multiply(v, sin, out=vy)
            self.batch.write_velocities()
            self.space.step(h)
            new = self.batch.read_poses()
            delta = new - poses
            # Wheel encoders see the displacement along the heading only.
            along = delta[:, 0] * cos
            along += delta[:, 1] * sin
            forward.append(along)
            turned.append(delta[:, 2])
            # Free motion moves exactly by the commanded velocity; a contact pushes it off. The
            # whole (N, 3) rows are contiguous: one call each, the heading column is ignored.
            off = self._robot_velocity * h
            np.subtract(delta, off, out=off)
            np.abs(off, out=off)
            if worst is None:
                worst = np.maximum(off[:, 0], off[:, 1])
            else:
                np.maximum(worst, off[:, 0], out=worst)
                np.maximum(worst, off[:, 1], out=worst)
            self.poses = new
        assert worst is not None  # substeps >= 1
        return Motion(forward, turned, worst > self._bump_tolerance)


class BodyBatch:
    """Velocities of every body in, poses of the robots out: one C call each.

    ``pymunk.batch.set_space_bodies`` and ``get_space_bodies`` build a ``pmBatchedData`` struct
    and read an enum at every call, which costs more than their C work for a hundred robots.
    This class makes the same C calls (``cpSpaceEachBody`` with pymunk's batch iterators) with
    structs built once. Those live in pymunk's private cffi module: if it is not as expected,
    the public ``pymunk.batch`` functions are used instead (``fast`` says which), and the tests
    check that both ways give the same poses.

    Args:
        space: the pymunk space.
        velocity: ``(B, 3)`` float64 array, one ``(vx, vy, w)`` row per body of ``space`` in
            ``cpSpaceEachBody`` order; :meth:`write_velocities` sends it to the bodies.
        n: number of leading bodies (the robots) whose poses :meth:`read_poses` returns.
        fast: try the direct C calls (False: always use ``pymunk.batch``).
    """

    def __init__(self, space: pymunk.Space, velocity: np.ndarray, n: int, fast: bool = True):
        self.space = space
        self.n = n
        self._set_buffer = pmb.Buffer()
        self._set_buffer.set_float_buf(velocity.reshape(-1))
        self._get_buffer = pmb.Buffer()
        self.fast = fast and self._prepare_direct_calls()

    def _prepare_direct_calls(self) -> bool:
        """Build the C call arguments once; False if pymunk's internals are not as expected."""
        try:
            from pymunk._chipmunk_cffi import ffi, lib

            set_data = ffi.new("pmBatchedData *")
            set_data.fields = _SET_FIELDS.value
            set_data.floatArray = self._set_buffer._float_arr
            set_data.intArray = self._set_buffer._int_arr
            get_data = ffi.new("pmBatchedData *")
            get_data.fields = _GET_FIELDS.value
            get_data.floatArray = self._get_buffer._float_arr
            get_data.intArray = self._get_buffer._int_arr
            self._set_call = (
                self.space._space,
                ffi.addressof(lib, "pmSpaceBodySetIteratorFuncBatched"),
                set_data,
            )
            self._get_call = (
                self.space._space,
                ffi.addressof(lib, "pmSpaceBodyGetIteratorFuncBatched"),
                get_data,
            )
            self._each_body = lib.cpSpaceEachBody
            self._ffi = ffi
        except Exception as error:  # any surprise in private internals: use the public path
            warnings.warn(
                f"anonloc: pymunk's batch internals differ ({error}); using pymunk.batch, "
                "which is slower",
                RuntimeWarning,
                stacklevel=3,
            )
            return False
        return True

    def write_velocities(self) -> None:
        """Set every body's velocity and angular velocity from the ``velocity`` array."""
        if not self.fast:
            pmb.set_space_bodies(self.space, _SET_FIELDS, self._set_buffer)
            return
        # The iterator reads the array from index ``num`` on; restore it afterwards, as
        # ``pymunk.batch.set_space_bodies`` does.
        array = self._set_buffer._float_arr
        size = array.num
        array.num = 0
        self._each_body(*self._set_call)
        array.num = size

    def read_poses(self) -> np.ndarray:
        """A new ``(n, 3)`` array of the robots' poses ``(x, y, theta)``."""
        buffer = self._get_buffer
        if self.fast:
            array = buffer._float_arr
            array.num = 0  # the iterator appends from ``num`` on (buffer.clear())
            self._each_body(*self._get_call)
            data = self._ffi.buffer(array.arr, 3 * self.n * 8)
        else:
            buffer.clear()
            pmb.get_space_bodies(self.space, _GET_FIELDS, buffer)
            data = buffer.float_buf()
        # A view of pymunk's buffer, which the next read overwrites: keep a copy.
        return np.frombuffer(data, dtype=_POSE, count=self.n).copy()
