"""Active identification: at each picture, drive so that the next picture tells most.

:class:`GreedyIdentification` is a one-step (greedy) information-seeking excitation in the spirit
of Chernoff's active hypothesis testing. At every picture each robot reads its own belief over the
rows of the picture (the team localizer's ``belief``; never the identifier's private tracks),
keeps its few most likely rows as hypotheses, draws a handful of candidate commands ``(v, w)``
(held until the next picture), predicts for each the belief it would hold after the next picture,
and drives the candidate with the smallest expected entropy of that belief, plus a small energy
penalty.

The prediction (all closed form, vectorised over robots x hypotheses x candidates):

* **My next position under hypothesis h.** A command held for ``T`` seconds moves the robot by
  ``d = (v/w sin(wT), v/w (1 - cos(wT)))`` in its own frame. If the robot's heading at row ``h``
  is known (the detector measures it, or it is reconstructed from the row of the previous
  picture that matches the robot's own last displacement) it lands at ``p_h + s R(theta_h) d``
  (a point, with Gaussian noise); otherwise anywhere on the ring of radius ``s |d|`` around
  ``p_h`` (the identifier then matches only the displacement's length).
* **The other robots' unknown motion.** The robot at a wrong row ``h'`` moves as another robot
  would: its command is drawn from ``others`` (by default the same box the candidates come from;
  robots are identical). With a known heading the chance that it lands where "I am h'" predicts
  me depends only on the distance between my displacement and its displacement, each in its own
  frame; with the heading unknown, on their lengths. Every other detection is background clutter
  of the identifier's density ``lambda`` (rows per image area).
* **Expected posterior.** If I am ``h*``, hypothesis ``h'`` keeps the likelihood ratio
  ``(lambda + collide(h*, h') + mimic(h')) / (lambda + peak(h*))`` against it: ``collide`` is the
  density of "I am h'" where I truly land (two hypotheses that predict the same place cannot be
  told apart), ``mimic`` that of the robot at ``h'`` moving like me, ``peak`` the density of my
  own detection under the truth. The expected entropy averages the entropy of the resulting
  posterior over ``h*`` weighted by the current belief.

On swarm duty (:class:`baselines.excitations.SwarmDuty`) the robot only chooses a deviation: the
duty tells it the shared command and the budget through
:meth:`~baselines.excitations.Excitation.follow`, the candidates are deviations (forward or
backward), and the predicted displacements are those of ``shared + budget * deviation``, for
the others too (they follow the same shared stream).

After a bump the robot reverses out, or escapes when pressed (the bump reflex of
:mod:`baselines.excitations.reflex` it holds), and resumes its choice.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from anonloc_env.identify import SensorModel, ring_loglik
from anonloc_env.rewards import turn_cost, wheel_travel
from baselines.excitations import Excitation
from baselines.excitations.candidates import GreedySettings, candidate_commands
from baselines.excitations.reflex import BumpReflex
from baselines.steps import BeliefView, Step


def unicycle(v: np.ndarray, w: np.ndarray, duration: float) -> np.ndarray:
    """Displacement ``(..., 2)`` in the robot's frame of ``(v, w)`` held for ``duration`` s."""
    v, w = np.asarray(v, np.float64), np.asarray(w, np.float64)
    if v.shape != w.shape:  # (broadcast_arrays costs more than the rest for equal shapes)
        v, w = np.broadcast_arrays(v, w)
    turn = w * duration
    small = np.abs(turn) < 1e-6
    safe = np.where(small, 1.0, w)
    forward = np.where(small, v * duration, v / safe * np.sin(turn))
    lateral = np.where(small, 0.5 * v * w * duration**2, v / safe * (1.0 - np.cos(turn)))
    return np.stack([forward, lateral], axis=-1)


@dataclass(frozen=True)
class Hypotheses:
    """Each robot's hypotheses at one picture, padded to ``K`` (weight 0 where absent).

    Attributes:
        weight: ``(R, K)`` normalised beliefs.
        pos: ``(R, K, 2)`` their rows' image positions.
        theta: ``(R, K)`` the robot's image heading if it is that row (0 where unknown).
        theta_var: ``(R, K)`` variance of that heading (rad^2).
        known: ``(R, K)`` whether the heading is known.
    """

    weight: np.ndarray
    pos: np.ndarray
    theta: np.ndarray
    theta_var: np.ndarray
    known: np.ndarray


