"""Robots out of view: each picture's footprint in the identifier's counting model.

A camera on a drone (:mod:`anonloc_env.camera_motion`) does not see the whole arena at every
picture: its footprint drifts, and robots near the edge leave the picture and come back. The
identifier's count law otherwise takes every robot as seen (``P_D``, floored at ``1 - 1e-6``), so
a robot carried out of view is a miss that costs 14 nats, and the row count, short of the team,
makes a miss cheap for every robot alike.

With the footprint of each picture (the field of view mapped into the frame the identifier
reads: through the registration's transform, or the landmarks' homography) the model becomes:

- a robot whose position is predicted (a track) is in view with probability ``p_in``, the share
  of its predicted position's law inside the footprint (and inside the arena, which it cannot
  leave), so it is missed with probability ``1 - P_D p_in``: a track predicted out of view
  continues through the miss at no cost, one well inside keeps today's penalty;
- a robot of unknown position is in view with the share of the arena in view, ``c``; the other
  robots too, in the count law (:func:`anonloc_env.identify.model.log_background`'s ``share``),
  so that a picture short of the robots the drift carried out is no longer evidence of a miss
  for every robot;
- a detection needs no factor: the row was seen, so its robot is in view (its Gaussian mass
  inside the footprint is ``p_in``, which the miss's ``1 - P_D p_in`` completes to one).

Robots coming back into view are found through their tracks, continued out of view by their own
motion: the rows near their prediction, at the view's edge, are the ones that extend them.

Each edge of the footprint is a half-plane ``n . x <= c``; a robot's coordinate along ``n`` is
Gaussian (its prediction, the ring of an unknown heading as a Gaussian of the same spread, and
the registration's error on the edge's place), truncated at the arena's wall along ``n`` (placed
with its own uncertainty: the registered frame's offset from the set point). An edge beyond the
arena by more than :data:`EDGE_SIGMAS` of that uncertainty is dropped; a camera that does not
move gets no footprint at all, so that the fixed camera's identifier is unchanged to the bit.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from anonloc_env.camera import Camera, survey
from anonloc_env.config import EnvConfig

#: An edge further than this many standard deviations beyond the arena cuts nothing.
EDGE_SIGMAS = 5.0
#: :func:`ndtr` is 1.0 to the bit from here on (its tail under half a unit in the last place
#: of 1 beyond 8.3: ``tests/test_identify_footprint.py`` checks it).
NDTR_ONE = 9.0


@dataclass(frozen=True)
class View:
    """What a robot knows of the camera's view (image units of the set point's frame).

    Attributes:
        field_of_view: ``(u_min, v_min, u_max, v_max)`` of the raw image, where detections lie.
        arena: the arena's four corners ``((u, v), ...)`` as the camera at its set point sees them.
        offset_sigma: standard deviation per component of the registered frame's offset from
            the set point (where the arena's walls are in the frame the identifier reads): the
            camera's stationary shift.
        fit_spreads: where each picture's footprint comes with it (a picture its landmarks
            rectified): a robot's typical step between pictures (standard deviation per
            component, image units) and the error of the footprint's place (the landmarks'
            fit, per coordinate); zeros where a registration gives them.
    """

    field_of_view: tuple[float, float, float, float]
    arena: tuple[tuple[float, float], ...]
    offset_sigma: float
    fit_spreads: tuple[float, float] = (0.0, 0.0)

    def corners(self) -> np.ndarray:
        """``(4, 2)`` the raw field of view's corners, in order round it."""
        u_min, v_min, u_max, v_max = self.field_of_view
        return np.array([[u_min, v_min], [u_max, v_min], [u_max, v_max], [u_min, v_max]])


def landmark_view(config: EnvConfig, fit_error: float) -> View:
    """The view of ``config``'s moving camera whose pictures its landmarks rectify into the set
    point's frame (so its walls are where the set point sees them), each picture's footprint
    off by the landmarks' fit error ``fit_error`` (image units, per coordinate)."""
    step = 0.5 * config.robot.v_max * config.schedule.picture_interval * config.camera.scale
    return dataclasses.replace(camera_view(config, 1e-6), fit_spreads=(step, fit_error))


def camera_view(config: EnvConfig, offset_sigma: float) -> View:
    """The view of ``config``'s camera, whose registered frame is ``offset_sigma`` (image units,
    per component) off the set point's."""
    width, height = config.arena_size
    arena = Camera(config).project(
        np.array([[0.0, 0.0], [width, 0.0], [width, height], [0.0, height]])
    )
    return View(
        field_of_view=survey(config).field_of_view,
        arena=tuple((float(u), float(v)) for u, v in arena),
        offset_sigma=float(offset_sigma),
    )


