"""Identification under a camera on a drone (docs/drone.md, issue 27's results).

Free motion, one robot per square metre, 1 px of noise, no headings, a picture a second, 30
pictures an episode; the ``bayes`` team with ``distinct`` motion and the bundled agent; the static
camera and the ``drone-hover`` / ``drone-windy`` presets, each with and without ground landmarks
(eight, :func:`anonloc_env.landmarks.border_landmarks`). For each condition: pictures to 99 % as a
censored mean with a 95 % bootstrap interval, confident decisions wrong, and the error of each
picture's estimated camera transform (image units, root mean square over the robots in view):
with landmarks the fitted homography against the true one; without, the registration's change
between consecutive pictures against the camera's true change (the frame's absolute offset is
never observable from the robots alone, and does not matter to identification).

    python benchmarks/drone.py --n 10 --episodes 10 --out results/drone-10.json

Episodes use seeds 1000, 1001, ... (``--seed0``; the same in every condition).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

import anonloc_env
import baselines
from anonloc_env.identify import first_step
from anonloc_env.identify.camera_pose import apply
from anonloc_env.landmarks import border_landmarks
from anonloc_env.rewards import EnergyCost
from baselines.scoring import bootstrap_mean, first_identified

PICTURES = 30
SEED0 = 1000


def condition_config(
    preset: str,
    n: int,
    landmarks: bool,
    source: str = "geometric",
    pixel_noise: float = 1.0,
    view_margin: float = 0.0,
    pooled: bool = False,
) -> Any:
    """The results' condition: ``preset``'s camera, N robots at 1 per m^2, ``pixel_noise``
    (1 px in the results; more to see what a noisier fixed camera costs), no headings.
    ``view_margin`` (m, each side; 0 in the results): a field of view wider than the arena by
    that much, so that the drift carries no robot out of the picture. ``pooled``: the robots
    share their motions (``camera.pooled_motion``; a communication)."""
    side = math.sqrt(n)
    camera: dict[str, Any] = {"pixel_noise": pixel_noise, "orientation": False, "source": source}
    camera["pooled_motion"] = pooled
    if landmarks:
        camera["landmarks"] = border_landmarks((side, side))
    config = anonloc_env.make_config(
        preset, n_robots=n, arena_size=(side, side), camera=camera, max_cycles=40 * PICTURES
    )
    if view_margin > 0.0:
        width = config.camera.scale * (side + 2.0 * view_margin)
        camera_config = dataclasses.replace(config.camera, image_size=(width, width))
        config = dataclasses.replace(config, camera=camera_config)
    return config


def _through(h: np.ndarray, uv: np.ndarray) -> np.ndarray:
    q = np.column_stack([uv, np.ones(len(uv))]) @ h.T
    return q[:, :2] / q[:, 2:3]


@dataclass
class Tally:
    """One condition's episodes."""

    pictures: list[float] = field(default_factory=list)
    reached: int = 0
    decided: int = 0
    wrong: int = 0
    pose_errors: list[float] = field(default_factory=list)
    # Without landmarks: each picture's true pose error over the error the registration stated.
    error_ratios: list[float] = field(default_factory=list)
    seconds: float = 0.0


def _pose_error(env: Any, team: Any, state: dict[str, Any]) -> float | None:
    """This picture's transform error (image units, RMS over the robots in view)."""
    picture = env.picture
    seen = picture.true_index >= 0
    if not seen.any():
        return None
    truth = env.camera.homography
    raw = _through(truth, env.world.poses[seen, :2])  # noise-free rows as taken
    if picture.homography is not None:
        err = _through(picture.homography, env.world.poses[seen, :2]) - raw
        return float(np.sqrt(np.mean(err**2)))
    registration = getattr(getattr(team.localizer, "identifier", None), "registration", None)
    if registration is None:
        return None
    to_set_point = env.camera.set_point @ np.linalg.inv(truth)
    offset = apply(registration.transform, registration.prior.centre, raw) - _through(
        to_set_point, raw
    )
    ids = np.flatnonzero(seen)
    previous = state.get("offset", {})
    now = dict(zip(ids.tolist(), offset, strict=True))
    state["offset"] = now
    both = sorted(set(previous) & set(now))
    if not both:
        return None
    change = np.array([now[i] - previous[i] for i in both])
    return float(np.sqrt(np.mean(change**2)))