@dataclass(frozen=True)
class PredictionGeometry:
    """What the prediction needs besides the hypotheses (image units, seconds).

    Each field is one number for all robots, or (``scale`` to ``p_detect``) an ``(R,)`` array,
    one per robot, where the robots of several envs are scored together
    (``entropies_together``).

    Attributes:
        scale: image units per metre.
        pixel_var: variance of a detection's ``u`` and ``v``.
        scale_spread: relative spread of the scale across the image.
        clutter: density of the other detections (rows per image area).
        p_detect: probability that a robot is in a picture.
        duration: time to the next picture (s).
    """

    scale: float | np.ndarray
    pixel_var: float | np.ndarray
    scale_spread: float | np.ndarray
    clutter: float | np.ndarray
    p_detect: float | np.ndarray
    duration: float


@dataclass(frozen=True)
class CandidateSet:
    """Each robot's candidate commands at one picture and what each is predicted to tell.

    Attributes:
        commands: ``(R, C, 2)`` the candidates ``(v, w)`` (m/s, rad/s); on swarm duty, the
            deviations (before the budget scales them).
        entropy: ``(R, C)`` expected entropy of the robot's belief after the next picture if it
            drives that candidate (nats; :func:`expected_entropy`).
        spent: ``(R, C)`` the candidate's energy over the interval (m of wheel travel, turns
            weighed by ``reward.turn_cost``).
        now: ``(R,)`` entropy of the robot's belief over its hypotheses now (nats).
        reach: ``(R, C)`` length of the candidate's displacement in image units.
    """

    commands: np.ndarray
    entropy: np.ndarray
    spent: np.ndarray
    now: np.ndarray
    reach: np.ndarray


@dataclass(frozen=True)
class ScoringJob:
    """One excitation's candidates at one picture, scored up to their expected entropy
    (``GreedyIdentification.prepare``).

    Attributes:
        commands: ``(R, C, 2)`` the candidates (as in ``CandidateSet``).
        hyp: the robots' hypotheses.
        geo: the prediction's geometry (numbers).
        own: ``(R, C, 2)`` each candidate's displacement in the robot's frame (m).
        others: ``(1, S, 2)`` or ``(R, S, 2)`` the other robots' possible displacements (m).
        spent: ``(R, C)`` each candidate's energy over the interval.
        ring_samples: points per ring where the heading is unknown.
    """

    commands: np.ndarray
    hyp: Hypotheses
    geo: PredictionGeometry
    own: np.ndarray
    others: np.ndarray
    spent: np.ndarray
    ring_samples: int

    def entropy(self) -> np.ndarray:
        """``(R, C)`` the expected entropies (``expected_entropy``)."""
        return expected_entropy(self.hyp, self.own, self.others, self.geo, self.ring_samples)

    def finish(self, entropy: np.ndarray) -> CandidateSet:
        """The candidate set, given this job's expected ``entropy`` ``(R, C)``."""
        weight = self.hyp.weight
        now = -(weight * np.log(np.maximum(weight, 1e-300))).sum(axis=1)
        reach = self.geo.scale * np.hypot(self.own[..., 0], self.own[..., 1])
        return CandidateSet(self.commands, entropy, self.spent, now, reach)


