"""The figures of ``docs/crowds.md`` from ``python -m benchmarks.crowds results --json``: the
reliability curve per density (every excitation and N pooled: top belief against how often the
top row is right, 95 % Wilson intervals, bins with at least
``benchmarks.plot_reliability.MIN_COUNT`` robot-pictures) and the share of robots right at
every picture, one panel per density and N. Needs matplotlib (``pip install anonloc[cli]``).

Usage: ``python -m benchmarks.crowds plot crowds.json docs/assets/crowds`` (writes
``crowds-reliability.png`` and ``crowds-share.png``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from benchmarks.plot_reliability import draw


def pooled(cells: Sequence[Mapping[str, Any]]) -> list[tuple[float, int, float]]:
    """The reliability rows of ``cells`` pooled per bin: ``(mean top belief, count, share
    right)`` for the bins with robot-pictures."""
    bins: dict[int, list[float]] = {}
    for cell in cells:
        for k, (_, _, count, accuracy, mean) in enumerate(cell["reliability"]):
            if count:
                total = bins.setdefault(k, [0.0, 0.0, 0.0])
                total[0] += count
                total[1] += count * accuracy
                total[2] += count * mean
    return [(t[2] / t[0], int(t[0]), t[1] / t[0]) for _, t in sorted(bins.items())]


def plot(cells: list[dict[str, Any]], prefix: str) -> None:
    """Write ``PREFIX-reliability.png`` and ``PREFIX-share.png`` from the grid ``cells``."""
    try:
        import matplotlib
    except ImportError as error:  # pragma: no cover - depends on the install
        raise ImportError("the crowd figures need matplotlib: pip install anonloc[cli]") from error
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    densities = sorted({c["density"] for c in cells})
    figure, axis = plt.subplots(figsize=(6.0, 4.6), constrained_layout=True)
    curves = []
    for density in densities:
        rows = pooled([c for c in cells if c["density"] == density])
        bins = [(math.nan, math.nan, count, right, mean) for mean, count, right in rows]
        curves.append((f"{density:g} robots/m²", bins))
    draw(axis, curves, "Reliability in a crowd, every excitation and N")
    figure.savefig(f"{prefix}-reliability.png", dpi=110)
    plt.close(figure)
    _share(cells, densities, f"{prefix}-share.png", plt)


def _share(cells: list[dict[str, Any]], densities: list[float], out: str, plt: Any) -> None:
    robots = sorted({c["n"] for c in cells})
    figure, axes = plt.subplots(
        len(robots),
        len(densities),
        figsize=(3.0 * len(densities), 2.6 * len(robots)),
        squeeze=False,
        sharey=True,
        constrained_layout=True,
    )
    names = list(dict.fromkeys(c["excitation"] for c in cells))
    for r, n in enumerate(robots):
        for d, density in enumerate(densities):
            axis = axes[r][d]
            for i, name in enumerate(names):
                for c in cells:
                    if (c["n"], c["density"], c["excitation"]) == (n, density, name):
                        axis.plot(c["share"], color=f"C{i}", lw=1.2, label=name)
            axis.axhline(0.99, color="0.6", lw=0.8, ls="--")
            axis.set_title(f"N = {n}, {density:g} robots/m²", fontsize=9)
            axis.set_ylim(0.0, 1.02)
            axis.grid(alpha=0.3)
            if r == len(robots) - 1:
                axis.set_xlabel("picture")
            if d == 0:
                axis.set_ylabel("share of robots right")
    axes[0][0].legend(fontsize=7, loc="lower right")
    figure.savefig(out, dpi=100)
    plt.close(figure)