def run_condition(
    preset: str,
    n: int,
    landmarks: bool,
    policy: str,
    episodes: int,
    source: str = "geometric",
    pixel_noise: float = 1.0,
    view_margin: float = 0.0,
    pooled: bool = False,
) -> Tally:
    """Play ``episodes`` episodes of one condition."""
    config = condition_config(preset, n, landmarks, source, pixel_noise, view_margin, pooled)
    tally = Tally()
    start = time.perf_counter()
    for k in range(episodes):
        seed = SEED0 + k
        env = anonloc_env.AnonLocEnv(config, reward_fn=EnergyCost())
        if policy == "bayes":
            team = baselines.make_team("bayes", env, excitation="distinct")
        else:
            team = baselines.make_team(policy, env)
        tally_episode(env, team, seed, tally)
    tally.seconds = time.perf_counter() - start
    return tally


def tally_episode(env: Any, team: Any, seed: int, tally: Tally) -> None:
    """One episode (as :func:`baselines.runner.run_episode` plays it): pictures to 99 %,
    confident decisions and how many were wrong, each picture's pose error."""
    n = env.config.n_robots
    observations, infos = env.reset(seed=seed)
    team.reset(np.random.SeedSequence(seed).spawn(n))
    agents = env.possible_agents
    state: dict[str, Any] = {}
    correct, present = [], []
    while True:
        actions = team.act([observations[a] for a in agents])
        if observations[agents[0]]["new_picture"][0] > 0.5:
            truth = np.array([infos[a]["true_index"] for a in agents])
            estimate = np.asarray(team.estimates(None))
            decided = estimate >= 0
            tally.decided += int(decided.sum())
            tally.wrong += int((decided & (estimate != truth)).sum())
            correct.append(decided & (estimate == truth))
            present.append(truth >= 0)
            error = _pose_error(env, team, state)
            if error is not None:
                tally.pose_errors.append(error)
                registration = getattr(team.localizer, "identifier", None)
                registration = getattr(registration, "registration", None)
                if registration is not None and registration.error > 0.0:
                    tally.error_ratios.append(error / registration.error)
            if len(correct) >= PICTURES:
                break
        if not env.agents:
            break
        observations, _, _, _, infos = env.step(dict(zip(agents, actions, strict=True)))
    c, p = np.array(correct).T, np.array(present).T
    first, _ = first_identified(c, p, np.zeros(c.shape), 0.99)
    tally.reached += first is not None
    tally.pictures.append(float(first if first is not None else len(correct)))


@dataclass
class Steps:
    """The identifier's picture updates of one timed episode (s, wall clock; ``cpu``: the
    process's CPU time, less sensitive to other work on the machine), the registration's share
    of each (s; 0 for a fixed camera), each picture's row count and tracks kept after it."""

    seconds: list[float] = field(default_factory=list)
    cpu: list[float] = field(default_factory=list)
    registration: list[float] = field(default_factory=list)
    rows: list[int] = field(default_factory=list)
    tracks: list[int] = field(default_factory=list)


def worst_step(
    n: int,
    pictures: int,
    preset: str = "drone-hover",
    view_margin: float = 0.0,
    pooled: bool = False,
) -> Steps:
    """Time the identifier's picture updates at ``n`` robots under ``preset`` without landmarks
    (registration included), ``distinct`` motion, seed :data:`SEED0`."""
    config = condition_config(preset, n, False, view_margin=view_margin, pooled=pooled)
    # A drone over a 31 m arena flies higher than 5 m: at 1.25 times the side, the gimbal's left
    # tilt bends the picture's far edges by well under a pixel (a similarity still fits).
    config = dataclasses.replace(
        config,
        camera=dataclasses.replace(config.camera, height=max(5.0, 1.25 * config.arena_size[0])),
    )
    env = anonloc_env.AnonLocEnv(config, reward_fn=EnergyCost())
    team = baselines.make_team("bayes", env, excitation="distinct")
    identifier = team.localizer.identifier
    steps = Steps()
    update = identifier.update
    registration = identifier.registration
    register = registration.register if registration is not None else None
    spent = [0.0]

    def timed_register(rows: np.ndarray, anchors: Any = None) -> np.ndarray:
        start = time.perf_counter()
        assert register is not None
        out = register(rows, anchors)
        spent[0] = time.perf_counter() - start
        return out

    def timed(*args: Any, **kwargs: Any) -> None:
        spent[0] = 0.0
        start, cpu = time.perf_counter(), time.process_time()
        update(*args, **kwargs)
        steps.seconds.append(time.perf_counter() - start)
        steps.cpu.append(time.process_time() - cpu)
        steps.registration.append(spent[0])
        steps.rows.append(0 if identifier.rows is None else len(identifier.rows))
        steps.tracks.append(len(identifier.tracks))

    identifier.update = timed
    if registration is not None:
        registration.register = timed_register
    tally_pictures = Tally()
    global PICTURES
    PICTURES, saved = pictures, PICTURES
    try:
        tally_episode(env, team, SEED0, tally_pictures)
    finally:
        PICTURES = saved
    return steps


