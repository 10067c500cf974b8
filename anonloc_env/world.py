"""The physical layer: a walled pymunk arena with N identical unicycle robots.

Each control step the world takes every robot's command ``(v, w)`` at once, advances the physics
once (in ``substeps`` equal sub-steps so that nothing tunnels), and returns, per sub-step, how far
each robot rolled forward and how much it turned, plus which robots a contact pushed or blocked.

Design notes:

* Bodies are dynamic with infinite moment: collisions push robots (a robot can shove another) but
  never spin them; headings change only by the commanded turn rate.
* Poses, velocities and forces are written and states read for all bodies at once with
  ``pymunk.batch``'s C iterators, one write and one read per sub-step (no per-body Python loop
  on the step path; see :class:`BodyBatch`). The poses live in numpy between sub-steps: they
  are written to the bodies at the start of the next one, with its forces (so between two
  ``step`` calls the bodies still hold the last sub-step's start and solved velocities;
  ``World.poses`` is the truth).
  ``cpSpaceEachBody`` visits the robots in the order they were added and the space's static body
  last; the order is checked once when the world is built.
* Solve, then move. pymunk integrates positions at the start of a step with the velocities its
  solver left at the end of the previous one. Writing the commanded velocities before each step
  would discard the solver's work (robots would move into each other by their full command and
  only the position correction would push them back out; crowds then overlapped by up to 80 %
  of a size and a long column pushed into a wall passed through it). So each sub-step asks for
  the command through the force that gives it in one sub-step (``damping = 0`` so the velocity
  is exactly ``f * h``), lets pymunk detect contacts and solve the velocities against them, and
  then moves every robot by its *solved* velocity itself (positions written back with zero
  velocities at the next sub-step, so that pymunk's own integration moves nothing).
* Solid robots: after the move, :class:`anonloc_env.separation.Separator` pushes apart the
  robots that still overlap (pymunk's solver does not converge in a wedged crowd, does not see
  turns, and sees a new contact only a sub-step late) until no pair overlaps by more than 3 % of
  the size (a bounded number of projections; see that module). pymunk's own position correction
  is off: it would correct the same overlaps a second time. Candidate pairs come from a numpy
  neighbour list, rebuilt every few steps; a sub-step in which no pair is close costs a few
  numpy calls.
* Positions are handled as complex numbers ``x + iy`` and headings as unit complex numbers
  ``exp(i theta)``, computed once per sub-step and shared by the forces, the odometry, the
  wall limits and the separation: one ufunc per operation on both coordinates.
* The walls are also a hard limit: after every sub-step a robot is clamped so that its shape
  reaches at most ``_WALL_TOLERANCE`` of its size into a wall, whatever the push. No robot ever
  leaves the arena, in any configuration.
* A sub-step is short enough that a robot (corner included) moves at most a tenth of its size.
"""

from __future__ import annotations

import math
import warnings
from typing import Any, NamedTuple

import numpy as np
import pymunk
import pymunk.batch as pmb

from anonloc_env import compiled
from anonloc_env.config import EnvConfig, placement_spacing, substeps_needed
from anonloc_env.overlap import robot_overlaps, wall_overlaps
from anonloc_env.separation import MAX_PROJECTIONS, SOLID, Separator

#: A robot whose sub-step displacement differs from its command by more than this fraction of
#: its size was pushed or blocked by a contact: its bumper fires.
_BUMP_TOLERANCE = 1e-9
# Flag unions built once: combining enum flags costs microseconds per call.
_STATE_FIELDS = pmb.BodyFields.POSITION | pmb.BodyFields.ANGLE | pmb.BodyFields.VELOCITY
_WRITE_FIELDS = _STATE_FIELDS | pmb.BodyFields.FORCE
#: One ``(x, y, theta, vx, vy)`` row: ``np.frombuffer`` with it gives ``(N, 5)`` arrays directly.
_STATE = np.dtype((np.float64, 5))
#: pymunk's solver iterations per sub-step (its default, 10).
_SOLVER_ITERATIONS = 10
#: How deep (fraction of the robot size) a shape may reach into a wall before it is clamped: a
#: little, so that pymunk still sees the contact and stops the robot itself.
_WALL_TOLERANCE = 0.05


