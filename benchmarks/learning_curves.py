"""Plot the learning curves of ``anonloc train`` runs from their ``tb/progress.csv`` logs.

Usage::

    python benchmarks/learning_curves.py runs/free-10 runs/swarm-10 --out curves.png

Three panels against the robot-decisions trained on: the mean episode return per robot
(``rollout/ep_rew_mean``), the share of the robots present in an episode's last picture that
were identified (``identify/correct_at_end``), and the censored pictures to 99 % of the progress
display's evaluation seeds (``eval/pictures_to_99``; runs without it leave the panel empty).
Needs matplotlib (the ``cli`` extra).
"""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path

PANELS = (
    ("rollout/ep_rew_mean", "episode return per robot"),
    ("identify/correct_at_end", "identified at the episode's end"),
    ("eval/pictures_to_99", "pictures to 99 % (evaluation seeds)"),
)


def read(run: Path) -> dict[str, list[tuple[float, float]]]:
    """``column -> [(decisions, value)]`` from a run's ``tb/progress.csv`` (blank cells skipped)."""
    with open(run / "tb" / "progress.csv", newline="") as file:
        rows = list(csv.DictReader(file))
    out: dict[str, list[tuple[float, float]]] = {}
    for column, _ in PANELS:
        points = []
        for row in rows:
            x, y = row.get("time/total_timesteps", ""), row.get(column, "")
            if x and y and math.isfinite(float(y)):
                points.append((float(x), float(y)))
        out[column] = points
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", type=Path, nargs="+", help="run folders of anonloc train")
    parser.add_argument("--out", type=Path, default=Path("learning_curves.png"))
    parser.add_argument("--smooth", type=int, default=5, help="moving-average window (points)")
    args = parser.parse_args()
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as error:  # pragma: no cover - depends on the installation
        raise SystemExit(
            f"the plot needs matplotlib: pip install 'anonloc[cli]' ({error})"
        ) from None
    fig, axes = plt.subplots(1, len(PANELS), figsize=(15, 3.6))
    for run in args.runs:
        curves = read(run)
        for ax, (column, _) in zip(axes, PANELS, strict=True):
            points = curves[column]
            if not points:
                continue
            xs = [p[0] for p in points]
            ys = [p[1] for p in points]
            k = max(1, args.smooth)
            smooth = [sum(ys[max(0, i - k + 1) : i + 1]) / len(ys[max(0, i - k + 1) : i + 1])
                      for i in range(len(ys))]  # fmt: skip
            ax.plot(xs, smooth, label=run.name)
    for ax, (_, title) in zip(axes, PANELS, strict=True):
        ax.set_xlabel("robot-decisions trained on")
        ax.set_title(title)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