def time_steps(
    n: int,
    view_margin: float,
    repetitions: int = 2,
    pooled: bool = False,
    pictures: int = 12,
) -> list[dict[str, Any]]:
    """The fixed camera and ``drone-hover`` alternated in one process, ``repetitions`` times each,
    ``pictures`` pictures an episode, after one untimed warm-up of each (the compiled kernels
    load at their first call); each with the compiled first step without headings
    (``identify.first_step``, the default) and with the general path it replaces
    (``first_step``: ``"compiled"`` or ``"general"``)."""
    for preset in ("default", "drone-hover"):
        worst_step(n, 3, preset, view_margin, pooled)
    rows = []
    applies = first_step.applies
    for rep in range(repetitions):
        for preset in ("default", "drone-hover"):
            for path in ("compiled", "general"):
                first_step.applies = applies if path == "compiled" else _never  # type: ignore[assignment]  # a switch for the timing
                try:
                    steps = worst_step(n, pictures, preset, view_margin, pooled)
                finally:
                    first_step.applies = applies  # type: ignore[assignment]  # restored
                row = {
                    "n": n,
                    "camera": preset,
                    "first_step": path,
                    "view_margin": view_margin,
                    "pooled_motion": pooled,
                    "rep": rep,
                    "worst_step_s": max(steps.seconds),
                    "median_step_s": float(np.median(steps.seconds)),
                    "worst_step_cpu_s": max(steps.cpu),
                    "median_step_cpu_s": float(np.median(steps.cpu)),
                    "worst_registration_s": max(steps.registration),
                    "step_s": steps.seconds,
                    "step_cpu_s": steps.cpu,
                    "rows": steps.rows,
                    "tracks": steps.tracks,
                }
                rows.append(row)
                print(json.dumps(row), flush=True)
    return rows


def _never(fast: bool, scoring: Any) -> bool:
    """``first_step.applies`` that never applies: the general path."""
    return False


