"""Where a robot's decided track went: the row of the newest picture that continues it best.

A robot decided at one picture (its top row at belief 0.99) keeps, for the next, the state of its
heaviest track at that row (``decided_tracks``). At the next picture ``continuations``
extends that one track to every row by the identifier's own likelihood (the interval as the model
took it, pushes and all) and names the row it fits best. Where the robot's top row is that row,
its belief continues the decided track; where it is another, the belief moved to another lineage
(a neighbour's track, a broken track's fresh start). ``baselines.decisions`` holds a decision
through a dip of the belief only in the first case.
"""

from __future__ import annotations

import numpy as np

from anonloc_env.identify.arrays import group_starts
from anonloc_env.identify.likelihood import Scoring, children
from anonloc_env.identify.tracks import Tracks
from anonloc_env.odometry import Interval


def decided_tracks(tracks: Tracks, robots: np.ndarray, rows: np.ndarray) -> Tracks:
    """Each robot of ``robots``'s heaviest track at row ``rows`` (same length), one per robot
    that has one, grouped by robot (``tracks`` sorted by robot, heaviest first, as the identifier
    keeps them). Robots with no explicit track at that row (their weight there is the uniform
    one's) get none."""
    wanted = np.full(int(tracks.slot.max(initial=-1)) + 1, -2)
    inside = robots < len(wanted)
    wanted[robots[inside]] = rows[inside]
    at = np.flatnonzero(tracks.row == wanted[tracks.slot] if len(wanted) else np.zeros(0, bool))
    if not len(at):
        return Tracks.empty()
    first = at[group_starts(tracks.slot[at])]  # the heaviest of each robot's
    return tracks.take(first)


def continuations(
    decided: Tracks, rows: np.ndarray, interval: Interval, pix_var: float, scoring: Scoring
) -> tuple[np.ndarray, np.ndarray]:
    """``(robots, best)``: for each track of ``decided`` (one per robot, anchored at a row of the
    previous picture), its robot and the row of ``rows`` (the newest picture) that continues it
    best, or -1 where none fits (every child ruled out). ``interval`` and ``pix_var`` are the
    identifier's for this picture (``Identifier.interval``, ``Identifier.pix_var``)."""
    m, n_rows = len(decided), len(rows)
    if m == 0 or n_rows == 0:
        return decided.slot.copy(), np.full(m, -1)
    parent = decided.take(np.repeat(np.arange(m), n_rows))
    cand = np.tile(np.arange(n_rows), m)
    kids = children(parent, rows, cand, interval, pix_var, 0.0, scoring)
    best = np.full(m, -1)
    if len(kids):
        starts = group_starts(kids.slot)
        top = np.maximum.reduceat(kids.logw, starts)
        owner = np.searchsorted(decided.slot, kids.slot[starts])
        is_top = kids.logw == np.repeat(top, np.diff(np.append(starts, len(kids))))
        first = np.flatnonzero(is_top)[group_starts(kids.slot[is_top])]
        best[owner] = kids.row[first]
    return decided.slot.copy(), best
