"""Localizers: turn pictures and own motion into "which row is me", for R robots at once.

Each localizer wraps the pure functions of :mod:`baselines.angular`, :mod:`baselines.linear`,
:mod:`baselines.motion` or the Bayesian ``anonloc_env.identify.Identifier``. It is told about
every picture (with the robots' own motion since the previous one) and keeps, per robot, an
estimate (a row of the newest picture, or -1 while undecided) and a belief over the rows.

``mode="faithful"`` runs the paper's algorithm as printed (typos aside); ``"corrected"`` (default)
runs the corrected one, whose decision thresholds come from the noise model (a chi-square test at
a false-rejection rate of 1e-4).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from anonloc_env.camera import survey
from anonloc_env.config import EnvConfig
from anonloc_env.identify import Identifier, Interval, SensorModel
from anonloc_env.identify.camera_pose import Registration
from anonloc_env.rewards import InformationGain
from baselines import angular, linear, matching, motion
from baselines.decisions import Decisions

MODES = ("corrected", "faithful")
#: Chi-square thresholds at a false-rejection rate of 1e-4, by degrees of freedom.
CHI2_THRESHOLD = {1: 15.14, 2: 18.42, 3: 21.11}
#: Chi-square margin over every other row for a corrected decision: the chosen row must be at
#: least 99 times as likely as the runner-up (2 ln 99).
CHI2_MARGIN = 2.0 * math.log(99.0)


def _commanded(interval: Interval, method: str) -> np.ndarray:
    """``(R, 2)`` the command ``(v, w)`` set at ``interval``'s start, which the paper's faithful
    ``method`` reads (Algorithm 1's ``r``, method B's ``v0`` and ``v1``)."""
    if interval.command is None:
        raise ValueError(
            f"the faithful {method} method reads the robots' commanded speeds, which this "
            "interval does not carry (Interval.command is None): run it in a Team, or use "
            "mode='corrected'"
        )
    return interval.command


class Localizer:
    """Base class of the localizers: from pictures and the robots' own motion to "which row of
    the newest picture is me", for R robots at once.

    A localizer sees only what its robots observe: the rows of each picture and each robot's own
    motion between pictures, never the env's state. A :class:`~baselines.policies.Team` calls it,
    in every episode:

    1. :meth:`reset`, at the start;
    2. :meth:`on_picture`, at every picture in order (the first one too), with the picture's rows
       and each robot's own motion since the previous picture.

    After each :meth:`on_picture` the team, and the runner that scores it, read ``estimate``
    and ``belief``.

    A subclass implements one of two hooks:

    * :meth:`decide` (compulsory unless :meth:`on_picture` is overridden): called by
      :meth:`on_picture` once ``needs`` pictures are kept. It reads ``pictures``,
      ``intervals`` and ``durations`` (newest last) and sets ``estimate`` and
      ``belief``. Until then every robot is undecided, with a uniform belief.
    * :meth:`on_picture` itself, for a localizer that carries its own state through every picture
      (as :class:`BayesLocalizer` does): it must then set ``estimate`` and ``belief`` at
      every call.

    Optional: ``needs`` (class attribute), and :meth:`reset` (call ``super().reset()`` first)
    for state of your own. Helpers for :meth:`decide`: :meth:`_sigma` (a robot's displacement
    tolerance in image units), :meth:`_reach` (how far any robot may have moved), and
    :meth:`_set_from_chi2` (belief and estimate from chi-square scores).

    A worked example that runs in an env is on the docs page *Extending*
    (``examples/custom_localizer.py``).

    Args:
        config: what the robots know of the task (nominal camera, robot and timing specs).
        n: number of robots R.
        mode: ``"corrected"`` or ``"faithful"`` (the paper as printed); a localizer without a
            faithful form refuses ``"faithful"``.

    Attributes:
        config: the task as the robots know it.
        n: number of robots R.
        mode: ``"corrected"`` or ``"faithful"``.
        model: the sensor model (``anonloc_env.identify.SensorModel``) built from ``config``:
            pixel, orientation and odometry noise, misses, false positives, scale bounds.
        scale: image units per metre (the largest the camera may have).
        sigma: pixel noise of one coordinate of a detection (image units).
        scale_gradient: largest relative change of the camera's scale per metre of ground (1/m;
            0 unless the camera is tilted): ``anonloc_env.camera.survey(config).scale_gradient``.
        pictures: the last three pictures' rows, each ``(n_k, 3)`` ``(u, v, theta)`` in image
            units and radians (``theta`` is 0 without detected headings), newest last. Row order
            is random in every picture.
        intervals: the robots' own motion between consecutive kept pictures (the last two), each
            an ``anonloc_env.odometry.Interval``: ``d`` ``(R, 2)`` displacement (m) in the
            robot's frame at the earlier picture, ``dphi`` ``(R,)`` heading change (rad), ``path``
            ``(R,)`` distance rolled (m), and what contacts may have pushed it.
        durations: the time between those pictures (s), one per interval.
        estimate: ``(R,)`` int: the row of the newest picture robot i believes is itself, -1 while
            undecided.
        belief: ``(R, n)`` float: robot i's probability for each row of the newest picture (a
            row's sum may fall short of 1: the rest is "I am not in the picture").
        footprint: ``(4, 2)`` the newest picture's field of view in its rows' frame where the
            observations carry it (a moving camera with ground landmarks), set by the team
            before each ``on_picture``; ``None`` otherwise. ``bayes`` gives it to its
            identifier (robots near the view's edge may have left it).
    """

    #: Pictures needed before a first decision.
    needs = 2

    def __init__(self, config: EnvConfig, n: int, mode: str = "corrected") -> None:
        if mode not in MODES:
            raise ValueError(f"mode must be one of {list(MODES)}, got {mode!r}")
        self.config = config
        self.n = n
        self.mode = mode
        self.model = SensorModel.from_config(config)
        self.scale = self.model.scale_bounds[1]
        self.sigma = math.hypot(self.model.pixel_noise, 1e-3)
        self.scale_gradient = survey(config).scale_gradient
        # A moving camera: the corrected methods read each picture in the set point's frame (the
        # faithful ones, as published, read the rows as they come).
        prior = self.model.registration
        self.registration = (
            Registration(prior, self.model.orientation)
            if prior is not None and mode == "corrected"
            else None
        )
        self.reset()

    def reset(self) -> None:
        """Forget all pictures: every robot undecided, no rows. Called at every episode start."""
        self.pictures: list[np.ndarray] = []
        self.intervals: list[Interval] = []
        self.durations: list[float] = []
        self.estimate = np.full(self.n, -1, dtype=np.int64)
        self.belief = np.zeros((self.n, 0))
        self.footprint: np.ndarray | None = None
        if self.registration is not None:
            self.registration.reset()

    def on_picture(self, rows: np.ndarray, interval: Interval | None, duration: float) -> None:
        """Take in a picture and update ``estimate`` and ``belief``.

        Args:
            rows: ``(n, 3)`` the picture's rows ``(u, v, theta)`` (image units, rad), padding
                removed, in random order.
            interval: each robot's own motion since the previous picture, None at the first
                (with the command ``(v, w)`` it set at that interval's start, ``command``: the
                paper's faithful angular and linear methods read it).
            duration: the time since the previous picture (s; 0 at the first).
        """
        if self.registration is not None:
            rows = self.registration.register(rows)
        self.pictures = [*self.pictures[-2:], rows]
        if interval is not None:
            self.intervals = [*self.intervals[-1:], interval]
            self.durations = [*self.durations[-1:], duration]
        n_rows = len(rows)
        self.estimate = np.full(self.n, -1, dtype=np.int64)
        self.belief = np.full((self.n, n_rows), 1.0 / max(n_rows, 1))
        if len(self.pictures) >= self.needs and len(self.intervals) >= self.needs - 1:
            self.decide()

    def attach(self, env: Any) -> None:
        """Told the env the robots will run in, when the localizer is built for one
        (:func:`baselines.make_team` with an env): a localizer may read what the env already
        computes. Default: nothing. :class:`BayesLocalizer` reads the identifier of the env's
        default reward."""

    def decide(self) -> None:
        """Set ``estimate`` ``(R,)`` and ``belief`` ``(R, n)`` from the kept
        ``pictures`` and ``intervals``, ``n`` being the newest picture's rows. Called by
        :meth:`on_picture` at every picture once ``needs`` pictures are kept."""
        raise NotImplementedError(f"{type(self).__name__} must implement decide()")

    def _reach(self, interval: Interval) -> float:
        """Farthest any robot may move in the image over ``interval`` (image units)."""
        return float(self.scale * 1.1 * interval.reach.max() + 6.0 * self.sigma + self.scale * 0.05)

    def _sigma(self, interval: Interval) -> np.ndarray:
        """``(R,)`` per-coordinate tolerance (image units) of a detection's displacement: pixel
        noise, each robot's odometry noise, and what contacts may have moved it unseen."""
        var_d, _ = self._odometry_variance(interval)
        return np.sqrt(self.sigma**2 + self.scale**2 * var_d)

    def _odometry_variance(self, interval: Interval) -> tuple[np.ndarray, np.ndarray]:
        """``(R,)`` variance per component of the own displacement (m^2: odometry and unseen
        contact pushes) and of the heading change (rad^2) over ``interval``."""
        var_d, var_dphi = interval.variances(self.model.odometry_noise)
        cov = interval.push_covariance()
        return var_d + 0.5 * (cov[:, 0, 0] + cov[:, 1, 1]), var_dphi

    def _set_from_chi2(self, chi2: np.ndarray, dof: int, margin: float = 0.0) -> None:
        """``belief`` ``exp(-chi2 / 2)`` normalised per robot, and ``estimate`` the row
        of smallest score if it passes the chi-square test at a false rejection of 1e-4 with
        ``dof`` (1, 2 or 3) degrees of freedom and every other row scores at least ``margin``
        more. ``chi2`` is ``(R, n)``, ``inf`` where impossible."""
        self.belief = matching.scores_to_belief(chi2)
        self.estimate = matching.decide(chi2, CHI2_THRESHOLD[dof], margin)

    def _set_from_deviation(self, deviation: np.ndarray) -> None:
        """Faithful decision: the smallest deviation wins, whatever its size."""
        best = np.argmin(deviation, axis=1) if deviation.shape[1] else np.zeros(0, int)
        found = np.isfinite(deviation[np.arange(self.n), best]) if deviation.shape[1] else []
        self.estimate = np.where(found, best, -1) if deviation.shape[1] else self.estimate
        onehot = np.zeros_like(deviation)
        onehot[np.flatnonzero(self.estimate >= 0), self.estimate[self.estimate >= 0]] = 1.0
        self.belief = np.where(
            (self.estimate >= 0)[:, None], onehot, 1.0 / max(deviation.shape[1], 1)
        )


class AngularLocalizer(Localizer):
    """Paper II.A (needs detected headings)."""

    def __init__(self, config: EnvConfig, n: int, mode: str = "corrected") -> None:
        if not config.camera.orientation:
            raise ValueError(
                "the angular method needs detected headings: camera.orientation is False "
                "(a blob detector gives none); use 'motion' or 'bayes'"
            )
        super().__init__(config, n, mode)

    def decide(self) -> None:
        first, second = self.pictures[-2], self.pictures[-1]
        interval = self.intervals[-1]
        if self.mode == "faithful":
            rate = _commanded(interval, "angular")[:, 1]
            rotation = rate * self.durations[-1]  # r * dt of Algorithm 1
            self._set_from_deviation(
                angular.faithful_residuals(first[:, 2], second[:, 2], rotation)
            )
            return
        size = self.config.robot.size
        shift = self.scale * (size + float(interval.reach.max())) + 6 * self.sigma
        res = angular.residuals(first, second, interval.dphi, shift)
        _, var_dphi = interval.variances(self.model.odometry_noise)
        var = 2 * self.model.orientation_noise**2 + var_dphi[:, None] + 1e-8
        self._set_from_chi2(res**2 / var, dof=1)


class LinearLocalizer(Localizer):
    """Paper II.B (three pictures, scale-free ratio)."""

    needs = 3

    def decide(self) -> None:
        p0, p1, p2 = (p[:, :2] for p in self.pictures[-3:])
        if self.mode == "faithful":
            # The speeds commanded over the two legs just driven.
            v0 = _commanded(self.intervals[-2], "linear")[:, 0]
            v1 = _commanded(self.intervals[-1], "linear")[:, 0]
            t0, t1 = self.durations[-2], self.durations[-1]
            with np.errstate(divide="ignore"):
                ratio = v0 * t0 / (v1 * t1)
            rows, deviation = linear.faithful_search(p0, p1, p2, ratio)
            dev = np.full((self.n, len(p2)), np.inf)
            ok = rows >= 0
            dev[np.flatnonzero(ok), rows[ok]] = deviation[ok]
            self._set_from_deviation(dev)
            return
        first, second = self.intervals[-2], self.intervals[-1]
        len0, len1 = np.hypot(*first.d.T), np.hypot(*second.d.T)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(len1 > 0, len0 / len1, np.inf)
        sigma = np.hypot(self._sigma(first), self._sigma(second))
        # The legs' midpoints lie (len0 + len1) / 2 apart: a tilted camera's scale differs there.
        change = self.scale_gradient * 0.5 * (len0 + len1)
        chi2 = linear.residuals(
            p0, p1, p2, ratio, sigma, self._reach(first), self._reach(second), change
        )
        self._set_from_chi2(chi2, dof=2)


class MotionLocalizer(Localizer):
    """Paper II.C with the scale known (two pictures)."""

    def decide(self) -> None:
        first, second = self.pictures[-2], self.pictures[-1]
        interval = self.intervals[-1]
        if self.mode == "faithful":
            dev = motion.faithful_deviation(first[:, :2], second[:, :2], interval.d, self.scale)
            # A first picture without rows (every robot out of a moving camera's view): no
            # row of the second continues one.
            best = dev.min(axis=1) if dev.shape[1] else np.full((self.n, len(second)), np.inf)
            self._set_from_deviation(best)
            return
        orientation = self.model.orientation_noise if self.model.orientation else None
        sigma = self._sigma(interval)
        chi2 = motion.residuals(
            first,
            second,
            interval.d,
            interval.dphi,
            self.scale,
            sigma,
            self._reach(interval),
            None if orientation is None else max(orientation, 1e-4),
            self.model.scale_spread,
        )
        self._set_from_chi2(chi2, dof=3 if orientation is not None else 1)


class Motion3Localizer(Localizer):
    """Paper eq. 24: the scale unknown, three pictures."""

    needs = 3

    def decide(self) -> None:
        p0, p1, p2 = (p[:, :2] for p in self.pictures[-3:])
        first, second = self.intervals[-2], self.intervals[-1]
        if self.mode == "faithful":
            dev = motion.faithful_scale_free_deviation(p0, p1, p2, first.d, first.dphi, second.d)
            self._set_from_deviation(dev)
            return
        var_d1, var_dphi1 = self._odometry_variance(first)
        var_d2, _ = self._odometry_variance(second)
        chi2 = motion.scale_free_residuals(
            p0,
            p1,
            p2,
            first.d,
            first.dphi,
            second.d,
            self.sigma,
            2 * self._reach(first),
            2 * self._reach(second),
            var_d1,
            var_d2,
            var_dphi1,
        )
        self._set_from_chi2(chi2, dof=2, margin=CHI2_MARGIN)


class BayesLocalizer(Localizer):
    """The Bayesian identifier (``anonloc_env.identify``) with a decision threshold.

    Built for an env whose reward is the default ``anonloc_env.rewards.InformationGain``
    (``make_team("bayes", env)``), a team of all its robots that knows the true noise model
    (``config`` is the env's, ``scale_known``) reads the identifier that reward already runs on
    the same observations, instead of running a second one: the beliefs are the same to the bit
    (tested), at half the cost. ``share=False`` keeps an identifier of its own.

    Args:
        config: what the robots know of the task.
        n: number of robots R.
        mode: only ``"corrected"``.
        threshold: belief above which a robot decides (default 0.99).
        scale_known: False estimates the camera scale per hypothesis.
        share: read the env's reward's identifier where it is the same (see above).
        keep: belief down to which a decided robot keeps its decision while its belief dips
            along the track it decided on (``baselines.decisions``); None: ``threshold``, no
            hold.
        settle: intervals pushed in a row past which a robot takes no new decision
            (``baselines.decisions``); None: no limit.
        release: path (m) a decided robot must have rolled since it decided to be held
            (``baselines.decisions``); None: no release.

    With none of ``keep``, ``settle`` and ``release`` given, the decisions are
    ``Decisions.crowd``: the hold with the release where the identifier models a crowd (above
    one robot per m^2, clean pictures), the same for robots touched in the newest two intervals
    in open space with clean pictures and a fixed camera, the plain threshold elsewhere.
    """

    needs = 1

    def __init__(
        self,
        config: EnvConfig,
        n: int,
        mode: str = "corrected",
        threshold: float = 0.99,
        scale_known: bool = True,
        share: bool = True,
        keep: float | None = None,
        settle: int | None = None,
        release: float | None = None,
    ) -> None:
        if mode != "corrected":
            raise ValueError("the Bayesian identifier has no faithful mode; use mode='corrected'")
        if keep is None and settle is None and release is None:
            self.decisions = Decisions.crowd(threshold)
        else:
            self.decisions = Decisions(threshold, keep, settle, release)
        self.threshold = threshold
        self.scale_known = scale_known
        self.share = share
        self._shared: InformationGain | None = None
        self._own: Identifier | None = None
        super().__init__(config, n, mode)

    @property
    def identifier(self) -> Identifier:
        """The identifier the beliefs come from: the env's reward's, if shared, else its own."""
        if self._shared is not None:
            assert self._shared.identifier is not None  # set at the env's reset
            return self._shared.identifier
        if self._own is None:
            model = SensorModel.from_config(self.config, scale_known=self.scale_known)
            self._own = Identifier(model, self.n)
        return self._own

    @property
    def shared(self) -> bool:
        """Whether the beliefs come from the env's reward's identifier."""
        return self._shared is not None

    def attach(self, env: Any) -> None:
        """Read the identifier of ``env``'s reward if it runs the same one (see the class)."""
        unwrapped = getattr(env, "unwrapped", env)
        reward = getattr(unwrapped, "reward_fn", None)
        same = (
            self.share
            and isinstance(reward, InformationGain)
            and self.scale_known
            and self.n == self.config.n_robots
            and getattr(unwrapped, "config", None) == self.config
        )
        if same:
            assert isinstance(reward, InformationGain)
            self._shared, self._own = reward, None
            self._seen = 0

    def reset(self) -> None:
        super().reset()
        self._seen = 0
        self.decisions.reset()
        if self._own is not None:  # (built at its first picture: a new one needs no reset)
            self._own.reset()

    def on_picture(self, rows: np.ndarray, interval: Interval | None, duration: float) -> None:
        if self._shared is None:
            self.identifier.update(rows, interval, self.footprint)
        else:
            self._check_in_step(rows)
        self._seen += 1
        self.belief = self.identifier.belief()
        self.estimate = self.decisions.decide(self.identifier, self.belief)

    def _check_in_step(self, rows: np.ndarray) -> None:
        """The shared identifier took in this very picture, and all the team's before it."""
        source = self._shared
        assert source is not None
        if source.pictures != self._seen + 1 or not np.array_equal(source.rows, rows):
            raise RuntimeError(
                "this bayes team shares the identifier of its env's reward, but the two went "
                f"out of step (the env's reward has taken {source.pictures} pictures of this "
                f"episode, the team {self._seen + 1}): step the env with this team's actions "
                "and reset both together, or build the team with share=False"
            )
