"""Each picture's camera transform, estimated from the pictures themselves (no landmarks).

A camera on a drone (:mod:`anonloc_env.camera_motion`) is never in the same pose twice: every row
of a picture moves by the camera's motion as well as by its robot's. :class:`Registration` maps
each picture back into the frame of the camera's set point before the identifier sees it, with
one transform per picture shared by all rows: a similarity about the principal point,

``u' = cu + a (u - cu) - b (v - cv) + tx``, ``v' = cv + b (u - cu) + a (v - cv) + ty``

(``a = (1 + s) cos(phi)``, ``b = (1 + s) sin(phi)``: a scale change ``s`` from the height, a turn
``phi`` from the yaw, a shift from the drift and what the gimbal left of the tilt).

The estimator uses what every robot has, the pictures: the robots are the scene. Between two
pictures every row moves by the camera's change plus its robot's own displacement, which is
unknown to the others but bounded, persistent from one interval to the next, and of zero mean
over many robots. So, at each picture:

1. the rows are mapped through the previous picture's transform, shifted by the offset most
   pairs of rows agree on (a mean shift over the pairs within reach), and each is matched to the row
   of the previous (registered) picture it continues, predicted one displacement on (the robot
   keeps its motion, as :mod:`anonloc_env.identify.others` models it; less the similarity all
   displacements share, which holds the registration's own error), mutual nearest neighbours within
   the reach of a robot plus the camera's change;
2. the transform is the maximum a posteriori fit of the matched pairs (weighted least squares,
   linear in ``(a, b, tx, ty)``), with a Gaussian prior on its change since the previous picture
   and on its distance from the set point, both from the hover's processes (their stationary and
   inter-picture spreads), each pair weighted by how predictable its robot's displacement is,
   and down-weighted (Cauchy) when its residual says it is a wrong match, a false positive or a
   robot crossing the edge of the view; matched again and refitted once.

Its error is what the robots' unknown displacements leave: about their spread over the square
root of the matches (:func:`registration_error`). The sensor model adds it to the pixel noise
(:func:`registered_pixel_noise`), so the identifier's beliefs stay calibrated. With ground
landmarks the detection source registers the picture itself (:mod:`anonloc_env.landmarks`) and
this estimator is not used.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from anonloc_env.camera import survey
from anonloc_env.config import EnvConfig
from anonloc_env.landmarks import landmark_error
from anonloc_env.neighbours import pairs_within

#: Cauchy scale of the pair weights, in standard deviations of a pair's residual.
CAUCHY_SIGMAS = 2.5
#: Standard deviation of a persistent robot's displacement change, per component: a fixed part
#: (m) and a part per metre of the displacement (the identifier's ``others`` model, measured).
PERSIST_JITTER = 0.03
PERSIST_TURN = 0.35


@dataclass(frozen=True)
class RegistrationPrior:
    """What the estimator knows of the camera's motion and of the robots' (image units, rad).

    Attributes:
        centre: the principal point ``(cu, cv)``, about which the similarity turns and scales.
        spread: standard deviation per component of a robot's displacement between two
            pictures when nothing predicts it (image units).
        persist: ``(fixed, per_length)``: that of a robot keeping its previous displacement
            (image units, and per image unit of displacement).
        change: standard deviations of the change of ``(a, b, tx, ty)`` between two pictures.
        absolute: standard deviations of ``(a - 1, b, tx, ty)`` about the set point.
        reach: the farthest a row moves between two pictures (image units): a robot's largest
            displacement plus four standard deviations of the camera's change.
    """

    centre: tuple[float, float]
    spread: float
    persist: tuple[float, float]
    change: tuple[float, float, float, float]
    absolute: tuple[float, float, float, float]
    reach: float


def _ou_change(sigma: float, tau: float, interval: float) -> float:
    """Standard deviation of an OU process's change over ``interval``."""
    return sigma * math.sqrt(2.0 * (1.0 - math.exp(-interval / tau)))