def entropies_together(jobs: Sequence[ScoringJob]) -> list[np.ndarray]:
    """Each job's ``ScoringJob.entropy``, the jobs of one shape (hypotheses, candidates,
    the others' commands and ring points alike) stacked along the robot axis and computed in
    one call of ``expected_entropy``, whose geometry is then one number per robot.

    Every operation of ``expected_entropy`` is elementwise along the robot axis or reduces
    along another, so each robot's values are those of its job's own call, to the bit
    (``tests/test_active.py`` and ``tests/test_vec.py`` check). K envs then cost a few numpy
    calls per picture instead of K times as many.
    """
    groups: dict[tuple[int, ...], list[int]] = {}
    for i, job in enumerate(jobs):
        key = (*job.hyp.weight.shape[1:], *job.own.shape[1:], *job.others.shape[1:])
        groups.setdefault((*key, job.ring_samples), []).append(i)
    out: list[np.ndarray] = [np.empty(0)] * len(jobs)
    for members in groups.values():
        if len(members) == 1:
            out[members[0]] = jobs[members[0]].entropy()
            continue
        part = [jobs[i] for i in members]
        sizes = [len(job.own) for job in part]
        hyp = Hypotheses(
            *(np.concatenate([getattr(job.hyp, f) for job in part]) for f in _HYPOTHESES)
        )
        fields = np.repeat(
            np.array([[getattr(job.geo, f) for f in _PER_ROBOT] for job in part]), sizes, axis=0
        )
        scale, pixel_var, spread, clutter, p_detect = fields.T
        geo = PredictionGeometry(
            scale, pixel_var, spread, clutter, p_detect, duration=part[0].geo.duration
        )
        own = np.concatenate([job.own for job in part])
        others = np.concatenate(
            [
                np.broadcast_to(job.others, (n, *job.others.shape[1:]))
                for job, n in zip(part, sizes, strict=True)
            ]
        )
        entropy = expected_entropy(hyp, own, others, geo, part[0].ring_samples)
        for i, piece in zip(members, np.split(entropy, np.cumsum(sizes)[:-1]), strict=True):
            out[i] = piece
    return out


_HYPOTHESES = ("weight", "pos", "theta", "theta_var", "known")
_PER_ROBOT = ("scale", "pixel_var", "scale_spread", "clutter", "p_detect")


def expected_entropy(
    hyp: Hypotheses,
    own: np.ndarray,
    others: np.ndarray,
    geo: PredictionGeometry,
    ring_samples: int = 8,
) -> np.ndarray:
    """``(R, C)`` expected entropy (nats) of each robot's belief after the next picture.

    Args:
        hyp: the robots' hypotheses (``K`` each).
        own: ``(R, C, 2)`` each candidate's displacement in the robot's frame (m).
        others: ``(R, S, 2)`` the other robots' possible displacements in their frames (m).
        geo: scale, noise and timing.
        ring_samples: points per ring where the heading is unknown.

    Where every heading is known (the detector measures them), the rings are never used and
    every landing point is the predicted one, so the densities are computed once instead of
    ``ring_samples`` times (:func:`_densities_known`); the result is the same to the bit as the
    general path's (:func:`_densities`), which ``tests/test_active.py`` checks.

    A hypothesis of weight 0 changes no robot's result (it adds exact zeros to every sum), so
    the hypotheses that weigh 0 for every robot are left out first: most robots soon hold one
    hypothesis, and the work grows with the square of their number.
    """
    hyp = _live(hyp)
    s = geo.scale
    rho = _per_robot(s, 2) * np.hypot(own[..., 0], own[..., 1])  # (R, C)
    known = hyp.known[:, :, None]  # (R, K, 1)
    var = (
        2.0 * _per_robot(geo.pixel_var, 3)
        + (_per_robot(geo.scale_spread, 3) * rho[:, None, :]) ** 2
        + np.where(known, hyp.theta_var[:, :, None], 0.0) * rho[:, None, :] ** 2
        + 1e-9
    )  # (R, K, C)
    cos, sin = np.cos(hyp.theta)[:, :, None], np.sin(hyp.theta)[:, :, None]
    s3 = _per_robot(s, 3)
    dx, dy = s3 * own[:, None, :, 0], s3 * own[:, None, :, 1]
    mu = hyp.pos[:, :, None, :] + np.stack([cos * dx - sin * dy, sin * dx + cos * dy], axis=-1)
    geometry = (rho, var, mu, s)
    if hyp.known.all():
        collide, mimic, peak = _densities_known(hyp, own, others, geometry, ring_samples)
    else:
        collide, mimic, peak = _densities(hyp, own, others, geometry, ring_samples)
    base = _per_robot(geo.clutter / geo.p_detect, 4)
    ratio = (base + collide + mimic[:, None]) / (base + peak[:, :, None])  # (R, K*, K', C)
    k = hyp.weight.shape[1]
    eye = np.eye(k, dtype=bool)[None, :, :, None]
    ratio = np.where(eye, 1.0, ratio)
    post = hyp.weight[:, None, :, None] * ratio
    post /= np.maximum(post.sum(axis=2, keepdims=True), 1e-300)
    entropy = -(post * np.log(np.maximum(post, 1e-300))).sum(axis=2)  # (R, K*, C)
    return (hyp.weight[:, :, None] * entropy).sum(axis=1)


