"""A learned localizer, as the authors' 2024 follow-up does: a multilayer perceptron over two
consecutive pictures and the robot's own odometry says which row is itself.

Poulet, Guinand and Guérin (*Robotics* 13(10):148, 2024, "DLA") feed an MLP the coordinates seen
in two consecutive aerial images and the robot's own motion, and read which detection is the
robot. Their network has one output per robot index, so it is tied to one team size. Here one
small MLP is **shared by every row**: it scores each row of the newest picture from that row's
relation to the previous picture and the robot's own odometry, and a softmax over the rows (plus
a learned "I am not in this picture" score) gives the belief. The same weights serve any N, any
false positives, any row order.

What the MLP sees for robot ``r`` and row ``j`` of the newest picture (:func:`row_features`,
:data:`FEATURES`): of the previous picture's rows, the :data:`NEIGHBOURS` that best fit the
robot's own motion, each by how far its displacement to row ``j`` misses the odometry (in units
of the localizer's own tolerance, :meth:`~baselines.localizers.Localizer._sigma`: pixel noise,
odometry noise, unseen pushes), by how far the heading change misses the odometry's turn (with
detected headings), and by the robot's belief in that previous row at the previous picture
(uniform at the first pair). The last input makes it a filter: beliefs carry from picture to
picture through the rows that fit.

Inference is numpy only (the weights are a ``.npz`` file, :data:`WEIGHTS`, a few tens of KB);
the training command is ``python -m agents.localizer_training`` (torch, the ``rl`` extra; see
``docs/baselines.md``).

>>> import anonloc_env, baselines
>>> env = anonloc_env.parallel_env("paper-motion")
>>> policy = baselines.make("mlp", env)
"""

from __future__ import annotations

import math
import re
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from anonloc_env.config import EnvConfig
from anonloc_env.geometry import wrap_angle
from anonloc_env.odometry import Interval
from baselines.localizers import Localizer

#: The weights shipped with the package (``python -m agents.localizer_training`` wrote them).
WEIGHTS = Path(__file__).parent / "data" / "mlp.npz"
#: How many rows of the previous picture the MLP sees per row of the newest one.
NEIGHBOURS = 4
#: The inputs of one previous-picture neighbour, in order (residuals are in units of the
#: localizer's tolerance and compressed by ``sign(x) log(1 + |x|)``).
NEIGHBOUR_FEATURES = (
    "present",  # 1, or 0 where the previous picture has fewer rows than NEIGHBOURS
    "ring",  # |displacement| - |own displacement|
    "along",  # displacement minus own, in the previous row's heading frame: forward
    "across",  # and sideways (0 without detected headings)
    "turn",  # heading change minus own turn (0 without detected headings)
    "prior",  # log(n * belief in that previous row at the previous picture), clipped
)
#: The inputs about the robot and the pictures.
GLOBAL_FEATURES = ("headings", "own_motion", "own_turn", "log_rows", "log_previous_rows")
#: Every input, in the order the weights read them.
FEATURES = (
    *(f"{name}_{k}" for k in range(NEIGHBOURS) for name in NEIGHBOUR_FEATURES),
    *GLOBAL_FEATURES,
)
#: Where a residual is missing (a neighbour that does not exist), it reads as this far off.
_FAR = 50.0
#: Work arrays are split over robots to stay under this many (row, previous row) pairs.
_CHUNK = 4_000_000


def _squash(x: np.ndarray) -> np.ndarray:
    return np.sign(x) * np.log1p(np.abs(x))


@dataclass(frozen=True)
class Geometry:
    """What the robots' own motion is compared with, per (row, previous row) pair; the same for
    every robot.

    Attributes:
        distance: ``(m, n)`` image distance between the rows (m, at the localizer's scale).
        local: ``(m, n, 2)`` the displacement in the previous row's heading frame (m).
        turn: ``(m, n)`` wrapped heading change (rad).
    """

    distance: np.ndarray
    local: np.ndarray
    turn: np.ndarray

    @classmethod
    def between(cls, previous: np.ndarray, rows: np.ndarray, scale: float) -> Geometry:
        """From the previous picture's rows ``(n, 3)`` to the newest's ``(m, 3)``."""
        disp = (rows[:, None, :2] - previous[None, :, :2]) / scale
        c, s = np.cos(previous[:, 2]), np.sin(previous[:, 2])
        local = np.stack(
            [c * disp[..., 0] + s * disp[..., 1], c * disp[..., 1] - s * disp[..., 0]], -1
        )
        turn = wrap_angle(rows[:, None, 2] - previous[None, :, 2])
        return cls(np.hypot(disp[..., 0], disp[..., 1]), local, turn)