def registration_prior(config: EnvConfig) -> RegistrationPrior | None:
    """The prior of ``config``'s camera motion, or ``None`` for a fixed camera, or one whose
    pictures its landmarks register (the detection source does it)."""
    cam = config.camera
    if not cam.moves or cam.landmarks:
        return None
    width, height = config.arena_size
    s = cam.scale
    centre = (
        cam.principal_point if cam.principal_point is not None else (s * width / 2, s * height / 2)
    )
    interval = config.schedule.picture_interval
    tilt = math.radians(cam.tilt_wobble_deg)
    if cam.gimbal_bandwidth > 0.0:
        tau_g = 1.0 / (2.0 * math.pi * cam.gimbal_bandwidth)
        tilt *= math.sqrt(tau_g / (cam.wobble_time + tau_g))
    shift = s * math.hypot(cam.drift, cam.height * tilt)
    shift_change = s * math.hypot(
        _ou_change(cam.drift, cam.drift_time, interval),
        cam.height * _ou_change(tilt, cam.wobble_time, interval),
    )
    zoom = cam.height_wobble / cam.height
    yaw = math.radians(cam.yaw_wobble_deg)
    rotate = math.hypot(zoom, yaw)
    rotate_change = _ou_change(rotate, cam.wobble_time, interval)
    step = config.robot.v_max * interval * s
    floor = 1e-6  # a process set to 0 is held (almost) exactly
    return RegistrationPrior(
        centre=(float(centre[0]), float(centre[1])),
        spread=0.5 * step,
        persist=(PERSIST_JITTER * s, PERSIST_TURN),
        change=(
            max(rotate_change, floor),
            max(rotate_change, floor),
            max(shift_change, floor),
            max(shift_change, floor),
        ),
        absolute=(max(rotate, floor), max(rotate, floor), max(shift, floor), max(shift, floor)),
        reach=1.2 * step + 4.0 * shift_change + 4.0 * rotate_change * _radius(config),
    )


def _radius(config: EnvConfig) -> float:
    """Root mean square distance of the field of view's points from its centre (image units)."""
    u_min, v_min, u_max, v_max = survey(config).field_of_view
    return math.sqrt(((u_max - u_min) ** 2 + (v_max - v_min) ** 2) / 12.0)


def registration_error(config: EnvConfig) -> float:
    """Expected error (image units, per coordinate, root mean square over the view) of a
    registered row's displacement between two pictures: the posterior spread of the transform's
    change, with every robot in view matched and unpredicted (a bound: persistence helps)."""
    prior = registration_prior(config)
    if prior is None:
        return 0.0
    cam = config.camera
    matches = max(config.n_robots * (1.0 - cam.p_miss), 1.0)
    data = matches / prior.spread**2
    radius = _radius(config)
    shift_var = 1.0 / (1.0 / prior.change[2] ** 2 + data)
    turn_var = 1.0 / (1.0 / prior.change[0] ** 2 + data * radius**2)
    return math.sqrt(shift_var + 2.0 * turn_var * radius**2 / 2.0)


def registered_pixel_noise(config: EnvConfig, pixel_noise: float) -> float:
    """The pixel noise a registered picture's rows have: ``pixel_noise`` plus half the
    registration's variance (a displacement takes two rows' noise, and one registration error),
    or, with landmarks, plus the variance of their fit (one per picture)."""
    if config.camera.landmarks:  # the detection source rectified the rows: the fit's error
        return math.sqrt(pixel_noise**2 + landmark_error(config, pixel_noise) ** 2)
    error = registration_error(config)
    return math.sqrt(pixel_noise**2 + 0.5 * error**2)


def apply(transform: np.ndarray, centre: tuple[float, float], rows: np.ndarray) -> np.ndarray:
    """``rows`` ``(M, >=2)`` with their ``(u, v)`` through the similarity ``(a, b, tx, ty)``
    about ``centre`` and, if present, their heading turned by its angle."""
    a, b, tx, ty = transform
    cu, cv = centre
    out = np.array(rows, dtype=np.float64, copy=True)
    du, dv = rows[:, 0] - cu, rows[:, 1] - cv
    out[:, 0] = cu + a * du - b * dv + tx
    out[:, 1] = cv + b * du + a * dv + ty
    if out.shape[1] > 2:
        turned = out[:, 2] + math.atan2(b, a)
        out[:, 2] = (turned + math.pi) % (2.0 * math.pi) - math.pi
    return out


