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
  on ``(theta, log s)`` predicts ``q = p + s R(theta) d``.
* "Nothing known yet" is kept implicitly: a weight spread evenly over the rows of the newest
  picture, and a weight for "not anchored anywhere" (missed, outside the view). Nothing is ever
  discarded for good, so an identity lost in a blackout is found again.

The posterior over the rows of the newest picture (plus "not in it") is calibrated when the model
matches the world: decisions taken at belief 0.99 are wrong about 1 % of the time or less.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from anonloc_env._checks import check_number, check_pair
from anonloc_env.camera import Camera, Picture
from anonloc_env.config import EnvConfig
from anonloc_env.geometry import rotate, wrap_angle
from anonloc_env.images.errors import effective_camera
from anonloc_env.neighbours import expand_ranges, pairs_within
from anonloc_env.odometry import Interval

LOG_2PI = math.log(2.0 * math.pi)
#: Hypotheses whose weight falls this many nats below their robot's best are dropped
#: (a factor 3e-7: what is dropped cannot move a 0.99 decision).
PRUNE_NATS = 15.0
#: Only a robot's heaviest tracks are continued through a miss; the rest of their weight
#: returns to "position unknown" (kept, never lost).
MISSED_PER_ROBOT = 32
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

    @classmethod
    def from_config(cls, config: EnvConfig, *, scale_known: bool = True) -> SensorModel:
        """The model a robot would build from the nominal specs of ``config``.

        The scale is the mean over the arena of the camera's local scale (what the paper did with
        its 20.8 to 22.07 range); its spread across the arena becomes ``scale_spread``. With
        ``scale_known=False`` the scale is left to be estimated within 0.5x to 2x of it.
        """
        camera = Camera(config)
        width, height = config.arena_size
        grid = np.stack(
            np.meshgrid(np.linspace(0, width, 9), np.linspace(0, height, 9)), axis=-1
        ).reshape(-1, 2)
        local = camera.local_scale(grid)
        mean = float(local.mean())
        u_min, v_min, u_max, v_max = camera.field_of_view
        cam = effective_camera(config)  # the image source's measured errors, if it is used
        return cls(
            scale=mean if scale_known else None,
            scale_range=(0.5 * mean, 2.0 * mean),
            scale_spread=float(local.std() / mean),
            pixel_noise=cam.pixel_noise,
            orientation=cam.orientation,
            orientation_noise=math.radians(cam.orientation_noise_deg),
            p_detect=1.0 - cam.p_miss,
            image_area=max((u_max - u_min) * (v_max - v_min), 1e-9),
            odometry_noise=config.robot.odometry_noise,
        )

    @property
    def scale_bounds(self) -> tuple[float, float]:
        """``(low, high)`` scale: the known scale twice, or the prior range."""
        if self.scale is not None:
            return (self.scale, self.scale)
        return self.scale_range


def _push_isotropic(interval: Interval) -> np.ndarray:
    """``(R,)`` variance per component (m^2) of the unseen contact pushes, spread evenly."""
    cov = interval.push_covariance()
    return 0.5 * (cov[:, 0, 0] + cov[:, 1, 1])


def log_i0e(x: np.ndarray) -> np.ndarray:
    """``log(I0(x) exp(-x))`` for ``x >= 0`` (Abramowitz and Stegun 9.8.1-2, error < 2e-7)."""
    x = np.asarray(x, dtype=np.float64)
    small = x < 3.75
    out = np.empty_like(x)
    t = (x[small] / 3.75) ** 2
    i0 = 1.0 + t * (
        3.5156229
        + t * (3.0899424 + t * (1.2067492 + t * (0.2659732 + t * (0.0360768 + t * 0.0045813))))
    )
    out[small] = np.log(i0) - x[small]
    big = ~small
    t = 3.75 / x[big]
    poly = 0.39894228 + t * (
        0.01328592
        + t
        * (
            0.00225319
            + t
            * (
                -0.00157565
                + t
                * (
                    0.00916281
                    + t * (-0.02057706 + t * (0.02635537 + t * (-0.01647633 + t * 0.00392377)))
                )
            )
        )
    )
    out[big] = np.log(poly) - 0.5 * np.log(x[big])
    return out


def ring_loglik(r: np.ndarray, rho: np.ndarray, var: np.ndarray) -> np.ndarray:
    """Log density of a 2-D displacement of length ``r`` when it is ``rho`` long in an unknown,
    uniform direction, with isotropic Gaussian noise of variance ``var`` per component."""
    x = r * rho / var
    return -LOG_2PI - np.log(var) - (r - rho) ** 2 / (2.0 * var) + log_i0e(x)


