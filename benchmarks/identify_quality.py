"""How right, and how well calibrated, the Bayesian identifier is on the hard cases.

Each named scenario records episodes once (the robots drive the ``random`` excitation, which does
not depend on what they believe), then replays the identifier on exactly the rows and own motion
the robots observed. Scored as the issue states: at picture k a robot is right when its belief
>= 0.99 is on its own true row; only robots that are in picture k are counted. Printed per
scenario: the share right at the named pictures with its 95 % Wilson interval, the share of
confident decisions (belief >= 0.99) that were wrong, and a reliability table (top belief
binned against how often the top row was the truth). ``motion3`` is scored on the same pictures
at its first decision where the scenario names it.

Scenarios:

* ``dense``: N = 100 at 1 robot per m^2, 1 px noise at 100 px/m, no detected headings.
* ``clutter``: N = 20 at 1 robot per m^2, 10 % misses, 2 false positives per picture, no headings.
* ``tilted``: ``paper-motion`` with the camera tilted 10 degrees; ``bayes`` with the scale
  unknown, and ``motion3``.
* ``headings``: N = 100, the default camera (detected headings), no clutter: for calibration.

With ``--linked``, each scenario also prints an upper bound on what the pictures allow: the
posterior of a robot that knows which rows belong to one robot (the true tracks, false positives
removed) and must only say which track is its own, under the identifier's own motion model (the
heading integrated on a grid, the legs' noise and pushes as the identifier models them, each leg
weighed against a robot driving anywhere within its top speed). No identifier that does not know
the linking can beat it on average. Printed for the scenarios with the scale known and no
detected headings (it uses positions alone).

Usage: ``python benchmarks/identify_quality.py [--scenarios dense,clutter] [--episodes K]
[--linked] [--json out.json]``; ``python benchmarks/plot_reliability.py out.json
docs/assets/x.png`` draws the reliability diagram from the JSON.
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

import anonloc_env
import baselines
from anonloc_env.config import EnvConfig
from anonloc_env.identify import Identifier, Interval, SensorModel
from anonloc_env.identify.model import push_isotropic
from baselines.localizers import Localizer, Motion3Localizer
from baselines.policies import Team
from baselines.runner import run_episode
from baselines.statistics import wilson

THRESHOLD = 0.99
BINS = np.array([0.0, 0.5, 0.8, 0.9, 0.95, 0.99, 0.999, 1.0 + 1e-12])


@dataclass(frozen=True)
class Scenario:
    """A hard case: env overrides, pictures to play, pictures to report, default episode count."""

    overrides: dict[str, Any]
    pictures: int
    report: tuple[int, ...]
    episodes: int
    scale_known: bool = True
    motion3: bool = False


def _side(n: int) -> tuple[float, float]:
    side = math.sqrt(n)
    return (side, side)


SCENARIOS: dict[str, Scenario] = {
    "dense": Scenario(
        {
            "n_robots": 100,
            "arena_size": _side(100),
            "camera": {"scale": 100.0, "pixel_noise": 1.0, "orientation": False},
        },
        pictures=10,
        report=(4, 6, 7, 8, 10),
        episodes=20,
    ),
    "clutter": Scenario(
        {
            "n_robots": 20,
            "arena_size": _side(20),
            "camera": {
                "scale": 100.0,
                "pixel_noise": 1.0,
                "orientation": False,
                "p_miss": 0.1,
                "false_positives": 2.0,
            },
        },
        pictures=15,
        report=(4, 6, 8, 10, 15),
        episodes=60,
    ),
    "tilted": Scenario(
        {"preset": "paper-motion", "camera": {"tilt_deg": 10.0}},
        pictures=6,
        report=(2, 3, 4, 5, 6),
        episodes=100,
        scale_known=False,
        motion3=True,
    ),
    "headings": Scenario(
        {
            "n_robots": 100,
            "arena_size": _side(100),
            "camera": {"scale": 100.0, "pixel_noise": 1.0, "orientation": True},
        },
        pictures=8,
        report=(2, 3, 4, 6, 8),
        episodes=10,
    ),
}


class _Recorder(Localizer):
    """Keeps what the robots observed at every picture (rows, own motion, duration)."""

    needs = 10**9

    def reset(self) -> None:
        super().reset()
        self.log: list[tuple[np.ndarray, Interval | None, float]] = []

    def on_picture(self, rows: np.ndarray, interval: Interval | None, duration: float) -> None:
        self.log.append((np.array(rows, dtype=np.float64), interval, duration))


@dataclass
class Episode:
    """What the robots saw in one episode, and the truth to score it."""

    config: EnvConfig
    observed: list[tuple[np.ndarray, Interval | None, float]]
    true_rows: list[np.ndarray]


def make_env(scenario: Scenario) -> Any:
    """The scenario's env (cheap reward: the identifier is replayed, not run by the env)."""
    overrides = dict(scenario.overrides)
    preset = overrides.pop("preset", None)
    return anonloc_env.parallel_env(
        preset, max_cycles=10**6, reward_fn=anonloc_env.EnergyCost(), **overrides
    )


