"""Contacts in a crowd: what a robot pressed against others for a while may have done unseen.

Without a detected heading a robot learns its heading from its track: the direction of its
displacement in the picture against that of its own odometry. A contact moves a robot sideways,
unseen by its wheels. A single bump does so once and at random, which the model's pushes
(:meth:`anonloc_env.odometry.Interval.push_covariance`, a share
:attr:`~anonloc_env.identify.SensorModel.push_share` of a push spread evenly up to its bound)
describe. A robot pressed against a wall or a neighbour for several intervals slides
*consistently*: the same way, interval after interval, up to its bound. Pushes independent from
interval to interval then take the slide for a heading: on a recorded episode at 4 robots per
m^2 a robot's heading was 0.62 rad off (2.1 standard deviations) after one leg and still off
after the next, its true track lost, and another robot's rows fitted at belief 0.996
(``docs/crowds.md``).

The model here, for a robot *pressed*: pushed in this interval and in the one before.

* Its pushes are spread evenly up to their bound: the share of the push covariance is
  :attr:`~anonloc_env.identify.SensorModel.crowd_push_share` (1 from ``from_config``) instead of
  ``push_share``. A slide then informs the heading little (the Kalman gain along the robot's
  side, which is where a heading error shows, is small), and the position still counts.
* But its likelihood mixes those wide pushes (weight
  :attr:`~anonloc_env.identify.SensorModel.crowd_push_tail`, 0.05) with a bump's narrow ones
  (:func:`mix_pushes`): most slides are short, and with the wide pushes alone a neighbour pressed
  against the robot fitted almost as well as its own row, so decided robots went undecided
  whenever they were pressed. A *jammed* robot, pushed more than
  :attr:`~anonloc_env.identify.SensorModel.crowd_jam` (:data:`JAM`) intervals in a row,
  keeps the wide pushes alone (robots jammed together for tens of intervals were taken for one
  another with the mixture) where the decisions do not guard it: up to one robot per m^2. In a
  crowd (above one robot per m^2, clean pictures, a fixed camera) its likelihood mixes them too
  (:attr:`~anonloc_env.identify.SensorModel.crowd_jam_tail`, :data:`CROWD_JAM_TAIL`): a
  jammed robot slides no wider than a pressed one, and with the wide pushes alone the beliefs
  of decided jammed robots drifted down along their own track, interval after interval, until
  they were undecided. Robots jammed alike were not decided on one another more often on
  tuning episodes (with the filtered positions and noise floor added since the jam limit).
* Its track may have broken (a slide taken for a heading, a swap with a pressed neighbour):
  with probability ``1 - exp(-push / contact_break)`` a robot's weight returns to the uniform
  weight over the previous picture's rows, so an identity lost in a jam is found again and the
  belief stays below certainty while the robot is pressed.

And for every robot, a heading learnt from a pushed first leg is uncertain by the push along the
robot's side (:func:`first_heading_variance`), not by its average over two directions.

Robots that bump once keep the model as it was but for that first leg. With
``crowd_push_share=None`` the identifier is the one before issue 23, bit for bit.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from anonloc_env.odometry import Interval

#: The share of the push covariance for a pressed robot: a push spread evenly up to its bound.
CROWD_PUSH_SHARE = 1.0
#: The weight of that wide push in a pressed robot's likelihood (see :func:`mix_pushes`); the
#: rest has the pushes of a robot that bumps once (``push_share``).
CROWD_PUSH_TAIL = 0.05
#: A robot pushed more intervals in a row than this is *jammed*: its likelihood keeps the wide
#: pushes alone (see :func:`mix_pushes`), but in a crowd (:data:`CROWD_JAM_TAIL`).
JAM = 10
#: The weight of the wide pushes in a jammed robot's likelihood in a crowd
#: (``SensorModel.crowd_jam_tail``, set by ``from_config`` above one robot per m^2 on clean
#: pictures with a fixed camera): the same mixture as a pressed robot's. A jammed robot slides no
#: wider than a pressed one (fitted share of the push covariance 0.044 against 0.047 on tuning
#: episodes at 6 per m^2), and with the wide pushes alone every interval it stays jammed moves a
#: little of its belief to the neighbours pressed against it: the beliefs of robots decided and
#: jammed for 11 to 28 intervals drifted down along their own track until they were undecided,
#: several at once (``docs/crowds.md``, twelfth round).
CROWD_JAM_TAIL = CROWD_PUSH_TAIL
#: The contact bound (m, summed over an interval) over which a pressed robot's track breaks
#: with probability ``1 - 1/e`` at one robot per m^2 or fewer (see :func:`break_length`); a
#: robot pressed through a whole interval at top speed has a bound of about 0.4 m.
CONTACT_BREAK = 100.0
#: The detections' noise in a crowd, as a multiple of the stated pixel noise
#: (``SensorModel.crowd_noise``): a model-mismatch term. The detections are as noisy as stated
#: (1 px per component at 4 robots per m^2, against the true poses) and a robot nothing touches
#: moves exactly as its wheels say, but a contact moves a robot in ways the pushes do not
#: describe: along its heading, where they have no spread (0.05 / 0.3 / 0.7 cm at the 50th /
#: 90th / 99th percentile for ``random`` at 4 per m^2), and across it with a tail and a
#: correlation from interval to interval that they leave out. Among many robots that hardly
#: move, each rival's fit then varies more than the model says, and the best of them beat the
#: true track more often than the beliefs promised. Replayed on tuning episodes (``random``,
#: N = 30, seeds 700 to 747; ``docs/crowds.md``, ninth round), 1.2 cut the confident decisions
#: wrong from 29 to 7 at 4 per m^2 and from 37 to 2 at 6 per m^2, with as many decisions and
#: pictures to 99 %; widening the pushes of pushed robots instead slowed identification and cut
#: fewer.
CROWD_NOISE = 1.2


def break_length(density: float) -> float:
    """The contact bound (m) over which a pressed robot's track breaks with probability
    ``1 - 1/e`` among ``density`` robots per m^2: :data:`CONTACT_BREAK` up to one robot per m^2,
    shorter by the square root of the density above it (a pressed robot has more neighbours to be
    mixed up with). Robots jammed together for tens of intervals at 4 and 6 per m^2 were taken
    for one another, or for a far robot jammed the same way once their own track had been
    pruned, at ``CONTACT_BREAK``; at ``CONTACT_BREAK / density`` (the fourth round) a break cost
    every pressed robot at 4 per m^2 up to 1.6 % of its belief per interval, so decided robots
    went undecided whenever they were pressed (``docs/crowds.md``, fifth round)."""
    if not density > 0.0:
        raise ValueError(f"density must be > 0 robots per m^2, got {density}")
    return CONTACT_BREAK / math.sqrt(max(1.0, density))


@dataclasses.dataclass(frozen=True)
class PressedInterval(Interval):
    """An interval whose pressed robots' pushes are widened (see :func:`pressed_interval`).

    Attributes:
        mixed: ``(R,)`` the robots whose likelihood mixes the wide pushes with narrow ones
            (:func:`mix_pushes`) with weight ``crowd_push_tail``: pressed, but not jammed.
        narrow: the interval as it was, pushes not widened.
        jammed: ``(R,)`` the jammed robots whose likelihood mixes them too, with weight
            ``jam_tail`` (None: none).
        jam_tail: that weight (``SensorModel.crowd_jam_tail``), or None.
    """

    mixed: np.ndarray | None = None
    narrow: Interval | None = None
    jammed: np.ndarray | None = None
    jam_tail: float | None = None


def pressed_interval(
    interval: Interval,
    run: np.ndarray,
    push_share: float,
    crowd_push_share: float,
    jam: int = JAM,
    jam_tail: float | None = None,
) -> Interval:
    """``interval`` with the pushes of the robots pressed (pushed ``run`` >= 2 intervals in a
    row, this one included) widened so that the model's share of their covariance is
    ``crowd_push_share`` instead of ``push_share`` (the same interval where none is pressed); a
    :class:`PressedInterval` that keeps ``interval`` as its ``narrow``, mixed in for the robots
    pushed at most ``jam`` intervals in a row, and for the jammed ones (pushed more) with weight
    ``jam_tail`` where it is below 1 (None: not for them)."""
    pressed = run >= 2
    if interval.push is None or interval.push_sum is None or not pressed.any():
        return interval
    factor = np.where(pressed, np.sqrt(crowd_push_share / push_share), 1.0)
    wide = {f.name: getattr(interval, f.name) for f in dataclasses.fields(interval)}
    wide.update(push=interval.push * factor, push_sum=interval.push_sum * factor[:, None])
    jammed = run > jam if jam_tail is not None and jam_tail < 1.0 else None
    return PressedInterval(
        **wide,
        mixed=pressed & (run <= jam),
        narrow=interval,
        jammed=jammed,
        jam_tail=None if jammed is None else jam_tail,
    )


def tail_candidates(interval: Interval, slot: np.ndarray, tail: float | None) -> np.ndarray:
    """Indices of the candidates (robots ``slot``) whose likelihood :func:`mix_pushes` mixes:
    those of pressed robots, where ``interval`` is a :class:`PressedInterval` and ``tail`` is
    below 1, and those of its mixed jammed robots (none otherwise)."""
    if not isinstance(interval, PressedInterval):
        return np.zeros(0, np.int64)
    assert interval.mixed is not None
    mixed = interval.mixed if tail is not None and tail < 1.0 else None
    if interval.jammed is not None:
        mixed = interval.jammed if mixed is None else mixed | interval.jammed
    if mixed is None:
        return np.zeros(0, np.int64)
    return np.flatnonzero(mixed[slot])


def tails(interval: Interval, robots: np.ndarray, tail: float) -> float | np.ndarray:
    """The weight of the wide pushes in the likelihood of candidates of ``robots`` (those of
    :func:`tail_candidates`): ``tail`` (``crowd_push_tail``), but for the jammed robots of a
    :class:`PressedInterval` whose own weight is ``jam_tail``."""
    if not isinstance(interval, PressedInterval) or interval.jammed is None:
        return tail
    jammed = interval.jammed[robots]
    if not jammed.any():
        return tail
    assert interval.jam_tail is not None
    return np.where(jammed, interval.jam_tail, tail)


def mix_pushes(wide: np.ndarray, narrow: np.ndarray, tail: float | np.ndarray) -> np.ndarray:
    """A pressed robot's log-likelihood: its pushes are those of a single bump (``narrow``,
    ``push_share``) but for a share ``tail`` of its intervals, where they are spread up to their
    bound (``wide``). Measured on the true poses of crowded episodes (greedy, distinct and
    random at 4 robots per m^2, 7,917 pressed intervals), the unseen sideways motion is 0.08 of
    the bound at the median, 0.26 at the 90th percentile, 0.45 at the 99th and up to 0.89: mostly
    a bump's, with a wide tail. With the wide pushes alone a neighbour pressed against the robot,
    one size away, fitted almost as well as the robot's own row and decided robots went
    undecided (``docs/crowds.md``). The heading and scale are updated with the wide pushes
    only, so a slide still does not turn into a heading. ``tail`` may be one per candidate."""
    if isinstance(tail, np.ndarray):
        return np.logaddexp(narrow + np.log1p(-tail), wide + np.log(tail))
    return np.logaddexp(narrow + math.log1p(-tail), wide + math.log(tail))


def break_tracks(
    logw: np.ndarray,
    slot: np.ndarray,
    uniform: np.ndarray,
    unanchored: np.ndarray,
    log_rows: float,
    push: np.ndarray,
    break_length: float,
) -> None:
    """Robots with ``push > 0`` may have broken their track: with probability
    ``1 - exp(-push / break_length)`` their weight returns to the uniform weight over the
    previous picture's rows (in place; each robot's weights sum to one before and after).

    Args:
        logw: ``(T,)`` the tracks' log weights.
        slot: ``(T,)`` each track's robot.
        uniform: ``(R,)`` each robot's log weight per row of the previous picture.
        unanchored: ``(R,)`` each robot's log weight of "position unknown".
        log_rows: log of the previous picture's row count (or of its rows' summed bias).
        push: ``(R,)`` the contact bound (m) of the robots that may have broken their track,
            0 elsewhere.
        break_length: the bound (m) over which a track breaks with probability ``1 - 1/e``;
            0 disables the breaks.
    """
    hit = push > 0.0
    if break_length == 0.0 or not np.isfinite(log_rows) or not hit.any():
        return
    keep = -push / break_length  # log of the probability that the track holds
    logw += keep[slot]
    unanchored += keep
    lost = np.log(-np.expm1(keep[hit]))
    uniform[hit] = np.logaddexp(uniform[hit] + keep[hit], lost - log_rows)


def first_heading_variance(
    which: np.ndarray, push_cov: np.ndarray, r: np.ndarray, p_tt: np.ndarray
) -> None:
    """A heading learnt from a pushed first leg is uncertain by the push along the robot's side,
    not by its average over two directions: add ``(lambda_max - trace / 2) / r^2`` of each
    candidate's push covariance ``push_cov`` ``(k, 2, 2)`` (image units) to ``p_tt[which]``
    (in place), ``r`` ``(k,)`` the displacement's length in the image."""
    if len(which) == 0:
        return
    half = 0.5 * (push_cov[:, 0, 0] + push_cov[:, 1, 1])
    det = push_cov[:, 0, 0] * push_cov[:, 1, 1] - push_cov[:, 0, 1] ** 2
    top = half + np.sqrt(np.maximum(half**2 - det, 0.0))
    p_tt[which] += (top - half) / np.maximum(r, 1e-12) ** 2
