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

import numpy as np

from anonloc_env.odometry import Interval

#: The share of the push covariance for a pressed robot: a push spread evenly up to its bound.
CROWD_PUSH_SHARE = 1.0
#: The contact bound (m, summed over an interval) over which a pressed robot's track breaks
#: with probability ``1 - 1/e`` at one robot per m^2 or fewer (see :func:`break_length`); a
#: robot pressed through a whole interval at top speed has a bound of about 0.4 m.
CONTACT_BREAK = 100.0


def break_length(density: float) -> float:
    """The contact bound (m) over which a pressed robot's track breaks with probability
    ``1 - 1/e`` among ``density`` robots per m^2: :data:`CONTACT_BREAK` up to one robot per m^2,
    shorter in proportion to the density above it (a pressed robot has that many more neighbours
    to be mixed up with). Robots jammed together for tens of intervals at 4 and 6 per m^2 were
    taken for one another, or for a far robot jammed the same way once their own track had been
    pruned, at ``CONTACT_BREAK`` (``docs/crowds.md``)."""
    if not density > 0.0:
        raise ValueError(f"density must be > 0 robots per m^2, got {density}")
    return CONTACT_BREAK / max(1.0, density)


def pressed_interval(
    interval: Interval, pressed: np.ndarray, push_share: float, crowd_push_share: float
) -> Interval:
    """``interval`` with the pushes of robots ``pressed`` widened so that the model's share of
    their covariance is ``crowd_push_share`` instead of ``push_share`` (the same interval where
    none is pressed)."""
    if interval.push is None or interval.push_sum is None or not pressed.any():
        return interval
    factor = np.where(pressed, np.sqrt(crowd_push_share / push_share), 1.0)
    return dataclasses.replace(
        interval, push=interval.push * factor, push_sum=interval.push_sum * factor[:, None]
    )


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