def record(scenario: Scenario, seed: int, env: Any = None) -> Episode:
    """Play one episode of ``scenario`` under the random excitation and keep what was seen."""
    env = make_env(scenario) if env is None else env
    config = env.config
    excitation = baselines.make_team("motion", config, excitation="random").excitation
    recorder = _Recorder(config, config.n_robots)
    team = Team(config, recorder, excitation)
    result = run_episode(env, team, seed, max_pictures=scenario.pictures)
    return Episode(config, list(recorder.log), result.true_rows)


@dataclass
class Scores:
    """Counts over robot-pictures."""

    pictures: int
    right: np.ndarray = field(init=False)
    present: np.ndarray = field(init=False)
    decided: int = 0
    wrong: int = 0
    top: list[float] = field(default_factory=list)
    top_right: list[bool] = field(default_factory=list)
    first_right: int = 0
    first_total: int = 0

    def __post_init__(self) -> None:
        self.right = np.zeros(self.pictures, dtype=np.int64)
        self.present = np.zeros(self.pictures, dtype=np.int64)


def score_identifier(
    episode: Episode, scores: Scores, scale_known: bool, model: SensorModel | None = None
) -> float:
    """Replay the identifier on ``episode`` and add to ``scores``; return its seconds."""
    config = episode.config
    model = SensorModel.from_config(config, scale_known=scale_known) if model is None else model
    ident = Identifier(model, config.n_robots)
    spent = 0.0
    robots = np.arange(config.n_robots)
    for k, ((rows, interval, _), true) in enumerate(
        zip(episode.observed, episode.true_rows, strict=True)
    ):
        start = time.perf_counter()
        ident.update(rows, interval)
        belief = ident.belief()
        spent += time.perf_counter() - start
        present = true >= 0
        scores.present[k] += int(present.sum())
        if belief.shape[1] == 0:
            continue
        best = belief.argmax(axis=1)
        top = belief[robots, best]
        sure = top >= THRESHOLD
        right = sure & (best == true)
        scores.right[k] += int(right.sum())
        scores.decided += int(sure.sum())
        scores.wrong += int((sure & (best != true)).sum())
        scores.top.extend(top.tolist())
        scores.top_right.extend((best == true).tolist())
    return spent


def score_motion3(episode: Episode, scores: Scores) -> None:
    """Replay the corrected ``motion3`` localizer; count its first decisions."""
    config = episode.config
    loc = Motion3Localizer(config, config.n_robots)
    first = np.full(config.n_robots, -2)
    for (rows, interval, duration), true in zip(episode.observed, episode.true_rows, strict=True):
        loc.on_picture(rows, interval, duration)
        new = (first == -2) & (loc.estimate >= 0)
        first[new] = (loc.estimate == true)[new].astype(int)
    scores.first_right += int((first == 1).sum())
    scores.first_total += int((first >= 0).sum())


def score_linked(episode: Episode, scores: Scores, grid: int = 720) -> None:
    """The linked upper bound (see the module docstring): right at picture k when the robot's
    posterior over the true tracks puts >= 0.99 on its own. Scale known only."""
    config = episode.config
    model = SensorModel.from_config(config)
    assert model.scale is not None
    s, n = model.scale, config.n_robots
    base = 2.0 * model.pixel_noise**2 + 1e-8
    theta0 = -math.pi + (np.arange(grid) + 0.5) * (2.0 * math.pi / grid)
    pos = np.full((len(episode.observed), n, 2), np.nan)
    for k, ((rows, _, _), true) in enumerate(zip(episode.observed, episode.true_rows, strict=True)):
        pos[k, true >= 0] = rows[true[true >= 0], :2]
    reach = s * config.robot.v_max * config.schedule.picture_interval
    for i in range(n):
        loglik = np.zeros((n, grid))
        last = pos[0].copy()
        carry = np.zeros((n, grid, 2))
        carry_var = np.zeros(n)
        span = np.zeros(n)
        turn = 0.0
        for k, ((_, interval, _), true) in enumerate(
            zip(episode.observed, episode.true_rows, strict=True)
        ):
            if k > 0:
                assert interval is not None
                d, heading = interval.d[i], theta0 + turn
                step = np.stack(
                    [
                        np.cos(heading) * d[0] - np.sin(heading) * d[1],
                        np.sin(heading) * d[0] + np.cos(heading) * d[1],
                    ],
                    axis=-1,
                )
                carry += s * step[None]
                var_d, _ = interval.variances(model.odometry_noise)
                carry_var += s * s * (push_isotropic(interval, model)[i] + var_d[i])
                turn += float(interval.dphi[i])
                span += 1
                seen = ~np.isnan(pos[k, :, 0]) & ~np.isnan(last[:, 0])
                e = pos[k, seen][:, None, :] - last[seen][:, None, :] - carry[seen]
                var = (base + carry_var[seen])[:, None]
                leg = -math.log(2 * math.pi) - np.log(var) - (e**2).sum(-1) / (2 * var)
                loglik[seen] += leg + np.log(math.pi * (reach * span[seen]) ** 2)[:, None]
                now = ~np.isnan(pos[k, :, 0])
                last[now], carry[now], carry_var[now], span[now] = pos[k, now], 0.0, 0.0, 0.0
            if true[i] < 0:
                continue
            logw = np.logaddexp.reduce(loglik, axis=1)
            w = np.exp(logw - logw.max())
            w /= w.sum()
            best = int(np.argmax(w))
            scores.present[k] += 1
            if w[best] >= THRESHOLD:
                scores.decided += 1
                scores.right[k] += int(best == i)
                scores.wrong += int(best != i)