@dataclass(frozen=True)
class Footprint:
    """One picture's field of view in the identifier's frame: the edges that cut the arena, and
    the strips of the arena beyond them (out of view).

    Attributes:
        normals: ``(E, 2)`` outward unit normals of the edges that cut the arena.
        edges: ``(E,)`` each edge's place along its normal (inside: ``n . x <= edge``).
        widths: ``(E,)`` the expected width of the arena beyond each edge (its strip out of
            view), the walls placed to their uncertainty.
        lengths: ``(E,)`` the arena's extent along each edge.
        edge_var: variance of the edges' place relative to the tracks (the registration's).
        share: the share of the arena in view, ``c``.
    """

    normals: np.ndarray
    edges: np.ndarray
    widths: np.ndarray
    lengths: np.ndarray
    edge_var: float
    share: float

    @classmethod
    def of(cls, view: View, corners: np.ndarray, edge_sigma: float) -> Footprint:
        """The footprint whose corners (``(4, 2)``, round the field of view, in the identifier's
        frame) are ``corners``, placed to ``edge_sigma`` (image units)."""
        arena = np.asarray(view.arena)
        nxt = np.roll(corners, -1, axis=0)
        along = nxt - corners
        normals = np.column_stack([along[:, 1], -along[:, 0]])
        normals /= np.hypot(normals[:, 0], normals[:, 1])[:, None]
        inside = corners.mean(axis=0)
        edges = np.einsum("ij,ij->i", normals, corners)
        flip = normals @ inside > edges  # outward: the view's centre on the inner side
        normals[flip] *= -1.0
        edges[flip] *= -1.0
        reach = arena @ normals.T  # (4 corners, E)
        spread = math.sqrt(edge_sigma**2 + view.offset_sigma**2)
        gap = (reach.max(axis=0) - edges) / spread  # the wall beyond the edge, in spreads
        widths = spread * (gap * ndtr(gap) + np.exp(-0.5 * gap**2) / math.sqrt(2.0 * math.pi))
        tangent = np.column_stack([-normals[:, 1], normals[:, 0]])
        spans = arena @ tangent.T
        lengths = spans.max(axis=0) - spans.min(axis=0)
        cuts = gap > -EDGE_SIGMAS
        area = _area(arena)
        share = float(np.clip(1.0 - (widths * lengths)[cuts].sum() / area, 1e-3, 1.0))
        return cls(normals[cuts], edges[cuts], widths[cuts], lengths[cuts], edge_sigma**2, share)

    def near(self, centre: np.ndarray, reach: np.ndarray | float) -> np.ndarray:
        """Indices of the points ``centre`` ``(H, 2)`` within ``reach`` of an edge that cuts
        the arena, or beyond it (the others are in view for sure)."""
        close = np.zeros(len(centre), bool)
        u, v = centre[:, 0], centre[:, 1]
        for (nu, nv), edge in zip(self.normals.tolist(), self.edges.tolist(), strict=True):
            close |= edge - (nu * u + nv * v) < reach  # one edge at a time: no (H, E) table
        return np.flatnonzero(close)

    def p_in(self, centre: np.ndarray, var: np.ndarray) -> np.ndarray:
        """``(H,)`` probability that a robot whose coordinates are Gaussian about ``centre``
        ``(H, 2)``, ``var`` per component, is inside the footprint (each edge placed to its
        variance). The arena's walls are left out: the registered frame's offset from the set
        point is too loosely known to truncate at them (taken in, a robot just beyond the
        edge but short of a wall placed too far out was often held in view)."""
        out = np.ones(len(centre))
        spread = np.sqrt(var + self.edge_var)
        for normal, edge in zip(self.normals, self.edges, strict=True):
            depth = (edge - centre @ normal) / spread
            # Most points are deep inside most edges, where ``ndtr`` is 1.0 to the bit: only
            # the others are multiplied (the same floats; NaN goes through).
            inside = depth >= NDTR_ONE
            if inside.any():
                at = np.flatnonzero(~inside)
                out[at] *= ndtr(depth[at])
            else:
                out *= ndtr(depth)
        return out

    def reentry(self, rows: np.ndarray, sigma: float) -> tuple[np.ndarray, float]:
        """Where a robot out of view in this picture is in the next one: ``(n,)`` its density
        (per image unit squared) at ``rows`` ``(n, >= 2)`` of the next picture, and the
        probability that it is back in view at all. It is spread evenly over the strips beyond
        the edges and moves a Gaussian of ``sigma`` per component (its own motion, the
        registration's error): a strip ``W`` wide gives a row ``t`` inside its edge the density
        ``(Phi((t + W) / sigma) - Phi(t / sigma)) / A_out`` (``A_out`` the strips' area), and
        brings back ``L (W (1 - Phi(W / sigma)) + sigma (phi(0) - phi(W / sigma))) / A_out``."""
        out_area = float((self.widths * self.lengths).sum())
        if out_area <= 0.0:
            return np.zeros(len(rows)), 0.0
        sigma = max(sigma, 1e-9)
        depth = (self.edges[None, :] - rows[:, :2] @ self.normals.T) / sigma  # (n, E)
        w = self.widths / sigma
        density = (ndtr(depth + w[None, :]) - ndtr(depth)).sum(axis=1) / out_area
        root = 1.0 / math.sqrt(2.0 * math.pi)
        back = w * (1.0 - ndtr(w)) + root * (1.0 - np.exp(-0.5 * w**2))
        return density, float(np.clip((self.lengths * back).sum() * sigma / out_area, 0.0, 1.0))


def _area(corners: np.ndarray) -> float:
    """Area of the polygon ``corners`` ``(K, 2)`` (shoelace)."""
    x, y = corners[:, 0], corners[:, 1]
    return float(abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))) / 2.0)


def ndtr(x: np.ndarray) -> np.ndarray:
    """The standard normal distribution function (Abramowitz and Stegun 7.1.26 for ``erfc``,
    absolute error under 1.5e-7: the package needs no scipy)."""
    x = np.asarray(x, dtype=np.float64)
    z = np.abs(x) / math.sqrt(2.0)
    t = 1.0 / (1.0 + 0.3275911 * z)
    poly = t * (
        0.254829592 + t * (-0.284496736 + t * (1.421413741 + t * (-1.453152027 + t * 1.061405429)))
    )
    tail = 0.5 * poly * np.exp(-z * z)  # 1 - Phi(|x|)
    return np.where(x >= 0.0, 1.0 - tail, tail)
