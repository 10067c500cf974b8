"""Where the identifier's worst step goes under a camera on a drone (issue 27's cost target).

Times each part of ``Identifier.update`` (CPU time, ``time.process_time``) at every picture of
one episode at N robots, for the fixed camera and ``drone-hover`` alternated in one process
(``benchmarks.drone.worst_step``'s condition: no landmarks, ``distinct`` motion, seed 1000),
after an untimed warm-up of each, and prints the parts of each condition's worst picture:

    OMP_NUM_THREADS=1 PYTHONPATH=. python benchmarks/drone_parts.py --n 1000 --repetitions 2

The parts (each includes what it calls): the registration (``register``), the children of the
anchored tracks (``anchored``; its compiled kernel and inputs ``known_compiled``), of the tracks
missed before (``from_missed``), of the uniform weight (``from_uniform``), the tracks continued
through a miss (``missed``), the footprint's shift of the tracks' misses (``view.tracks``) and
of the uniform weight's (``view.uniform_lost``), and the prune and normalisation (``prune``);
``other`` is the rest of the update.
"""

from __future__ import annotations

import argparse
import json
import time
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path
from typing import Any

from anonloc_env.identify import camera_pose, children, filter, fused_calls, out_of_view
from benchmarks import drone

#: ``(owner, attribute, label)`` of each timed part.
PARTS = (
    (camera_pose.Registration, "register", "register"),
    (children.Builder, "anchored", "anchored"),
    (fused_calls, "known_compiled", "known_compiled"),
    (children.Builder, "from_missed", "from_missed"),
    (children.Builder, "from_uniform", "from_uniform"),
    (children.Builder, "missed", "missed"),
    (out_of_view.OutOfView, "tracks", "view.tracks"),
    (out_of_view.OutOfView, "uniform_lost", "view.uniform_lost"),
    (filter.Identifier, "_normalise_and_prune", "prune"),
)


def _timed(f: Callable[..., Any], label: str, spent: dict[str, float]) -> Callable[..., Any]:
    def run(*args: Any, **kwargs: Any) -> Any:
        start = time.process_time()
        try:
            return f(*args, **kwargs)
        finally:
            spent[label] += time.process_time() - start

    return run


def parts(n: int, preset: str, pictures: int) -> list[dict[str, Any]]:
    """Each picture's update of one episode: its CPU time, its parts' and its tracks."""
    spent: dict[str, float] = defaultdict(float)
    saved = [(owner, name, getattr(owner, name)) for owner, name, _ in PARTS]
    for owner, name, label in PARTS:
        setattr(owner, name, _timed(getattr(owner, name), label, spent))
    update = filter.Identifier.update
    out: list[dict[str, Any]] = []

    def timed(self: Any, *args: Any, **kwargs: Any) -> None:
        spent.clear()
        start = time.process_time()
        update(self, *args, **kwargs)
        total = time.process_time() - start
        known = {k: v for k, v in spent.items() if k != "known_compiled"}
        row = {"picture": self.pictures, "cpu_s": total, "tracks": len(self.tracks)}
        row.update(spent)
        row["other"] = total - sum(known.values())
        out.append(row)

    filter.Identifier.update = timed  # type: ignore[method-assign]  # timed for the benchmark
    try:
        drone.worst_step(n, pictures, preset)
    finally:
        filter.Identifier.update = update  # type: ignore[method-assign]  # restored
        for owner, name, f in saved:
            setattr(owner, name, f)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1000)
    parser.add_argument("--repetitions", type=int, default=2)
    parser.add_argument("--pictures", type=int, default=5, help="pictures per episode")
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    presets = ("default", "drone-hover")
    for preset in presets:  # warm-up: the compiled kernels load at their first call
        parts(args.n, preset, 3)
    rows = []
    for rep in range(args.repetitions):
        for preset in presets:
            steps = parts(args.n, preset, args.pictures)
            worst = max(steps, key=lambda r: r["cpu_s"])
            row = {"n": args.n, "camera": preset, "rep": rep, "worst": worst, "steps": steps}
            rows.append(row)
            shares = " ".join(
                f"{k}={v:.3f}" for k, v in worst.items() if k not in ("picture", "cpu_s", "tracks")
            )
            print(
                f"{preset} rep {rep}: worst picture {worst['picture']} {worst['cpu_s']:.3f} s CPU "
                f"({worst['tracks']} tracks kept): {shares}",
                flush=True,
            )
    if args.out:
        args.out.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
