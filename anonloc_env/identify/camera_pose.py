"""Each picture's camera transform, estimated from the pictures themselves (no landmarks).

A camera on a drone (:mod:`anonloc_env.camera_motion`) is never in the same pose twice: every row
of a picture moves by the camera's motion as well as by its robot's. :class:`Registration` maps
each picture back into the frame of the camera's set point before the identifier sees it, with
one transform per picture shared by all rows: a similarity about the principal point,

``u' = cu + a (u - cu) - b (v - cv) + tx``, ``v' = cv + b (u - cu) + a (v - cv) + ty``

(``a = (1 + s) cos(phi)``, ``b = (1 + s) sin(phi)``: a scale change ``s`` from the height, a turn
``phi`` from the yaw, a shift from the drift and what the gimbal left of the tilt), and, where
the tilt the gimbal leaves bends the picture at the view's radius by more than the detector's
noise (``drone-windy`` from N = 100 on at 1 robot per m^2), its perspective to first order:
``u'`` and ``v'`` less ``du (g du + h dv)`` and ``dv (g du + h dv)`` (``du = u - cu``,
``dv = v - cv``), ``g`` and ``h`` the tilt's two components over the camera's height in
image units, with their prior from the gimbal's process (held at 0 below the noise).

The estimator uses what every robot has, the pictures: the robots are the scene. Between two
pictures every row moves by the camera's change plus its robot's own displacement, which is
unknown to the others but bounded and of zero mean over many robots. So, at each picture:

1. each row of the previous (registered) picture is predicted on: a robot that moved keeps its
   axis (the line of its previous displacement, less the displacement the whole team shared,
   which holds the previous registration's error): a robot turns little in a picture's
   interval, but it may drive on or back off (a bump's reverse drive), so it is either ahead
   on that line or behind, by how far the team's robots went on and went back lately, with
   the odds of each as lately seen (under ``distinct`` motion at 1 robot per m^2, about half
   go back), and off the line by little; one that did not move, or whose motion is unknown,
   may move the team's typical step (the median previous displacement) in any direction;
2. the rows are mapped through the previous picture's transform, shifted by the offset most
   pairs of rows agree on (a mean shift over the pairs within reach, so that a camera change as
   large as the robots' spacing is still matched), and matched to the predicted rows, mutual
   nearest neighbours within the reach of a robot plus the camera's change;
3. the transform is the maximum a posteriori fit of the matched pairs (weighted least squares,
   linear in ``(a, b, tx, ty)``, each pair's two equations along its robot's axis and across
   it), with a Gaussian prior on its change since the previous picture and on its distance
   from the set point, both from the hover's processes; each pair is ahead or behind as the
   fit says (both weighed, the spread along the axis widened by that doubt); the pairs'
   spreads are set to their own residuals (robust scales, across and along the axes for the
   robots that kept one, and for the others), and a pair whose residual says it is a wrong
   match, a false positive
   or a robot crossing the edge of the view is down-weighted (Cauchy); matched again through
   the fit and refitted until the matches hold (a turn or a zoom moves the rows far from the
   centre by more than the shift that the first matches come from).

Its error is what the robots' unknown displacements leave: the fit's posterior spread, at each
picture, from its own residuals, widened by the measured :data:`ERROR_FACTOR`
(``Registration.error``), plus what the guess of the robots' motion may have put in the fit
unseen by its residuals: the picture is registered again under the guess that the robots keep
their axes but that nothing tells how far along them, either way, and the two transforms' mean
square disagreement over the rows, beyond what the second fit's larger error explains, is
added to its variance. The identifier adds it to that
picture's pixel noise (``Registration.pixel_var``), so that a picture registered badly (few
robots in view, scattered displacements) weighs less; the sensor model's nominal figure
(:func:`registered_pixel_noise`, what the agent's candidate predictions and the corrected
localizers read) is a bound from the config. With ground landmarks the detection source
registers the picture itself (:mod:`anonloc_env.landmarks`) and this estimator is not used.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from anonloc_env.camera import survey
from anonloc_env.config import EnvConfig
from anonloc_env.identify.arrays import is_shared, shared
from anonloc_env.landmarks import landmark_error
from anonloc_env.neighbours import _LOOK_AT_ALL as LOOK_AT_ALL
from anonloc_env.neighbours import pairs_within

#: The transform at the set point: ``(a, b, tx, ty, g, h)``.
HOME = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
#: How far (a share of the reach) the rows may move between rounds of matching before the
#: pairs within reach of them are searched again (``_Near``).
NEAR_MARGIN = 0.1
#: Median absolute value of a standard Gaussian number.
NORMAL_MAD = 0.6745
#: Cauchy scale of the pair weights, in standard deviations of a pair's residual.
CAUCHY_SIGMAS = 2.5
#: A displacement shorter than this share of the team's typical one gives no axis.
HEADING_MIN = 0.25
#: Nor one shorter than this many times the error the registration and the detector put in it.
AXIS_SIGMAS = 1.0
#: Spread of a robot's guess that kept its axis, across it and along it, as shares of the
#: typical displacement, before the fit rescales them to its residuals.
DIRECTED_SHARE = 0.35
ALONG_SHARE = 0.55
#: How far along its axis a robot's guess is, either way, as a share of the typical
#: displacement.
MODE_SHARE = 1.05
#: The spread along its axis of a robot's guess that says only that it kept to it, as a
#: share of the typical displacement.
LINE_SHARE = 1.3
#: The least share of the robots with an axis taken to go on along it, or back.
WAY_SHARE_MIN = 0.02
#: The fit's posterior spread understates the registration's true error by this factor (measured
#: against the camera's true change, 25 robots driving under ``drone-hover``, five seeds: 1.44
#: to 1.76): it takes the robots' displacements as independent, which walls and the view's
#: edges make them not quite. The stated error is widened by it.
ERROR_FACTOR = 1.6
#: Fewest pairs a robust scale (or the typical displacement) is taken from.
MIN_PAIRS = 4
#: A picture's robust scales are shrunk towards the running ones (from the pictures before) as
#: if those were this many pairs: a scale from a handful of pairs is too noisy to trust, and
#: when the fit locks onto a few pairs that agree by chance it is also too small.
SCALE_PRIOR_PAIRS = 8.0
#: Weight of the newest picture in the running robust scales (an exponential average).
SCALE_MEMORY = 0.2
#: Most rounds of matching and fitting a picture: it is matched again through each fit until
#: the matches hold (a turn or zoom of the camera moves the rows far from the centre by more
#: than a robot's spacing, so the first matches, from a shift alone, are wrong there).
MATCH_ROUNDS = 6
#: Median length of a two-dimensional standard Gaussian vector: ``sqrt(2 ln 2)``.
RAYLEIGH_MEDIAN = math.sqrt(2.0 * math.log(2.0))


class Anchors(NamedTuple):
    """Rows ``row`` of the previous picture whose robot the identifier is sure of, where each
    should be in the new picture (``target``, ``(K, 2)``, the previous picture's registered
    frame) and the spread of that prediction (``sigma``, image units per component, the new
    row's pixel noise in it): built by ``anchors.sure_moves``."""

    row: np.ndarray
    target: np.ndarray
    sigma: np.ndarray


class Guess(NamedTuple):
    """Where each previous row's robot should be now: ``ahead`` of ``target`` (``(K, 2)``, the
    previous picture's registered frame) along ``axis`` (``(K, 2)`` unit vectors), or
    ``behind`` it, the second ``back_cost`` less likely (its squared Mahalanobis length's
    extra, ``2 log`` of the odds; ``ahead``, ``behind`` and ``back_cost`` 0 where nothing gives
    an axis), and how far off that may be: ``sigma`` across the axis and ``along`` it (image
    units, per component; both ``sigma`` where nothing gives an axis); ``directed``: the
    robots whose last displacement gave the axis; ``sure``: the anchored rows
    (``camera.pooled_motion``)."""

    target: np.ndarray
    sigma: np.ndarray
    directed: np.ndarray
    sure: np.ndarray
    axis: np.ndarray
    along: np.ndarray
    ahead: np.ndarray
    behind: np.ndarray
    back_cost: np.ndarray

    def sub(self, j: np.ndarray) -> Guess:
        """The guesses ``j``."""
        return Guess(*(field[j] for field in self))


def _isotropic(target: np.ndarray, sigma: np.ndarray) -> Guess:
    """A guess of spread ``sigma`` in every direction, nothing directed or anchored."""
    count = len(target)
    axis = np.zeros((count, 2))
    axis[:, 0] = 1.0
    zero = np.zeros(count)
    return Guess(
        target,
        sigma,
        _none(count),
        _none(count),
        axis,
        sigma.copy(),
        zero,
        zero.copy(),
        zero.copy(),
    )


@dataclass(frozen=True)
class RegistrationPrior:
    """What the estimator knows of the camera's motion and of the robots' (image units, rad).

    Attributes:
        centre: the principal point ``(cu, cv)``, about which the similarity turns and scales.
        spread: standard deviation per component of a robot's displacement between two
            pictures when nothing predicts it (image units), before the fit rescales it.
        pixel_noise: the detector's standard deviation per coordinate (image units).
        radius: root mean square distance of the field of view's points from its centre
            (image units).
        change: standard deviations of the change of ``(a, b, tx, ty, g, h)`` between two
            pictures (``g``, ``h``: per image unit; 0 where the perspective is held at 0).
        absolute: standard deviations of ``(a - 1, b, tx, ty, g, h)`` about the set point.
        reach: the farthest a row moves between two pictures (image units): a robot's largest
            displacement plus four standard deviations of the camera's change.
    """

    centre: tuple[float, float]
    spread: float
    pixel_noise: float
    radius: float
    change: tuple[float, float, float, float, float, float]
    absolute: tuple[float, float, float, float, float, float]
    reach: float


def _ou_change(sigma: float, tau: float, interval: float) -> float:
    """Standard deviation of an OU process's change over ``interval``."""
    return sigma * math.sqrt(2.0 * (1.0 - math.exp(-interval / tau)))


def registration_prior(
    config: EnvConfig, pixel_noise: float | None = None
) -> RegistrationPrior | None:
    """The prior of ``config``'s camera motion, or ``None`` for a fixed camera, or one whose
    pictures its landmarks register (the detection source does it). ``pixel_noise``: the
    detector's (image units; default ``camera.pixel_noise``, the image source's measured one
    where the sensor model has it)."""
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
    bend = tilt / (s * cam.height)  # the left tilt's perspective, per image unit
    bend_change = _ou_change(tilt, cam.wobble_time, interval) / (s * cam.height)
    noise = float(cam.pixel_noise if pixel_noise is None else pixel_noise)
    if bend * _radius(config) ** 2 < max(noise, 0.01):  # under the detector's noise: held at 0
        bend = bend_change = 0.0
    zoom = cam.height_wobble / cam.height
    yaw = math.radians(cam.yaw_wobble_deg)
    rotate = math.hypot(zoom, yaw)
    rotate_change = _ou_change(rotate, cam.wobble_time, interval)
    step = config.robot.v_max * interval * s
    floor = 1e-6  # a process set to 0 is held (almost) exactly
    return RegistrationPrior(
        centre=(float(centre[0]), float(centre[1])),
        spread=0.5 * step,
        pixel_noise=noise,
        radius=_radius(config),
        change=(
            max(rotate_change, floor),
            max(rotate_change, floor),
            max(shift_change, floor),
            max(shift_change, floor),
            bend_change,
            bend_change,
        ),
        absolute=(
            max(rotate, floor),
            max(rotate, floor),
            max(shift, floor),
            max(shift, floor),
            bend,
            bend,
        ),
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
    """``rows`` ``(M, >=2)`` with their ``(u, v)`` through the transform ``(a, b, tx, ty, g, h)``
    about ``centre`` (a similarity and the left tilt's perspective to first order, see the
    module docstring; ``(a, b, tx, ty)``: the similarity alone) and, if present, their heading
    turned by its angle."""
    a, b, tx, ty = transform[:4]
    cu, cv = centre
    out = np.array(rows, dtype=np.float64, copy=True)
    du, dv = rows[:, 0] - cu, rows[:, 1] - cv
    out[:, 0] = cu + a * du - b * dv + tx
    out[:, 1] = cv + b * du + a * dv + ty
    if len(transform) > 4 and (transform[4] or transform[5]):
        bend = transform[4] * du + transform[5] * dv
        out[:, 0] -= du * bend
        out[:, 1] -= dv * bend
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
        error: the newest registration's own error (image units, per coordinate, root mean
            square over the rows): the posterior spread of its change since the previous
            picture, the fit's residuals setting the robots' spread.
    """

    def __init__(self, prior: RegistrationPrior, orientation: bool = True) -> None:
        self.prior = prior
        self.orientation = orientation
        # The perspective is fitted only where the prior gives it room (see registration_prior).
        self._fitted = 6 if prior.absolute[4] > 0.0 else 4
        self._change_w = 1.0 / np.square(prior.change[: self._fitted])
        self._absolute_w = 1.0 / np.square(prior.absolute[: self._fitted])
        self.reset()

    def reset(self) -> None:
        """Forget the episode: the next picture is taken as seen from the set point."""
        self.transform = HOME.copy()
        self.error = 0.0
        self._previous: np.ndarray | None = None  # registered (u, v) of the previous picture
        self._motion: np.ndarray | None = None  # each previous row's last displacement (or nan)
        self._step: float | None = None  # the team's typical displacement (image units)
        # Running robust scales of the directed pairs and of the others (None: none yet).
        self._scales: list[float | None] = [None, None, None]
        # How far the robots that kept an axis went on along it and back, and the share that
        # went on (None: not learnt yet).
        self._onward: tuple[float, float, float] | None = None

    @property
    def pixel_var(self) -> float:
        """The variance per coordinate a registered row carries into a displacement between the
        previous picture and the newest: the detector's, plus half the registration's (a
        displacement takes two rows' noise and one registration error)."""
        return self.prior.pixel_noise**2 + 0.5 * self.error**2

    def unseen(self, pos_var: np.ndarray) -> np.ndarray:
        """``pos_var`` (per component, image units squared) of positions predicted for robots
        missed in the newest picture, widened by the frame's change since the previous picture
        (``error`` squared): a robot seen again ``m`` pictures later is compared across ``m``
        registrations, whose errors add up. A field shared by every track stays shared."""
        extra = self.error**2
        if is_shared(pos_var):
            return shared(float(pos_var[0]) + extra, len(pos_var))
        return pos_var + extra

    def register(self, rows: np.ndarray, anchors: Anchors | None = None) -> np.ndarray:
        """The picture ``rows`` ``(M, 3)`` in the set point's frame (same order). ``anchors``:
        rows of the previous picture whose robot the identifier is sure of, and where each
        should be now (``anchors.sure_moves``), in place of the guess of their motion."""
        rows = np.asarray(rows, dtype=np.float64)
        if self._previous is None or len(rows) == 0 or len(self._previous) == 0:
            registered = apply(self.transform, self.prior.centre, rows)
            self.error = _first_error(self.prior)
            self._remember(registered, None)
            return registered
        guess = _anchored(self._predicted(), anchors, _residual_floor(self.prior))
        transform, pairs, self.error, scales = self._registered(rows, guess)
        # Robots kept an axis: how far the guess that nothing tells how far along it moves it.
        if guess.directed.any():
            line_guess = _anchored(self._line(guess), anchors, _residual_floor(self.prior))
            line, _, line_error, _ = self._registered(rows, line_guess)
            gap = apply(transform, self.prior.centre, rows[:, :2])
            gap -= apply(line, self.prior.centre, rows[:, :2])
            expected = max(line_error**2 - self.error**2, 0.0)
            self.error = math.sqrt(self.error**2 + max(float(np.mean(gap**2)) - expected, 0.0))
        self.transform = transform
        for k, scale in enumerate(scales):
            old = self._scales[k]
            if scale is not None:
                mixed = (1.0 - SCALE_MEMORY) * old**2 + SCALE_MEMORY * scale**2 if old else None
                self._scales[k] = scale if mixed is None else math.sqrt(mixed)
        registered = apply(transform, self.prior.centre, rows)
        self._remember(registered, pairs)
        return registered

    def _registered(
        self, rows: np.ndarray, guess: Guess
    ) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray], float, list[float | None]]:
        """The transform of ``rows`` to the previous rows' places ``guess`` (coarse shift, then
        matched and fitted until the matches hold, at most ``MATCH_ROUNDS`` times), its
        pairs, its stated error and its robust scales."""
        transform = self.transform.copy()
        transform[2:4] += self._coarse_shift(
            apply(transform, self.prior.centre, rows[:, :2]), guess
        )
        pairs = (np.zeros(0, np.int64), np.zeros(0, np.int64))
        error = 0.0
        scales: list[float | None] = [None, None, None]
        near = _Near(guess.target, self.prior.reach)
        for round_ in range(MATCH_ROUNDS):
            matched = self._match(apply(transform, self.prior.centre, rows[:, :2]), guess, near)
            if round_ and _same(matched, pairs):  # the matches hold: the fit is done
                break
            pairs = matched
            transform, error, scales = self._fit(rows[:, :2], pairs, guess, transform)
        return transform, pairs, error, scales

    def _line(self, guess: Guess) -> Guess:
        """The guess that the robots with an axis keep to it but that nothing tells how far
        along it, either way: each at its previous place, ``LINE_SHARE`` of the typical
        step along the axis (``guess`` as :meth:`_predicted` gives it)."""
        assert self._step is not None
        out = Guess(*(a.copy() for a in guess))
        out.ahead[:] = out.behind[:] = out.back_cost[:] = 0.0
        out.along[guess.directed] = max(LINE_SHARE * self._step, _residual_floor(self.prior))
        return out

    def _predicted(self) -> Guess:
        """Where each previous row's robot should be now and the spread of that guess (image
        units, per component, before the fit rescales it): a robot that moved keeps its axis
        (the line of its last displacement), along which it drives on or backs off (a bump's
        reverse drive) by up to the team's typical step or so, and leaves it by little (its
        turn); one that did not, or whose motion is unknown, moves that step in any
        direction."""
        assert self._previous is not None
        assert self._motion is not None
        target = self._previous.copy()
        count = len(target)
        if self._step is None:  # the first interval: nothing known of the robots' motion
            return _isotropic(target, np.full(count, self.prior.spread))
        floor = _residual_floor(self.prior)
        guess = _isotropic(target, np.full(count, max(self._step / math.sqrt(2.0), floor)))
        directed, length = self._axes(self._motion)
        if self._step > 0.0:
            guess.directed[:] = directed
            guess.axis[directed] = self._motion[directed] / length[directed][:, None]
            guess.sigma[directed] = max(DIRECTED_SHARE * self._step, floor)
            guess.along[directed] = max(ALONG_SHARE * self._step, floor)
            ahead, behind, share = self._onward_or_prior()
            guess.ahead[directed], guess.behind[directed] = ahead, behind
            guess.back_cost[directed] = 2.0 * math.log(share / (1.0 - share))
        return guess

    def _coarse_shift(self, moved: np.ndarray, guess: Guess) -> np.ndarray:
        """``(2,)`` the shift most pairs of rows agree on: the mode of the pairs' offsets
        (mean shift, its kernel narrowed from twice the camera's expected change to a robot's
        spread), so that a camera change as large as the robots' spacing is still matched."""
        target = guess.target
        sigma = np.sqrt(0.5 * (guess.sigma**2 + guess.along**2))
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

    def _match(self, moved: np.ndarray, guess: Guess, near: _Near) -> tuple[np.ndarray, np.ndarray]:
        """Mutual nearest pairs ``(row, previous row)`` between the rows ``moved`` (through the
        current transform) and the previous rows' predicted places (``near``'s), within the
        reach, nearest in the guesses' spreads."""
        i, j = near.pairs(moved)
        if len(i) == 0:
            return i, j
        offset = _turned((guess.target[j] - moved[i]).reshape(-1), *guess.axis[j].T)
        score = _mahalanobis(offset.reshape(-1, 2), guess.sub(j))
        best_i = _best(i, j, score, len(moved))
        best_j = _best(j, i, score, len(guess.target))
        mutual = (best_i[i] == j) & (best_j[j] == i)
        return i[mutual], j[mutual]

    def _fit(
        self,
        raw: np.ndarray,
        pairs: tuple[np.ndarray, np.ndarray],
        guess: Guess,
        start: np.ndarray,
    ) -> tuple[np.ndarray, float, list[float | None]]:
        """The transform's maximum a posteriori fit to the pairs (Cauchy-reweighted, 3 rounds,
        the guesses' spreads rescaled to the residuals after the first), its error (from the
        spreads shrunk towards the running scales) and this picture's robust scales of the
        directed pairs across and along their axes and of the others (``None`` where too
        few)."""
        i, j = pairs
        cu, cv = self.prior.centre
        du, dv = raw[i, 0] - cu, raw[i, 1] - cv
        # Rows of the design: u' - cu = a du - b dv + tx, v' - cv = b du + a dv + ty, each
        # pair's two turned onto its guess's axis and across it.
        t0, t1 = guess.axis[j, 0], guess.axis[j, 1]
        design = np.zeros((2 * len(i), 6))
        design[0::2, 0], design[0::2, 1], design[0::2, 2] = du, -dv, 1.0
        design[1::2, 0], design[1::2, 1], design[1::2, 3] = dv, du, 1.0
        design[0::2, 4], design[0::2, 5] = -du * du, -du * dv
        design[1::2, 4], design[1::2, 5] = -dv * du, -dv * dv
        home, k = HOME[: self._fitted], self._fitted
        design = design[:, :k]
        observed = np.empty(2 * len(i))
        observed[0::2], observed[1::2] = guess.target[j, 0] - cu, guess.target[j, 1] - cv
        design, centre = _turned(design, t0, t1), _turned(observed, t0, t1)
        sub = guess.sub(j)
        transform, sigma, along = start, sub.sigma, sub.along
        scales: list[float | None] = [None, None, None]
        for round_ in range(3):
            fitted = design @ transform[:k]
            observed, nearer, mixed = _ways(centre, fitted, sub, along)
            if round_:  # the scales from the places nearer each row, ahead or behind
                floor = _residual_floor(self.prior)
                sigma, along, scales = _rescaled((nearer - fitted).reshape(-1, 2), sub, floor)
            residual = (observed - fitted).reshape(-1, 2)
            weights = _weights(residual, sigma, np.sqrt(along**2 + mixed))
            normal = self._normal(design, weights)
            rhs = design.T @ (weights * observed)
            rhs += self._change_w * self.transform[:k] + self._absolute_w * home
            transform = np.concatenate([np.linalg.solve(normal, rhs), HOME[k:]])
        # The stated error takes the spreads shrunk towards the running scales (the fit keeps
        # this picture's own: its transform is the same with or without the shrinking).
        sigma, along = _shrunk(sigma, along, sub, self._scales)
        cov = np.linalg.inv(
            self._normal(design, _weights(residual, sigma, np.sqrt(along**2 + mixed)))
        )
        spread = float(np.mean(du**2 + dv**2)) if len(i) else self.prior.radius**2
        error = 0.5 * (cov[2, 2] + cov[3, 3]) + 0.25 * (cov[0, 0] + cov[1, 1]) * spread
        if len(i) and k > 4:  # the perspective's: du (g du + h dv) and dv (g du + h dv)
            radial = du**2 + dv**2
            error += 0.5 * (
                cov[4, 4] * np.mean(du**2 * radial) + cov[5, 5] * np.mean(dv**2 * radial)
            )
        return transform, ERROR_FACTOR * math.sqrt(max(error, 0.0)), scales

    def _normal(self, design: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """The fit's normal matrix: the design's rows ``weights`` and the priors."""
        normal = design.T @ (weights[:, None] * design)
        normal[np.diag_indices(self._fitted)] += self._change_w + self._absolute_w
        return normal

    def _remember(
        self, registered: np.ndarray, pairs: tuple[np.ndarray, np.ndarray] | None
    ) -> None:
        """Keep this picture's registered rows, the matched ones' displacement and the team's
        typical displacement (the median matched one)."""
        motion = np.full((len(registered), 2), np.nan)
        if pairs is not None and self._previous is not None:
            i, j = pairs
            motion[i] = registered[i, :2] - self._previous[j]
            if len(i) >= MIN_PAIRS:
                # Less the displacement the team shares (its median): that holds this picture's
                # registration error, which must not be predicted to persist.
                motion[i] -= np.median(motion[i], axis=0)
                self._learn_onward(motion[i], j)
                self._step = float(np.median(np.hypot(motion[i, 0], motion[i, 1])))
        self._previous = registered[:, :2].copy()
        self._motion = motion

    def _axes(self, motion: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Which of the displacements ``motion`` ``(K, 2)`` (NaN: unknown) give their robot an
        axis, and their lengths: those at least ``HEADING_MIN`` of the typical one, and
        ``AXIS_SIGMAS`` times what the registration and the detector may have put in them (a
        team that stands still moves by the registration's own error, whose pattern (a turn or
        a zoom) would leave the fit free in just that direction)."""
        assert self._step is not None
        length = np.hypot(motion[:, 0], motion[:, 1])
        least = max(
            HEADING_MIN * self._step,
            AXIS_SIGMAS * math.hypot(self.error, _residual_floor(self.prior)),
        )
        return np.isfinite(length) & (length > 0.0) & (length >= least), length

    def _learn_onward(self, motion: np.ndarray, previous: np.ndarray) -> None:
        """Learn, from the robots that had an axis (rows ``previous`` of the previous picture,
        their new displacement ``motion``), how far they went on along it and how far back, and
        the share that went on (running averages, :data:`SCALE_MEMORY`)."""
        if self._step is None or self._motion is None:
            return
        old = self._motion[previous]
        directed, length = self._axes(old)
        if int(directed.sum()) < MIN_PAIRS:
            return
        along = np.sum(motion[directed] * old[directed], axis=1) / length[directed]
        on = along > 0.0
        before = self._onward_or_prior()
        now = (
            float(np.median(along[on])) if on.any() else before[0],
            float(np.median(-along[~on])) if (~on).any() else before[1],
            min(max(float(np.mean(on)), WAY_SHARE_MIN), 1.0 - WAY_SHARE_MIN),
        )
        mixed = [
            (1.0 - SCALE_MEMORY) * b + SCALE_MEMORY * n for b, n in zip(before, now, strict=True)
        ]
        self._onward = (mixed[0], mixed[1], mixed[2])

    def _onward_or_prior(self) -> tuple[float, float, float]:
        """How far the robots with an axis go on along it and back (image units), and the share
        that goes on: as learnt, or ``MODE_SHARE`` of the typical step either way, even odds."""
        assert self._step is not None
        if self._onward is not None:
            return self._onward
        return MODE_SHARE * self._step, MODE_SHARE * self._step, 0.5


class _Near:
    """The pairs of rows and ``target`` places within ``reach`` (``pairs_within``'s, the same
    pairs in the same order) as the rows move from one round of matching to the next: where the
    search would run in numpy, the pairs within ``reach`` and a margin of the rows' first places
    are kept, and each round takes those within ``reach`` of the rows' places now, until the
    rows have moved further than the margin (then searched again)."""

    def __init__(self, target: np.ndarray, reach: float) -> None:
        self.target, self.reach = target, reach
        self.margin = NEAR_MARGIN * reach
        self.base: np.ndarray | None = None
        self.i = self.j = np.zeros(0, np.int64)

    def pairs(self, moved: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(row, place)`` pairs within the reach of the rows ``moved``."""
        if len(moved) * len(self.target) <= LOOK_AT_ALL:  # the compiled search: as it is
            i, j, _ = pairs_within(moved, self.target, self.reach)
            return i, j
        if self.base is None or float(np.abs(moved - self.base).max()) > self.margin:
            self.base = moved.copy()
            self.i, self.j, _ = pairs_within(moved, self.target, self.reach + 2.0 * self.margin)
        i, j = self.i, self.j
        keep = np.hypot(*(self.target[j] - moved[i]).T) <= self.reach
        return i[keep], j[keep]


def _none(count: int) -> np.ndarray:
    """No row anchored: ``(count,)`` False."""
    return np.zeros(count, bool)


def _anchored(guess: Guess, anchors: Anchors | None, floor: float) -> Guess:
    """``guess`` with the ``anchors``' rows predicted by their robots' own tracks (their
    spreads at least ``floor``, the same in every direction), sure and not directed."""
    if anchors is None:
        return guess
    out = Guess(*(a.copy() for a in guess))
    row = anchors.row
    out.target[row] = anchors.target
    out.sigma[row] = np.maximum(anchors.sigma, floor)
    out.along[row] = out.sigma[row]
    out.axis[row] = (1.0, 0.0)
    out.ahead[row] = out.behind[row] = out.back_cost[row] = 0.0
    out.directed[row] = False
    out.sure[row] = True
    return out


def _first_error(prior: RegistrationPrior) -> float:
    """The error of a picture registered with nothing to match (the previous picture's
    transform kept): the camera's change itself, per coordinate over the view."""
    shift, turn = prior.change[2], prior.change[0]
    return math.sqrt(shift**2 + 0.5 * turn**2 * prior.radius**2)


def _residual_floor(prior: RegistrationPrior) -> float:
    """The smallest spread a guess may take (image units): two rows' detector noise, or a
    hundredth of a pixel for noise-free pictures."""
    return max(math.sqrt(2.0) * prior.pixel_noise, 0.01)


def _turned(x: np.ndarray, t0: np.ndarray, t1: np.ndarray) -> np.ndarray:
    """The interleaved ``(u, v)`` rows of ``x`` (``(2K, ...)``) turned onto the unit vectors
    ``(t0, t1)``: each pair's ``(along, across)``."""
    u, v = x[0::2], x[1::2]
    if x.ndim > 1:
        t0, t1 = t0[:, None], t1[:, None]
    out = np.empty_like(x)
    out[0::2], out[1::2] = t0 * u + t1 * v, t0 * v - t1 * u
    return out


def _costs(along: np.ndarray, guess: Guess, spread: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For rows ``along`` their guesses' axes from the guesses' targets (image units,
    ``(K,)``): the squared Mahalanobis lengths along the axis (in ``spread``) from the places
    ahead and behind, each with its odds' cost (the likelier way's 0)."""
    ahead = (along - guess.ahead) ** 2 / spread**2 + np.maximum(-guess.back_cost, 0.0)
    behind = (along + guess.behind) ** 2 / spread**2 + np.maximum(guess.back_cost, 0.0)
    return ahead, behind


def _ways(
    centre: np.ndarray, fitted: np.ndarray, guess: Guess, spread: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For the rows ``fitted`` (interleaved ``(along, across)`` rows, ``centre`` those of their
    guesses' targets): the place the guesses give them (ahead and behind weighed by how well
    each explains the row, in ``spread`` along the axis, the odds counted), the nearer of the
    two, and ``(K,)`` the variance that weighing adds along the axis (the mixture's
    spread)."""
    ahead, behind = _costs(fitted[0::2] - centre[0::2], guess, spread)
    on = 0.5 * (1.0 + np.tanh(0.25 * (behind - ahead)))  # the chance it went on
    mixed, nearer = centre.copy(), centre.copy()
    mixed[0::2] += on * guess.ahead - (1.0 - on) * guess.behind
    nearer[0::2] += np.where(behind < ahead, -guess.behind, guess.ahead)
    return mixed, nearer, on * (1.0 - on) * (guess.ahead + guess.behind) ** 2


def _mahalanobis(offset: np.ndarray, guess: Guess) -> np.ndarray:
    """The lengths of ``offset`` ``(K, 2)`` (along and across the guesses' axes, image units,
    from their targets to the rows) from the nearer of their places, in the ``guess``'s
    spreads (the odds counted)."""
    ahead, behind = _costs(-offset[:, 0], guess, guess.along)
    return np.sqrt(np.minimum(ahead, behind) + (offset[:, 1] / guess.sigma) ** 2)


def _weights(residual: np.ndarray, sigma: np.ndarray, along: np.ndarray) -> np.ndarray:
    """``(2K,)`` the weights of the pairs' rows (along, across their axes; ``residual``
    ``(K, 2)``): their spreads ``along`` and ``sigma``, down-weighted (Cauchy) by the
    residual's length in those spreads."""
    norm = np.hypot(residual[:, 0] / along, residual[:, 1] / sigma)
    cauchy = 1.0 / (1.0 + (norm / CAUCHY_SIGMAS) ** 2)
    out = np.empty(2 * len(sigma))
    out[0::2], out[1::2] = cauchy / along**2, cauchy / sigma**2
    return out


def _rescaled(
    residual: np.ndarray, guess: Guess, floor: float
) -> tuple[np.ndarray, np.ndarray, list[float | None]]:
    """The guesses' spreads (across and along their axes, ``guess`` of the pairs) set to their
    residuals' robust scales where a group has :data:`MIN_PAIRS`: the directed pairs across
    and along their axes apart (the median absolute residual over a Gaussian's, 0.6745), the
    others in every direction (the median residual length over a two-dimensional Gaussian's,
    :data:`RAYLEIGH_MEDIAN`); and those scales (``None`` where too few pairs). The anchored
    pairs (``sure``) keep their own spreads, widened by their residuals' robust scale over
    those spreads where that is above one (where a similarity cannot follow the picture, or an
    anchor was wrong)."""
    sigma, along = guess.sigma.copy(), guess.along.copy()
    scales: list[float | None] = [None, None, None]
    sure = guess.sure
    directed, others = guess.directed & ~sure, ~guess.directed & ~sure
    if int(directed.sum()) >= MIN_PAIRS:
        scales[0] = max(float(np.median(np.abs(residual[directed, 1]))) / NORMAL_MAD, floor)
        scales[2] = max(float(np.median(np.abs(residual[directed, 0]))) / NORMAL_MAD, floor)
        sigma[directed], along[directed] = scales[0], scales[2]
    if int(others.sum()) >= MIN_PAIRS:
        norm = np.hypot(residual[others, 0], residual[others, 1])
        scales[1] = max(float(np.median(norm)) / RAYLEIGH_MEDIAN, floor)
        sigma[others] = along[others] = scales[1]
    if int(sure.sum()) >= MIN_PAIRS:
        norm = np.hypot(residual[sure, 0], residual[sure, 1])
        ratio = float(np.median(norm / guess.sigma[sure])) / RAYLEIGH_MEDIAN
        sigma[sure] = along[sure] = guess.sigma[sure] * max(ratio, 1.0)
    return sigma, along, scales


def _shrunk(
    sigma: np.ndarray, along: np.ndarray, guess: Guess, running: list[float | None]
) -> tuple[np.ndarray, np.ndarray]:
    """The spreads ``sigma`` (across) and ``along`` of the pairs (``guess``) shrunk towards the
    ``running`` scale of their group (where there is one: the directed pairs across and along
    their axes, the others), weighed as :data:`SCALE_PRIOR_PAIRS` pairs against the group's
    own (the anchored pairs keep theirs)."""
    sigma, along = sigma.copy(), along.copy()
    directed, others = guess.directed & ~guess.sure, ~guess.directed & ~guess.sure
    for group, spread, before in (
        (directed, sigma, running[0]),
        (others, sigma, running[1]),
        (directed, along, running[2]),
        (others, along, running[1]),
    ):
        count = int(group.sum())
        if count and before is not None:
            mixed = SCALE_PRIOR_PAIRS * before**2 + count * np.square(spread[group])
            spread[group] = np.sqrt(mixed / (SCALE_PRIOR_PAIRS + count))
    return sigma, along


def _same(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]) -> bool:
    """Whether two sets of pairs (each sorted as ``Registration._match`` gives) are equal."""
    return bool(
        len(a[0]) == len(b[0]) and np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    )


def _best(key: np.ndarray, other: np.ndarray, score: np.ndarray, size: int) -> np.ndarray:
    """``(size,)`` for each value of ``key``, the ``other`` of its lowest ``score`` (-1 if none;
    of equal scores, the first): each key's run after a stable sort, its least score, its first
    pair that has it."""
    out = np.full(size, -1, np.int64)
    if len(key) == 0:
        return out
    order = np.argsort(key, kind="stable")
    sorted_key, sorted_score = key[order], score[order]
    start = np.ones(len(order), bool)
    start[1:] = sorted_key[1:] != sorted_key[:-1]
    run = np.cumsum(start) - 1
    least = np.minimum.reduceat(sorted_score, np.flatnonzero(start))
    hit = np.flatnonzero(sorted_score == least[run])
    first = np.ones(len(hit), bool)
    first[1:] = run[hit[1:]] != run[hit[:-1]]
    pick = order[hit[first]]
    out[key[pick]] = other[pick]
    return out