class Registration:
    """Maps each picture into the set point's frame (see the module docstring).

    Args:
        prior: the camera's and the robots' motion (:func:`registration_prior`).
        orientation: whether rows carry a measured heading (turned with the picture).

    Attributes:
        transform: ``(4,)`` ``(a, b, tx, ty)`` of the newest picture (raw to set-point frame).
    """

    def __init__(self, prior: RegistrationPrior, orientation: bool = True) -> None:
        self.prior = prior
        self.orientation = orientation
        self._change_w = 1.0 / np.square(prior.change)
        self._absolute_w = 1.0 / np.square(prior.absolute)
        self.reset()

    def reset(self) -> None:
        """Forget the episode: the next picture is taken as seen from the set point."""
        self.transform = np.array([1.0, 0.0, 0.0, 0.0])
        self._previous: np.ndarray | None = None  # registered (u, v) of the previous picture
        self._motion: np.ndarray | None = None  # each previous row's last displacement (or nan)

    def register(self, rows: np.ndarray) -> np.ndarray:
        """The picture ``rows`` ``(M, 3)`` in the set point's frame (same order)."""
        rows = np.asarray(rows, dtype=np.float64)
        if self._previous is None or len(rows) == 0 or len(self._previous) == 0:
            registered = apply(self.transform, self.prior.centre, rows)
            self._remember(registered, None, None)
            return registered
        transform = self.transform.copy()
        transform[2:] += self._coarse_shift(apply(transform, self.prior.centre, rows[:, :2]))
        pairs = None
        for _ in range(2):
            pairs = self._match(apply(transform, self.prior.centre, rows[:, :2]))
            transform = self._fit(rows[:, :2], pairs, transform)
        self.transform = transform
        registered = apply(transform, self.prior.centre, rows)
        self._remember(registered, pairs, registered)
        return registered

    def _predicted(self) -> tuple[np.ndarray, np.ndarray]:
        """Where each previous row's robot should be now, and the spread of that guess."""
        assert self._previous is not None
        assert self._motion is not None
        known = np.isfinite(self._motion[:, 0])
        motion = np.where(known[:, None], self._motion, 0.0)
        fixed, per_length = self.prior.persist
        length = np.hypot(motion[:, 0], motion[:, 1])
        sigma = np.where(known, np.hypot(fixed, per_length * length), self.prior.spread)
        return self._previous + motion, sigma

    def _coarse_shift(self, moved: np.ndarray) -> np.ndarray:
        """``(2,)`` the shift most pairs of rows agree on: the mode of the pairs' offsets
        (mean shift, its kernel narrowed from twice the camera's expected change to a robot's
        spread), so that a camera change as large as the robots' spacing is still matched."""
        target, sigma = self._predicted()
        i, j, _ = pairs_within(moved, target, self.prior.reach)
        shift = np.zeros(2)
        if len(i) == 0:
            return shift
        offset = target[j] - moved[i]
        spread = sigma[j] ** 2
        width = max(2.0 * self.prior.change[2], 2.0 * float(np.median(sigma[j])))
        for _ in range(12):
            gap = np.sum((offset - shift) ** 2, axis=1)
            weight = np.exp(-0.5 * gap / (width**2 + spread)) / (width**2 + spread)
            total = float(weight.sum())
            if total <= 0.0:
                break
            shift = weight @ offset / total
            width = max(0.7 * width, float(np.median(sigma[j])))
        # Never further than the camera's change may plausibly take it: a mode one robot
        # spacing away is another robot's, not the camera's.
        limit = 3.0 * self.prior.change[2]
        length = float(np.hypot(*shift))
        return shift * (limit / length) if length > limit else shift

    def _match(self, moved: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Mutual nearest pairs ``(row, previous row, spread)`` between the rows ``moved`` (through
        the current transform) and the previous rows' predicted places, within the reach."""
        target, sigma = self._predicted()
        i, j, dist = pairs_within(moved, target, self.prior.reach)
        if len(i) == 0:
            return i, j, np.zeros(0)
        score = dist / sigma[j]
        best_i = _best(i, j, score, len(moved))
        best_j = _best(j, i, score, len(target))
        mutual = (best_i[i] == j) & (best_j[j] == i)
        return i[mutual], j[mutual], sigma[j[mutual]]

    def _fit(
        self, raw: np.ndarray, pairs: tuple[np.ndarray, np.ndarray, np.ndarray], start: np.ndarray
    ) -> np.ndarray:
        """The transform's maximum a posteriori fit to the pairs (Cauchy-reweighted, 3 rounds)."""
        i, j, sigma = pairs
        target, _ = self._predicted()
        cu, cv = self.prior.centre
        du, dv = raw[i, 0] - cu, raw[i, 1] - cv
        # Rows of the design: u' - cu = a du - b dv + tx, v' - cv = b du + a dv + ty.
        design = np.zeros((2 * len(i), 4))
        design[0::2, 0], design[0::2, 1], design[0::2, 2] = du, -dv, 1.0
        design[1::2, 0], design[1::2, 1], design[1::2, 3] = dv, du, 1.0
        observed = np.empty(2 * len(i))
        observed[0::2], observed[1::2] = target[j, 0] - cu, target[j, 1] - cv
        home = np.array([1.0, 0.0, 0.0, 0.0])
        transform = start
        for _ in range(3):
            residual = (observed - design @ transform).reshape(-1, 2)
            r = np.hypot(residual[:, 0], residual[:, 1]) / sigma
            weight = 1.0 / (sigma**2 * (1.0 + (r / CAUCHY_SIGMAS) ** 2))
            w2 = np.repeat(weight, 2)
            normal = design.T @ (w2[:, None] * design)
            normal[np.diag_indices(4)] += self._change_w + self._absolute_w
            rhs = design.T @ (w2 * observed) + self._change_w * self.transform
            rhs += self._absolute_w * home
            transform = np.linalg.solve(normal, rhs)
        return transform

    def _remember(
        self,
        registered: np.ndarray,
        pairs: tuple[np.ndarray, np.ndarray, np.ndarray] | None,
        now: np.ndarray | None,
    ) -> None:
        """Keep this picture's registered rows and, for the matched ones, their displacement."""
        motion = np.full((len(registered), 2), np.nan)
        if pairs is not None and now is not None and self._previous is not None:
            i, j, _ = pairs
            if len(i) >= 2:
                # Less the similarity all rows share: that is the camera's (its error included),
                # which must not be predicted to persist.
                motion[i] = now[i, :2] - _common(self._previous[j], now[i, :2])
        self._previous = registered[:, :2].copy()
        self._motion = motion


def _common(before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """``before`` ``(M, 2)`` through the similarity that maps it best onto ``after`` (least
    squares: ``after ~ z before + t`` in complex numbers)."""
    cb, ca = before.mean(axis=0), after.mean(axis=0)
    zb = (before[:, 0] - cb[0]) + 1j * (before[:, 1] - cb[1])
    za = (after[:, 0] - ca[0]) + 1j * (after[:, 1] - ca[1])
    spread = float(np.sum(np.abs(zb) ** 2))
    z = complex(np.sum(np.conj(zb) * za) / spread) if spread > 0.0 else 1.0
    moved = z * zb
    return np.column_stack([moved.real + ca[0], moved.imag + ca[1]])


def _best(key: np.ndarray, other: np.ndarray, score: np.ndarray, size: int) -> np.ndarray:
    """``(size,)`` for each value of ``key``, the ``other`` of its lowest ``score`` (-1 if none)."""
    order = np.lexsort((score, key))
    first = np.ones(len(order), bool)
    first[1:] = key[order][1:] != key[order][:-1]
    out = np.full(size, -1, np.int64)
    out[key[order][first]] = other[order][first]
    return out