def table(files: list[Path]) -> str:
    """The docs' table of the rows in ``files`` (JSON written by this script), each condition
    beside the static camera without landmarks of the same N and policy (geometric source)."""
    rows = [row for f in files for row in json.loads(f.read_text()) if "policy" in row]
    static = {
        (r["n"], r["policy"]): r["pictures_to_99"][0]
        for r in rows
        if r["camera"] == "default"
        and not r["landmarks"]
        and r.get("source") == "geometric"
        and r.get("pixel_noise", 1.0) == 1.0
        and not r.get("view_margin", 0.0)
    }
    lines = [
        "| N | policy | camera | source | landmarks | reached 99 % / episodes "
        "| pictures to 99 % [95 % CI] | vs static | wrong / confident decisions "
        "| pose error, px: RMS / p95 |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        mean, low, high = r["pictures_to_99"]
        base = static.get((r["n"], r["policy"]))
        noise = r.get("pixel_noise", 1.0)
        margin = r.get("view_margin", 0.0)
        first = r["camera"] == "default" and not r["landmarks"] and noise == 1.0 and not margin
        camera = r["camera"] if noise == 1.0 else f"{r['camera']}, {noise:g} px"
        camera += f", view +{margin:g} m" if margin else ""
        pooled = r.get("pooled_motion") and r["camera"] != "default" and not r["landmarks"]
        camera += ", pooled" if pooled else ""
        delta = "" if base is None or first else f"{mean - base:+.2f}"
        wrong, decided = r["wrong"]
        share = 100.0 * wrong / decided if decided else 0.0
        pose = (
            f"{r['pose_error_rms']:.2f} / {r['pose_error_p95']:.2f}" if r["pose_error_rms"] else "-"
        )
        lines.append(
            f"| {r['n']} | {r['policy']} | {camera} | {r.get('source', 'geometric')} "
            f"| {'yes' if r['landmarks'] else 'no'} "
            f"| {r.get('reached_99', '-')} / {r['episodes']} "
            f"| {mean:.2f} [{low:.2f}, {high:.2f}] | {delta} "
            f"| {wrong} / {decided} ({share:.2f} %) | {pose} |"
        )
    return "\n".join(lines)


def main() -> None:
    global SEED0
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=10)
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--policy", action="append", default=None)
    parser.add_argument("--preset", action="append", default=None)
    parser.add_argument("--out", type=Path)
    parser.add_argument("--source", default="geometric", choices=["geometric", "image"])
    parser.add_argument("--landmarks", choices=["both", "no", "yes"], default="both")
    parser.add_argument(
        "--pixel-noise", type=float, default=1.0, help="detector noise (px); 1 in the results"
    )
    parser.add_argument(
        "--view-margin",
        type=float,
        default=0.0,
        help="field of view wider than the arena by this much each side (m); 0 in the results",
    )
    parser.add_argument(
        "--pooled-motion",
        action="store_true",
        help="the robots share their motions (camera.pooled_motion; a communication)",
    )
    parser.add_argument("--worst-step", action="store_true", help="time the identifier at --n")
    parser.add_argument(
        "--repetitions", type=int, default=2, help="--worst-step: timed episodes per condition"
    )
    parser.add_argument(
        "--worst-pictures",
        type=int,
        default=12,
        help="--worst-step: pictures per timed episode (the worst is the third)",
    )
    parser.add_argument(
        "--seed0", type=int, default=SEED0, help="first episode's seed (the rest follow it)"
    )
    parser.add_argument("--table", type=Path, nargs="*", help="print the docs' table of files")
    args = parser.parse_args()
    SEED0 = args.seed0
    if args.table:
        print(table(args.table))
        return
    if args.worst_step:
        rows = time_steps(
            args.n, args.view_margin, args.repetitions, args.pooled_motion, args.worst_pictures
        )
        _write(args.out, rows)
        return
    rows = []
    choices = {"both": (False, True), "no": (False,), "yes": (True,)}[args.landmarks]
    for policy in args.policy or ["bayes", "agent"]:
        for preset in args.preset or ["default", "drone-hover", "drone-windy"]:
            for landmarks in choices:
                t = run_condition(
                    preset,
                    args.n,
                    landmarks,
                    policy,
                    args.episodes,
                    args.source,
                    args.pixel_noise,
                    args.view_margin,
                    args.pooled_motion,
                )
                mean = bootstrap_mean(t.pictures)
                pose = float(np.sqrt(np.mean(np.square(t.pose_errors)))) if t.pose_errors else 0.0
                row = {
                    "n": args.n,
                    "policy": policy,
                    "camera": preset,
                    "landmarks": landmarks,
                    "source": args.source,
                    "pixel_noise": args.pixel_noise,
                    "view_margin": args.view_margin,
                    "pooled_motion": args.pooled_motion,
                    "episodes": args.episodes,
                    "seed0": args.seed0,
                    "pictures_to_99": [mean.mean, mean.low, mean.high],
                    "reached_99": t.reached,
                    "wrong": [t.wrong, t.decided],
                    "pose_error_rms": pose,
                    "pose_error_p95": float(np.quantile(t.pose_errors, 0.95))
                    if t.pose_errors
                    else 0.0,
                    "error_ratio_quantiles": [
                        float(q) for q in np.quantile(t.error_ratios, [0.5, 0.9, 0.99])
                    ]
                    if t.error_ratios
                    else None,
                    "seconds": t.seconds,
                }
                rows.append(row)
                print(json.dumps(row), flush=True)
                _write(args.out, rows)


def _write(path: Path | None, rows: list[dict[str, Any]]) -> None:
    """``rows`` as JSON at ``path``, atomically (nothing without ``--out``: printed only)."""
    if path is None:
        return
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(rows, indent=1))
    os.replace(tmp, path)


if __name__ == "__main__":
    sys.exit(main())
