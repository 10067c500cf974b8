"""The limit beside the policies: how few pictures any excitation can need to reach 99 %.

Two numbers for a scenario, both in the unit of :func:`baselines.scoring.pictures_to_identify`
(the index of the picture at which 99 % of the robots present are identified at belief 0.99;
index ``k`` means ``k`` intervals of motion, so index 0 carries no motion):

* the **information bound**: the identities hold ``ln N!`` nats for the team; a picture can
  carry at most the capacity of the channel from the displacement (and, with detected headings,
  the turn) a robot can produce in one interval to what the camera sees, per robot. A lower bound
  on the mean picture index that any excitation achieves, under the assumptions of
  ``docs/limit.md`` (a genie that tracks every row and gives the starting positions only helps;
  contacts neglected; odometry error Gaussian).
* the **union estimate**: what uncoordinated random codes need (every robot draws its command
  uniformly from its box at every interval): the picture at which a Markov and union bound over
  the other ``N - 1`` robots puts a robot's chance of not being identified at belief 0.99 below
  1 %. An estimate, not a bound: it uses the swap test of two known displacements.

Pure numpy and scipy; nothing is simulated. The derivation is ``docs/limit.md``.

>>> from benchmarks.excitations import scenario
>>> limit = picture_limit(scenario(100, 30))
>>> round(limit.information, 2), round(limit.union, 2)
(1.12, 3.18)
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy import optimize
from scipy.stats import qmc

from anonloc_env.config import EnvConfig
from anonloc_env.identify import SensorModel
from baselines.active import unicycle
from baselines.excitations.swarm import DUTY_BUDGET

CONDITIONS = ("free", "swarm")
#: Points of the (deterministic, unscrambled) Halton sequence the union estimate averages over.
CODE_SAMPLES = 1 << 15
LOG_2PI_E = math.log(2.0 * math.pi * math.e)


@dataclass(frozen=True)
class PictureLimit:
    """The two limits of one scenario, in picture indices (0 = the picture at reset).

    Attributes:
        information: lower bound on the mean picture index at which ``fraction`` of the robots
            are identified, whatever the excitation (pictures; >= 1 for N >= 2, ``inf`` if no
            picture carries information). A bound under the assumptions of ``docs/limit.md``.
        union: the picture index at which uncoordinated uniform random codes leave each robot at
            most a 1 % chance of not being identified (pictures; an estimate, ``inf`` if never).
        nats_needed: information each robot's identity must gain, the team's need per robot
            (nats): ``(ln N! - what the decisions may leave open) / N``.
        nats_per_picture: most information a picture after the first motion carries per robot
            (nats), misses discounted.
        nats_first: the same for the first motion (picture 1), length alone without detected
            headings (nats).
        confusion: the union estimate's chance per picture after the first that another robot's
            random code looks like one's own (the swap test's Bhattacharyya coefficient, in
            [0, 1]), misses included.
        confusion_first: the same for the first motion.
    """

    information: float
    union: float
    nats_needed: float
    nats_per_picture: float
    nats_first: float
    confusion: float
    confusion_first: float


def picture_limit(
    config: EnvConfig,
    condition: str = "free",
    budget: float = DUTY_BUDGET,
    *,
    fraction: float = 0.99,
    threshold: float = 0.99,
) -> PictureLimit:
    """Both limits of ``config``'s scenario.

    Args:
        config: the scenario: robots, camera (scale, pixel noise, headings, misses), interval.
        condition: ``"free"`` (a robot's command anywhere in its limits) or ``"swarm"`` (one
            shared command plus a deviation of at most ``budget`` times the limits,
            :class:`baselines.excitations.SwarmDuty`).
        budget: the swarm deviation, a fraction of ``v_max`` and ``omega_max`` in [0, 1]
            (checked, used only on ``"swarm"``).
        fraction: share of the robots that must be identified, in (0, 1).
        threshold: belief at which a robot decides, in (0, 1).

    Returns:
        The :class:`PictureLimit`.

    Raises:
        TypeError: ``config`` is not an ``anonloc_env.EnvConfig``.
        ValueError: ``condition``, ``budget``, ``fraction`` or ``threshold`` out of range.
    """
    _check(config, condition, budget, fraction, threshold)
    n = config.n_robots
    model = SensorModel.from_config(config)
    needed = nats_needed(n, fraction, threshold)
    channel = _Channel.of(config, model, condition, budget)
    first = model.p_detect * channel.first_capacity()
    later = channel.later_capacity()
    p_first, p_later = channel.confusion()
    if n == 1:
        return PictureLimit(0.0, 0.0, 0.0, later, first, p_later, p_first)
    return PictureLimit(
        information=_information(needed, first, later),
        union=_union(n, p_first, p_later, _clutter(model), fraction, threshold),
        nats_needed=needed,
        nats_per_picture=later,
        nats_first=first,
        confusion=p_later,
        confusion_first=p_first,
    )


def nats_needed(n: int, fraction: float = 0.99, threshold: float = 0.99) -> float:
    """Information each robot must gain (nats): the team's ``ln N!`` less what the decisions may
    leave open, divided by N.

    At the picture that counts, ``ceil(fraction N)`` robots hold belief ``>= threshold`` on a
    row, so (beliefs calibrated) each keeps at most ``h(1 - threshold) + (1 - threshold)
    ln(N - 1)`` nats of doubt; each of the others at most ``ln N``.

    Raises:
        ValueError: ``n`` < 1, ``fraction`` outside (0, 1) or ``threshold`` outside (0, 1).
    """
    if not (isinstance(n, int | np.integer) and n >= 1):
        raise ValueError(f"n must be an integer >= 1, got {n!r}")
    _check_probabilities(fraction, threshold)
    if n == 1:
        return 0.0
    identified = math.ceil(fraction * n - 1e-9)
    doubt = 1.0 - threshold
    open_each = -threshold * math.log(threshold) - doubt * math.log(doubt)
    open_each += doubt * math.log(n - 1)
    left_open = identified * open_each + (n - identified) * math.log(n)
    return max(math.lgamma(n + 1) - left_open, 0.0) / n


def displacement_capacity(
    radius: float, pixel_noise: float, radial: float = 0.0, innovation: bool = True
) -> float:
    """Upper bound (nats) on the information per picture of a 2-D displacement anywhere in the
    disc of ``radius`` (image units), seen with ``pixel_noise`` (image units, per coordinate and
    picture) plus a radial error of ``radial`` times its length (relative: odometry, scale).

    The dual bound ``C <= max_x D(W_x || q)`` with ``q`` flat in noise units on the disc and a
    Gaussian skirt of rate ``lambda`` outside it, minimised over ``lambda``, or the
    second-moment bound where that is lower (``docs/limit.md``).
    ``innovation``: the displacement is measured from the previous picture's noisy detection (a
    later picture); without it the starting position is given (the first motion). ``inf``
    without pixel noise.
    """
    if radius <= 0.0:
        return 0.0
    if pixel_noise <= 0.0:
        return math.inf
    s2, k2 = pixel_noise**2, radial**2
    rim = s2 + k2 * radius**2  # radial noise variance at the rim
    # The weight 1 / sqrt(det noise) over the disc: 2 pi (sqrt(rim) - sigma) / (sigma k^2).
    inside = 2.0 * math.pi * radius**2 / (pixel_noise * (math.sqrt(rim) + pixel_noise))
    repeats = 4.0 if innovation else 2.0  # the output's trace: one or two pictures' noise
    rim_trace = repeats * s2 + k2 * radius**2
    # Jensen on the weight's log-determinant; the ratio is monotone in the length: its ends.
    slack = 0.5 * math.log1p(max(repeats * k2, k2 * rim_trace / rim))

    def bound(log_rate: float) -> float:
        rate = math.exp(log_rate)
        skirt = math.pi * (radius * math.sqrt(math.pi / rate) + 1.0 / rate)
        return math.log(inside + skirt / math.sqrt(rim * s2)) + rate * rim_trace

    # Or the second-moment bound (a Gaussian q), better where the disc is a few noises wide.
    power = math.log((radius**2 + rim_trace) / (2.0 * s2))
    return max(min(_minimum(bound) - LOG_2PI_E + slack, power), 0.0)


def interval_capacity(
    width: float, noise: float, relative: float = 0.0, innovation: bool = False
) -> float:
    """Upper bound (nats) on the information per picture of a scalar anywhere in an interval of
    ``width`` (image units or rad), seen with Gaussian ``noise`` (same unit, per picture) plus
    ``relative`` times its size: a displacement's length, or a detected turn. The 1-D form of
    :func:`displacement_capacity`; ``innovation`` as there. ``inf`` without noise.
    """
    if width <= 0.0:
        return 0.0
    if noise <= 0.0:
        return math.inf
    s2, k2 = noise**2, relative**2
    rim = s2 + k2 * width**2
    k = math.sqrt(k2)
    inside = math.asinh(k * width / noise) / k if k * width > 1e-6 * noise else width / noise
    repeats = 2.0 if innovation else 1.0
    rim_var = repeats * s2 + k2 * width**2
    slack = 0.5 * math.log1p(max(repeats * k2, k2 * rim_var / rim))

    def bound(log_rate: float) -> float:
        rate = math.exp(log_rate)
        tails = 0.5 * math.sqrt(math.pi / rate) * (1.0 / noise + 1.0 / math.sqrt(rim))
        return math.log(inside + tails) + rate * rim_var

    power = 0.5 * math.log((0.25 * width**2 + rim_var) / s2)
    return max(min(_minimum(bound) - 0.5 * LOG_2PI_E + slack, power), 0.0)


def _minimum(bound: Callable[[float], float]) -> float:
    """The least value of a bound over the skirt's log rate (any rate gives a valid bound)."""
    best = optimize.minimize_scalar(bound, bounds=(-40.0, 10.0), method="bounded")
    return min(float(best.fun), bound(float(best.x)))


