"""Crowd features a learned agent may see (issue 23): the contact risk of each candidate command
and the free space around the robot's believed self, by name.

A robot fairly sure of its row knows where it is and sees every other robot in the picture; the
hand-written ``gaps`` excitation (``baselines.excitations.GapSeeking``) steers by that. These
functions put the same information in reach of the learned agent, in the units of its other
features (``agents.candidate_features``), each computed from what the robot has: its belief over
the picture's rows, the rows, and its identifier's heaviest track (its believed heading).

* ``contact_risk`` ``(R, C)``: the share of the candidate's path over the next interval (5
  points) that comes within one robot size of another row, or within half a size of the field
  of view's edge, from the robot's top row and believed heading (the mean over 8 headings when it
  is unknown), weighed by its top belief, plus 0.5 times the rest;
* ``free_space`` ``(R,)``: the distance from the top row to the nearest other row in robot
  sizes, over ``look`` (at most 1), weighed by the top belief, plus 1 times the rest (what is
  unknown counts as free);
* ``crowding`` ``(R,)``: the sum of size over distance over the other rows within ``look``
  sizes of the top row, weighed by the top belief;
* ``density`` ``(R,)``: the rows of the picture per square metre of the field of view, the same
  for every robot: how crowded the whole arena is, also where no robot is near (ninth round).

They are not in the layout (``agents.candidate_features.LAYOUT`` 2, which a saved agent is checked
against): an agent trained with them names them in its features, and only the named ones are
computed. The bundled agent (ninth round) names ``density`` alone.
"""

from __future__ import annotations

import numpy as np

from agents.candidate_features import Feature
from anonloc_env.identify import Identifier
from anonloc_env.neighbours import pairs_within

#: The candidate features, by name and meaning (appended after the layout's own when a spec
#: names them, :class:`agents.candidates.CandidateChooser`).
CROWD_CANDIDATE_SPEC = (
    Feature(
        "contact_risk",
        "share of the candidate's path within a robot size of another row or half a size of "
        "the view's edge, from the believed self, weighed by the top belief (0.5 unknown)",
    ),
)
#: The context features, by name and meaning.
CROWD_CONTEXT_SPEC = (
    Feature("free_space", "nearest other row from the believed self, in robot sizes over look"),
    Feature(
        "crowding", "sum of size / distance over the rows within look sizes of the believed self"
    ),
    Feature("density", "rows in the picture per square metre of the field of view"),
)
#: Every crowd feature's name.
CROWD_FEATURES = frozenset(f.name for f in CROWD_CANDIDATE_SPEC + CROWD_CONTEXT_SPEC)
#: Points along a candidate's path.
PATH_POINTS = 5
#: Headings tried where the robot does not know its own.
UNKNOWN_HEADINGS = 8


def believed_heading(identifier: Identifier) -> np.ndarray:
    """``(R,)`` each robot's heading in the image (rad) on its heaviest track (nan where that
    track does not know it, or the robot has none)."""
    out = np.full(identifier.n, np.nan)
    tracks = identifier.tracks
    if len(tracks):
        first = np.flatnonzero(np.r_[True, tracks.slot[1:] != tracks.slot[:-1]])
        out[tracks.slot[first]] = tracks.theta[first]  # sorted by robot, heaviest first
    return out