@dataclass
class _Tracks:
    """Explicit hypotheses of all robots, flat arrays grouped by robot."""

    slot: np.ndarray  # robot of the hypothesis
    row: np.ndarray  # row in the newest picture, -1 if missed there
    pos: np.ndarray  # (H, 2) image position at the newest picture (detection or prediction)
    pos_var: np.ndarray  # variance of that position per component
    theta: np.ndarray  # image heading at the newest picture (nan: unknown)
    p_tt: np.ndarray  # variance of theta
    log_s: np.ndarray  # log scale (nan: unknown)
    p_ts: np.ndarray  # covariance of theta and log s
    p_ss: np.ndarray  # variance of log s
    logw: np.ndarray  # log weight

    @classmethod
    def empty(cls) -> _Tracks:
        z = np.zeros(0)
        return cls(
            np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 2)), z, z, z, z, z, z, z
        )

    def take(self, index: np.ndarray) -> _Tracks:
        return _Tracks(*(getattr(self, f)[index] for f in _FIELDS))

    @staticmethod
    def concat(parts: list[_Tracks]) -> _Tracks:
        return _Tracks(*(np.concatenate([getattr(p, f) for p in parts]) for f in _FIELDS))

    def __len__(self) -> int:
        return len(self.slot)


_FIELDS = ("slot", "row", "pos", "pos_var", "theta", "p_tt", "log_s", "p_ts", "p_ss", "logw")


@dataclass
class _Geometry:
    """Per candidate (parent track, new row): the displacement and its noise."""

    d: np.ndarray  # (K, 2) own displacement of the parent's robot (m)
    rho0: np.ndarray  # |d|
    dphi: np.ndarray  # own heading change
    var_dphi: np.ndarray  # its variance
    delta: np.ndarray  # (K, 2) image displacement from the parent's position to the row
    r: np.ndarray  # |delta|
    ang_delta: np.ndarray  # direction of delta
    ang_d: np.ndarray  # direction of d
    s: np.ndarray  # scale the parent assumes (its estimate, or the largest possible)
    push_cov: np.ndarray  # (K, 2, 2) unseen contact pushes (m^2, robot frame)
    base_var: np.ndarray  # isotropic variance per component without the pushes
    iso_var: np.ndarray  # with the pushes spread evenly
    still: np.ndarray  # too little motion to learn the heading from

    @classmethod
    def of(
        cls, parent: _Tracks, z: np.ndarray, interval: Interval, model: SensorModel, pix_var: float
    ) -> _Geometry:
        slot = parent.slot
        d = interval.d[slot]
        rho0 = np.hypot(d[:, 0], d[:, 1])
        var_d_all, var_dphi_all = interval.variances(model.odometry_noise)
        delta = z[:, :2] - parent.pos
        scale_known = np.isfinite(parent.log_s)
        s_high = model.scale_bounds[1]
        s = np.where(scale_known, np.exp(np.where(scale_known, parent.log_s, 0.0)), s_high)
        push_cov = interval.push_covariance()[slot]
        base_var = (
            pix_var + parent.pos_var + s**2 * var_d_all[slot] + (model.scale_spread * s * rho0) ** 2
        )
        iso_var = base_var + s**2 * 0.5 * (push_cov[:, 0, 0] + push_cov[:, 1, 1])
        return cls(
            d=d,
            rho0=rho0,
            dphi=interval.dphi[slot],
            var_dphi=var_dphi_all[slot],
            delta=delta,
            r=np.hypot(delta[:, 0], delta[:, 1]),
            ang_delta=np.arctan2(delta[:, 1], delta[:, 0]),
            ang_d=np.arctan2(d[:, 1], d[:, 0]),
            s=s,
            push_cov=push_cov,
            base_var=base_var,
            iso_var=iso_var,
            still=s_high * rho0 < 2.0 * np.sqrt(iso_var),
        )

    def standing_loglik(self, which: np.ndarray) -> np.ndarray:
        """Log density of the displacement of a robot that did not move, for ``which``."""
        var = self.iso_var[which]
        return -LOG_2PI - np.log(var) - self.r[which] ** 2 / (2 * var)


