"""Reliability diagram of the Bayesian identifier from ``identify_quality.py --json`` results.

For each scenario and each bin of the top belief, the share of robot-pictures whose top row was
the truth (with its 95 % Wilson interval) against the mean top belief in the bin; a calibrated
identifier lies on the diagonal. The x axis is ``-log10(1 - belief)`` so that the bins near 1,
where decisions are taken, are spread out. Bins with fewer than :data:`MIN_COUNT`
robot-pictures are left out. Needs matplotlib (``pip install anonloc[cli]``).

Usage: ``python benchmarks/plot_reliability.py results.json out.png``
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from baselines.statistics import wilson

#: Bins with fewer robot-pictures are left out (their interval spans the whole axis).
MIN_COUNT = 30
#: Beliefs are drawn at most this close to 1 (``-log10(1 - b)`` <= 4).
CLOSEST = 1e-4


def _x(belief: np.ndarray) -> np.ndarray:
    return -np.log10(np.maximum(1.0 - belief, CLOSEST))


def draw(axis: Any, curves: Sequence[tuple[str, Sequence[Sequence[float]]]], title: str) -> None:
    """One reliability curve per ``(label, rows)`` of ``curves`` on ``axis``: rows as
    ``identify_quality.reliability`` gives them (low, high, count, share right, mean belief);
    bins with fewer than :data:`MIN_COUNT` robot-pictures are left out."""
    ticks = np.array([0.0, 0.5, 0.9, 0.99, 0.999, 0.9999])
    axis.plot(_x(ticks), _x(ticks), color="0.6", lw=1, ls="--", label="calibrated")
    for i, (label, all_rows) in enumerate(curves):
        rows = [r for r in all_rows if r[2] >= MIN_COUNT]
        if not rows:
            continue
        count = np.array([r[2] for r in rows])
        accuracy = np.array([r[3] for r in rows])
        mean = np.array([r[4] for r in rows])
        bounds = np.array(
            [wilson(round(a * c), int(c)) for a, c in zip(accuracy, count, strict=True)]
        )
        y = _x(accuracy)
        low, high = _x(bounds[:, 0]), _x(bounds[:, 1])
        axis.errorbar(
            _x(mean),
            y,
            yerr=[np.maximum(y - low, 0.0), np.maximum(high - y, 0.0)],
            marker="o",
            ms=4,
            capsize=3,
            color=f"C{i}",
            label=f"{label} ({int(count.sum()):,} robot-pictures)",
        )
    labels = [f"{t:g}" for t in ticks]
    axis.set_xticks(_x(ticks), labels)
    axis.set_yticks(_x(ticks), labels)
    axis.set_xlabel("top belief (bin mean)")
    axis.set_ylabel("top row right (95 % Wilson)")
    axis.set_title(title)
    axis.legend(fontsize=8, loc="upper left")
    axis.grid(alpha=0.3)


def plot(results: list[dict[str, Any]], out: str) -> None:
    """Draw the diagram of every scenario in ``results`` into ``out`` (PNG)."""
    try:
        import matplotlib
    except ImportError as error:  # pragma: no cover - depends on the install
        raise ImportError(
            "the reliability diagram needs matplotlib: pip install anonloc[cli]"
        ) from error
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axis = plt.subplots(figsize=(6.0, 4.6), constrained_layout=True)
    curves = [(r["scenario"], r["reliability"]) for r in results]
    draw(axis, curves, "Bayesian identifier: reliability")
    figure.savefig(out, dpi=110)
    plt.close(figure)


def main(argv: list[str] | None = None) -> None:
    """Read the JSON, write the PNG."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("results", help="JSON written by identify_quality.py --json")
    parser.add_argument("out", help="PNG to write")
    args = parser.parse_args(argv)
    with open(args.results) as f:
        results = json.load(f)
    if not any(math.isfinite(r[3]) for res in results for r in res["reliability"] if r[2]):
        parser.error("no reliability bins with robot-pictures in the results")
    plot(results, args.out)


if __name__ == "__main__":
    main()
