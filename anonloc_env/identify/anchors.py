"""The robots the identifier is sure of, as anchors of the next picture's registration.

Without landmarks the registration (``anonloc_env.identify.camera_pose``) fits each picture
to where the previous picture's rows should be now, and it does not know the robots'
displacements: it guesses them (a robot keeps its heading and moves the team's typical step),
and their spread, about 12 px per component at 1 robot per m^2, is most of its error. But every
robot knows its own motion: once a robot's identity is sure, its track predicts its row to the
pixel noise and its odometry's (its heading and scale known). ``sure_moves`` gives those
predictions, and the registration takes them in place of its guess for those rows: the camera's
transform is estimated jointly with the identities, as the issue asks, and it sharpens as the
team identifies itself.

Only a robot whose heaviest track holds at least ``SURE`` of its weight, anchored at a row of
the previous picture (seen there) with its heading and scale known, anchors; a row two robots
are sure of anchors neither. A wrong anchor is a pair whose residual is far beyond its spread:
the fit's Cauchy weights set it aside, as they do a wrong match.
"""

from __future__ import annotations

import numpy as np

from anonloc_env.identify.arrays import group_starts
from anonloc_env.identify.gate import Gate
from anonloc_env.identify.model import SensorModel
from anonloc_env.identify.pose_guess import Anchors
from anonloc_env.identify.tracks import Tracks
from anonloc_env.odometry import Interval

#: A robot anchors the registration when its heaviest track holds at least this share of its
#: weight (the decisions' threshold).
SURE = 0.6


def sure_moves(
    tracks: Tracks,
    interval: Interval,
    model: SensorModel,
    pixel_noise: float,
    theta_var: float,
) -> Anchors | None:
    """The anchors among ``tracks`` (the identifier's, normalised: ``exp(logw)`` is each
    track's probability; grouped by robot, heaviest first) for the picture after ``interval``,
    or None where no robot is sure. ``pixel_noise``: the detector's (image units), that of the
    new row; ``theta_var``: the detected heading's variance (rad^2), for the gate's turn."""
    if not len(tracks):
        return None
    best = group_starts(tracks.slot)
    sure = np.exp(tracks.logw[best]) >= SURE
    sure &= tracks.row[best] >= 0
    sure &= np.isfinite(tracks.theta[best]) & np.isfinite(tracks.log_s[best])
    sure &= ~(tracks.carry[best].any(axis=1) | (tracks.turn[best] != 0.0))
    pick = best[sure]
    if not len(pick):
        return None
    rows, counts = np.unique(tracks.row[pick], return_counts=True)
    alone = np.isin(tracks.row[pick], rows[counts == 1])
    pick = pick[alone]
    if not len(pick):
        return None
    sub = tracks.take(pick)
    gate = Gate.of(sub, interval, model, pixel_noise**2, theta_var)
    return Anchors(sub.row, gate.centre, np.sqrt(gate.spread))