def _rate(successes: int, trials: int) -> str:
    if trials == 0:
        return "n/a"
    low, high = wilson(successes, trials)
    return f"{100 * successes / trials:.1f} % [{100 * low:.1f}, {100 * high:.1f}]"


def reliability(scores: Scores) -> list[tuple[float, float, int, float, float]]:
    """Per belief bin: (low edge, high edge, count, observed accuracy of the top row, mean top
    belief)."""
    top = np.asarray(scores.top)
    ok = np.asarray(scores.top_right, dtype=bool)
    out = []
    for low, high in itertools.pairwise(BINS):
        inside = (top >= low) & (top < high)
        count = int(inside.sum())
        accuracy = float(ok[inside].mean()) if count else math.nan
        mean = float(top[inside].mean()) if count else math.nan
        out.append((float(low), float(high), count, accuracy, mean))
    return out


def run_scenario(name: str, episodes: int | None = None, linked: bool = False) -> dict[str, Any]:
    """Record and score ``episodes`` episodes of scenario ``name`` (and the linked bound)."""
    scenario = SCENARIOS[name]
    count = scenario.episodes if episodes is None else episodes
    env = make_env(scenario)
    scores = Scores(scenario.pictures)
    m3 = Scores(scenario.pictures)
    bound = Scores(scenario.pictures)
    # The bound uses positions alone: it is one only where headings are not detected.
    linked = linked and scenario.scale_known and not SensorModel.from_config(env.config).orientation
    ident_s = 0.0
    start = time.perf_counter()
    for seed in range(count):
        episode = record(scenario, seed, env)
        ident_s += score_identifier(episode, scores, scenario.scale_known)
        if scenario.motion3:
            score_motion3(episode, m3)
        if linked:
            score_linked(episode, bound)
    return {
        "scenario": name,
        "episodes": count,
        "right": {
            k: [int(scores.right[k - 1]), int(scores.present[k - 1])] for k in scenario.report
        },
        "wrong": [scores.wrong, scores.decided],
        "motion3_first": [m3.first_right, m3.first_total] if scenario.motion3 else None,
        "linked": {k: [int(bound.right[k - 1]), int(bound.present[k - 1])] for k in scenario.report}
        if linked
        else None,
        "linked_wrong": [bound.wrong, bound.decided] if linked else None,
        "reliability": reliability(scores),
        "identifier_s": ident_s,
        "wall_s": time.perf_counter() - start,
    }


def print_result(result: dict[str, Any]) -> None:
    """Print one scenario's table."""
    print(f"\n### {result['scenario']} ({result['episodes']} episodes)\n")
    linked = result.get("linked")
    print("| picture | right at >= 0.99 (95 % Wilson) | robots in picture | linked bound |")
    print("|---:|---:|---:|---:|")
    for k, (right, present) in result["right"].items():
        bound = _rate(*linked[k]) if linked else "-"
        print(f"| {k} | {_rate(right, present)} | {present} | {bound} |")
    wrong, decided = result["wrong"]
    print(f"\nwrong among decisions at >= 0.99: {wrong} / {decided} ({_rate(wrong, decided)})")
    if linked:
        wrong, decided = result["linked_wrong"]
        print(f"linked bound: wrong among its decisions at >= 0.99: {wrong} / {decided}")
    if result["motion3_first"] is not None:
        right, total = result["motion3_first"]
        print(f"motion3 right at its first decision: {_rate(right, total)} of {total}")
    print("\n| top belief | robot-pictures | mean top belief | top row right |")
    print("|---|---:|---:|---:|")
    for low, high, count, acc, mean in result["reliability"]:
        print(
            f"| [{low:.3f}, {min(high, 1.0):.3f}) | {count} | {100 * mean:.2f} % | "
            f"{100 * acc:.2f} % |"
        )
    print(
        f"\nidentifier time {result['identifier_s']:.1f} s, wall {result['wall_s']:.1f} s "
        "(shared machine)"
    )


def main(argv: list[str] | None = None) -> None:
    """Print the tables."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scenarios", default=",".join(SCENARIOS))
    parser.add_argument("--episodes", type=int, default=None, help="default: the scenario's own")
    parser.add_argument("--linked", action="store_true", help="also the linked upper bound")
    parser.add_argument("--json", default=None, help="also write the results to this file")
    args = parser.parse_args(argv)
    results = []
    for name in args.scenarios.split(","):
        if name not in SCENARIOS:
            parser.error(f"unknown scenario {name!r}; valid: {list(SCENARIOS)}")
        result = run_scenario(name, args.episodes, args.linked)
        print_result(result)
        results.append(result)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=1)


if __name__ == "__main__":
    main()
