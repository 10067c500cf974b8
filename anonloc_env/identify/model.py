"""The likelihood model: what a robot knows of its camera, detector and wheels, and the densities
of a displacement under it. See :mod:`anonloc_env.identify` for the model as a whole."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from anonloc_env._checks import check_number, check_pair
from anonloc_env.camera import survey
from anonloc_env.config import EnvConfig
from anonloc_env.identify.contact import (
    CROWD_JAM_TAIL,
    CROWD_NOISE,
    CROWD_PUSH_SHARE,
    CROWD_PUSH_TAIL,
    JAM,
    break_length,
)
from anonloc_env.identify.footprint import View, camera_view, landmark_view
from anonloc_env.identify.pose_prior import (
    RegistrationPrior,
    registered_pixel_noise,
    registration_prior,
)
from anonloc_env.landmarks import landmark_error
from anonloc_env.odometry import Interval

LOG_2PI = math.log(2.0 * math.pi)
#: Gates reach this many standard deviations.
GATE_SIGMAS = 5.0


@dataclass(frozen=True)
class SensorModel:
    """What a robot knows (or assumes) about its camera, detector and wheels.

    Attributes:
        scale: image units per metre; ``None`` if unknown (then estimated per hypothesis).
        scale_range: ``(low, high)`` prior range of the scale when it is unknown.
        scale_spread: relative standard deviation of the scale across the image (a tilted
            camera), in [0, 1).
        pixel_noise: standard deviation of a detection's ``u`` and ``v`` (image units).
        orientation: whether detections carry a measured heading.
        orientation_noise: standard deviation of a detected heading (rad).
        p_detect: probability that the robot is in a picture, in (0, 1].
        image_area: area of the field of view (image units squared), where other detections lie.
        odometry_noise: multiplicative noise of each control step's distance and turn.
        n_robots: how many robots the world holds (this one included), or ``None``. With it the
            other detections of a picture are the other ``n_robots - 1`` robots, each seen with
            probability ``p_detect``, plus Poisson false positives; without it they are Poisson
            clutter whose mean is estimated from the row count (see :func:`log_background`).
        false_positives: mean number of false detections per picture (used with ``n_robots``).
        push_share: the covariance of what contacts moved a robot unseen, as a share of
            :meth:`anonloc_env.odometry.Interval.push_covariance` (a push spread evenly up to its
            bound), in (0, 1].
            ``from_config`` sets :data:`PUSH_SHARE`, measured.
        others_sigma: standard deviation per component (m) of another robot's displacement
            between two consecutive pictures, or ``None``. With it (and ``n_robots``), where
            pictures have misses or false positives the other robots persist from picture to
            picture (:mod:`anonloc_env.identify.others`) instead of being clutter drawn afresh.
            ``from_config`` sets half the top speed times the picture interval (the spread of a
            displacement uniform over the disc a robot can reach).
        others_repeat: probability, in [0, 1), that another robot's displacement repeats its
            previous one (up to ``others_jitter`` and ``others_turn``) rather than being drawn
            afresh within ``others_sigma``: robots keep their commands for a while, and one
            that stood still tends to stay still. 0 (the default) draws every displacement
            afresh. ``from_config`` sets :data:`OTHERS_REPEAT`, measured.
        others_jitter: standard deviation per component (m) of the change of a repeated
            displacement, whatever its length. ``from_config`` sets :data:`OTHERS_JITTER`.
        others_turn: standard deviation per component of the change of a repeated displacement
            per unit of its length (turns, speed changes), >= 0. ``from_config`` sets
            :data:`OTHERS_TURN`.
        crowd_push_share: ``push_share`` for a robot pressed (pushed in this interval and the
            one before: it slides consistently, see :mod:`anonloc_env.identify.contact`), in
            (0, 1]; ``None`` (the default): ``push_share`` for every robot. ``from_config``
            sets :data:`anonloc_env.identify.contact.CROWD_PUSH_SHARE` where pictures have no
            misses and no false positives, ``None`` elsewhere (measured worse there).
        crowd_push_tail: the weight, in (0, 1], of ``crowd_push_share`` in a pressed robot's
            likelihood; the rest has ``push_share`` (a mixture, see
            :func:`anonloc_env.identify.contact.mix_pushes`; the heading is updated with
            ``crowd_push_share`` alone). 1 (the default): ``crowd_push_share`` alone.
            ``from_config`` sets :data:`anonloc_env.identify.contact.CROWD_PUSH_TAIL` with
            ``crowd_push_share``.
        crowd_jam: a robot pushed more than this many intervals in a row (>= 2) is jammed: its
            likelihood keeps ``crowd_push_share`` alone (but see ``crowd_jam_tail``). The
            default: :data:`anonloc_env.identify.contact.JAM`.
        crowd_jam_tail: the weight, in (0, 1], of ``crowd_push_share`` in a jammed robot's
            likelihood, the rest ``push_share`` (the mixture of ``crowd_push_tail``); ``None``
            (the default): ``crowd_push_share`` alone. ``from_config`` sets
            :data:`anonloc_env.identify.contact.CROWD_JAM_TAIL` where it sets ``crowd_noise``
            above 1 (a crowd on clean pictures, a fixed camera), ``None`` elsewhere.
        contact_break: the contact bound (m, summed over an interval) over which a
            pressed robot's track breaks with probability ``1 - 1/e`` (its weight returns to the
            uniform weight; see :func:`anonloc_env.identify.contact.break_tracks`), >= 0; 0 (the
            default): never. ``from_config`` sets
            :func:`anonloc_env.identify.contact.break_length` of the robots per m^2 of the
            arena (0 where it sets no ``crowd_push_share``).
        filter_position: a track's position is the detection combined with its predicted
            position where its heading and scale are known (a Kalman step on the position,
            ``anonloc_env.identify.likelihood.filter_positions``), not the detection alone:
            consecutive displacements share a detection's noise. ``False`` (the default): the
            detection. ``from_config`` sets it in a crowd: above ``FILTER_DENSITY`` robots
            per m^2, where pictures have no misses and no false positives.
        crowd_noise: the detections' noise is taken this many times ``pixel_noise`` (>= 1): a
            model-mismatch term for what the model of a crowd misses (see
            ``anonloc_env.identify.contact.CROWD_NOISE``). 1 (the default): ``pixel_noise``
            as stated. ``from_config`` sets ``CROWD_NOISE`` where it sets ``filter_position``
            and the camera is fixed.
        registration: the camera's motion when it moves and no landmarks register its pictures
            (:mod:`anonloc_env.identify.camera_pose`): the identifier then maps every picture into
            the set point's frame first, and ``from_config`` adds the registration's error to
            ``pixel_noise``. ``None``: a fixed (or landmark-registered) camera.
        view: a moving camera's view (:mod:`anonloc_env.identify.footprint`): each picture's
            footprint then enters the count law, and robots predicted out of view are expected
            to be missed. ``None``: a fixed camera, every robot in view.
        pooled_motion: with ``registration``, the robots share their motions
            (``camera.pooled_motion``): the robots the identifier is sure of anchor the registration
            (``anchors``) and a row another robot is sure of is taken from the rest
            (``out_of_view.claimed_elsewhere``). False: each robot's belief depends on the
            pictures and its own motion only.
        density: the robots per m^2 of the arena, as the config states them (>= 0; 0, the
            default: not stated). The identifier does not read it; ``bayes``'s decisions do
            (``baselines.decisions.in_cluttered_crowd``: pinned robots in a crowd with misses or
            false positives). ``from_config`` sets it.
    """

    scale: float | None
    scale_range: tuple[float, float]
    scale_spread: float
    pixel_noise: float
    orientation: bool
    orientation_noise: float
    p_detect: float
    image_area: float
    odometry_noise: float
    n_robots: int | None = None
    false_positives: float = 0.0
    push_share: float = 1.0
    others_sigma: float | None = None
    others_repeat: float = 0.0
    others_jitter: float = 0.0
    others_turn: float = 0.0
    crowd_push_share: float | None = None
    crowd_push_tail: float = 1.0
    crowd_jam: int = JAM
    crowd_jam_tail: float | None = None
    contact_break: float = 0.0
    filter_position: bool = False
    crowd_noise: float = 1.0
    registration: RegistrationPrior | None = None
    view: View | None = None
    pooled_motion: bool = False
    density: float = 0.0

    def __post_init__(self) -> None:
        if self.scale is not None:
            check_number("scale", self.scale, 0.0, low_open=True)
        low, high = check_pair("scale_range", self.scale_range)
        if not high >= low:
            raise ValueError(f"scale_range must have high >= low, got {self.scale_range}")
        check_number("scale_spread", self.scale_spread, 0.0, 1.0, high_open=True)
        check_number("pixel_noise", self.pixel_noise, 0.0)
        check_number("orientation_noise", self.orientation_noise, 0.0, math.pi)
        check_number("p_detect", self.p_detect, 0.0, 1.0, low_open=True)
        check_number("image_area", self.image_area, 0.0, low_open=True)
        check_number("odometry_noise", self.odometry_noise, 0.0, 1.0, high_open=True)
        if self.n_robots is not None and not (
            isinstance(self.n_robots, int | np.integer) and self.n_robots >= 1
        ):
            raise ValueError(f"n_robots must be an integer >= 1 or None, got {self.n_robots!r}")
        check_number("false_positives", self.false_positives, 0.0)
        check_number("push_share", self.push_share, 0.0, 1.0, low_open=True)
        if self.others_sigma is not None:
            check_number("others_sigma", self.others_sigma, 0.0, low_open=True)
        check_number("others_repeat", self.others_repeat, 0.0, 1.0, high_open=True)
        check_number("others_jitter", self.others_jitter, 0.0)
        check_number("others_turn", self.others_turn, 0.0)
        if self.crowd_push_share is not None:
            check_number("crowd_push_share", self.crowd_push_share, 0.0, 1.0, low_open=True)
        check_number("crowd_push_tail", self.crowd_push_tail, 0.0, 1.0, low_open=True)
        if not (isinstance(self.crowd_jam, int | np.integer) and self.crowd_jam >= 2):
            raise ValueError(f"crowd_jam must be an integer >= 2, got {self.crowd_jam!r}")
        if self.crowd_jam_tail is not None:
            check_number("crowd_jam_tail", self.crowd_jam_tail, 0.0, 1.0, low_open=True)
        check_number("contact_break", self.contact_break, 0.0)
        if not isinstance(self.filter_position, bool | np.bool_):
            raise ValueError(f"filter_position must be a bool, got {self.filter_position!r}")
        check_number("crowd_noise", self.crowd_noise, 1.0)
        check_number("density", self.density, 0.0)

    @classmethod
    def from_config(cls, config: EnvConfig, *, scale_known: bool = True) -> SensorModel:
        """The model a robot would build from the nominal specs of ``config`` (derived once per
        config and ``scale_known``, then cached: the model is frozen, so it is shared).

        The scale is the mean over the arena of the camera's local scale (what the paper did with
        its 20.8 to 22.07 range); its spread across the arena becomes ``scale_spread`` (see
        :func:`anonloc_env.camera.survey`). With ``scale_known=False`` the scale is left to
        be estimated within 0.5x to 2x of it.

        The camera's errors are read as ``config.camera`` states them; nothing is rendered or
        measured here. For the image source, whose own errors the nominal fields do not describe,
        pass the config the env holds (``env.config``) or
        :func:`anonloc_env.detection.stated_config` of it: it states the measured errors.
        """
        return _from_config(config, scale_known)

    @property
    def scale_bounds(self) -> tuple[float, float]:
        """``(low, high)`` scale: the known scale twice, or the prior range."""
        if self.scale is not None:
            return (self.scale, self.scale)
        return self.scale_range


def _view(config: EnvConfig, registration: RegistrationPrior | None) -> View | None:
    """A moving camera's view (its pictures' footprints), None for a fixed camera."""
    if registration is not None:
        return camera_view(config, registration.absolute[2])
    if config.camera.landmarks and config.camera.moves:
        return landmark_view(config, landmark_error(config, config.camera.pixel_noise))
    return None


@functools.lru_cache(maxsize=64)
def _from_config(config: EnvConfig, scale_known: bool) -> SensorModel:
    """:meth:`~anonloc_env.identify.model.SensorModel.from_config`, computed."""
    camera = survey(config)
    mean = camera.scale
    u_min, v_min, u_max, v_max = camera.field_of_view
    cam = config.camera
    clean = cam.p_miss == 0.0 and cam.false_positives == 0.0
    area = config.arena_size[0] * config.arena_size[1]
    registration = registration_prior(config, cam.pixel_noise)
    # 1e-9: an arena sized for exactly FILTER_DENSITY robots per m^2, rounded.
    crowd = clean and config.n_robots / area > FILTER_DENSITY * (1.0 + 1e-9)
    return SensorModel(
        scale=mean if scale_known else None,
        scale_range=(0.5 * mean, 2.0 * mean),
        scale_spread=camera.scale_spread,
        pixel_noise=registered_pixel_noise(config, cam.pixel_noise),
        orientation=cam.orientation,
        orientation_noise=math.radians(cam.orientation_noise_deg),
        p_detect=1.0 - cam.p_miss,
        image_area=max((u_max - u_min) * (v_max - v_min), 1e-9),
        odometry_noise=config.robot.odometry_noise,
        n_robots=config.n_robots,
        false_positives=cam.false_positives,
        push_share=PUSH_SHARE,
        others_sigma=0.5 * config.robot.v_max * config.schedule.picture_interval,
        others_repeat=OTHERS_REPEAT,
        others_jitter=OTHERS_JITTER,
        others_turn=OTHERS_TURN,
        # The crowd's contact model was measured on clean pictures; with misses or false
        # positives it made `random` slower and less reliable at one robot per m^2 (docs/crowds.md).
        crowd_push_share=CROWD_PUSH_SHARE if clean else None,
        crowd_push_tail=CROWD_PUSH_TAIL if clean else 1.0,
        contact_break=break_length(config.n_robots / area) if clean else 0.0,
        filter_position=crowd,
        crowd_noise=CROWD_NOISE if crowd and registration is None else 1.0,
        crowd_jam_tail=CROWD_JAM_TAIL if crowd and registration is None else None,
        registration=registration,
        view=_view(config, registration),
        pooled_motion=registration is not None and config.camera.pooled_motion,
        density=config.n_robots / area,
    )


#: ``from_config`` filters the tracks' positions (``SensorModel.filter_position``) above this
#: many robots per m^2, on clean pictures: in a crowd most robots hardly move, and a track
#: anchored at each detection lets a still robot's own pictures fit worse than a stranger's
#: (docs/crowds.md, eighth round). Up to one robot per m^2 (open space, the agents'
#: evaluation conditions) the identifier stays as it was, bit for bit, and keeps its fast
#: kernels.
FILTER_DENSITY = 1.0

#: What contacts move a robot unseen is far below its bound (``push_bound``): measured against
#: the true poses on the clutter scenario of ``benchmarks/identify_quality.py`` (1 robot per m^2,
#: 1,432 intervals with a contact), the unseen displacement is 0.08 of the bound at the median,
#: 0.37 at the 99th percentile and 0.62 at most. A push spread evenly up to the bound has a
#: standard deviation of 0.58 of it along the push; this share of its covariance makes that 0.2,
#: so the largest measured push is about 3 standard deviations out.
PUSH_SHARE = 0.12

#: How the other robots' displacement between consecutive pictures follows their previous one,
#: fitted (maximum likelihood over a grid) to the true tracks of the clutter scenario of
#: ``benchmarks/identify_quality.py`` on seeds 100 to 115 (disjoint from the benchmark's; 2,960
#: pairs of consecutive displacements under the ``random`` excitation, 1 s between pictures):
#: with probability 0.85 the displacement repeats the previous one, changed by 0.025 m plus 0.3
#: of its length per component (speed changes, turns, a start after a bump); else it is drawn
#: afresh (``others_sigma``). The median displacement is 0.1 m (a quarter of the robots move
#: less than 0.025 m: they turn in place after a bump), far below what ``others_sigma`` (0.25 m)
#: spreads; the fit gains 1.6 nats per displacement over drawing every one afresh.
OTHERS_REPEAT = 0.85
OTHERS_JITTER = 0.025
OTHERS_TURN = 0.3

#: The detection probability and false-positive rate are floored here in the count law, so that
#: no row count is impossible (a robot may leave the view, a detector may see a ghost).
P_DETECT_CEILING = 1.0 - 1e-6
FALSE_POSITIVE_FLOOR = 1e-3


def log_background(model: SensorModel, n_rows: int, share: float = 1.0) -> float:
    """``log lambda``: the density (per image unit squared) that a picture of ``n_rows`` rows
    puts on the other detections when it is weighed against "this robot was missed".

    A robot's hypothesis "I am row q" is worth ``P_D f(z_q) / lambda`` against "I was missed"
    (``1 - P_D``), with ``lambda = n P(B = n) / (P(B = n - 1) A)``: ``B`` is the number of
    other detections and ``A`` the image area (rows are shuffled, so a given row is mine with
    probability ``1 / n``). With ``n_robots`` known, ``B`` is the other ``n_robots - 1`` robots
    seen with probability ``P_D`` each plus Poisson false positives: when every robot is in the
    picture, the count itself says so. Without it, ``B`` is Poisson with mean ``n - P_D``
    (its plug-in estimate from the row count), and ``lambda = (n - P_D) / A``.

    ``share``: the share of the arena in view (a moving camera's footprint, see
    :mod:`anonloc_env.identify.footprint`): each robot is then seen with ``P_D share``.
    """
    try:  # a pure function of its arguments, asked at every picture: remembered
        return _log_background_cached(model, n_rows, share)
    except TypeError:  # a model with an unhashable field
        return _log_background(model, n_rows, share)


@functools.lru_cache(maxsize=1024)
def _log_background_cached(model: SensorModel, n_rows: int, share: float) -> float:
    return _log_background(model, n_rows, share)


def _log_background(model: SensorModel, n_rows: int, share: float) -> float:
    """:func:`log_background`, computed."""
    area = model.image_area
    p_seen = model.p_detect if share == 1.0 else model.p_detect * share
    if model.n_robots is None:
        return math.log(max(n_rows - p_seen, 0.5) / area)
    if n_rows == 0:
        return math.log(0.5 / area)  # unused: no row to weigh
    p = min(model.p_detect, P_DETECT_CEILING)
    if share != 1.0:
        p *= share
    rate = max(model.false_positives, FALSE_POSITIVE_FLOOR)
    ratio = _log_count(n_rows, model.n_robots - 1, p, rate) - _log_count(
        n_rows - 1, model.n_robots - 1, p, rate
    )
    return math.log(n_rows) + ratio - math.log(area)


def _log_count(k: int, others: int, p: float, rate: float) -> float:
    """``log P(Binomial(others, p) + Poisson(rate) = k)``."""
    log_fact = _log_factorials(max(k, others))
    j = np.arange(min(k, others) + 1)
    rest = k - j
    terms = (
        log_fact[others]
        - log_fact[j]
        - log_fact[others - j]
        + j * math.log(p)
        + (others - j) * math.log1p(-p)
        + rest * math.log(rate)
        - rate
        - log_fact[rest]
    )
    top = float(terms.max())
    return top + math.log(float(np.exp(terms - top).sum()))


def _log_factorials(n: int) -> np.ndarray:
    """``log(m!)`` for ``m = 0 .. n``."""
    out = np.zeros(n + 1)
    np.cumsum(np.log(np.arange(1, n + 1)), out=out[1:])
    return out


def push_covariance(interval: Interval, model: SensorModel) -> np.ndarray:
    """``(R, 2, 2)`` covariance (m^2, robot frame) of the unseen contact pushes in the model."""
    return interval.push_covariance() * model.push_share


def push_isotropic(interval: Interval, model: SensorModel) -> np.ndarray:
    """``(R,)`` variance per component (m^2) of the unseen contact pushes, spread evenly."""
    cov = push_covariance(interval, model)
    return 0.5 * (cov[:, 0, 0] + cov[:, 1, 1])


#: Abramowitz and Stegun 9.8.1: ``I0(x)`` for ``x < 3.75``, a series in ``t = (x / 3.75)^2``
#: (lowest power first).
I0_SMALL = (1.0, 3.5156229, 3.0899424, 1.2067492, 0.2659732, 0.0360768, 0.0045813)
#: Abramowitz and Stegun 9.8.2: ``I0(x) exp(-x) sqrt(x)`` for ``x >= 3.75``, a series in
#: ``t = 3.75 / x`` (lowest power first).
I0_LARGE = (
    0.39894228,
    0.01328592,
    0.00225319,
    -0.00157565,
    0.00916281,
    -0.02057706,
    0.02635537,
    -0.01647633,
    0.00392377,
)


def series(t: np.ndarray, coefficients: tuple[float, ...]) -> np.ndarray:
    """``c0 + t (c1 + t (c2 + ...))`` (Horner's rule, innermost first)."""
    out = coefficients[-1] * t
    for c in coefficients[-2:0:-1]:
        out = t * (c + out)
    return coefficients[0] + out


def log_i0e(x: np.ndarray) -> np.ndarray:
    """``log(I0(x) exp(-x))`` for ``x >= 0`` (Abramowitz and Stegun 9.8.1-2, error < 2e-7)."""
    x = np.asarray(x, dtype=np.float64)
    small = x < 3.75
    out = np.empty_like(x)
    t = (x[small] / 3.75) ** 2
    out[small] = np.log(series(t, I0_SMALL)) - x[small]
    big = ~small
    t = 3.75 / x[big]
    out[big] = np.log(series(t, I0_LARGE)) - 0.5 * np.log(x[big])
    return out


def ring_loglik(r: np.ndarray, rho: np.ndarray, var: np.ndarray) -> np.ndarray:
    """Log density of a 2-D displacement of length ``r`` when it is ``rho`` long in an unknown,
    uniform direction, with isotropic Gaussian noise of variance ``var`` per component."""
    x = r * rho / var
    return -LOG_2PI - np.log(var) - (r - rho) ** 2 / (2.0 * var) + log_i0e(x)


#: ``log(I0(x) exp(-x) sqrt(x))`` of ``log_i0e`` is at most this, for every ``x > 0`` (its
#: largest value is -0.7575, near ``x = 0.79``; it tends to ``-log(2 pi) / 2`` as ``x`` grows).
LOG_I0E_ROOT_MAX = -0.75


def ring_loglik_bound(r: np.ndarray, rho: np.ndarray, var: np.ndarray) -> np.ndarray:
    """An upper bound of ``ring_loglik`` (same arguments), cheaper: ``log_i0e(x)`` bounded
    by ``min(0, LOG_I0E_ROOT_MAX - log(x) / 2)``. Within 0.17 nat of it where ``x = r rho /
    var`` is large (a ring much longer than its noise), so that candidates far below their
    robot's best can be dropped before they are scored."""
    x = r * rho / var
    with np.errstate(divide="ignore"):
        tail = np.minimum(0.0, LOG_I0E_ROOT_MAX - 0.5 * np.log(x))
    return -LOG_2PI - np.log(var) - (r - rho) ** 2 / (2.0 * var) + tail
