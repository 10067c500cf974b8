"""Why decided robots in a crowd stopped being decided (issue 23, fourth round): what a contact
really moves a pressed robot, and which of the contact model's parts takes its decision away.

Plays episodes of ``bayes`` with each excitation (as :mod:`benchmarks.crowds` does), then:

* **slides**: for every pressed interval (the robot pushed in it and in the one before), the
  unseen sideways motion from the true poses (true displacement in the robot's frame at the
  first picture minus its odometry), along the contact's summed lateral direction, over the
  contact bound ``Interval.push``: its quantiles;
* **variants**: replays each episode's pictures and motion through the identifier with the
  wide pushes alone (``crowd_push_tail=1``, the model before this round), with the model as it
  is (pressed pushes mixed, :func:`anonloc_env.identify.contact.mix_pushes`), without track
  breaks (``contact_break=0``), and with jammed robots mixed too (``crowd_jam`` unbounded), and
  counts, per variant: the confident decisions and the wrong
  ones, the robots right and decided at one picture and not at the next (*lost*), how many of
  them were pressed, how many kept the right row on top (undecided, not wrong), and how many
  had a neighbour's row (a robot within 1.5 sizes) second; the share right and decided at
  pictures 10, 20 and the last (the replays' motion is the played one).

Usage::

    python -m benchmarks.crowd_pressed --density 4 --robots 100 --excitations greedy \\
        --seeds 20000 20002
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

import anonloc_env
from anonloc_env.identify import Identifier, SensorModel
from anonloc_env.identify.contact import mix_pushes
from benchmarks.crowds import PICTURES, THRESHOLD, Played, play, was_pushed
from benchmarks.excitations import scenario


def slides(episodes: Sequence[Played]) -> dict[str, Any]:
    """Quantiles (0.5, 0.9, 0.99, 1) of a pressed robot's unseen sideways motion over its
    contact bound, and the count of pressed intervals."""
    ratios = []
    for p in episodes:
        intervals = p.result.intervals
        for k in range(2, len(p.poses)):
            now, before = intervals[k - 1], intervals[k - 2]
            if now.push is None or now.push_sum is None or before.push is None:
                continue
            for i in np.flatnonzero((now.push > 0) & (before.push > 0)):
                x0, y0, phi = p.poses[k - 1][i]
                c, s = np.cos(phi), np.sin(phi)
                dx, dy = p.poses[k][i, :2] - (x0, y0)
                moved = np.array([c * dx + s * dy, -s * dx + c * dy])  # robot frame
                side = now.push_sum[i] / max(float(np.hypot(*now.push_sum[i])), 1e-12)
                ratios.append(abs(float((moved - now.d[i]) @ side)) / float(now.push[i]))
    quantiles = np.quantile(ratios, [0.5, 0.9, 0.99, 1.0]) if ratios else np.zeros(4)
    return {"pressed intervals": len(ratios), "quantiles": np.round(quantiles, 3).tolist()}


#: Classes of pushed intervals by how many intervals in a row the robot was pushed (``--fit``).
PUSH_CLASSES = ("bump", "pressed", "jammed")


def pushed_residuals(
    episodes: Sequence[Played], jam: int
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per class of :data:`PUSH_CLASSES` (pushed once: ``bump``; 2 to ``jam`` intervals in a
    row: ``pressed``; more: ``jammed``), ``(e, C)``: ``e`` ``(k, 2)`` the unseen motion of every
    pushed interval from the true poses (true displacement in the robot's frame at the first
    picture less its odometry, m) and ``C`` ``(k, 2, 2)`` the interval's push covariance
    (``Interval.push_covariance``, a push spread evenly up to its bound, m^2)."""
    found: dict[str, tuple[list[np.ndarray], list[np.ndarray]]] = {
        c: ([], []) for c in PUSH_CLASSES
    }
    for p in episodes:
        run = np.zeros(p.result.n_robots, np.int64)
        for k in range(1, len(p.poses)):
            interval = p.result.intervals[k - 1]
            pushed = np.zeros(len(run), bool) if interval.push is None else interval.push > 0
            run = np.where(pushed, run + 1, 0)
            if not pushed.any():
                continue
            phi = p.poses[k - 1][:, 2]
            dx, dy = (p.poses[k][:, :2] - p.poses[k - 1][:, :2]).T
            c, s = np.cos(phi), np.sin(phi)
            e = np.column_stack([c * dx + s * dy, -s * dx + c * dy]) - interval.d
            cov = interval.push_covariance()
            for name, which in zip(
                PUSH_CLASSES, (run == 1, (run >= 2) & (run <= jam), run > jam), strict=True
            ):
                found[name][0].append(e[which])
                found[name][1].append(cov[which])
    return {
        name: (np.concatenate([np.zeros((0, 2)), *e]), np.concatenate([np.zeros((0, 2, 2)), *c]))
        for name, (e, c) in found.items()
    }


