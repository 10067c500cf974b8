"""The PettingZoo ``ParallelEnv`` adapter: spaces, reset, step, state, infos, rendering."""

from __future__ import annotations

import functools
import numbers
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces
from gymnasium.utils import EzPickle
from pettingzoo import ParallelEnv

from anonloc_env.actions import check_action_array, stack_actions
from anonloc_env.camera import Camera, DetectionSource, Picture
from anonloc_env.camera_motion import CameraMotion
from anonloc_env.config import EnvConfig
from anonloc_env.detection import detection_source, stated_config
from anonloc_env.geometry import wrap_angle
from anonloc_env.observation import ObservationBuilder, observation_space, space_copy
from anonloc_env.odometry import Interval, Odometry
from anonloc_env.presets import PRESETS
from anonloc_env.rewards import EnergyCost, InformationGain, RewardFunction, StepContext
from anonloc_env.robot_view import Step
from anonloc_env.schedule import PictureSchedule
from anonloc_env.world import WheelTravel, World, check_poses, random_poses

RESET_OPTIONS = ("poses",)

ObsDict = dict[str, dict[str, np.ndarray]]


@dataclass(frozen=True)
class ArrayStep:
    """One step of every robot as arrays (:meth:`anonloc_env.env.AnonLocEnv.step_arrays`).

    Attributes:
        seen: what the robots observed, read back from the arrays their observations are built
            from (:class:`anonloc_env.robot_view.Step`, the same bits as ``read_step`` of the
            observation dicts).
        rewards: ``(N,)`` float64, the values of ``step``'s rewards dict.
        truncated: the episode is over (``max_cycles`` reached).
        true_index: ``(N,)`` int64, read-only: each robot's row in the newest picture (-1: not
            in it), the infos' ``true_index``. Ground truth, for scoring only.
    """

    seen: Step
    rewards: np.ndarray
    truncated: bool
    true_index: np.ndarray


def _frozen_int(values: np.ndarray) -> np.ndarray:
    out = np.array(values, dtype=np.int64)
    out.flags.writeable = False
    return out