def row_features(
    geometry: Geometry,
    d: np.ndarray,
    dphi: np.ndarray,
    sigma: np.ndarray,
    sigma_turn: np.ndarray,
    headings: bool,
    prior: np.ndarray,
) -> np.ndarray:
    """The MLP's inputs :data:`FEATURES` for R robots and every row of the newest picture.

    Args:
        geometry: the (row, previous row) pairs, ``Geometry.between``.
        d: ``(R, 2)`` each robot's own displacement since the previous picture (m, its frame).
        dphi: ``(R,)`` its own turn (rad).
        sigma: ``(R,)`` the displacement tolerance per component (m).
        sigma_turn: ``(R,)`` the turn tolerance (rad).
        headings: whether the pictures carry detected headings.
        prior: ``(R, n)`` each robot's belief in each previous row, summing to 1 per robot.

    Returns:
        ``(R, m, len(FEATURES))`` float64.
    """
    m, n = geometry.distance.shape
    R = len(d)
    k = min(NEIGHBOURS, n)
    sig = sigma[:, None, None]
    ring = (geometry.distance[None] - np.hypot(d[:, 0], d[:, 1])[:, None, None]) / sig
    if headings:
        miss = (geometry.local[None] - d[:, None, None, :]) / sig[..., None]
        turn = wrap_angle(geometry.turn[None] - dphi[:, None, None]) / sigma_turn[:, None, None]
        cost = (miss**2).sum(-1) + turn**2
    else:
        miss = np.zeros((R, m, n, 2))
        turn = np.zeros((R, m, n))
        cost = ring**2
    best = np.argsort(cost, axis=2, kind="stable")[:, :, :k]
    pick = (np.arange(R)[:, None, None], np.arange(m)[None, :, None], best)
    log_prior = np.clip(np.log(np.maximum(prior * n, 1e-12)), -8.0, 4.0)
    per = np.zeros((R, m, NEIGHBOURS, len(NEIGHBOUR_FEATURES)))
    per[..., 1:5] = _squash(np.array(_FAR))
    per[:, :, :k, 0] = 1.0
    per[:, :, :k, 1] = _squash(ring[pick])
    per[:, :, :k, 2] = _squash(miss[..., 0][pick])
    per[:, :, :k, 3] = _squash(miss[..., 1][pick])
    per[:, :, :k, 4] = _squash(turn[pick])
    per[:, :, :k, 5] = log_prior[np.arange(R)[:, None, None], best]
    own = np.hypot(d[:, 0], d[:, 1]) / sigma
    own_turn = np.abs(dphi) / sigma_turn if headings else np.zeros(R)
    glob = np.stack(
        [
            np.full(R, float(headings)),
            _squash(own),
            _squash(own_turn),
            np.full(R, math.log(max(m, 1))),
            np.full(R, math.log(max(n, 1))),
        ],
        -1,
    )
    return np.concatenate([per.reshape(R, m, -1), np.broadcast_to(glob[:, None], (R, m, 5))], -1)


@dataclass(frozen=True)
class MLPWeights:
    """The MLP's weights: ``layers`` of ``(W, b)``, ReLU between them, one score out per row;
    ``absent`` the score of "I am not in this picture".

    Attributes:
        layers: ``W`` ``(inputs, outputs)`` and ``b`` ``(outputs,)`` per layer; the first reads
            :data:`FEATURES`, the last gives one output.
        absent: the learned score of "not in this picture".
        mean: ``(len(FEATURES),)`` input centring, subtracted first.
        scale: ``(len(FEATURES),)`` input scaling, divided by next.
    """

    layers: tuple[tuple[np.ndarray, np.ndarray], ...]
    absent: float
    mean: np.ndarray
    scale: np.ndarray

    def scores(self, x: np.ndarray) -> np.ndarray:
        """``(..., len(FEATURES))`` inputs -> ``(...)`` scores."""
        h = (x - self.mean) / self.scale
        for i, (W, b) in enumerate(self.layers):
            h = h @ W + b
            if i < len(self.layers) - 1:
                h = np.maximum(h, 0.0)
        return h[..., 0]

    def save(self, path: Path | str) -> None:
        """Write the weights to ``path`` (``.npz``, no pickle), atomically."""
        path = Path(path)
        arrays: dict[str, Any] = {
            "features": np.array(FEATURES),
            "absent": np.array(self.absent),
            "mean": self.mean,
            "scale": self.scale,
        }
        for i, (W, b) in enumerate(self.layers):
            arrays[f"W{i}"], arrays[f"b{i}"] = W, b
        tmp = path.with_name(path.name + ".tmp")
        with open(tmp, "wb") as handle:
            np.savez_compressed(handle, **arrays)
        tmp.replace(path)