@dataclass(frozen=True)
class _Channel:
    """What one interval lets a robot show: ranges (image units, rad) and noises."""

    config: EnvConfig
    model: SensorModel
    swarm: bool
    budget: float
    scale: float  # image units per metre
    reach: float  # radius of the disc of displacements that tell robots apart (image units)
    lengths: float  # width of the interval of first-interval lengths (image units)
    turns: float  # width of the interval of turns that tell robots apart (rad)
    odometry: float  # relative std of a straight drive's measured distance

    @classmethod
    def of(cls, config: EnvConfig, model: SensorModel, condition: str, budget: float) -> _Channel:
        robot, period = config.robot, config.picture_interval
        scale = float(model.scale or 1.0)
        full = robot.v_max * period * scale
        swarm = condition == "swarm"
        if swarm:
            # Deviation of speed b v_max and of turn rate b omega_max from the shared command:
            # |displacement - shared displacement| <= b v_max T (1 + omega_max T / 2).
            reach = min(budget * full * (1.0 + 0.5 * robot.omega_max * period), 2.0 * full)
            lengths = min(2.0 * reach, full)
            turns = min(2.0 * budget * robot.omega_max * period, 2.0 * math.pi)
        else:
            reach, lengths = full, full
            turns = min(2.0 * robot.omega_max * period, 2.0 * math.pi)
        steps = max(round(period / config.dt), 1)
        odometry = robot.odometry_noise / math.sqrt(steps)
        return cls(config, model, swarm, budget, scale, reach, lengths, turns, odometry)

    @property
    def relative(self) -> float:
        """Relative radial error of a displacement: odometry and the scale's spread."""
        return math.hypot(self.odometry, self.model.scale_spread)

    def turn_capacity(self, intervals: int = 1) -> float:
        """Nats per picture of the detected turn over ``intervals`` intervals (0 without
        detected headings)."""
        if not self.model.orientation:
            return 0.0
        width = min(self.turns * intervals, 2.0 * math.pi)
        noise = self.model.orientation_noise
        return interval_capacity(width, noise, self.odometry, innovation=True)

    def first_capacity(self) -> float:
        """Nats of the first motion, before misses: the length alone unless headings are
        detected."""
        noise = self.model.pixel_noise
        if self.model.orientation:
            shown = displacement_capacity(self.reach, noise, self.relative, innovation=False)
            return shown + self.turn_capacity()
        return interval_capacity(self.lengths, noise, self.relative)

    def later_capacity(self) -> float:
        """Nats of a later picture, misses discounted: a miss carries nothing, and a detection
        after ``g`` misses shows the ``g + 1`` intervals since the last one."""
        p_detect = self.model.p_detect
        p_miss = 1.0 - p_detect
        total, gap = 0.0, 0
        while gap == 0 or p_miss**gap > 1e-12:
            span = self.reach * (gap + 1)
            shown = displacement_capacity(span, self.model.pixel_noise, self.relative)
            shown += self.turn_capacity(gap + 1)
            total += p_detect * p_miss**gap * p_detect * shown
            gap += 1
        return total

    def confusion(self) -> tuple[float, float]:
        """The union estimate's per-picture confusion of two random codes: first, later."""
        config, robot = self.config, self.config.robot
        period, dt = config.picture_interval, config.dt
        points = qmc.Halton(d=6, scramble=False).random(CODE_SAMPLES + 1)[1:]  # skip the origin
        box = 2.0 * points - 1.0
        v_limit, w_limit = robot.v_max, robot.omega_max
        if self.swarm:
            v_shared, w_shared = box[:, 4] * v_limit, box[:, 5] * w_limit
            b = self.budget
            v = np.clip(v_shared[:, None] + b * v_limit * box[:, [0, 2]], -v_limit, v_limit)
            w = np.clip(w_shared[:, None] + b * w_limit * box[:, [1, 3]], -w_limit, w_limit)
        else:
            v, w = v_limit * box[:, [0, 2]], w_limit * box[:, [1, 3]]
        shift = unicycle(v, w, period) * self.scale  # own-frame displacements, image units
        x, y, turn = shift[..., 0], shift[..., 1], w * period
        steps = max(round(period / dt), 1)
        noise = robot.odometry_noise
        # The identifier's odometry variance (Interval.variances) of a held command, per axis.
        sum_ds2 = steps * (v * dt) ** 2
        var_d = noise**2 * (sum_ds2 + (np.abs(v) * period) ** 2 * steps * (w * dt) ** 2 / 3.0) / 2
        var = 2.0 * self.model.pixel_noise**2 + self.scale**2 * var_d.mean(axis=1)
        length = np.hypot(x, y)
        var = var + 0.5 * (self.model.scale_spread * length.mean(axis=1)) ** 2
        var = np.maximum(var, 1e-300)  # without noise only equal codes are confused
        gap2 = (x[:, 0] - x[:, 1]) ** 2 + (y[:, 0] - y[:, 1]) ** 2
        later = np.exp(-gap2 / (4.0 * var))
        if self.model.orientation:
            var_turn = 2.0 * self.model.orientation_noise**2 + noise**2 * steps * (w * dt) ** 2
            turns = np.exp(-((turn[:, 0] - turn[:, 1]) ** 2) / (4.0 * var_turn.mean(axis=1)))
            # The first motion: the heading at the reset picture is known to its noise only.
            slip = 0.5 * self.model.orientation_noise**2 * (length**2).mean(axis=1)
            first = np.exp(-gap2 / (4.0 * (var + slip))) * turns
            later = later * turns
        else:
            first = np.exp(-((length[:, 0] - length[:, 1]) ** 2) / (4.0 * var))
        p_detect = self.model.p_detect
        return (
            float(p_detect * first.mean() + 1.0 - p_detect),
            float(p_detect * later.mean() + 1.0 - p_detect),
        )