class AnonLocEnv(ParallelEnv[str, dict[str, np.ndarray], np.ndarray], EzPickle):
    """N identical robots must each find which detection of an overhead camera's picture is itself.

    | | |
    |---|---|
    | Agents | `robot_0` ... `robot_{N-1}`, all alive for the whole episode |
    | Action shape | `(2,)` float32 in [-1, 1] |
    | Observation | `Dict` of float32 arrays: the shared picture, own odometry, bumper |
    | State shape | `(N, 3)` float32: every robot's `(x, y, theta)` |
    | Import | `anonloc_env.parallel_env(preset=None, **overrides)` |

    ## Description
    A camera above a walled arena photographs N identical unicycle robots every
    `picture_interval` seconds. Every robot receives the same picture: an unlabelled, shuffled list
    of detections `(u, v, theta)` in image coordinates, where robots may be missing and false
    detections may appear. No robot has an ID and none communicate. Each robot knows only its own
    velocity commands and wheel odometry, and must work out which row of the picture is itself
    (Poulet, Guerin and Guinand, ICCAR 2017). pymunk resolves collisions between robots and with
    the walls.

    ## Action Space
    `Box(-1, 1, (2,), float32)` per agent: `(v / v_max, w / omega_max)`, the forward speed and
    the counter-clockwise turn rate held for one control step `dt`. Out-of-range actions are
    clipped; a missing, misshapen or non-finite action raises a `ValueError` naming the agent.
    `anonloc_env.to_actions(v, w, robot)` and `to_commands(actions, robot)` convert.

    ## Observation Space
    A `Dict` of fixed-shape float32 arrays (see `anonloc_env.observation`): `detections`
    `(D, 3)` and `mask` `(D,)` of the newest picture (shared, read-only, the same object for every
    agent), `new_picture` `(1,)`, `since_picture` `(1,)` s, the robot's own `odometry`
    `(dx, dy, dphi)` `(3,)` since the newest picture in its frame at that picture, and `bumper`
    `(1,)`. With `observation.history = K > 0`, the K previous pictures and the robot's motion
    between them are added. Observations never contain ground truth.

    ## Rewards
    Pluggable (`reward_fn`, see `anonloc_env.rewards`). The default, `InformationGain`, gives at
    each new picture the information gained about the robot's identity,
    `log P_k(true row) - log P_(k-1)(true row)` in nats under the Bayesian identifier with the true
    noise model, and at every step `-energy_weight * dt * (|v| + turn_cost * |w|)`.
    `EnergyCost` is the energy term alone (cheaper).

    ## Starting State
    Random non-overlapping poses with uniform headings, drawn from the generator seeded by
    `reset(seed=...)`; `reset(options={"poses": array (N, 3)})` sets them exactly. The first
    picture is taken at reset (unless t = 0 lies in a blackout).

    ## Episode End
    No terminations. Every agent is truncated after `max_cycles` steps.

    ## Infos
    `infos[agent]` holds ground truth about the newest picture, for scoring only: `true_index`
    (row of this robot in it, -1 if it was missed or no picture was taken yet), `pose` (the
    robot's true `(x, y, theta)` when it was taken, float64, m and rad; the pose at reset before
    any picture), `picture` (number of pictures taken so far) and `camera_pose` (the camera's
    true pose `(x, y, z, yaw, pitch, roll)` when it was taken, m and rad, read-only: it moves
    with `camera.drift` and the wobbles, see `anonloc_env.camera_motion`). Every robot's current
    pose is `env.state()`.

    ## Arguments
    `config` (an `EnvConfig`; `parallel_env` builds it from a preset and overrides),
    `render_mode` (`None`, `"human"` or `"rgb_array"`), `reward_fn` (a `RewardFunction`), and
    `detector` (a `DetectionSource` to replace the built-in camera). With
    `camera={"source": "image"}` pictures are rendered and their markers detected with OpenCV
    (`anonloc_env.images`, the `images` extra); `render` then shows the image in a corner, and
    `env.config` states the detector's errors measured on seeded pictures in place of the camera's
    nominal `pixel_noise`, `orientation_noise_deg`, `p_miss` and `false_positives`, which the image
    path does not apply (`anonloc_env.detection.stated_config`: the calibration step, once per
    config), so that localizers built for the env model the pictures it takes.

    ## Copies
    A copy made with `pickle` or `copy.deepcopy` is rebuilt from the constructor's arguments
    (`EzPickle`): it is a new env that must be `reset()` before it steps, whatever the episode of
    the original was. To replay an episode, reset the copy with the same seed and actions.

    ## Version History
    * v0: initial release.
    """

    metadata: ClassVar[dict[str, Any]] = {
        "name": "anonloc_v0",
        "render_modes": ["human", "rgb_array"],
        "render_fps": 20,
        "is_parallelizable": True,
    }

    def __init__(
        self,
        config: EnvConfig | None = None,
        render_mode: str | None = None,
        reward_fn: RewardFunction | None = None,
        detector: DetectionSource | None = None,
    ) -> None:
        EzPickle.__init__(self, config, render_mode, reward_fn, detector)
        self.config = config if config is not None else PRESETS["default"]
        if not isinstance(self.config, EnvConfig):
            raise TypeError(f"config must be an EnvConfig, got {type(self.config).__name__}")
        if detector is None:  # its own image source: the config states the measured errors
            self.config = stated_config(self.config)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be one of {[None, *self.metadata['render_modes']]}, "
                f"got {render_mode!r}"
            )
        if reward_fn is not None and not isinstance(reward_fn, RewardFunction):
            raise TypeError("reward_fn must have reset(config, rng) and __call__(context) methods")
        self.render_mode = render_mode
        self.reward_fn: RewardFunction = reward_fn if reward_fn is not None else InformationGain()
        self.camera = Camera(self.config)
        self.camera_motion = CameraMotion(self.config)
        """The camera's pose over the episode (a drone's hover; fixed unless the config says)."""
        if detector is not None and not callable(getattr(detector, "take", None)):
            raise TypeError(
                "detector must have a take(poses, rng, time, index) method returning a Picture "
                f"(see anonloc_env.DetectionSource), got {type(detector).__name__}"
            )
        self.detector: DetectionSource = (
            detector if detector is not None else detection_source(self.config, self.camera)
        )
        self.max_cycles = self.config.max_cycles
        """Steps before truncation; may be changed between episodes (``parallel_api_test`` does)."""

        n = self.config.n_robots
        self.possible_agents = [f"robot_{i}" for i in range(n)]
        self.agents: list[str] = []
        capacity = getattr(self.detector, "capacity", self.camera.capacity)
        if (
            isinstance(capacity, bool)
            or not isinstance(capacity, (int, np.integer))
            or capacity < 1
        ):
            raise ValueError(f"detector.capacity must be an integer >= 1, got {capacity!r}")
        self.capacity = int(capacity)
        """Rows of a picture in the observations (``D``): the detector's ``capacity``, else the
        config's."""
        robot = self.config.robot
        self._command_scale = np.array([robot.v_max, robot.omega_max])
        self._all_false = dict.fromkeys(self.possible_agents, False)
        self._all_true = dict.fromkeys(self.possible_agents, True)
        self._info_templates: list[dict[str, Any]] | None = []
        self._info_source: tuple[np.ndarray, int, Any] = (np.zeros((0, 3)), 0, None)
        self._rng: np.random.Generator | None = None
        self.world: World | None = None
        self.odometry = self._new_odometry()
        self.picture: Picture | None = None
        self.pictures_taken = 0
        self.steps = 0
        self.guesses: dict[str, int | None] = {}
        """Row each robot currently believes is itself; drawn by ``render`` if set (optional)."""
        self._renderer: Any = None

    # The spaces are built when first asked for: building a Box formats its bounds (the state
    # space's (N, 3) arrays through numpy's printer), about 2 ms per env at N = 30, which the
    # learning path (agents.vec builds an env per redrawn episode) never reads.
    @functools.cached_property
    def observation_spaces(self) -> dict[str, spaces.Space[Any]]:
        """One observation space per agent, built once: seeding one agent's space leaves the
        others alone. They share one set of (read-only) bound arrays: memory stays linear in N."""
        obs_space = observation_space(self.config, self.capacity)
        return {
            agent: obs_space if i == 0 else space_copy(obs_space)
            for i, agent in enumerate(self.possible_agents)
        }

    @functools.cached_property
    def action_spaces(self) -> dict[str, spaces.Space[Any]]:
        """One action space per agent, ``Box(-1, 1, (2,), float32)``, each with its own
        generator."""
        return {agent: spaces.Box(-1.0, 1.0, (2,), np.float32) for agent in self.possible_agents}

    @functools.cached_property
    def state_space(self) -> spaces.Box:
        """The space of :meth:`state`: ``(N, 3)`` float32 ``(x, y, theta)`` within the arena."""
        n = self.config.n_robots
        width, height = self.config.arena_size
        high = np.tile(np.array([width, height, np.pi], np.float32), (n, 1))
        low = np.tile(np.array([0.0, 0.0, -np.pi], np.float32), (n, 1))
        return spaces.Box(low, high, (n, 3), np.float32)

    def _new_odometry(self) -> Odometry:
        robot = self.config.robot
        statistics = bool(getattr(self.reward_fn, "needs_statistics", True))
        return Odometry(
            self.config.n_robots, robot.odometry_noise, robot.v_max, self.config.dt, statistics
        )

    # -- PettingZoo API -------------------------------------------------------------------------

    def observation_space(self, agent: str) -> spaces.Space[Any]:
        """The observation space of ``agent`` (the same object on every call)."""
        return self.observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Space[Any]:
        """The action space of ``agent`` (the same object on every call)."""
        return self.action_spaces[agent]

    @property
    def rng(self) -> np.random.Generator:
        """The env's one random generator (seeded by ``reset``)."""
        if self._rng is None:
            raise RuntimeError("call reset() before using the environment")
        return self._rng

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[ObsDict, dict[str, dict[str, Any]]]:
        """Start an episode.

        Args:
            seed: seeds the env's generator (``np.random.default_rng(seed)``); ``None`` continues
                the current stream (or draws fresh entropy on the first reset).
            options: ``{"poses": (N, 3) array}`` sets the initial poses ``(x, y, theta)`` in m
                and rad. Other keys are ignored with a warning listing the valid ones.
        """
        # Everything is checked before any state changes: a refused reset leaves the running
        # episode (and its generator) as it was.
        if seed is not None and (
            isinstance(seed, (bool, np.bool_)) or not isinstance(seed, numbers.Integral) or seed < 0
        ):
            raise ValueError(f"seed must be None or an integer >= 0, got {seed!r}")
        if options is not None and not isinstance(options, Mapping):
            raise TypeError(
                f"options must be a dict such as {{'poses': array (N, 3)}} or None, got {options!r}"
            )
        options = dict(options or {})
        unknown = sorted(map(str, set(options) - set(RESET_OPTIONS)))
        if unknown:
            warnings.warn(
                f"reset options {unknown} are ignored; valid options: {list(RESET_OPTIONS)}",
                stacklevel=2,
            )
        given = check_poses(self.config, options["poses"]) if "poses" in options else None
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        elif self._rng is None:
            self._rng = np.random.default_rng()
        rng = self._rng
        poses = given if given is not None else random_poses(self.config, rng)
        self.world = World(self.config, poses)
        self.odometry = self._new_odometry()
        self.schedule = PictureSchedule(self.config.schedule, self.config.dt, rng)
        self.builder = ObservationBuilder(self.config, self.capacity)
        self.agents = self.possible_agents[:]
        self.steps = 0
        self.pictures_taken = 0
        self.picture = None
        self.guesses = {}
        self.camera_motion.reset(rng)
        self.camera.move_to(self.camera_motion.pose if self.camera_motion.moves else None)
        if self._maybe_take_picture(0.0) is None:
            self._update_info_templates()
        self.reward_fn.reset(self.config, rng, self.picture)
        n = self.config.n_robots
        self.builder.record(self.odometry.since_picture, 0.0)
        observations = self.builder.build(
            self.agents, np.zeros(n, bool), self.picture is not None, 0.0
        )
        infos = self._infos()
        if self.render_mode == "human":
            self.render()
        return observations, infos

    def step(
        self, actions: dict[str, Any]
    ) -> tuple[
        ObsDict,
        dict[str, float],
        dict[str, bool],
        dict[str, bool],
        dict[str, dict[str, Any]],
    ]:
        """Hold every robot's command for ``dt``, advance physics once, maybe take a picture."""
        self._check_running()
        # (N, 2) columns (v, w): to_commands with one multiplication instead of two.
        commands = stack_actions(actions, self.agents)
        agents = self.agents
        motion, new_picture, time, reward_values, truncated = self._advance(commands)
        observations = self.builder.build(agents, motion.contact, new_picture, time)
        rewards = dict(zip(agents, reward_values.tolist(), strict=True))
        terminations = self._all_false.copy()
        truncations = self._all_true.copy() if truncated else self._all_false.copy()
        infos = self._infos()
        if self.render_mode == "human":
            self.render()
        return observations, rewards, terminations, truncations, infos

    def step_arrays(self, actions: np.ndarray, rewards: bool = True) -> ArrayStep:
        """:meth:`step` for callers that hold arrays, not per-agent dicts (the learning path:
        ``agents.crew``): the same episode to the bit, with no dict built.

        Args:
            actions: ``(N, 2)`` actions in robot order (clipped to ``[-1, 1]``).
            rewards: False: the reward function is not called and the step's ``rewards`` are
                zeros, for a caller that computes them itself from the actions, every step of an
                interval at once (``agents.crew`` with :class:`~anonloc_env.rewards.EnergyCost`).
                Only an ``EnergyCost`` reward may be skipped: it keeps nothing between steps.

        Raises:
            ValueError: ``actions`` is not ``(N, 2)`` or holds a non-finite value, or
                ``rewards`` is False and the reward function is not an ``EnergyCost``.
        """
        self._check_running()
        if not rewards and type(self.reward_fn) is not EnergyCost:
            raise ValueError(
                "rewards=False skips the reward function, which only EnergyCost allows (it keeps "
                f"nothing between steps); this env's is {type(self.reward_fn).__name__}"
            )
        commands = check_action_array(actions, len(self.agents))
        motion, new_picture, _, reward_values, truncated = self._advance(commands, rewards)
        seen = self.builder.seen(new_picture, motion.contact)
        if self.render_mode == "human":
            self.render()
        return ArrayStep(seen, reward_values, truncated, self._true_index)

    def _check_running(self) -> None:
        if self.world is None:
            raise RuntimeError(
                "step() called before reset(): call reset() first (a new env, or a copy made "
                "with pickle or copy.deepcopy, starts unreset)"
            )
        if not self.agents:
            raise RuntimeError("step() called on a finished episode; call reset() first")

    def _advance(
        self, commands: np.ndarray, rewards: bool = True
    ) -> tuple[WheelTravel, bool, float, np.ndarray, bool]:
        """One step from the clipped ``(N, 2)`` actions (scaled here, in place): the wheels'
        motion, whether a picture was taken, the time, the rewards (zeros without ``rewards``)
        and whether the episode is over (``self.agents`` is then emptied)."""
        world = self.world
        assert world is not None
        commands *= self._command_scale
        v, w = commands[:, 0], commands[:, 1]
        motion = world.step(v, w)
        self.odometry.integrate(motion, self.rng, v)
        self.steps += 1
        time = self.steps * self.config.dt
        between = self._maybe_take_picture(time)
        new_picture = between is not None
        self.builder.record(self.odometry.since_picture, time)
        truncated = self.steps >= self.max_cycles
        if truncated:
            self.agents = []
        if not rewards:
            return motion, new_picture, time, np.zeros(len(v)), truncated
        if type(self.reward_fn) is EnergyCost:  # it reads the commands only
            return motion, new_picture, time, EnergyCost.of(self.config, v, w), truncated
        context = StepContext(
            config=self.config,
            time=time,
            v=v,
            w=w,
            contact=motion.contact,
            picture=self.picture if new_picture else None,
            interval=between if self.pictures_taken > 1 else None,
            observed=functools.partial(self.builder.seen, new_picture, motion.contact),
        )
        reward_values = np.asarray(self.reward_fn(context), dtype=np.float64)
        return motion, new_picture, time, reward_values, truncated

    def _maybe_take_picture(self, time: float) -> Interval | None:
        """Take a picture if one is due; return the odometry interval it closes (or None)."""
        if not self.schedule.take_now(time):
            return None
        assert self.world is not None
        if self.camera_motion.moves:
            self.camera.move_to(self.camera_motion.advance(time, self.rng))
        picture = self.detector.take(self.world.poses, self.rng, time, self.pictures_taken)
        if picture.n_rows > self.capacity:
            raise ValueError(
                f"the detector returned {picture.n_rows} rows, more than its capacity "
                f"{self.capacity} (DetectionSource.capacity sizes the observations)"
            )
        self.picture = picture
        self.pictures_taken += 1
        between = self.odometry.mark_picture()
        self.builder.add_picture(self.picture, between)
        self._update_info_templates()
        return between

    def _update_info_templates(self) -> None:
        """Note the per-agent infos after a picture (or at reset): they change only then. The
        dicts are built when ``step`` or ``reset`` first hands them out (``step_arrays``
        callers never read them), from the poses as they are now."""
        assert self.world is not None
        if self.picture is not None:
            self._true_index = _frozen_int(self.picture.true_index)
        else:
            self._true_index = _frozen_int(np.full(self.config.n_robots, -1))
        self._info_source = (self.world.poses.copy(), self.pictures_taken, self.camera_motion.pose)
        self._info_templates = None

    def _infos(self) -> dict[str, dict[str, Any]]:
        if self._info_templates is None:
            poses, count, camera_pose = self._info_source
            poses[:, 2] = wrap_angle(poses[:, 2])
            poses.flags.writeable = False
            rows = self._true_index.tolist()
            self._info_templates = [
                {"true_index": row, "pose": pose, "picture": count, "camera_pose": camera_pose}
                for row, pose in zip(rows, list(poses), strict=True)
            ]
        # Fresh shallow copies: a wrapper that adds keys to one step's infos leaves the next alone.
        copies = map(dict.copy, self._info_templates)  # a loop in C (see ``_dicts``)
        return dict(zip(self.possible_agents, copies, strict=True))

    def state(self) -> np.ndarray:
        """Every robot's true pose ``(x, y, theta)`` as a ``(N, 3)`` float32 array (m, rad)."""
        if self.world is None:
            raise RuntimeError("call reset() before state()")
        poses = self.world.poses.astype(np.float32)
        poses[:, 2] = wrap_angle(self.world.poses[:, 2])
        return poses

    @property
    def time(self) -> float:
        """Time since reset (s)."""
        return self.steps * self.config.dt

    def render(self) -> np.ndarray | None:
        """Draw the arena, robots, newest detections and guesses (``render_mode`` decides how)."""
        if self.render_mode is None:
            warnings.warn(
                "render() called without a render_mode; pass render_mode='rgb_array' or 'human'",
                stacklevel=2,
            )
            return None
        if self.world is None:
            raise RuntimeError("call reset() before render()")
        if self._renderer is None:
            from anonloc_env.render import Renderer  # pygame is an optional extra

            self._renderer = Renderer(self.config, self.camera, self.render_mode)
        return self._renderer.draw(
            self.world.poses,
            self.picture,
            self.guesses,
            self.possible_agents,
            self.time,
            image=getattr(self.detector, "last_image", None),
        )

    def close(self) -> None:
        """Release the rendering window, if any."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def __repr__(self) -> str:
        cfg = self.config
        return (
            f"AnonLocEnv(n_robots={cfg.n_robots}, arena_size={cfg.arena_size}, dt={cfg.dt}, "
            f"picture_interval={cfg.picture_interval}, max_cycles={self.max_cycles})"
        )