@dataclass
class _Child:
    """The new tracks' log-likelihoods and states, filled case by case."""

    loglik: np.ndarray
    theta: np.ndarray
    p_tt: np.ndarray
    log_s: np.ndarray
    p_ts: np.ndarray
    p_ss: np.ndarray

    @classmethod
    def start(cls, parent: _Tracks) -> _Child:
        n = len(parent)
        return cls(
            loglik=np.full(n, -np.inf),
            theta=np.full(n, np.nan),
            p_tt=np.full(n, np.inf),
            log_s=parent.log_s.copy(),
            p_ts=parent.p_ts.copy(),
            p_ss=parent.p_ss.copy(),
        )

    def heading_from_displacement(self, which: np.ndarray, geo: _Geometry) -> None:
        """A first heading for ``which``: the image direction of the move minus that of the
        robot's own, turned by its own turn; uncertain by the noise over the length."""
        self.theta[which] = geo.ang_delta[which] - geo.ang_d[which] + geo.dphi[which]
        self.p_tt[which] = (
            geo.iso_var[which] / np.maximum(geo.r[which], 1e-12) ** 2 + geo.var_dphi[which]
        )


class Identifier:
    """Multi-hypothesis "which row is me" filter for R robots at once.

    Call :meth:`update` with every picture (and each robot's motion since the previous one), then
    read :meth:`belief`. The robots share nothing but the pictures: robot i's belief depends only
    on the pictures and ``interval`` row i.

    Args:
        model: the sensor model (see :class:`SensorModel`).
        n_robots: R, the number of robots identified at once.
        max_tracks: most hypotheses kept per robot (the best ones).
    """

    def __init__(self, model: SensorModel, n_robots: int, max_tracks: int = 1024) -> None:
        self.model = model
        self.n = n_robots
        self.max_tracks = max_tracks
        # A robot is never certain to be in a picture (it may leave the view): a floor of 1e-6
        # keeps its identity recoverable without costing more than one miss per track.
        self.log_pd = math.log(min(model.p_detect, 1.0 - 1e-6))
        self.log_miss = math.log(max(1.0 - model.p_detect, 1e-6))
        self.reset()

    def reset(self) -> None:
        """Forget everything: no picture seen."""
        self.tracks = _Tracks.empty()
        self.uniform = np.full(self.n, -np.inf)  # log weight of each row of the newest picture
        self.unanchored = np.zeros(self.n)  # log weight of "position unknown"
        self.rows: np.ndarray | None = None  # newest picture (n_rows, 3)
        self._belief: np.ndarray | None = None
        self._missing = np.ones(self.n)
        self.pictures = 0

    # -- noise floors: float32 observations limit what "noise free" can mean ---------------------
    def _pixel_var(self, rows: np.ndarray) -> float:
        extent = float(np.abs(rows[:, :2]).max()) if len(rows) else 1.0
        floor = 1e-4 + 1e-6 * extent
        return self.model.pixel_noise**2 + floor**2

    def _theta_var(self) -> float:
        return self.model.orientation_noise**2 + 1e-10

    def update(self, rows: np.ndarray, interval: Interval | None = None) -> None:
        """Take in a picture.

        Args:
            rows: ``(n, 3)`` detections ``(u, v, theta)`` of the new picture (no padding).
            interval: each robot's motion since the previous picture; ignored for the first one.
        """
        rows = np.asarray(rows, dtype=np.float64).reshape(-1, 3)
        n_rows = len(rows)
        log_bg = math.log(max(n_rows - self.model.p_detect, 0.5) / self.model.image_area)
        if self.rows is None or interval is None:
            # A first picture (or one with no known motion before it): start from "unknown".
            parts: list[_Tracks] = []
            before = np.zeros(self.n)
            unanchored = before + self.log_miss
        else:
            parts, unanchored = self._extend(rows, interval, log_bg)
            before = self.unanchored
        # "Position unknown" before the picture: now seen at any row alike, or still unknown.
        fresh = before + self.log_pd - math.log(self.model.image_area) - log_bg
        self.uniform = fresh if n_rows else np.full(self.n, -np.inf)
        self.unanchored = unanchored
        self.tracks = _Tracks.concat(parts) if parts else _Tracks.empty()
        self.rows = rows
        self.pictures += 1
        self._normalise_and_prune()
        self._compute_belief()

    # -- one interval ----------------------------------------------------------------------------
    def _extend(
        self, rows: np.ndarray, interval: Interval, log_bg: float
    ) -> tuple[list[_Tracks], np.ndarray]:
        model = self.model
        assert self.rows is not None
        prev = self.rows
        pix_var = self._pixel_var(np.concatenate([prev, rows]))
        var_d, _ = interval.variances(model.odometry_noise)
        s_high = model.scale_bounds[1]
        spread = model.scale_spread
        # Reach of each robot in the image: its path at the largest scale plus the noise.
        sigma_max = np.sqrt(
            2 * pix_var + s_high**2 * var_d + (spread * s_high * interval.path) ** 2
        )
        push = interval.push if interval.push is not None else 0.0
        travel = interval.path * (1 + GATE_SIGMAS * model.odometry_noise) + push
        reach = s_high * travel + GATE_SIGMAS * sigma_max
        radius = float(reach.max()) if len(reach) else 0.0
        i_pair, j_pair, dist = pairs_within(prev[:, :2], rows[:, :2], max(radius, 1e-9))
        parts: list[_Tracks] = []
        unanchored = self.unanchored + self.log_miss  # unknown before, missed again

        # 1. Explicit tracks anchored at a row of the previous picture: candidate rows by pairs.
        tracks = self.tracks
        anchored = np.flatnonzero(tracks.row >= 0)
        if len(anchored):
            starts = np.searchsorted(i_pair, tracks.row[anchored], side="left")
            ends = np.searchsorted(i_pair, tracks.row[anchored], side="right")
            parent = np.repeat(anchored, ends - starts)
            cand = j_pair[expand_ranges(starts, ends - starts)]
            parts.append(self._children(tracks.take(parent), rows, cand, interval, pix_var, log_bg))
        # 2. Explicit tracks missed in the previous picture: candidates around their prediction.
        missed = np.flatnonzero(tracks.row < 0)
        if len(missed):
            a, b, _ = pairs_within(tracks.pos[missed], rows[:, :2], max(radius, 1e-9))
            parts.append(self._children(tracks.take(missed[a]), rows, b, interval, pix_var, log_bg))
        # 3. Every explicit track may be missed in the new picture.
        if len(tracks):
            continued, lost_slot, lost_logw = self._missed(tracks, interval, pix_var)
            parts.append(continued)
            np.logaddexp.at(unanchored, lost_slot, lost_logw)
        # 4. The implicit uniform weight over previous rows: anchor it at every plausible pair.
        live = np.flatnonzero(np.isfinite(self.uniform))
        if len(live) and len(i_pair):
            parts.append(
                self._from_uniform(
                    live, prev, rows, i_pair, j_pair, dist, interval, pix_var, var_d, log_bg
                )
            )
            # ... or the robot was missed then: its position is unknown again.
            lost = self.uniform[live] + math.log(len(prev)) + self.log_miss
            unanchored[live] = np.logaddexp(unanchored[live], lost)
        return [p for p in parts if len(p)], unanchored

    def _from_uniform(
        self,
        live: np.ndarray,
        prev: np.ndarray,
        rows: np.ndarray,
        i_pair: np.ndarray,
        j_pair: np.ndarray,
        dist: np.ndarray,
        interval: Interval,
        pix_var: float,
        var_d: np.ndarray,
        log_bg: float,
    ) -> _Tracks:
        """Anchor the uniform weight of robots ``live``: every pair whose length fits its motion."""
        model = self.model
        s_low, s_high = model.scale_bounds
        rho0 = np.hypot(*interval.d[live].T)
        push_iso = _push_isotropic(interval)[live]
        sigma = np.sqrt(
            s_high**2 * push_iso
            + 2 * pix_var
            + s_high**2 * var_d[live]
            + (model.scale_spread * s_high * rho0) ** 2
        )
        lo = s_low * rho0 - GATE_SIGMAS * sigma
        hi = s_high * rho0 + GATE_SIGMAS * sigma
        by_length = np.argsort(dist, kind="stable")
        sorted_len = dist[by_length]
        start = np.searchsorted(sorted_len, lo, side="left")
        stop = np.searchsorted(sorted_len, hi, side="right")
        counts = stop - start
        pick = by_length[expand_ranges(start, counts)]
        slot = np.repeat(live, counts)
        p_row = i_pair[pick]
        n_par = len(pick)
        if model.orientation:
            theta = prev[p_row, 2]
            p_tt = np.full(n_par, self._theta_var())
        else:
            theta = np.full(n_par, np.nan)
            p_tt = np.full(n_par, np.inf)
        log_scale = math.log(model.scale) if model.scale is not None else np.nan
        known = model.scale is not None
        parent = _Tracks(
            slot=slot,
            row=p_row,
            pos=prev[p_row, :2],
            pos_var=np.full(n_par, pix_var),
            theta=theta,
            p_tt=p_tt,
            log_s=np.full(n_par, log_scale),
            p_ts=np.zeros(n_par),
            p_ss=np.zeros(n_par) if known else np.full(n_par, np.inf),
            logw=self.uniform[slot],
        )
        return self._children(parent, rows, j_pair[pick], interval, pix_var, log_bg)

    def _missed(
        self, tracks: _Tracks, interval: Interval, pix_var: float
    ) -> tuple[_Tracks, np.ndarray, np.ndarray]:
        """Continue every track through a miss: predicted position if its heading is known,
        otherwise its weight returns to "position unknown"."""
        logw = tracks.logw + self.log_miss
        # Tracks are kept sorted by robot, heaviest first (see _normalise_and_prune).
        rank = np.arange(len(tracks)) - np.searchsorted(tracks.slot, tracks.slot, side="left")
        knows = np.isfinite(tracks.theta) & np.isfinite(tracks.log_s) & (rank < MISSED_PER_ROBOT)
        k = np.flatnonzero(knows)
        slot = tracks.slot[k]
        d = interval.d[slot]
        s = np.exp(tracks.log_s[k])
        var_d, var_dphi = interval.variances(self.model.odometry_noise)
        rho = np.hypot(*d.T)
        moved = rotate(d, tracks.theta[k]) * s[:, None]
        continued = _Tracks(
            slot=slot,
            row=np.full(len(k), -1),
            pos=tracks.pos[k] + moved,
            pos_var=tracks.pos_var[k]
            + s**2 * (var_d[slot] + _push_isotropic(interval)[slot])
            + (s * rho) ** 2 * tracks.p_tt[k],
            theta=wrap_angle(tracks.theta[k] + interval.dphi[slot]),
            p_tt=tracks.p_tt[k] + var_dphi[slot],
            log_s=tracks.log_s[k],
            p_ts=tracks.p_ts[k],
            p_ss=tracks.p_ss[k],
            logw=logw[k],
        )
        lost = np.flatnonzero(~knows)
        return continued, tracks.slot[lost], logw[lost]

    def _children(
        self,
        parent: _Tracks,
        rows: np.ndarray,
        cand: np.ndarray,
        interval: Interval,
        pix_var: float,
        log_bg: float,
    ) -> _Tracks:
        """Extend each parent track by candidate row ``cand`` (same length): weight and state."""
        model = self.model
        keep = self._plausible(parent, rows[cand], interval, pix_var)
        parent, cand = parent.take(keep), cand[keep]
        if len(cand) == 0:
            return _Tracks.empty()
        z = rows[cand]
        geo = _Geometry.of(parent, z, interval, model, pix_var)
        child = _Child.start(parent)
        heading_known = np.isfinite(parent.theta)
        scale_known = np.isfinite(parent.log_s)
        s_low, s_high = model.scale_bounds
        # A. heading unknown, scale known: the ring.
        a = ~heading_known & scale_known
        child.loglik[a] = ring_loglik(geo.r[a], geo.s[a] * geo.rho0[a], geo.iso_var[a])
        learn = a & ~geo.still & (geo.r > 0)
        child.heading_from_displacement(learn, geo)
        # C. heading and scale unknown: any length in the scale range, log-uniform scale.
        c = ~heading_known & ~scale_known
        self._scale_free(c, geo, child, s_low, s_high)
        learn = c & ~geo.still & (geo.r > 0)
        child.heading_from_displacement(learn, geo)
        child.log_s[learn] = np.log(geo.r[learn] / geo.rho0[learn])
        child.p_ss[learn] = geo.iso_var[learn] / np.maximum(geo.r[learn], 1e-12) ** 2
        child.p_ts[learn] = 0.0
        # D. heading known, scale unknown: the direction is tested, the length sets the scale.
        dd = heading_known & ~scale_known
        if dd.any():
            self._direction_only(dd, geo, parent, child, s_low, s_high)
        # B. heading known, scale known or estimated: extended Kalman filter on (theta, log s).
        b = heading_known & scale_known
        if b.any():
            self._kalman(b, geo, parent, child)
        # The detected heading, if any, is one more measurement.
        if model.orientation:
            self._orientation(z[:, 2], child.theta, child.p_tt, child.loglik)
        logw = parent.logw + self.log_pd + child.loglik - log_bg
        return _Tracks(
            slot=parent.slot,
            row=cand,
            pos=z[:, :2].copy(),
            pos_var=np.full(len(cand), pix_var),
            theta=wrap_angle(child.theta),
            p_tt=child.p_tt,
            log_s=child.log_s,
            p_ts=child.p_ts,
            p_ss=child.p_ss,
            logw=logw,
        ).take(np.flatnonzero(np.isfinite(logw)))

    def _plausible(
        self, parent: _Tracks, z: np.ndarray, interval: Interval, pix_var: float
    ) -> np.ndarray:
        """Indices of the candidates worth scoring: a cheap, generous test (every variance at
        its largest) drops those no weighting could keep within ``PRUNE_NATS`` of the best."""
        slot = parent.slot
        d = interval.d[slot]
        s_high = self.model.scale_bounds[1]
        var_d, var_dphi = interval.variances(self.model.odometry_noise)
        push = interval.push[slot] if interval.push is not None else 0.0
        rho = s_high * np.hypot(*d.T)
        var = (
            pix_var
            + parent.pos_var
            + s_high**2 * (var_d[slot] + push**2 / 3.0)
            + (self.model.scale_spread * rho) ** 2
        )
        limit = 2.0 * (2.0 * PRUNE_NATS + 5.0)  # on a chi-square: -0.5 chi2 is the log-likelihood
        delta = z[:, :2] - parent.pos
        known = np.isfinite(parent.theta) & np.isfinite(parent.log_s)
        chi2 = np.zeros(len(z))
        # Heading known: distance to the predicted point, the heading's swing added.
        k = np.flatnonzero(known)
        if len(k):
            scale = np.exp(parent.log_s[k])
            pred = rotate(d[k], parent.theta[k]) * scale[:, None]
            spread = var[k] + (scale * np.hypot(*d[k].T)) ** 2 * parent.p_tt[k]
            chi2[k] = ((delta[k] - pred) ** 2).sum(axis=1) / spread
            if self.model.orientation:
                turn = wrap_angle(z[k, 2] - parent.theta[k] - interval.dphi[slot[k]])
                chi2[k] += turn**2 / (parent.p_tt[k] + var_dphi[slot[k]] + self._theta_var())
        # Heading unknown, scale known: the ring.
        ring = np.flatnonzero(~np.isfinite(parent.theta) & np.isfinite(parent.log_s))
        if len(ring):
            length = np.hypot(*delta[ring].T)
            chi2[ring] = (length - np.exp(parent.log_s[ring]) * np.hypot(*d[ring].T)) ** 2 / (
                2.0 * var[ring]
            )
        return np.flatnonzero(chi2 <= limit)

    @staticmethod
    def _scale_free(
        mask: np.ndarray, geo: _Geometry, child: _Child, s_low: float, s_high: float
    ) -> None:
        moving = mask & ~geo.still
        width = math.log(s_high / s_low) if s_high > s_low else 1e-9
        rr = np.maximum(geo.r[moving], 1e-12)
        sigma = np.sqrt(geo.iso_var[moving])
        rho0 = geo.rho0[moving]
        inside = (rr >= s_low * rho0 - GATE_SIGMAS * sigma) & (
            rr <= s_high * rho0 + GATE_SIGMAS * sigma
        )
        # Density of a 2-D displacement of length r in a uniform direction, r log-uniform.
        child.loglik[moving] = np.where(
            inside, -LOG_2PI - 2.0 * np.log(rr) - math.log(width), -np.inf
        )
        standing = mask & geo.still
        child.loglik[standing] = geo.standing_loglik(standing)

    @staticmethod
    def _direction_only(
        mask: np.ndarray,
        geo: _Geometry,
        parent: _Tracks,
        child: _Child,
        s_low: float,
        s_high: float,
    ) -> None:
        moving = np.flatnonzero(mask & ~geo.still)
        rr = np.maximum(geo.r[moving], 1e-12)
        var = geo.iso_var[moving]
        rho0 = geo.rho0[moving]
        width = math.log(s_high / s_low) if s_high > s_low else 1e-9
        predicted = parent.theta[moving] + geo.ang_d[moving]
        err = wrap_angle(geo.ang_delta[moving] - predicted)
        var_ang = parent.p_tt[moving] + var / rr**2
        sigma = np.sqrt(var)
        inside = (rr >= s_low * rho0 - GATE_SIGMAS * sigma) & (
            rr <= s_high * rho0 + GATE_SIGMAS * sigma
        )
        # Angle density times the log-uniform length density, per unit area (the 1/r Jacobian).
        angle_ll = -0.5 * (math.log(2 * math.pi) + np.log(var_ang) + err**2 / var_ang)
        child.loglik[moving] = np.where(
            inside, angle_ll - 2.0 * np.log(rr) - math.log(width), -np.inf
        )
        gain = parent.p_tt[moving] / var_ang
        child.theta[moving] = parent.theta[moving] + gain * err + geo.dphi[moving]
        child.p_tt[moving] = parent.p_tt[moving] * (1 - gain) + geo.var_dphi[moving]
        child.log_s[moving] = np.log(rr / rho0)
        child.p_ss[moving] = var / rr**2
        child.p_ts[moving] = 0.0
        standing = np.flatnonzero(mask & geo.still)
        child.loglik[standing] = geo.standing_loglik(standing)
        child.theta[standing] = parent.theta[standing] + geo.dphi[standing]
        child.p_tt[standing] = parent.p_tt[standing] + geo.var_dphi[standing]

    @staticmethod
    def _kalman(mask: np.ndarray, geo: _Geometry, parent: _Tracks, child: _Child) -> None:
        k = np.flatnonzero(mask)
        th, ls = parent.theta[k], parent.log_s[k]
        ptt, pts, pss = parent.p_tt[k], parent.p_ts[k], parent.p_ss[k]
        # Unseen pushes (robot frame, scaled to the image) turned by the heading: R C R^T.
        push = geo.push_cov[k] * (geo.s[k] ** 2)[:, None, None]
        c, sn = np.cos(th), np.sin(th)
        cxx, cxy, cyy = push[:, 0, 0], push[:, 0, 1], push[:, 1, 1]
        q11 = c * c * cxx - 2 * c * sn * cxy + sn * sn * cyy
        q12 = c * sn * (cxx - cyy) + (c * c - sn * sn) * cxy
        q22 = sn * sn * cxx + 2 * c * sn * cxy + c * c * cyy
        s = np.exp(ls)
        pred = rotate(geo.d[k], th) * s[:, None]  # h(x) = s R(theta) d
        h_t = rotate(pred, math.pi / 2.0)  # dh/dtheta
        h_s = pred  # dh/dlog s
        e = geo.delta[k] - pred
        # S = base I + R C R^T + H P H^T with H = [h_t h_s] (2x2), P = [[ptt, pts], [pts, pss]].
        hp_t = h_t * ptt[:, None] + h_s * pts[:, None]  # H P first column
        hp_s = h_t * pts[:, None] + h_s * pss[:, None]  # H P second column
        base = geo.base_var[k]
        s11 = base + q11 + hp_t[:, 0] * h_t[:, 0] + hp_s[:, 0] * h_s[:, 0]
        s12 = q12 + hp_t[:, 0] * h_t[:, 1] + hp_s[:, 0] * h_s[:, 1]
        s22 = base + q22 + hp_t[:, 1] * h_t[:, 1] + hp_s[:, 1] * h_s[:, 1]
        det = s11 * s22 - s12**2
        i11, i12, i22 = s22 / det, -s12 / det, s11 / det
        maha = e[:, 0] ** 2 * i11 + 2 * e[:, 0] * e[:, 1] * i12 + e[:, 1] ** 2 * i22
        child.loglik[k] = -LOG_2PI - 0.5 * np.log(det) - 0.5 * maha
        # Gain K = P H^T S^-1 (2x2); rows: theta, log s.
        sinv_e = np.column_stack([i11 * e[:, 0] + i12 * e[:, 1], i12 * e[:, 0] + i22 * e[:, 1]])
        dth = np.einsum("ij,ij->i", hp_t, sinv_e)
        dls = np.einsum("ij,ij->i", hp_s, sinv_e)
        # P' = P - (H P)^T S^-1 (H P)
        a_t = np.column_stack(
            [i11 * hp_t[:, 0] + i12 * hp_t[:, 1], i12 * hp_t[:, 0] + i22 * hp_t[:, 1]]
        )
        a_s = np.column_stack(
            [i11 * hp_s[:, 0] + i12 * hp_s[:, 1], i12 * hp_s[:, 0] + i22 * hp_s[:, 1]]
        )
        child.theta[k] = th + dth + geo.dphi[k]
        child.p_tt[k] = np.maximum(ptt - np.einsum("ij,ij->i", hp_t, a_t), 1e-14) + geo.var_dphi[k]
        child.log_s[k] = ls + dls
        child.p_ts[k] = pts - np.einsum("ij,ij->i", hp_t, a_s)
        child.p_ss[k] = np.maximum(pss - np.einsum("ij,ij->i", hp_s, a_s), 0.0)

    def _orientation(
        self, detected: np.ndarray, theta: np.ndarray, p_tt: np.ndarray, loglik: np.ndarray
    ) -> None:
        var_z = self._theta_var()
        known = np.isfinite(theta)
        err = wrap_angle(detected[known] - theta[known])
        var = p_tt[known] + var_z
        loglik[known] += -0.5 * (math.log(2 * math.pi) + np.log(var) + err**2 / var)
        gain = p_tt[known] / var
        theta[known] = theta[known] + gain * err
        p_tt[known] = p_tt[known] * (1 - gain)
        # A heading learnt nowhere else comes from the detection itself.
        unknown = ~known
        theta[unknown] = detected[unknown]
        p_tt[unknown] = var_z

    # -- bookkeeping -----------------------------------------------------------------------------
    def _normalise_and_prune(self) -> None:
        tracks = self.tracks
        n_rows = 0 if self.rows is None else len(self.rows)
        log_rows = math.log(n_rows) if n_rows else -np.inf
        uniform_total = self.uniform + log_rows
        best = np.maximum(uniform_total, self.unanchored)
        if len(tracks):
            np.maximum.at(best, tracks.slot, tracks.logw)
        lost = ~np.isfinite(best)
        if lost.any():  # the model ruled everything out (it does not fit): start over
            self.unanchored[lost] = 0.0
            best[lost] = 0.0
        keep = tracks.logw >= best[tracks.slot] - PRUNE_NATS
        tracks = tracks.take(np.flatnonzero(keep & ~lost[tracks.slot]))
        # Cap the number of tracks per robot: keep the heaviest.
        order = np.lexsort((-tracks.logw, tracks.slot))
        tracks = tracks.take(order)
        rank = np.arange(len(tracks)) - np.searchsorted(tracks.slot, tracks.slot, side="left")
        tracks = tracks.take(np.flatnonzero(rank < self.max_tracks))
        # Normalise each robot's weights to sum to one.
        sums = np.exp(uniform_total - best) + np.exp(self.unanchored - best)
        sums += np.bincount(
            tracks.slot, weights=np.exp(tracks.logw - best[tracks.slot]), minlength=self.n
        )
        total = best + np.log(sums)
        tracks.logw = tracks.logw - total[tracks.slot]
        self.uniform = self.uniform - total
        self.unanchored = self.unanchored - total
        # Implicit weights too small to matter stop costing anything.
        self.uniform[self.uniform + log_rows < -PRUNE_NATS] = -np.inf
        self.unanchored[self.unanchored < -PRUNE_NATS] = -np.inf
        self.tracks = tracks

    def _compute_belief(self) -> None:
        n_rows = 0 if self.rows is None else len(self.rows)
        belief = np.repeat(np.exp(self.uniform)[:, None], n_rows, axis=1)
        tracks = self.tracks
        weights = np.exp(tracks.logw)
        seen = tracks.row >= 0
        np.add.at(belief, (tracks.slot[seen], tracks.row[seen]), weights[seen])
        missing = np.exp(self.unanchored) + np.bincount(
            tracks.slot[~seen], weights=weights[~seen], minlength=self.n
        )
        total = belief.sum(axis=1) + missing
        self._belief = belief / total[:, None]
        self._missing = missing / total

    def belief(self) -> np.ndarray:
        """``(R, n)`` probability that each row of the newest picture is robot i."""
        if self._belief is None:
            raise RuntimeError("no picture yet: call update() first")
        return self._belief

    def missing(self) -> np.ndarray:
        """``(R,)`` probability that robot i is not in the newest picture."""
        return self._missing

    def n_tracks(self) -> np.ndarray:
        """``(R,)`` explicit hypotheses kept per robot (a measure of ambiguity and cost)."""
        return np.bincount(self.tracks.slot, minlength=self.n)


def picture_rows(picture: Picture) -> np.ndarray:
    """The ``(n, 3)`` detection rows of a picture."""
    return picture.detections