#: The arrays a weights file holds (any other member is never read).
_WANTED = re.compile(r"features|absent|mean|scale|[Wb]\d{1,3}")
#: The most bytes a weights file may declare for one array, and in all (checked before any is
#: read: a small ``.npz`` can declare gigabytes of zeros).
MAX_ARRAY_BYTES = 64 << 20
MAX_TOTAL_BYTES = 256 << 20


def _check_sizes(path: Path) -> None:
    """Refuse a weights file whose declared array sizes pass :data:`MAX_ARRAY_BYTES` (or
    :data:`MAX_TOTAL_BYTES` in all), before any array is read."""
    with zipfile.ZipFile(path) as archive:
        members = [
            m for m in archive.infolist() if _WANTED.fullmatch(m.filename.removesuffix(".npy"))
        ]
    for member in members:
        if member.file_size > MAX_ARRAY_BYTES:
            raise ValueError(
                f"array {member.filename} declares {member.file_size} bytes, more than the "
                f"{MAX_ARRAY_BYTES} a weights array may hold"
            )
    if sum(m.file_size for m in members) > MAX_TOTAL_BYTES:
        raise ValueError(f"its arrays declare more than {MAX_TOTAL_BYTES} bytes in all")


def load_weights(path: Path | str = WEIGHTS) -> MLPWeights:
    """The weights in ``path`` (default: the ones shipped, :data:`WEIGHTS`).

    Raises:
        FileNotFoundError: no such file.
        ValueError: the file is not such weights (not an ``.npz``, arrays missing, other
            inputs than :data:`FEATURES`, or shapes that do not chain); the message names it.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no MLP localizer weights at {path}")
    try:
        _check_sizes(path)
        with np.load(path, allow_pickle=False) as data:  # only the arrays it uses are read
            arrays = {key: data[key] for key in data.files if _WANTED.fullmatch(key)}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as error:
        raise ValueError(f"{path} is not an MLP localizer weights file (.npz): {error}") from None

    def bad(why: str) -> ValueError:
        return ValueError(
            f"{path} is not an MLP localizer weights file for this version: {why} "
            "(retrain with `python -m agents.localizer_training`)"
        )

    needed = {"features", "absent", "mean", "scale", "W0", "b0"}
    if not needed <= set(arrays):
        raise bad(f"missing {sorted(needed - set(arrays))}")
    if tuple(str(f) for f in arrays["features"]) != FEATURES:
        raise bad("its inputs are not baselines.mlp.FEATURES")
    layers: list[tuple[np.ndarray, np.ndarray]] = []
    width = len(FEATURES)
    while f"W{len(layers)}" in arrays:
        W = np.asarray(arrays[f"W{len(layers)}"], dtype=np.float64)
        b = np.asarray(arrays.get(f"b{len(layers)}", np.zeros(0)), dtype=np.float64)
        if W.ndim != 2 or W.shape[0] != width or b.shape != (W.shape[1],):
            raise bad(f"layer {len(layers)} has shapes {W.shape} and {b.shape}")
        layers.append((W, b))
        width = W.shape[1]
    if width != 1:
        raise bad(f"the last layer gives {width} outputs, not 1")
    mean = np.asarray(arrays["mean"], dtype=np.float64)
    scale = np.asarray(arrays["scale"], dtype=np.float64)
    if mean.shape != (len(FEATURES),) or scale.shape != mean.shape or np.any(scale <= 0):
        raise bad("its input normalisation has the wrong shape or a scale <= 0")
    if np.shape(arrays["absent"]) != ():
        raise bad(f"its 'absent' score has shape {np.shape(arrays['absent'])}, not a number")
    values = [mean, scale, *(a for layer in layers for a in layer), arrays["absent"]]
    if not all(np.all(np.isfinite(v)) for v in values):
        raise bad("it holds values that are not finite")
    return MLPWeights(tuple(layers), float(arrays["absent"]), mean, scale)


class MLPLocalizer(Localizer):
    """The learned localizer (see the module): a shared MLP scores each row of the newest
    picture, a softmax over the rows and "not in this picture" is the belief, and a robot
    decides on its top row once that belief reaches ``threshold``.

    Args:
        config: what the robots know of the task.
        n: number of robots R.
        mode: only ``"corrected"`` (there is no printed version to be faithful to).
        threshold: belief at which a robot decides, in (0.5, 1) (default 0.99, as ``bayes``).
        weights: an :class:`MLPWeights`, or a path to a weights file (default: the shipped
            ones, :data:`WEIGHTS`).

    Raises:
        ValueError: another mode, a threshold outside (0.5, 1), or a bad weights file (the
            message names the file).
        FileNotFoundError: no weights file at the path.
    """

    needs = 2

    def __init__(
        self,
        config: EnvConfig,
        n: int,
        mode: str = "corrected",
        threshold: float = 0.99,
        weights: MLPWeights | Path | str | None = None,
    ) -> None:
        if mode != "corrected":
            raise ValueError("the MLP localizer has no faithful mode; use mode='corrected'")
        if not 0.5 < threshold < 1.0:
            raise ValueError(f"threshold must be in (0.5, 1), got {threshold}")
        self.threshold = threshold
        self.weights = (
            weights
            if isinstance(weights, MLPWeights)
            else load_weights(WEIGHTS if weights is None else weights)
        )
        super().__init__(config, n, mode)

    def reset(self) -> None:
        super().reset()
        self._prior: np.ndarray | None = None

    def decide(self) -> None:
        previous, rows = self.pictures[-2], self.pictures[-1]
        interval = self.intervals[-1]
        m, n = len(rows), len(previous)
        prior = self._prior
        if prior is None or prior.shape != (self.n, n):
            prior = np.full((self.n, n), 1.0 / max(n, 1))
        else:
            prior = prior / np.maximum(prior.sum(axis=1, keepdims=True), 1e-12)
        scores = np.full((self.n, m), -np.inf)
        if m and n:
            scores = self._scores(previous, rows, interval, prior)
        absent = np.full((self.n, 1), self.weights.absent)
        logits = np.concatenate([scores, absent], axis=1)
        logits -= logits.max(axis=1, keepdims=True)
        p = np.exp(logits)
        p /= p.sum(axis=1, keepdims=True)
        self.belief = p[:, :m]
        self._prior = self.belief
        if m == 0:
            return
        best = self.belief.argmax(axis=1)
        sure = self.belief[np.arange(self.n), best] >= self.threshold
        self.estimate = np.where(sure, best, -1)

    def _scores(
        self, previous: np.ndarray, rows: np.ndarray, interval: Interval, prior: np.ndarray
    ) -> np.ndarray:
        """``(R, m)`` the MLP's score of each row for each robot."""
        geometry = Geometry.between(previous, rows, self.scale)
        sigma = self._sigma(interval) / self.scale
        _, var_turn = interval.variances(self.model.odometry_noise)
        sigma_turn = np.sqrt(2 * self.model.orientation_noise**2 + var_turn + 1e-6)
        headings = bool(self.model.orientation)
        step = max(1, _CHUNK // max(len(rows) * len(previous), 1))
        out = np.empty((self.n, len(rows)))
        for start in range(0, self.n, step):
            part = slice(start, start + step)
            x = row_features(
                geometry,
                interval.d[part],
                interval.dphi[part],
                sigma[part],
                sigma_turn[part],
                headings,
                prior[part],
            )
            out[part] = self.weights.scores(self._inputs(x))
        return out

    def _inputs(self, x: np.ndarray) -> np.ndarray:
        """The inputs of a chunk of robots, as scored (a hook: training records them here)."""
        return x