Densities = tuple[np.ndarray, np.ndarray, np.ndarray]


def _live(hyp: Hypotheses) -> Hypotheses:
    """The hypotheses without those of weight 0 for every robot (all of them if none is left)."""
    live = hyp.weight.any(axis=0)
    if live.all() or not live.any():
        return hyp
    return Hypotheses(*(getattr(hyp, f)[:, live] for f in _HYPOTHESES))


def _per_robot(value: float | np.ndarray, ndim: int) -> float | np.ndarray:
    """A field of ``PredictionGeometry`` ready to broadcast against an array of ``ndim``
    axes whose first is the robot's: a number as it is, an ``(R,)`` array (robots of several
    envs scored together, ``entropies_together``) as ``(R, 1, ...)``."""
    if np.ndim(value) == 0:
        return value
    return np.reshape(value, (-1,) + (1,) * (ndim - 1))


def _densities(
    hyp: Hypotheses,
    own: np.ndarray,
    others: np.ndarray,
    geometry: tuple[np.ndarray, np.ndarray, np.ndarray, float | np.ndarray],
    ring_samples: int,
) -> Densities:
    """The general path: ``collide`` ``(R, K*, K', C)``, ``mimic`` ``(R, K', C)`` and ``peak``
    ``(R, K*, C)`` (see the module doc), any heading known or not."""
    rho, var, mu, s = geometry
    known = hyp.known[:, :, None]  # (R, K, 1)
    # Where I land if I am h*: the point, or ring_samples points on the ring.
    phi = 2.0 * math.pi * (np.arange(ring_samples) + 0.5) / ring_samples
    circle = np.stack([np.cos(phi), np.sin(phi)], axis=-1)  # (M, 2)
    ring_points = hyp.pos[:, :, None, None, :] + rho[:, None, :, None, None] * circle
    land = np.where(known[..., None, None], mu[:, :, :, None, :], ring_points)  # (R, K, C, M, 2)
    collide = _collide(hyp, land, mu, var, rho)
    # Density of "I am h'" where the robot truly at h' goes: (R, K', C).
    mimic = _mimic_known(own, others, var, s)
    # Heading unknown at h' (of weight > 0: one of weight 0 weighs nothing): the ring's density.
    at = np.nonzero(~hyp.known & (hyp.weight > 0.0))
    if len(at[0]):
        other_len = _per_robot(s, 2) * np.hypot(others[..., 0], others[..., 1])  # (R or 1, S)
        other_len = np.broadcast_to(other_len, (len(hyp.known), other_len.shape[-1]))
        shape = (len(at[0]), rho.shape[1], other_len.shape[1])  # (Q, C, S)
        ring = ring_loglik(
            np.broadcast_to(other_len[at[0]][:, None, :], shape),
            np.broadcast_to(rho[at[0]][:, :, None], shape),
            var[at][:, :, None],
        )
        mimic[at] = _exp(ring).mean(axis=-1)
    # My own detection's density under the truth: (R, K*, C).
    peak = np.where(
        known, 1.0 / (2.0 * math.pi * var), np.exp(ring_loglik(rho[:, None], rho[:, None], var))
    )
    return collide, mimic, peak


def _collide(
    hyp: Hypotheses, land: np.ndarray, mu: np.ndarray, var: np.ndarray, rho: np.ndarray
) -> np.ndarray:
    """``(R, K*, K', C)`` density of "I am h'" at the points ``land`` ``(R, K*, C, M, 2)`` where
    I land if I am h*, averaged over the M points: the Gaussian around ``mu`` where the heading
    at h' is known, the ring's density otherwise.

    A known h* lands M times on ``mu``: its densities are computed once (at ``mu``, for every
    h* alike, which is cheap) and averaged as M equal values; only the unknown h* of weight > 0
    are computed on their M ring points (those of weight 0 keep the values at ``mu``: they
    weigh nothing). The values that count are those of computing every point."""
    pos, known = hyp.pos, hyp.known
    at_mu = _density_at(  # axes (robot, h*, h', candidate)
        mu[:, :, None],
        mu[:, None],
        var[:, None],
        pos[:, None, :, None, :],
        rho[:, None, None, :],
        known[:, None, :, None],
    )
    collide = _mean_of_equal(at_mu, land.shape[3]).copy()
    # The robots and h* whose heading is unknown, of weight > 0 (a hypothesis of weight 0
    # weighs nothing in the expected entropy, whatever its densities).
    ring = np.nonzero(~known & (hyp.weight > 0.0))
    if len(ring[0]):
        r = ring[0]
        values = _density_at(  # axes (robot and h*, h', candidate, point)
            land[ring][:, None],
            mu[r][:, :, :, None, :],
            var[r][:, :, :, None],
            pos[r][:, :, None, None, :],
            rho[r][:, None, :, None],
            known[r][:, :, None, None],
        )
        collide[ring] = values.mean(axis=-1)
    return collide


