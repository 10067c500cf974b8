"""Frozen, validated configuration of the task.

Four layers, one dataclass each, gathered in :class:`EnvConfig`:

* :class:`RobotConfig`: the identical unicycle robots (size, speed limits, odometry noise);
* :class:`CameraConfig`: the overhead pinhole camera and its detector (scale, tilt, noise, misses,
  false positives, orientation);
* :class:`ScheduleConfig`: when pictures are taken (interval, jitter, blackouts);
* :class:`ObservationConfig` and :class:`RewardConfig`: what each robot observes, and the built-in
  reward's weights.

Units are SI: metres (m), seconds (s), radians (rad) unless a field's name says ``_deg``. Image
coordinates are in *image units* (pixels for a real camera). Every value is checked when the object
is built; a wrong value raises an error naming the field and its accepted range, so a bad config
never reaches the simulation.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Sized
from dataclasses import dataclass, field

from anonloc_env._checks import check_choice, check_number, check_pair

ROBOT_SHAPES = ("square", "circle")
CAMERA_SOURCES = ("geometric", "image")

#: Fraction of the robot size a robot (corner included) may move in one physics sub-step.
MAX_MOVE_PER_SUBSTEP = 0.1
#: Most physics sub-steps one control step may take; a robot so small or fast that it needs more
#: is refused (a step would take seconds or hang).
MAX_SUBSTEPS = 1000
#: Largest arena side, camera scale times arena side, and image coordinate accepted: far inside
#: float32 (observations are float32), so that no detection can become infinite.
MAX_LENGTH = 1e6
MAX_IMAGE_COORDINATE = 1e9
#: Upper bound of each reward weight and of ``reward.turn_cost``: rewards stay finite.
MAX_WEIGHT = 1e6
#: Cells across the square drawn on a robot in rendered images: the marker (6 cells, border
#: included) and its white quiet zone (``anonloc_env.images.marker``).
MARKER_TEMPLATE_CELLS = 10
#: Fewest pixels per marker cell ``camera.image_pixels_per_unit`` may give (the image source
#: draws and blurs the marker at that scale; below it the blur grows without bound).
MIN_CELL_PIXELS = 0.1
#: Most ground landmarks ``camera.landmarks`` may hold: ids 1 to 49 of the 50 of ``DICT_4X4_50``
#: (id 0 is the robots').
MAX_LANDMARKS = 49


@dataclass(frozen=True)
class RobotConfig:
    """The N identical robots: unicycles commanded by a forward speed and a turn rate.

    Attributes:
        shape: ``"square"`` (as in the paper's Player-Stage robots) or ``"circle"``.
        size: side of the square, or diameter of the circle (m), in [1e-3, 1e3].
        v_max: largest forward speed |v| a command can ask for (m/s), in (0, 1e6]. An action of
            +1 (or -1) on the first component means ``v = +v_max`` (or ``-v_max``).
        omega_max: largest turn rate |w| (rad/s), in (0, 1e6]. An action of +1 on the second
            component means a counter-clockwise turn at ``omega_max``.

    Physics moves a robot at most a tenth of its size per sub-step, so a control step of
    ``dt`` takes ``ceil((v_max + omega_max * radius) * dt / (0.1 * size))`` sub-steps; the
    :class:`EnvConfig` refuses a robot and ``dt`` that would need more than 1000 (see
    :func:`substeps_needed`).
        odometry_noise: standard deviation of the multiplicative error of each control step's
            measured travelled distance and turned angle (dimensionless, in [0, 1)); 0 means
            exact wheel encoders.
    """

    shape: str = "square"
    size: float = 0.2
    v_max: float = 0.5
    omega_max: float = 1.0
    odometry_noise: float = 0.0

    def __post_init__(self) -> None:
        check_choice("robot.shape", self.shape, ROBOT_SHAPES)
        check_number("robot.size", self.size, 1e-3, 1e3)
        check_number("robot.v_max", self.v_max, 0.0, 1e6, low_open=True)
        check_number("robot.omega_max", self.omega_max, 0.0, 1e6, low_open=True)
        check_number("robot.odometry_noise", self.odometry_noise, 0.0, 1.0, high_open=True)

    @property
    def radius(self) -> float:
        """Radius of the smallest circle around the robot (m)."""
        return self.size / math.sqrt(2.0) if self.shape == "square" else self.size / 2.0

    @property
    def marker_cell(self) -> float:
        """Side of one cell of the marker the robot wears in rendered images (m): the square
        drawn on it (the robot's side, or the largest square in its circle) is
        :data:`MARKER_TEMPLATE_CELLS` cells wide (see ``anonloc_env.images.marker``)."""
        side = self.size if self.shape == "square" else self.size / math.sqrt(2.0)
        return side / MARKER_TEMPLATE_CELLS


@dataclass(frozen=True)
class CameraConfig:
    """The overhead pinhole camera and the detector that turns its picture into a list of rows.

    Untilted, a robot at world position ``(x, y)`` appears at
    ``u = scale * (x - xc) + cu``, ``v = scale * (y - yc) + cv`` where ``(xc, yc)`` is the arena
    centre and ``(cu, cv)`` the ``principal_point``. The image frame is right-handed (``v`` up), so
    a counter-clockwise turn of a robot increases its detected ``theta``. A tilt turns this affine
    map into a homography: the scale then varies across the image (see :mod:`anonloc_env.camera`).

    Attributes:
        scale: image units per metre at the arena centre, in (0, 1e9]; ``scale`` times the
            larger arena side must be at most 1e9 image units. The paper's lambda.
        tilt_deg: rotation of the camera about the world x axis through the arena centre (deg),
            in (-80, 80). Positive tilt puts the camera on the low-y side, so robots at larger y
            are farther away and look smaller.
        height: distance from the camera to the arena centre (m), in (0, 1e9]. Only matters with a
            tilt; it must exceed ``arena_height / 2 * |sin(tilt)|`` so the whole arena is in front
            of the camera.
        principal_point: image coordinates ``(cu, cv)`` of the arena centre, each in [-1e9, 1e9]
            (so that every image coordinate stays finite in float32). ``None`` puts them at
            ``scale * arena_size / 2``, so that untilted, the world origin maps to the image origin.
        image_size: ``(width, height)`` of the field of view in image units, centred on the
            principal point, each in (0, 1e9]; robots outside are not detected. ``None``: the
            whole arena is seen.
        pixel_noise: standard deviation of the Gaussian noise on ``u`` and ``v`` (image units),
            in [0, 1e6].
        orientation: whether the detector measures each robot's heading (a fiducial marker such
            as the paper's ARToolKit patterns does; a blob detector does not). Without it the
            ``theta`` column of every picture is 0.
        orientation_noise_deg: standard deviation of the Gaussian noise on ``theta`` (deg), in
            [0, 180).
        p_miss: probability that a robot is missing from a picture, in [0, 1).
        false_positives: mean number of false detections per picture (Poisson), in [0, 1000].
            They are uniform over the field of view, with a uniform ``theta``.
        source: how pictures are taken: ``"geometric"`` (project the poses and add the noise
            above) or ``"image"`` (render a grayscale image in which every robot carries the same
            ArUco marker and detect the markers with OpenCV; see :mod:`anonloc_env.images`; needs
            the ``images`` extra). With ``"image"`` the errors are the detector's own:
            ``pixel_noise``, ``orientation_noise_deg``, ``p_miss`` and ``false_positives`` are not
            applied; the env states the measured values in their place in ``env.config``
            (:func:`anonloc_env.detection.stated_config`), and localizers model those.
        image_pixels_per_unit: pixels of the rendered image per image unit, in (0, 1000],
            and at least what gives a marker cell 0.1 pixel (:data:`MIN_CELL_PIXELS`).
            ``None`` chooses it so that one cell of a robot's marker spans 5 pixels (a marker of
            30 pixels). Detections are converted back to image units.
        image_blur: standard deviation of the Gaussian blur of the rendered image (pixels), in
            [0, 20].
        image_noise: standard deviation of the Gaussian sensor noise (grey levels of 255), in
            [0, 100].
        image_gradient: illumination gradient: the fraction of brightness lost from the top-left
            to the bottom-right corner of the image, in [0, 1).
        drift: standard deviation of the camera's horizontal position about its set point (m,
            per axis), in [0, 100]: a hovering drone's drift (see ``docs/drone.md``). 0 (and the
            wobbles below at 0) is a fixed camera. Each axis is an Ornstein-Uhlenbeck process.
        drift_time: correlation time of the horizontal drift (s), in (0, 1e6].
        height_wobble: standard deviation of the camera's height about its set point (m), in
            [0, height / 10]: the scale changes with it.
        yaw_wobble_deg: standard deviation of the camera's yaw about the vertical (deg), in
            [0, 30]: the picture turns with it.
        tilt_wobble_deg: standard deviation of the drone's roll and pitch (deg, each), in
            [0, 20], before the gimbal corrects them.
        wobble_time: correlation time of the height, yaw and roll/pitch wobbles (s), in
            (0, 1e6].
        gimbal_bandwidth: bandwidth of the gimbal that holds the camera's tilt against the
            drone's roll and pitch (Hz), in [0, 1000]: the camera is left with the part of the
            wobble faster than it (a first-order lag of time constant ``1 / (2 pi bandwidth)``).
            0: no gimbal, the camera tilts with the drone.
        landmarks: ground positions ``(x, y)`` (m, inside the arena) of fixed markers with
            distinct ids (ArUco ids 1, 2, ... of the robots' dictionary; the robots all wear id
            0), at most 49, at least ``robot.size`` apart. Every picture carries each landmark
            seen, with the same noise and
            misses as a robot's detection: what a localizer needs to know the camera's pose.
        pooled_motion: a moving camera without landmarks, registered by the robots the
            identifier is sure of (their tracks, so their odometry, predict their rows) and each
            row another robot is sure of taken from the rest: the robots then share their
            motions (communication, which the paper's robots do not have; ``docs/drone.md``).
            False (the default): robot i's belief depends on the pictures and its own motion
            only.
    """

    scale: float = 100.0
    tilt_deg: float = 0.0
    height: float = 5.0
    principal_point: tuple[float, float] | None = None
    image_size: tuple[float, float] | None = None
    pixel_noise: float = 0.0
    orientation: bool = True
    orientation_noise_deg: float = 0.0
    p_miss: float = 0.0
    false_positives: float = 0.0
    source: str = "geometric"
    image_pixels_per_unit: float | None = None
    image_blur: float = 0.0
    image_noise: float = 0.0
    image_gradient: float = 0.0
    drift: float = 0.0
    drift_time: float = 5.0
    height_wobble: float = 0.0
    yaw_wobble_deg: float = 0.0
    tilt_wobble_deg: float = 0.0
    wobble_time: float = 1.0
    gimbal_bandwidth: float = 0.0
    landmarks: tuple[tuple[float, float], ...] = ()
    pooled_motion: bool = False

    def __post_init__(self) -> None:
        check_number("camera.scale", self.scale, 0.0, MAX_IMAGE_COORDINATE, low_open=True)
        check_number("camera.tilt_deg", self.tilt_deg, -80.0, 80.0, low_open=True, high_open=True)
        check_number("camera.height", self.height, 0.0, MAX_IMAGE_COORDINATE, low_open=True)
        if self.principal_point is not None:
            pp = check_pair(
                "camera.principal_point",
                self.principal_point,
                low=-MAX_IMAGE_COORDINATE,
                high=MAX_IMAGE_COORDINATE,
            )
            object.__setattr__(self, "principal_point", pp)
        if self.image_size is not None:
            size = check_pair("camera.image_size", self.image_size, high=MAX_IMAGE_COORDINATE)
            object.__setattr__(self, "image_size", size)
        check_number("camera.pixel_noise", self.pixel_noise, 0.0, 1e6)
        if not isinstance(self.orientation, bool):
            raise TypeError(f"camera.orientation must be True or False, got {self.orientation!r}")
        if not isinstance(self.pooled_motion, bool):
            raise TypeError(
                f"camera.pooled_motion must be True or False, got {self.pooled_motion!r}"
            )
        check_number(
            "camera.orientation_noise_deg", self.orientation_noise_deg, 0.0, 180.0, high_open=True
        )
        check_number("camera.p_miss", self.p_miss, 0.0, 1.0, high_open=True)
        check_number("camera.false_positives", self.false_positives, 0.0, 1000.0)
        check_choice("camera.source", self.source, CAMERA_SOURCES)
        if self.image_pixels_per_unit is not None:
            check_number(
                "camera.image_pixels_per_unit",
                self.image_pixels_per_unit,
                0.0,
                1000.0,
                low_open=True,
            )
        check_number("camera.image_blur", self.image_blur, 0.0, 20.0)
        check_number("camera.image_noise", self.image_noise, 0.0, 100.0)
        check_number("camera.image_gradient", self.image_gradient, 0.0, 1.0, high_open=True)
        self._check_motion()

    def _check_motion(self) -> None:
        """Check the camera-motion fields and the landmarks (see the class docstring)."""
        check_number("camera.drift", self.drift, 0.0, 100.0)
        check_number("camera.drift_time", self.drift_time, 0.0, 1e6, low_open=True)
        check_number("camera.height_wobble", self.height_wobble, 0.0, self.height / 10.0)
        check_number("camera.yaw_wobble_deg", self.yaw_wobble_deg, 0.0, 30.0)
        check_number("camera.tilt_wobble_deg", self.tilt_wobble_deg, 0.0, 20.0)
        check_number("camera.wobble_time", self.wobble_time, 0.0, 1e6, low_open=True)
        check_number("camera.gimbal_bandwidth", self.gimbal_bandwidth, 0.0, 1000.0)
        if isinstance(self.landmarks, (str, bytes)) or not isinstance(self.landmarks, Iterable):
            raise TypeError(
                "camera.landmarks must be a sequence of (x, y) ground positions in metres, e.g. "
                f"((0.5, 0.5), (3.5, 0.5)), or () for none; got {self.landmarks!r}"
            )
        given = list(itertools.islice(self.landmarks, MAX_LANDMARKS + 1))  # counted first
        if len(given) > MAX_LANDMARKS:
            count = len(self.landmarks) if isinstance(self.landmarks, Sized) else "more"
            raise ValueError(
                f"camera.landmarks must hold at most {MAX_LANDMARKS} positions (ArUco ids 1 to "
                f"{MAX_LANDMARKS}), got {count}"
            )
        points = tuple(
            check_pair(f"camera.landmarks[{i}]", point, low=-MAX_LENGTH, high=MAX_LENGTH)
            for i, point in enumerate(given)
        )
        object.__setattr__(self, "landmarks", points)

    @property
    def moves(self) -> bool:
        """Whether the camera moves between pictures (a drift or a wobble is set)."""
        return (
            self.drift > 0.0
            or self.height_wobble > 0.0
            or self.yaw_wobble_deg > 0.0
            or self.tilt_wobble_deg > 0.0
        )


@dataclass(frozen=True)
class ScheduleConfig:
    """When the camera takes pictures.

    The first picture is taken at reset (t = 0); picture k is due at ``k * picture_interval``
    plus a jitter drawn uniformly in ``[-jitter, +jitter]``, and is taken at the first control
    step at or after that time. No picture is taken inside a blackout window.

    Attributes:
        picture_interval: nominal time between two pictures (s), in (0, 1e9]; at least ``dt``.
        jitter: half-width of the uniform jitter of each picture time (s), in
            [0, picture_interval / 2).
        blackouts: windows ``(start, end)`` in seconds since reset, ``0 <= start < end``, during
            which no picture is taken (a tunnel, an occluded camera).
    """

    picture_interval: float = 1.0
    jitter: float = 0.0
    blackouts: tuple[tuple[float, float], ...] = ()

    def __post_init__(self) -> None:
        check_number("schedule.picture_interval", self.picture_interval, 0.0, 1e9, low_open=True)
        check_number(
            "schedule.jitter", self.jitter, 0.0, self.picture_interval / 2.0, high_open=True
        )
        if isinstance(self.blackouts, (str, bytes)) or not isinstance(self.blackouts, Iterable):
            raise TypeError(
                "schedule.blackouts must be a sequence of (start, end) windows in seconds, e.g. "
                f"((10.0, 20.0),), or () for none; got {self.blackouts!r}"
            )
        windows = []
        for i, window in enumerate(self.blackouts):
            start, end = check_pair(f"schedule.blackouts[{i}]", window, low=-math.inf)
            check_number(f"schedule.blackouts[{i}][0] (start, s)", start, 0.0)
            if not end > start:
                raise ValueError(
                    f"schedule.blackouts[{i}] must have end > start, got ({start}, {end})"
                )
            windows.append((start, end))
        object.__setattr__(self, "blackouts", tuple(windows))


@dataclass(frozen=True)
class ObservationConfig:
    """What each robot observes besides the newest picture and its own odometry.

    Attributes:
        history: number K of earlier pictures kept in the observation, with the robot's own
            odometry between consecutive ones, in [0, 64]. 0 leaves the history keys out.
        max_detections: number of rows of a picture in the observation, in [n_robots, 100000].
            ``None`` sizes it to hold every robot plus the false positives of all but one picture
            in a million. Extra false positives beyond it are dropped (never true detections).
    """

    history: int = 0
    max_detections: int | None = None

    def __post_init__(self) -> None:
        check_number("observation.history", self.history, 0, 64, integer=True)
        if self.max_detections is not None:
            check_number(
                "observation.max_detections", self.max_detections, 1, 100_000, integer=True
            )


@dataclass(frozen=True)
class RewardConfig:
    """Weights of the built-in rewards (see :mod:`anonloc_env.rewards`).

    The energy a robot spends in a control step of length ``dt`` is
    ``dt * (|v| + turn_cost * |w|)`` (m): the distance its wheels roll.

    Attributes:
        information_weight: reward per nat of information gained about the robot's identity,
            in [0, 1e6].
        energy_weight: reward lost per metre of wheel travel (1/m), in [0, 1e6].
        turn_cost: wheel travel per radian turned in place (m/rad), in [0, 1e6]; ``None`` uses
            half the robot's size (a differential drive with wheels at its sides).

    The bounds keep every reward finite: with ``dt``, ``robot.v_max`` and ``robot.omega_max`` at
    their own bounds a step costs at most ``1e6 * 10 * (1e6 + 1e6 * 1e6)`` = 1e19.
    """

    information_weight: float = 1.0
    energy_weight: float = 0.01
    turn_cost: float | None = None

    def __post_init__(self) -> None:
        check_number("reward.information_weight", self.information_weight, 0.0, MAX_WEIGHT)
        check_number("reward.energy_weight", self.energy_weight, 0.0, MAX_WEIGHT)
        if self.turn_cost is not None:
            check_number("reward.turn_cost", self.turn_cost, 0.0, MAX_WEIGHT)


#: The most ``step()`` calls an episode may last (:attr:`EnvConfig.max_cycles`).
MAX_CYCLES = 1_000_000


@dataclass(frozen=True)
class EnvConfig:
    """The whole task: arena, robots, camera, picture schedule, observation and reward.

    Attributes:
        n_robots: number N of identical robots, in [1, 100000].
        arena_size: ``(width, height)`` of the walled arena (m), each in (0, 1e6]; the lower-left
            corner is the world origin. It must hold N robots without overlap. (With
            :func:`anonloc_env.make_config`, overriding ``n_robots`` alone grows the preset's
            arena to keep its density; a size given explicitly is kept, and refused if too small.)
        dt: control step (s), in (0, 10]: a command is held this long; physics advances once per
            ``step()`` (sub-stepped internally so nothing tunnels, at most 1000 sub-steps: see
            :class:`RobotConfig`).
        max_cycles: number of ``step()`` calls before every agent is truncated, in
            [1, 1000000] (:data:`MAX_CYCLES`: 50,000 s of simulated time at the default ``dt``;
            a longer episode is a hang, not an experiment).
        robot: see :class:`RobotConfig`.
        camera: see :class:`CameraConfig`.
        schedule: see :class:`ScheduleConfig`.
        observation: see :class:`ObservationConfig`.
        reward: see :class:`RewardConfig`.
    """

    n_robots: int = 4
    arena_size: tuple[float, float] = (4.0, 4.0)
    dt: float = 0.05
    max_cycles: int = 600
    robot: RobotConfig = field(default_factory=RobotConfig)
    camera: CameraConfig = field(default_factory=CameraConfig)
    schedule: ScheduleConfig = field(default_factory=ScheduleConfig)
    observation: ObservationConfig = field(default_factory=ObservationConfig)
    reward: RewardConfig = field(default_factory=RewardConfig)

    def __post_init__(self) -> None:
        check_number("n_robots", self.n_robots, 1, 100_000, integer=True)
        object.__setattr__(self, "n_robots", int(self.n_robots))
        arena = check_pair("arena_size", self.arena_size, high=MAX_LENGTH)
        object.__setattr__(self, "arena_size", arena)
        check_number("dt", self.dt, 0.0, 10.0, low_open=True)
        object.__setattr__(self, "dt", float(self.dt))
        check_number("max_cycles", self.max_cycles, 1, MAX_CYCLES, integer=True)
        object.__setattr__(self, "max_cycles", int(self.max_cycles))
        for name, cls in SECTIONS.items():
            if not isinstance(getattr(self, name), cls):
                raise TypeError(
                    f"{name} must be a {cls.__name__} (or a dict of its fields), "
                    f"got {type(getattr(self, name)).__name__}"
                )
        if self.schedule.picture_interval < self.dt:
            raise ValueError(
                f"picture_interval must be >= dt ({self.dt} s), "
                f"got {self.schedule.picture_interval} s"
            )
        substeps = substeps_needed(self.robot, self.dt)
        if substeps > MAX_SUBSTEPS:
            raise ValueError(
                f"robot.v_max + robot.omega_max * radius = "
                f"{self.robot.v_max + self.robot.omega_max * self.robot.radius:g} m/s with "
                f"robot.size={self.robot.size:g} m and dt={self.dt:g} s needs {substeps} physics "
                f"sub-steps per step (a robot moves at most a tenth of its size per sub-step); "
                f"at most {MAX_SUBSTEPS} are allowed: lower the speeds or dt, or enlarge the robot"
            )
        ppu = self.camera.image_pixels_per_unit
        if ppu is not None:
            low = MIN_CELL_PIXELS / (self.robot.marker_cell * self.camera.scale)
            if ppu < low:
                raise ValueError(
                    f"camera.image_pixels_per_unit must be in [{low:.4g}, 1000] with "
                    f"robot.size={self.robot.size:g} m and camera.scale={self.camera.scale:g} "
                    f"(a marker cell of at least {MIN_CELL_PIXELS:g} pixel), got {ppu!r}"
                )
        extent = self.camera.scale * max(self.arena_size)
        if extent > MAX_IMAGE_COORDINATE:
            raise ValueError(
                f"camera.scale * the larger arena side must be at most {MAX_IMAGE_COORDINATE:g} "
                f"image units (float32 observations stay finite), got {extent:g}"
            )
        capacity = arena_capacity(self.arena_size, self.robot)
        if self.n_robots > capacity:
            raise ValueError(
                f"arena_size {self.arena_size} m holds at most {capacity} {self.robot.shape} "
                f"robots of size {self.robot.size} m without overlap; got n_robots={self.n_robots}"
            )
        half_depth = self.arena_size[1] / 2.0 * abs(math.sin(math.radians(self.camera.tilt_deg)))
        if self.camera.height <= half_depth * 1.05:
            raise ValueError(
                f"camera.height must exceed {half_depth * 1.05:.3g} m for tilt_deg="
                f"{self.camera.tilt_deg} (the far edge of the arena would be behind the camera), "
                f"got {self.camera.height} m"
            )
        for i, (x, y) in enumerate(self.camera.landmarks):
            if not (0.0 <= x <= self.arena_size[0] and 0.0 <= y <= self.arena_size[1]):
                raise ValueError(
                    f"camera.landmarks[{i}] must lie in the arena [0, {self.arena_size[0]:g}] x "
                    f"[0, {self.arena_size[1]:g}] m, got ({x:g}, {y:g})"
                )
            for j, (u, v) in enumerate(self.camera.landmarks[:i]):
                if math.hypot(x - u, y - v) < self.robot.size:
                    raise ValueError(
                        f"camera.landmarks[{i}] ({x:g}, {y:g}) is within robot.size = "
                        f"{self.robot.size:g} m of camera.landmarks[{j}] ({u:g}, {v:g}): "
                        "landmarks are markers of a robot's size, so they would overlap, and "
                        "landmarks at one place fix no camera pose (they made localizers decide "
                        "wrongly)"
                    )
        if self.observation.max_detections is not None and (
            self.observation.max_detections < self.n_robots
        ):
            raise ValueError(
                f"observation.max_detections must be in [n_robots={self.n_robots}, 100000], "
                f"got {self.observation.max_detections}"
            )

    @property
    def picture_interval(self) -> float:
        """Nominal time between pictures (s); the same as ``schedule.picture_interval``."""
        return self.schedule.picture_interval

    @property
    def steps_per_picture(self) -> float:
        """Nominal number of control steps between two pictures."""
        return self.schedule.picture_interval / self.dt


#: The config's sections: the name of each nested field of :class:`EnvConfig` and its type.
SECTIONS: dict[str, type] = {
    "robot": RobotConfig,
    "camera": CameraConfig,
    "schedule": ScheduleConfig,
    "observation": ObservationConfig,
    "reward": RewardConfig,
}


def substeps_needed(robot: RobotConfig, dt: float) -> int:
    """Physics sub-steps per control step of ``dt`` s so that no robot (corner included) moves
    more than a tenth of its size in one sub-step."""
    fastest = robot.v_max + robot.omega_max * robot.radius
    return max(1, math.ceil(fastest * dt / (MAX_MOVE_PER_SUBSTEP * robot.size)))


def placement_spacing(robot: RobotConfig) -> float:
    """Centre-to-centre distance (m) that keeps two robots apart whatever their headings."""
    return 2.0 * robot.radius * 1.05


def arena_capacity(arena_size: tuple[float, float], robot: RobotConfig) -> int:
    """How many robots the placement grid of :mod:`anonloc_env.world` fits in the arena."""
    spacing = placement_spacing(robot)
    nx = math.floor(arena_size[0] / spacing)
    ny = math.floor(arena_size[1] / spacing)
    return max(nx, 0) * max(ny, 0)