class WheelTravel(NamedTuple):
    """What the wheels did during one control step.

    Attributes:
        forward: ``(S, N)``, a row per sub-step: the distance each robot moved along its heading
            (m). Sideways motion (being pushed) is not seen by wheel encoders and is left out.
        turned: ``(S, N)``, a row per sub-step: each robot's heading change (rad).
        contact: ``(N,)`` True where a contact moved the robot off its commanded path (it was
            blocked by a wall or a robot, or pushed): what a bumper switch reports.
    """

    forward: np.ndarray
    turned: np.ndarray
    contact: np.ndarray


def substeps_for(config: EnvConfig) -> int:
    """Number of physics sub-steps per control step that keeps every move short (see module)."""
    return substeps_needed(config.robot, config.dt)


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
    """Validate user-given initial poses: shape ``(N, 3)``, finite, and every robot's *shape*
    (not only its centre) inside the arena and clear of the others (touching is allowed)."""
    n = config.n_robots
    expected = f"must have shape (n_robots, 3) = ({n}, 3): rows of numbers (x, y, theta)"
    if isinstance(poses, (str, bytes)):
        raise TypeError(f"options['poses'] {expected}, got {poses!r}")
    try:
        arr = np.array(poses, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise TypeError(f"options['poses'] {expected}; {error}") from None
    if arr.shape != (n, 3):
        raise ValueError(f"options['poses'] {expected}, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("options['poses'] must be finite")
    robot = config.robot
    tolerance = 1e-9 * robot.size
    i, j, depth = robot_overlaps(robot, arr)
    clash = depth > tolerance
    if clash.any():
        a, b = int(i[clash][0]), int(j[clash][0])
        raise ValueError(
            f"options['poses'][{a}] and [{b}] overlap by {float(depth[clash][0]):.3g} m: the "
            f"robots' shapes ({robot.shape}s of size {robot.size:g} m at these headings) must "
            "not overlap"
        )
    into_wall = wall_overlaps(robot, config.arena_size, arr) > tolerance
    if into_wall.any():
        k = int(np.flatnonzero(into_wall)[0])
        width, height = config.arena_size
        raise ValueError(
            f"options['poses'][{k}] = {arr[k].tolist()} puts part of the robot outside the arena "
            f"[0, {width:g}] x [0, {height:g}] m: its {robot.shape} of size {robot.size:g} m at "
            "that heading must lie wholly inside"
        )
    return arr


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
        space.damping = 0.0  # a body's velocity before the solve is exactly force * h (mass 1)
        space.iterations = _SOLVER_ITERATIONS
        space.collision_slop = robot.size * 1e-3
        # pymunk's position correction off (bias 1: no overlap removed); the Separator does it.
        space.collision_bias = 1.0
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
            shape.filter = SOLID
            space.add(body, shape)
            bodies.append(body)
        self._add_walls()
        self._bodies = bodies  # keeps the Python wrappers alive next to the C bodies
        self._check_body_order(bodies)
        self.separator = Separator(robot, self.n)

        # (N + 1, 7) rows (x, y, theta, vx, vy, fx, fy): robots first, the static body last (its
        # row stays zero: it sits at the origin, at rest). The velocities stay zero.
        self._state = np.zeros((self.n + 1, 7), dtype=np.float64)
        self.batch = BodyBatch(space, self._state, self.n)
        # Views of the robots' columns, made once; ufuncs write into them.
        self._force = self._state[: self.n, 5:].view(np.complex128)[:, 0]  # fx + i fy
        self._x, self._y, self._theta = self._state[: self.n, :3].T
        self._pose_rows = self._state[: self.n, :3]
        self._xy = self._state[: self.n, :2]
        self._z = self._xy.view(np.complex128)[:, 0]  # x + iy
        # A numpy scalar: comparing an array with a Python float costs a conversion per call.
        self._bump_tolerance = np.float64(_BUMP_TOLERANCE * robot.size)
        self._inv_h = np.float64(1.0 / self.substep_dt)
        self._square = robot.shape == "square"
        self._half = np.float64(robot.size / 2.0)
        self._wall_slack = np.float64(_WALL_TOLERANCE * robot.size)
        # compiled.substep's sizes: the sub-step (s), half size, wall slack, width, height (m).
        self._sizes = np.array(
            [self.substep_dt, self._half, self._wall_slack, *config.arena_size], dtype=np.float64
        )
        self.poses = np.asarray(poses, dtype=np.float64).copy()
        """``(N, 3)`` current poses ``(x, y, theta)``; theta is not wrapped."""
        self._state[: self.n, :3] = self.poses
        # The unit headings exp(i theta) of the current poses and the arena limits of the
        # centres at those headings (see _set_headings): both change only when robots turn.
        self._arena = np.array(config.arena_size, dtype=np.float64)
        self._width, self._height = (float(side) for side in config.arena_size)
        # Two buffers, swapped at each turn: a sub-step still reads the headings it started with.
        self._heading = np.empty(self.n, dtype=np.complex128)
        self._spare_heading = np.empty(self.n, dtype=np.complex128)
        self._low = np.empty((self.n, 1))
        self._high = np.empty((self.n, 2))
        self._set_headings()
        self.compiled = compiled.mode()
        """None: the sub-steps run numpy; else they run :mod:`anonloc_env.compiled`
        (same floats), whose complex products are fused (True) or not, as numpy's are."""

    def _add_walls(self) -> None:
        width, height = self.config.arena_size
        r = max(self.config.robot.size / 2.0, 0.05)  # thick walls: their inner faces are the arena
        corners = [(-r, -r), (width + r, -r), (width + r, height + r), (-r, height + r)]
        for a, b in zip(corners, corners[1:] + corners[:1], strict=True):
            wall = pymunk.Segment(self.space.static_body, a, b, r)
            wall.friction = 0.0
            wall.elasticity = 0.0
            wall.filter = SOLID
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

    def step(self, v: np.ndarray, w: np.ndarray) -> WheelTravel:
        """Hold commands ``v`` (m/s) and ``w`` (rad/s), arrays of shape ``(N,)``, for one ``dt``.

        Each sub-step: the command as a force, pymunk's step (contacts, velocity solve), then
        the move by the solved velocities, clamped to the arena, and the separation of the
        robots that still overlap (see the module). Positions are worked on as complex numbers
        ``x + iy`` and headings as unit complex numbers (one ufunc per operation on both
        coordinates), through views of the state array that goes back to pymunk.
        """
        h = self.substep_dt
        if self.compiled is not None:
            scaled = np.empty((3, self.n))  # the three lines below, in one compiled call
            compiled.scaled(v, w, self._inv_h, h, scaled)
            return self._step_compiled(scaled[0], scaled[1], scaled[2], self.compiled)
        speed = v * self._inv_h  # the force that gives ``v`` in one sub-step (mass 1)
        travel = v * h  # the free move along the heading in one sub-step
        turn = w * h
        z, theta = self._z, self._theta
        forward = np.empty((self.substeps, self.n))
        turned = np.empty((self.substeps, self.n))
        # Per robot, the largest gap between a sub-step's move and its command, along and
        # across its heading.
        worst = np.zeros((self.n, 2))
        for k in range(self.substeps):
            heading = self._heading
            np.multiply(speed, heading, out=self._force)
            self.batch.write()
            self.batch.step(h)
            state = self.batch.read_state()  # (N, 5): the poses as written, solved velocities
            start = state[:, :2].view(np.complex128)[:, 0]
            np.multiply(state[:, 3:].view(np.complex128)[:, 0], h, out=z)
            z += start
            np.add(state[:, 2], turn, out=theta)
            self._set_headings()
            self._clamp_to_arena()
            self.separator.separate(self._xy, self._heading, self._clamp_to_arena)
            # The move in the robot's frame at the start of the sub-step: along + i across.
            moved = (z - start) * heading.conj()
            forward[k] = moved.real  # wheel encoders see the move along the heading only
            np.subtract(theta, state[:, 2], out=turned[k])
            # Free motion moves exactly by the command; a contact pushes the robot off it.
            off = moved - travel
            np.maximum(worst, np.abs(off.view(np.float64).reshape(-1, 2)), out=worst)
        self.poses = self._pose_rows.copy()
        return WheelTravel(forward, turned, self._bumped(worst))

    def _step_compiled(
        self, speed: np.ndarray, travel: np.ndarray, turn: np.ndarray, fused: bool
    ) -> WheelTravel:
        """:meth:`step` with each sub-step's numpy work compiled (same floats): one call
        (``compiled.substep``) while the neighbour list of square robots stands, else three."""
        h, n, kernels = self.substep_dt, self.n, compiled
        forward = np.empty((self.substeps, n))
        turned = np.empty((self.substeps, n))
        worst = np.zeros((n, 2))
        width, height = self._width, self._height
        ours, low, high, force = self._state, self._low, self._high, self._force
        batch, separator = self.batch, self.separator
        for k in range(self.substeps):
            heading, spare = self._heading, self._spare_heading
            np.multiply(speed, heading, out=force)
            batch.write()
            batch.step(h)
            state = batch.read_state()
            self._heading, self._spare_heading = spare, heading
            listed = separator.first_pass()
            if listed is not None:
                pairs, anchor, params = listed
                done = kernels.substep(
                    state, ours, turn, heading, spare, low, high, self._sizes, pairs, anchor,
                    params, MAX_PROJECTIONS, travel, forward[k], turned[k], worst, fused,
                )  # fmt: skip
                if done == 0:
                    continue
                separator.separate_compiled(ours, spare, low, high, fused, first=done)
            else:
                kernels.move(
                    state, ours, n, h, turn, spare, low, high,
                    self._half, self._wall_slack, width, height, self._square,
                )  # fmt: skip
                separator.separate_compiled(ours, spare, low, high, fused)
            kernels.record(state, ours, n, heading, travel, forward[k], turned[k], worst, fused)
        self.poses = self._pose_rows.copy()
        return WheelTravel(forward, turned, kernels.bumped(worst, self._bump_tolerance))

    def _bumped(self, worst: np.ndarray) -> np.ndarray:
        """``(N,)`` whether a robot's largest gap ``worst`` ``(N, 2)`` (along, across) exceeds
        the bump tolerance: ``worst.max(axis=1) > tolerance``, with one elementwise maximum
        (a reduction along an axis of two costs four times more)."""
        return np.maximum(worst[:, 0], worst[:, 1]) > self._bump_tolerance

    def _set_headings(self) -> None:
        """Unit headings ``exp(i theta)`` and the arena limits of the centres at them."""
        heading = self._spare_heading
        self._spare_heading = self._heading
        self._heading = heading
        np.cos(self._theta, out=heading.real)
        np.sin(self._theta, out=heading.imag)
        if self._square:
            extent = np.abs(heading.real)
            extent += np.abs(heading.imag)
            extent *= self._half
        else:
            extent = np.full(self.n, self._half)
        np.subtract(extent, self._wall_slack, out=self._low[:, 0])
        np.subtract(self._arena, self._low, out=self._high)

    def _clamp_to_arena(self) -> None:
        """Keep every shape within ``_WALL_TOLERANCE`` of its size of the walls' inner faces.

        Clamping a centre that is inside its limits leaves it as it was (bit for bit), so every
        robot is clamped, without a test first.
        """
        xy = self._xy
        np.maximum(xy, self._low, out=xy)
        np.minimum(xy, self._high, out=xy)


class BodyBatch:
    """Poses and forces of every body in, states of the robots out: one C call each.

    ``pymunk.batch.set_space_bodies`` and ``get_space_bodies`` build a ``pmBatchedData`` struct
    and read an enum at every call, which costs more than their C work for a hundred robots.
    This class makes the same C calls (``cpSpaceEachBody`` with pymunk's batch iterators) with
    structs built once. Those live in pymunk's private cffi module: if it is not as expected,
    the public ``pymunk.batch`` functions are used instead (``fast`` says which), and the tests
    check that both ways give the same poses.

    Args:
        space: the pymunk space.
        state: ``(B, 7)`` float64 array of ``(x, y, theta, vx, vy, fx, fy)`` rows, one per body
            of ``space`` in ``cpSpaceEachBody`` order; :meth:`write` sends it to the bodies.
        n: number of leading bodies (the robots) whose states :meth:`read_state` returns.
        fast: try the direct C calls (False: always use ``pymunk.batch``).
    """

    def __init__(self, space: pymunk.Space, state: np.ndarray, n: int, fast: bool = True):
        self.space = space
        self.n = n
        self._state_buffer = pmb.Buffer()
        self._state_buffer.set_float_buf(state.reshape(-1))
        self._get_buffer = pmb.Buffer()
        self._read_at: Any = None  # where the last fast read's view points (a cffi pointer)
        self._read_view = np.zeros((0, 5))
        self.fast = fast and self._prepare_direct_calls()

    def _prepare_direct_calls(self) -> bool:
        """Build the C call arguments once; False if pymunk's internals are not as expected."""
        try:
            from pymunk._chipmunk_cffi import ffi, lib

            def call(buffer: pmb.Buffer, fields: pmb.BodyFields, setter: bool) -> tuple[Any, ...]:
                data = ffi.new("pmBatchedData *")
                data.fields = fields.value
                data.floatArray = buffer._float_arr
                data.intArray = buffer._int_arr
                kind = "Set" if setter else "Get"
                name = f"pmSpaceBody{kind}IteratorFuncBatched"
                return (self.space._space, ffi.addressof(lib, name), data)

            self._state_call = call(self._state_buffer, _WRITE_FIELDS, True)
            self._get_call = call(self._get_buffer, _STATE_FIELDS, False)
            self._each_body = lib.cpSpaceEachBody
            self._space_step = lib.cpSpaceStep
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

    def _set(self, buffer: pmb.Buffer, fields: pmb.BodyFields, call: tuple[Any, ...]) -> None:
        if not self.fast:
            pmb.set_space_bodies(self.space, fields, buffer)
            return
        # The iterator reads the array from index ``num`` on; restore it afterwards, as
        # ``pymunk.batch.set_space_bodies`` does.
        array = buffer._float_arr
        size = array.num
        array.num = 0
        self._each_body(*call)
        array.num = size

    def step(self, dt: float) -> None:
        """``space.step(dt)``: the C step alone while the space has nothing queued that its
        Python wrapper would handle (bodies to check, shapes to add, remove or release,
        post-step callbacks; the world registers no collision handler), else the wrapper."""
        space = self.space
        if self.fast and not (
            space._bodies_to_check
            or space._add_later
            or space._remove_later
            or space._post_step_callbacks
            or space._removed_shapes
        ):
            self._space_step(space._space, dt)
            return
        space.step(dt)

    def write(self) -> None:
        """Set every body's position, angle, velocity and force from the ``state`` array."""
        self._set(self._state_buffer, _WRITE_FIELDS, self._state_call if self.fast else ())

    def read_state(self) -> np.ndarray:
        """A view ``(n, 5)`` of the robots' ``(x, y, theta, vx, vy)``, valid until the next read."""
        buffer = self._get_buffer
        if self.fast:
            array = buffer._float_arr
            array.num = 0  # the iterator appends from ``num`` on (buffer.clear())
            self._each_body(*self._get_call)
            pointer = array.arr
            if pointer != self._read_at:  # the first read, or pymunk moved its array
                data = self._ffi.buffer(pointer, 5 * self.n * 8)
                self._read_view = np.frombuffer(data, dtype=_STATE, count=self.n)
                self._read_at = pointer
            return self._read_view
        buffer.clear()
        pmb.get_space_bodies(self.space, _STATE_FIELDS, buffer)
        return np.frombuffer(buffer.float_buf(), dtype=_STATE, count=self.n)
