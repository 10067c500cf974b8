"""The paper's three experiments (its section III and table), run on our simulator.

One run is one episode of a ``paper-*`` preset with the method's own excitation, two robots
localizing at once. Three localizers listen to the very same episode: the faithful version, the
corrected version, and the Bayesian identifier. Each run also measures the paper's second-row
quantity for every robot, from the true rows (ground truth) and the robot's own motion.

Success is counted per robot at its first decision (the paper's measure); the Bayesian identifier
is also scored at the 4th picture.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

import anonloc_env
from anonloc_env.geometry import wrap_angle
from baselines.localizers import BayesLocalizer, Localizer
from baselines.paper_noise import SCALE_USED, xy_disagreement
from baselines.registry import POLICIES, make_team
from baselines.runner import EpisodeResult, run_episode
from baselines.statistics import wilson


@dataclass(frozen=True)
class PaperExperiment:
    """One column of the paper's table.

    Attributes:
        preset: the env preset recreating its conditions.
        runs: the paper's number of runs.
        success: the paper's success rate (%).
        deviation: the paper's second row (mean, standard deviation).
        deviation_label: what that row measures.
    """

    preset: str
    runs: int
    success: float
    deviation: tuple[float, float]
    deviation_label: str


EXPERIMENTS: dict[str, PaperExperiment] = {
    "angular": PaperExperiment("paper-angular", 65, 96.9, (1.6, 1.1), "rotation error (deg)"),
    "linear": PaperExperiment("paper-linear", 100, 84.0, (0.823, 2.93), "ratio deviation"),
    "motion": PaperExperiment(
        "paper-motion", 118, 82.2, (7.22, 7.3), "x/y heading disagreement (deg)"
    ),
}
"""The paper's table, by method."""

#: The Bayesian identifier is scored at this picture index (the 4th picture).
BAYES_PICTURE = 3


@dataclass(frozen=True)
class RunOutcome:
    """What one run of one experiment gave, per robot.

    Attributes:
        method: ``angular``, ``linear`` or ``motion``.
        seed: the episode's seed.
        faithful: first decision of the faithful version right (per robot).
        corrected: first decision of the corrected version right.
        faithful_picture, corrected_picture: picture of that decision (-1: never decided).
        bayes_first: first decision of the Bayesian identifier right.
        bayes_picture: picture of that decision (-1: never).
        bayes_at_4th: the Bayesian identifier's estimate at the 4th picture right.
        deviation: the paper's second-row quantity for each robot (nan if not measurable).
    """

    method: str
    seed: int
    faithful: tuple[bool, ...]
    corrected: tuple[bool, ...]
    faithful_picture: tuple[int, ...]
    corrected_picture: tuple[int, ...]
    bayes_first: tuple[bool, ...]
    bayes_picture: tuple[int, ...]
    bayes_at_4th: tuple[bool, ...]
    deviation: tuple[float, ...]


def play(
    method: str,
    seed: int,
    overrides: dict[str, Any] | None = None,
    listeners: Mapping[str, Localizer] | None = None,
) -> EpisodeResult:
    """One run of experiment ``method`` with episode seed ``seed``, as played: the corrected
    version drives (with the method's own excitation), the faithful version (``"faithful"``) and
    the Bayesian identifier (``"bayes"``) listen, and so do ``listeners`` (more localizers, by
    name, for the experiment's config and robots: e.g. ``{"mlp": MLPLocalizer(config, 2)}``).
    ``overrides`` (keyword overrides of ``anonloc_env.make_config``, e.g.
    ``{"camera": {"source": "image"}}``) change the preset.

    Raises:
        ValueError: an unknown experiment.
    """
    if method not in EXPERIMENTS:
        raise ValueError(f"unknown experiment {method!r}; valid: {list(EXPERIMENTS)}")
    # The env's reward is not used here: the cheap one spares it the referee identifier.
    env = anonloc_env.parallel_env(
        EXPERIMENTS[method].preset, reward_fn=anonloc_env.EnergyCost(), **(overrides or {})
    )
    config = env.config
    n = config.n_robots
    localizer_class, _ = POLICIES[method]
    team = make_team(method, config, n, mode="corrected")
    team.listeners = {
        "faithful": localizer_class(config, n, "faithful"),
        "bayes": BayesLocalizer(config, n),
        **(listeners or {}),
    }
    team.reset([None] * n)
    return run_episode(env, team, seed, max_pictures=BAYES_PICTURE + 1)


