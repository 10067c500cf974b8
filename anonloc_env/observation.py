"""Per-agent observations: the shared newest picture, plus each robot's own odometry.

Every observation is a dict of fixed-shape float32 arrays (SB3's ``MultiInputPolicy`` takes it as
is). The picture arrays are shared by all agents: one read-only array per picture, the same object
in every agent's dict. The odometry arrays are read-only row views of one ``(N, ...)`` array built
per step. ``new_picture`` and ``bumper`` are one of two read-only constants, ``[0.]`` or
``[1.]``, shared by every agent and step. Arrays are never changed after they are handed out, so
an observation kept by the caller stays valid.

Keys (D = max detections, K = history length):

| key | shape | meaning |
|---|---|---|
| `detections` | `(D, 3)` | newest picture's rows `(u, v, theta)`, zero-padded, shuffled |
| `mask` | `(D,)` | 1 where `detections` holds a row, else 0 |
| `new_picture` | `(1,)` | 1 if the newest picture arrived at this step, else 0 |
| `since_picture` | `(1,)` | time since the newest picture (s); since reset if none yet |
| `odometry` | `(3,)` | own motion `(dx, dy, dphi)` since the newest picture (m, m, rad) |
| `bumper` | `(1,)` | 1 if a contact pushed or blocked the robot during this step |
| `odometry_between` | `(3,)` | own motion from the previous picture to the newest (0 before) |
| `interval` | `(1,)` | time between the previous picture and the newest (s) |
| `history_detections` | `(K, D, 3)` | the K pictures before the newest, most recent first |
| `history_mask` | `(K, D)` | their masks (all 0 for pictures not taken yet) |
| `history_odometry` | `(K, 3)` | own motion from history picture k to the next newer one |
| `history_interval` | `(K,)` | time from history picture k to the next newer one (s) |
| `footprint` | `(4, 2)` | moving camera with landmarks only: the view's corners, as `detections` |

`footprint` (only where the camera moves and ground landmarks rectify its pictures) is the newest
picture's field of view in the frame of `detections`: its corners, round it, through the
landmarks' fit (zeros before a picture). The robots see the landmarks in the picture; it tells
where the arena was in view.

Odometry is in the robot's own frame at the start of its interval: `odometry` in the frame at the
newest picture, `odometry_between` in the frame at the previous picture, `history_odometry[k]` in
the frame at history picture k.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from itertools import repeat
from typing import Any

import numpy as np
from gymnasium import spaces

from anonloc_env._dicts import copy_each, set_each
from anonloc_env.camera import Picture
from anonloc_env.config import EnvConfig
from anonloc_env.odometry import Interval
from anonloc_env.robot_view import Step, gather_step


def observation_space(config: EnvConfig, capacity: int) -> spaces.Dict:
    """The observation space of one agent (see the module table)."""
    inf = np.inf
    d, k = capacity, config.observation.history
    entries: dict[str, spaces.Space[Any]] = {
        "detections": spaces.Box(-inf, inf, (d, 3), np.float32),
        "mask": spaces.Box(0.0, 1.0, (d,), np.float32),
        "new_picture": spaces.Box(0.0, 1.0, (1,), np.float32),
        "since_picture": spaces.Box(0.0, inf, (1,), np.float32),
        "odometry": spaces.Box(-inf, inf, (3,), np.float32),
        "bumper": spaces.Box(0.0, 1.0, (1,), np.float32),
        "odometry_between": spaces.Box(-inf, inf, (3,), np.float32),
        "interval": spaces.Box(0.0, inf, (1,), np.float32),
    }
    if has_footprint(config):
        entries["footprint"] = spaces.Box(-inf, inf, (4, 2), np.float32)
    if k > 0:
        entries["history_detections"] = spaces.Box(-inf, inf, (k, d, 3), np.float32)
        entries["history_mask"] = spaces.Box(0.0, 1.0, (k, d), np.float32)
        entries["history_odometry"] = spaces.Box(-inf, inf, (k, 3), np.float32)
        entries["history_interval"] = spaces.Box(0.0, inf, (k,), np.float32)
    return spaces.Dict(entries)


def has_footprint(config: EnvConfig) -> bool:
    """Whether ``config``'s observations carry each picture's ``footprint``: a moving camera
    whose pictures its ground landmarks rectify (the robots see the landmarks; see
    ``anonloc_env.landmarks``)."""
    return bool(config.camera.landmarks) and config.camera.moves


def space_copy(space: spaces.Dict) -> spaces.Dict:
    """A new observation space equal to ``space`` with its own random generator, whose boxes
    share ``space``'s bound arrays (read-only): N agents' spaces then cost O(N), not O(N * D)."""
    boxes: dict[str, spaces.Space[Any]] = {}
    for key, box in space.spaces.items():
        assert isinstance(box, spaces.Box)  # observation_space builds boxes only
        clone = copy.copy(box)
        vars(clone)["_np_random"] = None  # seeded on its own, as if new
        for bound in (box.low, box.high, box.bounded_below, box.bounded_above):
            bound.flags.writeable = False
        boxes[key] = clone
    return spaces.Dict(boxes)


def _frozen(array: np.ndarray) -> np.ndarray:
    array.flags.writeable = False
    return array


#: Stands in a template for the per-agent arrays, which replace it before it is handed out.
_PLACEHOLDER = _frozen(np.zeros(0, np.float32))


class ObservationBuilder:
    """Keeps the picture arrays and history, and assembles every agent's observation dict.

    Args:
        config: the task configuration.
        capacity: rows per picture (``D``).
    """

    def __init__(self, config: EnvConfig, capacity: int) -> None:
        self.n = config.n_robots
        self.capacity = capacity
        self.history = config.observation.history
        k, d, n = self.history, capacity, self.n
        self._shared: dict[str, np.ndarray] = {
            "detections": _frozen(np.zeros((d, 3), np.float32)),
            "mask": _frozen(np.zeros(d, np.float32)),
        }
        if has_footprint(config):
            self._shared["footprint"] = _frozen(np.zeros((4, 2), np.float32))
        if k > 0:
            self._shared["history_detections"] = _frozen(np.zeros((k, d, 3), np.float32))
            self._shared["history_mask"] = _frozen(np.zeros((k, d), np.float32))
            self._shared["history_interval"] = _frozen(np.zeros(k, np.float32))
            self._history_odometry = _frozen(np.zeros((n, k, 3), np.float32))
            self._history_rows: list[np.ndarray] = list(self._history_odometry)
        self._picture_time: float | None = None
        self._interval = _frozen(np.zeros(1, np.float32))
        self._between = _frozen(np.zeros((n, 3), np.float32))
        self._between_rows = list(self._between)
        self._odometry = _frozen(np.zeros((n, 3), np.float32))
        self._time = 0.0
        self._flags = {
            True: _frozen(np.ones(1, np.float32)),
            False: _frozen(np.zeros(1, np.float32)),
        }

    def add_picture(self, picture: Picture, interval: Interval) -> None:
        """Make ``picture`` the newest; ``interval`` is each robot's own motion from the previous
        picture to this one."""
        odometry_between = np.column_stack([interval.d, interval.dphi])
        d = self.capacity
        rows = picture.detections.shape[0]
        detections = np.zeros((d, 3), np.float32)
        detections[:rows] = picture.detections
        mask = np.zeros(d, np.float32)
        mask[:rows] = 1.0
        if self.history > 0:
            self._push_history(picture.time, odometry_between)
        self._shared["detections"] = _frozen(detections)
        self._shared["mask"] = _frozen(mask)
        if "footprint" in self._shared and picture.footprint is not None:
            self._shared["footprint"] = _frozen(np.asarray(picture.footprint, np.float32))
        if self._picture_time is not None:
            self._interval = _frozen(np.array([picture.time - self._picture_time], np.float32))
            self._between = _frozen(odometry_between.astype(np.float32))
            self._between_rows = list(self._between)
        self._picture_time = picture.time

    def _push_history(self, time: float, odometry_between: np.ndarray) -> None:
        shared = self._shared
        if self._picture_time is None:
            return  # the first picture has no predecessor
        hist_det = np.concatenate([shared["detections"][None], shared["history_detections"][:-1]])
        hist_mask = np.concatenate([shared["mask"][None], shared["history_mask"][:-1]])
        interval = np.concatenate(
            [[time - self._picture_time], shared["history_interval"][:-1]]
        ).astype(np.float32)
        odo = np.concatenate(
            [odometry_between[:, None, :].astype(np.float32), self._history_odometry[:, :-1]],
            axis=1,
        )
        shared["history_detections"] = _frozen(hist_det)
        shared["history_mask"] = _frozen(hist_mask)
        shared["history_interval"] = _frozen(interval)
        self._history_odometry = _frozen(odo)
        self._history_rows = list(odo)

    def record(self, odometry: np.ndarray, time: float) -> None:
        """The step's own motion since the picture, ``odometry`` ``(N, 3)``, at ``time`` (s):
        what :meth:`build` hands out and :meth:`seen` reads back (as float32)."""
        self._odometry = _frozen(odometry.astype(np.float32))
        self._time = time

    def build(
        self,
        agents: Sequence[str],
        bumper: np.ndarray,
        new_picture: bool,
        time: float,
    ) -> dict[str, dict[str, np.ndarray]]:
        """Every agent's observation of the step :meth:`record` took in at ``time``; ``agents``
        are in robot order, ``bumper`` is ``(N,)`` bool."""
        if time != self._time:
            raise ValueError(f"build({time}) after record({self._time}): record the step first")
        since = time - (self._picture_time if self._picture_time is not None else 0.0)
        since_arr = _frozen(np.array([since], np.float32))
        flag = self._flags[new_picture]
        # A copy of one template per agent, then its own values set in (see ``_dicts``). The
        # bumper arrays are the read-only constants [0.] and [1.], like ``new_picture``.
        obs = copy_each(repeat(self._template(flag, since_arr), len(agents)))
        bumped = bumper.nonzero()[0].tolist()  # usually few robots
        if bumped:
            set_each(map(obs.__getitem__, bumped), "bumper", repeat(self._flags[True]))
        set_each(obs, "odometry", self._odometry)  # row views
        set_each(obs, "odometry_between", self._between_rows)  # rows changed at pictures only
        if self.history > 0:
            set_each(obs, "history_odometry", self._history_rows)
        return dict(zip(agents, obs, strict=True))

    def seen(self, new_picture: bool, bumper: np.ndarray) -> Step:
        """What the robots observed in the observations :meth:`build` made last, as
        :func:`anonloc_env.robot_view.read_step` reads it from them (the same bits, without
        going through N dicts); ``new_picture`` and ``bumper`` as given to :meth:`build`."""
        odometry = self._odometry.astype(np.float64)
        if not new_picture:
            return gather_step(False, odometry, bumper)
        shared = self._shared
        between = self._between.astype(np.float64)
        interval = float(self._interval[0])
        footprint = shared.get("footprint")
        return gather_step(
            True,
            odometry,
            bumper,
            shared["detections"],
            shared["mask"],
            between,
            interval,
            footprint,
        )

    def _template(self, flag: np.ndarray, since: np.ndarray) -> dict[str, np.ndarray]:
        """An observation of a robot whose bumper is off, with the shared arrays, and a
        placeholder where the per-agent rows go."""
        shared = self._shared
        template = {
            "detections": shared["detections"],
            "mask": shared["mask"],
            "new_picture": flag,
            "since_picture": since,
            "odometry": _PLACEHOLDER,
            "bumper": self._flags[False],
            "odometry_between": _PLACEHOLDER,
            "interval": self._interval,
        }
        if "footprint" in shared:
            template["footprint"] = shared["footprint"]
        if self.history > 0:
            template["history_detections"] = shared["history_detections"]
            template["history_mask"] = shared["history_mask"]
            template["history_odometry"] = _PLACEHOLDER
            template["history_interval"] = shared["history_interval"]
        return template