def _information(needed: float, first: float, later: float) -> float:
    """Least mean picture index whose pictures can carry ``needed`` nats: at least one motion
    (picture 0 carries none), then ``first`` nats and ``later`` per further picture."""
    if needed <= first:
        return 1.0
    if later <= 0.0:
        return math.inf
    return 1.0 + (needed - first) / later


def _clutter(model: SensorModel) -> float:
    """The union estimate's share of the newest picture's false rows: ``F`` times the chance
    (Bhattacharyya) that one falls where the robot is predicted, ``8 pi sigma^2 / A`` with the
    prediction's variance ``sigma^2`` of two detections."""
    return model.false_positives * 8.0 * math.pi * 2.0 * model.pixel_noise**2 / model.image_area


def _union(
    n: int, first: float, later: float, clutter: float, fraction: float, threshold: float
) -> float:
    """Least (real) picture index ``m >= 1`` with
    ``sqrt(t / (1 - t)) ((N - 1) first later^(m - 1) + clutter) <= 1 - fraction``."""
    odds = math.sqrt(threshold / (1.0 - threshold))
    room = (1.0 - fraction) / odds - clutter  # what the other robots may still take
    if room <= 0.0:
        return math.inf
    if first == 0.0 or (n - 1) * first <= room:
        return 1.0
    if later == 0.0:
        return 2.0  # the second motion tells every code apart
    if later >= 1.0:
        return math.inf
    return 1.0 + math.log((n - 1) * first / room) / -math.log(later)


def _check_probabilities(fraction: float, threshold: float) -> None:
    if not (isinstance(fraction, int | float) and 0.0 < fraction < 1.0):
        raise ValueError(f"fraction must be in (0, 1), got {fraction!r}")
    if not (isinstance(threshold, int | float) and 0.0 < threshold < 1.0):
        raise ValueError(f"threshold must be in (0, 1), got {threshold!r}")


def _check(
    config: EnvConfig, condition: str, budget: float, fraction: float, threshold: float
) -> None:
    if not isinstance(config, EnvConfig):
        raise TypeError(f"config must be an EnvConfig, got {type(config).__name__}")
    if condition not in CONDITIONS:
        raise ValueError(f"condition must be one of {list(CONDITIONS)}, got {condition!r}")
    if not (isinstance(budget, int | float) and 0.0 <= budget <= 1.0):
        raise ValueError(f"budget must be a number in [0, 1], got {budget!r}")
    _check_probabilities(fraction, threshold)