def run(method: str, seed: int, overrides: dict[str, Any] | None = None) -> RunOutcome:
    """One run of experiment ``method`` with episode seed ``seed`` (:func:`play`), scored."""
    result = play(method, seed, overrides)
    n = result.n_robots
    first = {name: result.decisions(name) for name in ("", "faithful", "bayes")}
    at_4th = [
        r.correct for r in result.records if r.localizer == "bayes" and r.picture == BAYES_PICTURE
    ]
    return RunOutcome(
        method=method,
        seed=seed,
        faithful=tuple(d.correct for d in first["faithful"]),
        corrected=tuple(d.correct for d in first[""]),
        faithful_picture=tuple(d.picture for d in first["faithful"]),
        corrected_picture=tuple(d.picture for d in first[""]),
        bayes_first=tuple(d.correct for d in first["bayes"]),
        bayes_picture=tuple(d.picture for d in first["bayes"]),
        bayes_at_4th=tuple(at_4th) if at_4th else (False,) * n,
        deviation=tuple(deviations(method, result)),
    )


def deviations(method: str, result: EpisodeResult) -> np.ndarray:
    """The paper's second-row quantity per robot, over the first decision's pictures.

    * angular: ``|wrap(theta_q - theta_p) - dphi|`` (deg), the measured rotation of the true rows
      against the robot's own (exact) rotation;
    * linear: ``||q - p| / |r - q| - |d0| / |d1||``, the true rows' distance ratio against the
      robot's own;
    * motion: the x/y heading disagreement of the true pair (deg), nan without a solution.
    """
    pictures, truth, intervals = result.pictures, result.true_rows, result.intervals
    n = result.n_robots
    out = np.full(n, np.nan)
    need = 3 if method == "linear" else 2
    if len(pictures) < need or len(intervals) < need - 1:
        return out
    rows = [pictures[k][np.maximum(truth[k], 0)] for k in range(need)]
    seen = np.all([truth[k] >= 0 for k in range(need)], axis=0)
    if method == "angular":
        measured = wrap_angle(rows[1][:, 2] - rows[0][:, 2])
        out = np.degrees(np.abs(wrap_angle(measured - intervals[0].dphi)))
    elif method == "linear":
        first = np.hypot(*(rows[1][:, :2] - rows[0][:, :2]).T)
        second = np.hypot(*(rows[2][:, :2] - rows[1][:, :2]).T)
        own = np.hypot(*intervals[0].d.T) / np.hypot(*intervals[1].d.T)
        with np.errstate(divide="ignore", invalid="ignore"):
            out = np.abs(first / second - own)
    else:
        delta = rows[1][:, :2] - rows[0][:, :2]
        out = np.degrees(xy_disagreement(delta, intervals[0].d, SCALE_USED))
    return np.where(seen, out, np.nan)


@dataclass(frozen=True)
class Rate:
    """A success rate with its 95 % Wilson interval (fractions) and counts."""

    successes: int
    trials: int

    @property
    def value(self) -> float:
        """The rate, a fraction."""
        return self.successes / self.trials if self.trials else float("nan")

    @property
    def interval(self) -> tuple[float, float]:
        """95 % Wilson interval (:func:`baselines.statistics.wilson`)."""
        return wilson(self.successes, self.trials)

    def __str__(self) -> str:
        low, high = self.interval
        return f"{100 * self.value:.1f} % [{100 * low:.1f}, {100 * high:.1f}]"


def summarise(outcomes: list[RunOutcome]) -> dict[str, object]:
    """Success rates (per robot) and the second row, over runs of one experiment."""

    def rate(field: str) -> Rate:
        flat = [x for o in outcomes for x in getattr(o, field)]
        return Rate(sum(flat), len(flat))

    dev = np.array([x for o in outcomes for x in o.deviation], dtype=float)
    return {
        "runs": len(outcomes),
        "faithful": rate("faithful"),
        "corrected": rate("corrected"),
        "bayes_first": rate("bayes_first"),
        "bayes_at_4th": rate("bayes_at_4th"),
        "deviation_mean": float(np.nanmean(dev)) if np.isfinite(dev).any() else float("nan"),
        "deviation_std": float(np.nanstd(dev)) if np.isfinite(dev).any() else float("nan"),
    }