def _top(belief: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    if belief.shape[1] == 0:
        return np.zeros(len(belief), np.int64), np.zeros(len(belief))
    row = belief.argmax(axis=1)
    return row, belief[np.arange(len(belief)), row]


def free_space(
    belief: np.ndarray, rows: np.ndarray, size: float, look: float = 3.0
) -> tuple[np.ndarray, np.ndarray]:
    """``(free_space, crowding)``, each ``(R,)`` (see the module), for rows in image units and
    ``size`` a robot's size in image units."""
    row, top = _top(belief)
    n = len(belief)
    near = np.full(n, look)
    crowd = np.zeros(n)
    if len(rows) > 1:
        i, j, dist = pairs_within(rows[row, :2], rows[:, :2], look * size)
        keep = j != row[i]
        i, dist = i[keep], np.maximum(dist[keep], 1e-9)
        np.minimum.at(near, i, dist / size)
        np.add.at(crowd, i, size / dist)
    return top * (near / look) + (1.0 - top), top * crowd


def contact_risk(
    belief: np.ndarray,
    rows: np.ndarray,
    heading: np.ndarray,
    commands: np.ndarray,
    interval: float,
    scale: float,
    size: float,
    view: tuple[float, float, float, float],
) -> np.ndarray:
    """``(R, C)`` each candidate's contact risk (see the module).

    Args:
        belief: ``(R, n)`` beliefs over the rows.
        rows: ``(n, 3)`` the picture's rows (image units).
        heading: ``(R,)`` believed headings in the image (rad; nan: unknown).
        commands: ``(R, C, 2)`` candidates ``(v, w)`` (m/s, rad/s).
        interval: the picture interval (s).
        scale: image units per metre.
        size: a robot's size in image units.
        view: the field of view ``(u_min, v_min, u_max, v_max)``.
    """
    row, top = _top(belief)
    n, c = commands.shape[:2]
    if len(rows) == 0:
        return np.full((n, c), 0.5)
    known = np.isfinite(heading)
    tries = np.where(known[:, None], heading[:, None], 0.0) + np.where(
        known[:, None], 0.0, np.linspace(0, 2 * np.pi, UNKNOWN_HEADINGS, endpoint=False)
    )  # (R, H)
    t = interval * np.arange(1, PATH_POINTS + 1) / PATH_POINTS  # (P,)
    v, w = commands[..., 0][:, :, None, None], commands[..., 1][:, :, None, None]
    th0 = tries[:, None, :, None]  # (R, 1, H, 1)
    safe_w = np.where(np.abs(w) < 1e-9, 1.0, w)
    turn = th0 + w * t
    straight = np.abs(w) < 1e-9
    dx = np.where(straight, v * t * np.cos(th0), v / safe_w * (np.sin(turn) - np.sin(th0)))
    dy = np.where(straight, v * t * np.sin(th0), -v / safe_w * (np.cos(turn) - np.cos(th0)))
    px = rows[row, 0][:, None, None, None] + scale * dx  # (R, C, H, P)
    py = rows[row, 1][:, None, None, None] + scale * dy
    u0, v0, u1, v1 = view
    edge = 0.5 * size
    hit = (px < u0 + edge) | (px > u1 - edge) | (py < v0 + edge) | (py > v1 - edge)
    reach = scale * float(np.abs(commands[..., 0]).max(initial=0.0)) * interval + size
    i, j, _ = pairs_within(rows[row, :2], rows[:, :2], reach)
    keep = j != row[i]
    i, j = i[keep], j[keep]
    for robot in np.unique(i):
        near = rows[j[i == robot], :2]  # the other rows this robot's paths may reach
        gap2 = (px[robot, ..., None] - near[:, 0]) ** 2 + (py[robot, ..., None] - near[:, 1]) ** 2
        hit[robot] |= gap2.min(axis=-1) < size**2
    risk = hit.mean(axis=(2, 3))  # over headings and points
    return top[:, None] * risk + 0.5 * (1.0 - top[:, None])


def density(count: int, scale: float, view: tuple[float, float, float, float]) -> float:
    """Rows per square metre: ``count`` rows over the field of view ``view`` (image units) at
    ``scale`` image units per metre.

    >>> density(20, 100.0, (0.0, 0.0, 200.0, 250.0))
    4.0
    """
    u0, v0, u1, v1 = view
    return count * scale * scale / max((u1 - u0) * (v1 - v0), 1e-12)


def crowd_columns(
    belief: np.ndarray,
    rows: np.ndarray,
    heading: np.ndarray,
    commands: np.ndarray | None,
    interval: float,
    scale: float,
    size: float,
    view: tuple[float, float, float, float],
    names: frozenset[str] = CROWD_FEATURES,
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """The crowd features named in ``names`` (default: all), by name: ``({"contact_risk": (R,
    C)}, {"free_space": (R,), "crowding": (R,), "density": (R,)})`` (arguments as
    :func:`contact_risk`'s; ``commands`` None: nothing was scored, so no candidate feature)."""
    context = {"density": np.full(len(belief), density(len(rows), scale, view))}
    if names & {"free_space", "crowding"}:
        context["free_space"], context["crowding"] = free_space(belief, rows, size)
    if commands is None or "contact_risk" not in names:
        return {}, context
    risk = contact_risk(belief, rows, heading, commands, interval, scale, size, view)
    return {"contact_risk": risk}, context
