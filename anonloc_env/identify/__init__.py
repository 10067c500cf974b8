"""The likelihood model of "which row is me", and the Bayesian identifier built on it.

This is part of the task definition: the environment's default reward (information gain about each
robot's identity) and the ``bayes`` baseline both use it. It needs numpy alone.

Model (image frame, right-handed; see ``docs/baselines.md`` for the derivation):

* A robot's own motion between two pictures is ``(d, dphi)``: displacement in its frame at the
  first picture and heading change. In the image it moves by ``s R(theta) d`` where ``s`` is the
  camera scale and ``theta`` its image heading at the first picture.
* A picture holds the robot's detection with probability ``P_D`` (Gaussian pixel noise ``sigma``
  per coordinate, and a heading with noise ``sigma_theta`` if the detector measures it), plus
  other detections (other robots, false positives) spread over the image with density ``lambda``.
* A hypothesis is a track: which row of each picture was the robot (or that it was missed), with
  a Gaussian estimate of its heading (and of ``log s`` when the scale is unknown). Extending a
  track by row ``q`` multiplies its weight by ``P_D f(z_q | track) / lambda``; by a miss, by
  ``1 - P_D``. With the heading unknown (no orientation, first interval) ``f`` is the ring density
  of ``|q - p|`` around ``s |d|`` (the heading marginalised); afterwards an extended Kalman filter
  on ``(theta, log s)`` predicts ``q = p + s R(theta) d``. A track's position ``p`` is its newest
  detection, or, with ``SensorModel.filter_position`` (a crowd), that detection combined with
  the track's prediction (a robot standing still is at the mean of its detections).
* "Nothing known yet" is kept implicitly: a weight spread evenly over the rows of the newest
  picture, and a weight for "not anchored anywhere" (missed, outside the view). Nothing is ever
  discarded for good, so an identity lost in a blackout is found again.

The posterior over the rows of the newest picture (plus "not in it") is calibrated when the model
matches the world: decisions taken at belief 0.99 are wrong about 1 % of the time or less.

Layout: :mod:`~anonloc_env.identify.model` (the sensor model and the densities),
:mod:`~anonloc_env.identify.tracks` (the hypotheses' container),
:mod:`~anonloc_env.identify.arrays` (helpers on arrays grouped by robot),
:mod:`~anonloc_env.identify.gate` (the cheap test of which rows may extend a hypothesis),
:mod:`~anonloc_env.identify.likelihood` (how a row extends a hypothesis: the general path),
:mod:`~anonloc_env.identify.kernels` (faster forms of two of its cases; ``fast=False`` on the
:class:`Identifier` forces the general path),
:mod:`~anonloc_env.identify.others` (the other robots persisting between pictures, where pictures
have misses or false positives: a link's weight in place of ``1 / lambda``),
:mod:`~anonloc_env.identify.children` (how each hypothesis extends to a new picture: the
children of the tracks and of the uniform weight, gated and scored),
:mod:`~anonloc_env.identify.filter` (the :class:`Identifier`: extending, pruning, beliefs) and
:mod:`~anonloc_env.identify.reference` (an exact enumerator for small cases, to check the
identifier against).
"""

from anonloc_env.identify.children import MISSED_PER_ROBOT
from anonloc_env.identify.filter import PRUNE_NATS, Identifier
from anonloc_env.identify.model import GATE_SIGMAS, SensorModel, log_i0e, ring_loglik
from anonloc_env.odometry import Interval

__all__ = [
    "GATE_SIGMAS",
    "MISSED_PER_ROBOT",
    "PRUNE_NATS",
    "Identifier",
    "Interval",
    "SensorModel",
    "log_i0e",
    "ring_loglik",
]