def _density_at(
    x: np.ndarray,
    mu: np.ndarray,
    v2: np.ndarray,
    pos: np.ndarray,
    rho: np.ndarray,
    known: np.ndarray,
) -> np.ndarray:
    """Density of "I am h'" at the points ``x`` (``(..., 2)``): the Gaussian around ``mu`` of
    variance ``v2`` where the heading at h' is ``known``, otherwise the ring of radius ``rho``
    around the row ``pos`` (every argument broadcast against the others)."""
    gap = x - mu
    gauss = _exp(-0.5 * (gap[..., 0] ** 2 + gap[..., 1] ** 2) / v2) / (2.0 * math.pi * v2)
    off = x - pos
    r = np.hypot(off[..., 0], off[..., 1])
    ring = _exp(ring_loglik(r, np.broadcast_to(rho, r.shape), v2))
    return np.where(known, gauss, ring)


def _densities_known(
    hyp: Hypotheses,
    own: np.ndarray,
    others: np.ndarray,
    geometry: tuple[np.ndarray, np.ndarray, np.ndarray, float | np.ndarray],
    ring_samples: int,
) -> Densities:
    """:func:`_densities` where every heading is known: each landing point is ``mu``, so each
    density is computed once and averaged as the general path averages its ``ring_samples``
    equal values (the same sum, so the same bits)."""
    _, var, mu, s = geometry
    v2 = var[:, None]  # (R, 1, K', C)
    gx = mu[:, :, None, :, 0] - mu[:, None, :, :, 0]
    gy = mu[:, :, None, :, 1] - mu[:, None, :, :, 1]
    gauss = _exp(-0.5 * (gx**2 + gy**2) / v2) / (2.0 * math.pi * v2)  # (R, K*, K', C)
    collide = _mean_of_equal(gauss, ring_samples)
    mimic = _mimic_known(own, others, var, s)
    return collide, mimic, 1.0 / (2.0 * math.pi * var)


def _mimic_known(
    own: np.ndarray, others: np.ndarray, var: np.ndarray, s: float | np.ndarray
) -> np.ndarray:
    """``(R, K', C)`` density of "I am h'" where the robot at h' goes, its heading known."""
    # The distance between the displacements, as ``np.linalg.norm`` sums it (the same bits):
    # (R, C, S).
    dx = own[:, :, None, 0] - others[:, None, :, 0]
    dy = own[:, :, None, 1] - others[:, None, :, 1]
    apart = _per_robot(s, 3) * np.sqrt(dx * dx + dy * dy)
    vs = var[..., None]
    return (_exp(-0.5 * apart[:, None] ** 2 / vs) / (2.0 * math.pi * vs)).mean(axis=-1)


#: Where a density's exponent is below this, it is raised to it. numpy's vector ``exp`` takes a
#: slow path, about 25 times slower per value, for results that underflow (exponents below
#: about -708), and far-apart hypotheses give many. A density of ``exp(-700)`` (about 1e-304,
#: over a variance of at least a pixel^2) only ever meets the clutter base (at least 1e-8 per
#: pixel^2) in a sum, where it is lost below the base's last bit: the expected entropies keep
#: their bits (``tests/test_active.py`` checks them against the unclamped densities).
EXP_FLOOR = -700.0


def _exp(exponent: np.ndarray) -> np.ndarray:
    """``exp`` of the exponents, those below ``EXP_FLOOR`` raised to it (in place)."""
    return np.exp(np.maximum(exponent, EXP_FLOOR, out=exponent), out=exponent)


