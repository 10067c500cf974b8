"""Gap seeking: a crowd-aware excitation that uses the picture to keep out of contact
(:class:`GapSeeking`, registered as ``gaps``).

In a crowd, contacts are what identification loses to (``docs/crowds.md``): a robot pressed
against a wall or a neighbour slides unseen by its wheels, a robot that reverses out of a bump
bumps the one behind, and robots pressed together for many intervals stop being told apart. A
robot that is fairly sure of its row knows where it is, and it sees every other robot in the
picture. So, between two pictures:

* a robot sure of its row (belief at least ``sure``) whose heading it knows steers toward free
  space (away from the rows and walls within ``look`` robot sizes, each weighed by the inverse
  of its distance), at a speed that drops with the free space around it, and waits (speed 0,
  turning toward free space) while a robot of the picture or a wall is less than ``gap`` robot
  sizes ahead of where its own odometry puts it, for at most ``wait`` (0.5 s) between two
  pictures: a robot sure of a wrong row takes itself for crowded, and one that waits gives its
  identifier nothing to correct it by (at 6 robots per m^2 one such robot stayed wrong for 22
  pictures). Past the wait it drives as an unsure robot until the next picture. It never
  reverses: behind it may stand another robot;
* any other robot moves as :class:`~baselines.excitations.DistinctMotion` does (a new random
  command at every picture, at full speed: long legs are what tells a robot from the others),
  but escapes a bump (:class:`Escape`): it reverses slowly (``back_speed``, 0.08 m/s) for 0.7 to
  1.2 s while turning at the full rate one way or the other, so it leaves facing away from what
  it hit. Reversing at 0.3 m/s bumps the robot behind; reversing for 0.2 to 0.5 s at a uniform
  rate turns it so little that it drives back into the same robot or wall; not reversing leaves
  it pressed. At 4 robots per m^2 (N = 100, tuning seeds 700 to 719) this escape took the
  pictures to 99 % from 28 to 9.6.

Its heading is known from a detected heading, or else from its own last leg free of contact
between two pictures where it was sure of its row (the direction of its displacement in the
arena against that of its odometry), carried on by its odometry's turns (a contact does not turn
a robot). The picture is taken back to the arena through the camera the config describes, as
``anonloc_env.identify.SensorModel.from_config`` does.

Commands stay in ``[-back_speed, speed[1]] x [-turn, turn]``; every random draw comes from the
robot's own generator (``turn`` and ``speed`` drawn at every picture for every robot, the
back-off's draws at its bumps), so an episode replays bit for bit from its seed.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from anonloc_env.camera import Camera
from anonloc_env.config import EnvConfig
from anonloc_env.geometry import wrap_angle
from anonloc_env.neighbours import pairs_within
from baselines.excitations.backoff import BackOff, DistinctSettings, check_command_box
from baselines.excitations.base import Excitation
from baselines.steps import BeliefView, Step


@dataclass
class GapSettings:
    """Gap seeking, in SI units and robot sizes.

    Attributes:
        speed: range of forward speeds (m/s), drawn at every picture.
        turn: largest turn rate (rad/s); random rates are uniform in ``[-turn, turn]``.
        sure: the belief in its top row at which a robot takes that row as where it is, in
            (0.5, 1].
        look: rows and walls within this many robot sizes shape the free-space direction, > 0.
        gap: a robot waits while something is less than this many robot sizes ahead, >= 0.
        steer: turn rate per radian between the heading and free space (1/s), >= 0.
        back_speed: speed of an unsure robot's reverse after a bump (m/s), >= 0.
        back_time: range of that reverse's duration (s).
        wait: longest a robot waits for a gap between two pictures (s), >= 0: after that it
            drives as an unsure robot until the next picture (``inf``: it waits as long as it
            is blocked).
    """

    speed: tuple[float, float] = (0.1, 0.3)
    turn: float = 1.0
    sure: float = 0.9
    look: float = 3.0
    gap: float = 0.5
    steer: float = 1.0
    back_speed: float = 0.08
    back_time: tuple[float, float] = (0.7, 1.2)
    wait: float = 0.5

    def __post_init__(self) -> None:
        check_command_box(self.speed, self.turn)
        if not 0.5 < self.sure <= 1.0:
            raise ValueError(f"sure must be in (0.5, 1], got {self.sure}")
        if not self.look > 0.0:
            raise ValueError(f"look must be > 0, got {self.look}")
        for name in ("gap", "steer", "back_speed", "wait"):
            if not getattr(self, name) >= 0.0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")
        if not 0.0 <= self.back_time[0] <= self.back_time[1]:
            raise ValueError(
                f"back_time must be (low, high) with 0 <= low <= high s, got {self.back_time}"
            )

    def escape(self) -> DistinctSettings:
        """The settings of :class:`Escape` (the unsure robots' back-off; also the bump reflex of
        a pressed robot in the candidate excitations, ``baselines.excitations.reflex``)."""
        return DistinctSettings(self.speed, self.turn, self.back_speed, self.back_time)


class Escape(BackOff):
    """The back-off of an unsure robot in a crowd: reverse slowly while turning at the full
    rate, one way or the other at random, so the robot comes out of the bump facing away from
    what it hit (a uniform rate mostly turns it little, and it drives back into the same robot
    or wall after the back-off)."""

    def turn_rates(self, hit: np.ndarray) -> list[float]:
        turn = self.settings.turn
        return [turn if self.rngs[i].random() < 0.5 else -turn for i in hit]


class GapSeeking(Excitation):
    """Steer into free space and hold back when crowded (see the module).

    Args:
        settings: speeds, turns, the thresholds in robot sizes (defaults above).
    """

    backoff: Escape  # narrows Excitation.backoff: this excitation always has one

    def __init__(self, settings: GapSettings | None = None) -> None:
        super().__init__()
        self.settings = settings or GapSettings()
        self.backoff = Escape(self.settings.escape())
        self._camera: Camera | None = None
        self._config: EnvConfig | None = None

    def reset(self, rngs: Sequence[np.random.Generator]) -> None:
        super().reset(rngs)
        n = self.n
        self.v = np.zeros(n)
        self.w = np.zeros(n)
        self.backoff.reset(rngs)
        self.position = np.full((n, 2), np.nan)
        """``(R, 2)`` where each robot was at the latest picture (m; nan: not sure)."""
        self.heading = np.full(n, np.nan)
        """``(R,)`` each robot's heading at the latest picture (rad, arena frame; nan: unknown)."""
        self.free = np.zeros(n)
        """``(R,)`` the direction of free space at the latest picture (rad)."""
        self.drawn = (np.zeros(n), np.zeros(n))
        """``(R,)`` speeds and turn rates drawn at the latest picture (an unsure robot's)."""
        self.waited = np.zeros(n)
        """``(R,)`` time each robot waited for a gap since the latest picture (s)."""
        self.others = np.zeros((0, 2))
        self.pair_i = np.zeros(0, np.int64)
        self.pair_j = np.zeros(0, np.int64)
        self.box = np.zeros(4)

    def on_picture(self, step: Step, view: BeliefView) -> None:
        s = self.settings
        size = view.config.robot.size
        world = self._arena_points(view)
        sure, row = self._sure_rows(view.belief)
        previous = self.position
        self.position = np.full((self.n, 2), np.nan)
        self.position[sure] = world[row[sure]]
        self._update_headings(view, previous, sure, row)
        # Free space: away from the other rows and the walls within ``look`` sizes.
        reach = s.look * size
        i, j, dist = pairs_within(np.nan_to_num(self.position), world, reach)
        keep = sure[i] & (j != row[i])
        i, j, dist = i[keep], j[keep], np.maximum(dist[keep], 1e-6)
        push = (self.position[i] - world[j]) / dist[:, None] ** 2
        away = np.zeros((self.n, 2))
        np.add.at(away, i, push)
        width, height = view.config.arena_size
        self.box = np.array([0.0, 0.0, width, height])
        away += self._walls(reach)
        self.free = np.arctan2(away[:, 1], away[:, 0])
        crowd = np.zeros(self.n)
        np.add.at(crowd, i, size / dist)
        self.others, self.pair_i, self.pair_j = world, i, j
        # Random commands for every robot (the same draws whatever it knows: replayable).
        v = np.array([self.rngs[k].uniform(*s.speed) for k in range(self.n)])
        w = np.array([self.rngs[k].uniform(-s.turn, s.turn) for k in range(self.n)])
        self.drawn = (v, w)
        self.waited = np.zeros(self.n)
        steering = sure & np.isfinite(self.heading)
        err = wrap_angle(self.free - self.heading)
        toward = np.clip(s.steer * err, -s.turn, s.turn)
        w = np.where(steering & (crowd > 0), np.clip(0.5 * w + toward, -s.turn, s.turn), w)
        v = np.where(steering, v / (1.0 + crowd), v)
        self.v, self.w = v, w

    def commands(self, step: Step, dt: float) -> tuple[np.ndarray, np.ndarray]:
        known = np.isfinite(self.heading) & np.isfinite(self.position[:, 0])
        steering = known & (self.waited < self.settings.wait)  # past the wait: as unsure
        bumper = step.bumper & ~steering  # a steering robot never reverses
        own = dataclasses.replace(step, bumper=bumper)
        mine = (
            np.where(steering, self.v, self.drawn[0]),
            np.where(steering, self.w, self.drawn[1]),
        )
        v, w = self.backoff.commands(own, dt, lambda hit: mine)
        if not steering.any():
            return v, w
        blocked = self._blocked(step.odometry, steering)
        self.waited += np.where(blocked, dt, 0.0)
        s = self.settings
        heading_now = self.heading + step.odometry[:, 2]
        toward = np.clip(s.steer * wrap_angle(self.free - heading_now), -s.turn, s.turn)
        v = np.where(blocked, 0.0, v)
        w = np.where(blocked, toward, w)
        return v, w

    # -- what a robot knows at a picture -------------------------------------------------------
    def _arena_points(self, view: BeliefView) -> np.ndarray:
        """The picture's rows taken back to the arena (m), through the camera of the config."""
        if self._camera is None or self._config is not view.config:
            self._camera, self._config = Camera(view.config), view.config
        return self._camera.unproject(view.rows[:, :2].astype(np.float64))

    def _sure_rows(self, belief: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Which robots are sure of a row (belief >= ``sure``), and each robot's top row."""
        if belief.shape[1] == 0:
            return np.zeros(self.n, bool), np.zeros(self.n, np.int64)
        row = np.argmax(belief, axis=1)
        return belief[np.arange(self.n), row] >= self.settings.sure, row

    def _update_headings(
        self, view: BeliefView, previous: np.ndarray, sure: np.ndarray, row: np.ndarray
    ) -> None:
        """Carry each heading by its robot's turn, and learn it again where the picture says."""
        interval = view.interval
        if interval is not None:
            self.heading = wrap_angle(self.heading + interval.dphi)
        if view.model.orientation:
            detected = np.where(sure, view.rows[row, 2] if len(view.rows) else np.nan, np.nan)
            self.heading = np.where(sure, detected, self.heading)
            return
        if interval is None:
            return
        moved = self.position - previous
        free = np.ones(self.n, bool) if interval.push is None else interval.push == 0.0
        d = interval.d
        learn = sure & np.isfinite(moved[:, 0]) & free & (np.hypot(d[:, 0], d[:, 1]) > 0.02)
        start = np.arctan2(moved[:, 1], moved[:, 0]) - np.arctan2(d[:, 1], d[:, 0])
        self.heading = np.where(learn, wrap_angle(start + interval.dphi), self.heading)
        self.heading = np.where(sure, self.heading, np.nan)

    def _walls(self, reach: float) -> np.ndarray:
        """``(R, 2)`` the walls' push away from them, for the robots within ``reach``."""
        x, y = self.position[:, 0], self.position[:, 1]
        x0, y0, x1, y1 = self.box
        out = np.zeros((self.n, 2))
        sides = ((x - x0, 0, 1.0), (x1 - x, 0, -1.0), (y - y0, 1, 1.0), (y1 - y, 1, -1.0))
        for gap, axis, sign in sides:
            near = np.isfinite(gap) & (gap < reach)
            out[near, axis] += sign / np.maximum(gap[near], 1e-3)
        return out

    def _blocked(self, odometry: np.ndarray, steering: np.ndarray) -> np.ndarray:
        """``(R,)`` steering robots with a row or a wall less than ``gap`` sizes ahead of where
        their odometry puts them."""
        size = self._config.robot.size if self._config is not None else 0.0
        heading = self.heading + odometry[:, 2]
        c, s = np.cos(self.heading), np.sin(self.heading)
        here = self.position + np.column_stack(
            [c * odometry[:, 0] - s * odometry[:, 1], s * odometry[:, 0] + c * odometry[:, 1]]
        )
        ahead = np.column_stack([np.cos(heading), np.sin(heading)])
        limit = (1.0 + self.settings.gap) * size
        blocked = np.zeros(self.n, bool)
        i, j = self.pair_i, self.pair_j
        if len(i):
            rel = self.others[j] - here[i]
            along = (rel * ahead[i]).sum(axis=1)
            across = np.abs(rel[:, 0] * ahead[i, 1] - rel[:, 1] * ahead[i, 0])
            hit = (along > 0.0) & (along < limit) & (across < size)
            blocked[i[hit]] = True
        x0, y0, x1, y1 = self.box
        tip = here + ahead * (limit - 0.5 * size)
        out = (tip[:, 0] < x0) | (tip[:, 0] > x1) | (tip[:, 1] < y0) | (tip[:, 1] > y1)
        return steering & (blocked | out)