def gaussian_loglik(e: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """``(k,)`` log densities of ``e`` ``(k, 2)`` under zero-mean Gaussians ``cov``
    ``(k, 2, 2)``."""
    det = cov[:, 0, 0] * cov[:, 1, 1] - cov[:, 0, 1] ** 2
    ex, ey = e[:, 0], e[:, 1]
    maha = (ex**2 * cov[:, 1, 1] - 2 * ex * ey * cov[:, 0, 1] + ey**2 * cov[:, 0, 0]) / det
    return -math.log(2 * math.pi) - 0.5 * np.log(det) - 0.5 * maha


def push_fit(
    residuals: dict[str, tuple[np.ndarray, np.ndarray]], model: SensorModel, noise_var: float
) -> dict[str, Any]:
    """Per class: the share of the push covariance that fits the unseen motion best (maximum
    likelihood over a grid from 0.001 to 2, a zero-mean Gaussian ``share C + noise_var I``,
    ``noise_var`` the two pictures' pixel variance in m^2), and the mean log-likelihood (nats
    per interval) there and under the model's pushes for that class (``push_share`` for a
    bump; the mixture of ``push_share`` and ``crowd_push_share`` for a pressed robot; the
    latter alone for a jammed one)."""
    assert model.crowd_push_share is not None
    narrow, wide, tail = model.push_share, model.crowd_push_share, model.crowd_push_tail
    eye = noise_var * np.eye(2)
    out: dict[str, Any] = {}
    for name, (e, cov) in residuals.items():
        if not len(e):
            continue
        grid = np.geomspace(1e-3, 2.0, 200)
        means = [float(gaussian_loglik(e, g * cov + eye).mean()) for g in grid]
        best = int(np.argmax(means))
        if name == "bump":
            now = gaussian_loglik(e, narrow * cov + eye)
        elif name == "jammed":
            now = gaussian_loglik(e, wide * cov + eye)
        else:
            now = mix_pushes(
                gaussian_loglik(e, wide * cov + eye), gaussian_loglik(e, narrow * cov + eye), tail
            )
        out[name] = {
            "intervals": len(e),
            "fitted share": round(float(grid[best]), 4),
            "loglik fitted": round(means[best], 3),
            "loglik model": round(float(now.mean()), 3),
        }
    return out


def variant(model: SensorModel, episodes: Sequence[Played], size: float) -> dict[str, Any]:
    """Decisions, wrong ones and lost ones of ``model`` replayed on ``episodes`` (see the
    module)."""
    out = dict.fromkeys(("decided", "wrong", "lost", "pressed", "right on top", "neighbour"), 0)
    share = []
    for p in episodes:
        result = p.result
        identifier = Identifier(model, result.n_robots)
        good_before = np.zeros(result.n_robots, bool)
        row_share = []
        for k, rows in enumerate(result.pictures):
            identifier.update(rows, result.intervals[k - 1] if k else None)
            belief, true = identifier.belief(), result.true_rows[k]
            top, row = belief.max(axis=1), belief.argmax(axis=1)
            sure = top >= THRESHOLD
            good = sure & (row == true)
            out["decided"] += int(sure.sum())
            out["wrong"] += int((sure & (row != true)).sum())
            for i in np.flatnonzero(good_before & ~good):
                out["lost"] += 1
                out["pressed"] += int(
                    k >= 2
                    and was_pushed(result.intervals[k - 2], i)
                    and was_pushed(result.intervals[k - 1], i)
                )
                out["right on top"] += int(row[i] == true[i])
                second = int(np.argsort(-belief[i])[1])
                who = np.flatnonzero(true == second)
                near = len(who) and np.hypot(*(p.poses[k][i, :2] - p.poses[k][who[0], :2]))
                out["neighbour"] += int(bool(len(who)) and near < 1.5 * size)
            good_before = good
            row_share.append(float(good.mean()))
        share.append(row_share)
    mean = np.mean(share, axis=0)
    return {**out, "share at 10, 20, last": np.round(mean[[10, 20, -1]], 3).tolist()}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--density", type=float, nargs="+", default=[4.0])
    parser.add_argument("--robots", type=int, default=100)
    parser.add_argument("--excitations", nargs="+", default=["greedy"])
    parser.add_argument("--seeds", type=int, nargs=2, default=[20000, 20002])
    parser.add_argument(
        "--fit", action="store_true", help="fit the pushes' share per class instead (see push_fit)"
    )
    args = parser.parse_args(argv)
    played: list[Played] = []
    for density in args.density:
        config = scenario(args.robots, PICTURES, density)
        env = anonloc_env.AnonLocEnv(config, reward_fn=anonloc_env.EnergyCost())
        model = SensorModel.from_config(config)
        for name in args.excitations:
            episodes = [play(env, name, seed) for seed in range(*args.seeds)]
            if args.fit:
                played += episodes
            else:
                compare(model, name, episodes, config.robot.size)
    if args.fit:
        noise_var = 2.0 * (model.pixel_noise / (model.scale or 1.0)) ** 2
        fitted = push_fit(pushed_residuals(played, model.crowd_jam), model, noise_var)
        print(json.dumps(fitted, indent=1))


def compare(model: SensorModel, name: str, episodes: Sequence[Played], size: float) -> None:
    """Print the slides of ``episodes`` (excitation ``name``) and each variant's losses."""
    variants = {
        "wide pushes alone (before)": dataclasses.replace(model, crowd_push_tail=1.0),
        "mixed (now)": model,
        "mixed, no breaks": dataclasses.replace(model, contact_break=0.0),
        "mixed, jammed robots too": dataclasses.replace(model, crowd_jam=10**9),
    }
    print(name, "slides", json.dumps(slides(episodes)), flush=True)
    for label, m in variants.items():
        found = variant(m, episodes, size)
        print(f"  {label}: {json.dumps(found)}", flush=True)


if __name__ == "__main__":
    main()