def _mean_of_equal(values: np.ndarray, count: int) -> np.ndarray:
    """The mean of ``count`` copies of each value, summed as numpy sums them (exact, and thus
    ``values`` itself, when ``count`` is a power of two)."""
    if count & (count - 1) == 0:
        return values
    return np.broadcast_to(values[..., None], (*values.shape, count)).mean(axis=-1)


class GreedyIdentification(Excitation):
    """Drive, at each picture, the candidate command that best separates the robot's hypotheses
    (see the module documentation for the model).

    At every picture the team tells it what the robots believe (a
    :class:`~baselines.steps.BeliefView`: the team localizer's ``belief`` and sensor ``model``,
    the picture's ``rows``, the robots' limits, picture interval and turn cost from its
    ``config``). Until the first picture has been taken in, and for a robot with no row above
    ``floor``, it drives a random candidate.

    Args:
        settings: candidates, the others' model, hypotheses and energy weight.
    """

    backoff: BumpReflex  # narrows Excitation.backoff: this excitation always has one

    def __init__(self, settings: GreedySettings | None = None) -> None:
        super().__init__()
        self.settings = settings or GreedySettings()
        self.backoff = self.settings.reflex()
        self.base = (np.zeros(0), np.zeros(0))
        self.budget = 1.0
        self.following = False
        self._others: tuple[GreedySettings, bool, np.ndarray] | None = None

    def reset(self, rngs: Sequence[np.random.Generator]) -> None:
        super().reset(rngs)
        self.v = np.zeros(self.n)
        self.w = np.zeros(self.n)
        self.base = (np.zeros(self.n), np.zeros(self.n))
        self.budget = 1.0
        self.following = False
        self.backoff.reset(rngs)
        self._previous: np.ndarray | None = None
        self._pending: tuple[Hypotheses, PredictionGeometry, float] | None = None
        self.last_entropy = np.zeros(self.n)
        """``(R,)`` expected entropy of the command chosen at the newest picture (nats)."""

    def follow(self, v: np.ndarray, w: np.ndarray, budget: float) -> None:
        self.base = (np.asarray(v, np.float64), np.asarray(w, np.float64))
        self.budget = budget
        self.following = True

    def on_picture(self, step: Step, view: BeliefView) -> None:
        belief = np.asarray(view.belief, dtype=np.float64)
        rows = step.rows
        model = view.model
        config = view.config
        if belief.shape[1] == 0 or len(rows) == 0:
            self._pending = None
            self._previous = rows
            return
        hyp = self._hypotheses(belief, rows, step, model.scale_bounds[1], model)
        geo = PredictionGeometry(
            scale=model.scale_bounds[1],
            pixel_var=max(model.pixel_noise, 1e-3) ** 2,
            scale_spread=model.scale_spread,
            clutter=max(len(rows) - model.p_detect, 0.5) / model.image_area,
            p_detect=model.p_detect,
            duration=config.schedule.picture_interval,
        )
        self._pending = (hyp, geo, turn_cost(config))
        self._previous = rows

    def _hypotheses(
        self, belief: np.ndarray, rows: np.ndarray, step: Step, scale: float, model: SensorModel
    ) -> Hypotheses:
        st = self.settings
        k = min(st.hypotheses, belief.shape[1])
        order = np.argsort(-belief, axis=1, kind="stable")[:, :k]
        weight = np.take_along_axis(belief, order, axis=1)
        weight = np.where(weight >= st.floor, weight, 0.0)
        weight /= np.maximum(weight.sum(axis=1, keepdims=True), 1e-300)
        pos = rows[order, :2]
        if model.orientation:
            theta = rows[order, 2]
            sd = float(model.orientation_noise)
            return Hypotheses(
                weight, pos, theta, np.full(theta.shape, sd**2 + 1e-6), np.ones_like(theta, bool)
            )
        return self._reconstructed(weight, pos, step, scale, float(model.pixel_noise))

    def _reconstructed(
        self, weight: np.ndarray, pos: np.ndarray, step: Step, scale: float, pixel_noise: float
    ) -> Hypotheses:
        """Headings from the previous picture: the row whose distance to ``pos`` best matches
        the robot's own last displacement gives its direction of travel."""
        shape = weight.shape
        theta = np.zeros(shape)
        known = np.zeros(shape, bool)
        sigma = max(pixel_noise, 1e-3)
        length = scale * np.hypot(step.between[:, 0], step.between[:, 1])  # (R,)
        var = np.full(shape, 4.0 * sigma**2 / np.maximum(length, 1e-9)[:, None] ** 2)
        prev = self._previous
        if prev is not None and len(prev):
            gap = pos[:, :, None, :] - prev[None, None, :, :2]  # (R, K, P, 2)
            dist = np.hypot(gap[..., 0], gap[..., 1])
            miss = np.abs(dist - length[:, None, None])
            best = miss.argmin(axis=2)
            fit = np.take_along_axis(miss, best[..., None], axis=2)[..., 0]
            vec = np.take_along_axis(gap, best[..., None, None], axis=2)[:, :, 0]
            known = (fit < 3.0 * math.sqrt(2.0) * sigma) & (length[:, None] > 5.0 * sigma)
            own = np.arctan2(step.between[:, 1], step.between[:, 0])
            theta = np.where(
                known,
                np.arctan2(vec[..., 1], vec[..., 0]) - own[:, None] + step.between[:, 2:3],
                0.0,
            )
        return Hypotheses(weight, pos, theta, var, known)

    def _candidates(self, deviation: bool) -> np.ndarray:
        """``(R, C, 2)`` candidate commands, each robot from its own generator."""
        st = self.settings
        return candidate_commands(self.rngs, st.candidates, st.speed, st.turn, deviation)

    def score(self) -> CandidateSet | None:
        """Draw every robot's candidate commands for the interval now starting (each robot from
        its own generator) and predict what each would tell (the module's model); ``None`` until
        the first picture with a row has been taken in (and after the candidates were scored for
        this picture)."""
        job = self.prepare()
        return None if job is None else job.finish(job.entropy())

    def prepare(self) -> ScoringJob | None:
        """``score`` up to the expected entropy, which the job computes (``entropy``) or
        which ``entropies_together`` computes for the jobs of several envs in one call. The
        candidates are drawn here, so the robots' generators advance as in ``score``."""
        deviation = self.following
        cand = self._candidates(deviation)
        if self._pending is None:
            self.v, self.w = cand[:, 0, 0].copy(), cand[:, 0, 1].copy()
            return None
        hyp, geo, cost = self._pending
        self._pending = None
        st = self.settings
        bv, bw = self.base[0][:, None], self.base[1][:, None]
        total_v = bv + self.budget * cand[..., 0]
        total_w = bw + self.budget * cand[..., 1]
        own = unicycle(total_v, total_w, geo.duration)
        other = self._other_commands(deviation)[None]
        others = unicycle(
            bv + self.budget * other[..., 0], bw + self.budget * other[..., 1], geo.duration
        )
        spent = wheel_travel(total_v, total_w, cost, geo.duration)
        return ScoringJob(cand, hyp, geo, own, others, spent, st.ring_samples)

    def _other_commands(self, deviation: bool) -> np.ndarray:
        """``self.settings.other_commands(deviation)``, built once per settings (read-only)."""
        cached = self._others
        if cached is None or cached[0] is not self.settings or cached[1] != deviation:
            commands = np.array(self.settings.other_commands(deviation))  # our own copy
            commands.flags.writeable = False
            cached = self._others = (self.settings, deviation, commands)
        return cached[2]

    def drive(self, cset: CandidateSet, pick: np.ndarray) -> None:
        """Hold candidate ``pick`` ``(R,)`` of each robot until the next picture."""
        rows = np.arange(self.n)
        self.v, self.w = cset.commands[rows, pick, 0], cset.commands[rows, pick, 1]
        self.last_entropy = cset.entropy[rows, pick]

    def choose(self) -> None:
        """Pick every robot's command for the interval now starting (the module's rule: the
        smallest expected entropy plus ``energy_weight`` times the wheel travel)."""
        cset = self.score()
        if cset is not None:
            self.drive(cset, (cset.entropy + self.settings.energy_weight * cset.spent).argmin(1))

    def commands(self, step: Step, dt: float) -> tuple[np.ndarray, np.ndarray]:
        return self.backoff.commands(step, dt, lambda hit: self._own(step))

    def _own(self, step: Step) -> tuple[np.ndarray, np.ndarray]:
        """The command chosen at the newest picture (chosen now at a new one)."""
        if step.new_picture:
            self.choose()
        return self.v, self.w
