"""Plots of the study's sweeps (matplotlib, Agg backend): lines with 95 % confidence bands.

The files are written atomically, as PNG and SVG, with the provenance record (versions, command,
configs) embedded as their ``Description`` metadata.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from anonloc_cli import store


def sweep(
    definition: Any,
    rows: Sequence[dict[str, Any]],
    ylabels: tuple[str, str],
    stem: Path,
    record: dict[str, Any],
) -> list[Path]:
    """Draw success (left) and pictures (right) against x, one line per policy; write
    ``stem.png`` and ``stem.svg``; return their paths."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, (left, right) = plt.subplots(1, 2, figsize=(10, 3.8), constrained_layout=True)
    variants = list(dict.fromkeys(r["variant"] for r in rows))
    for i, variant in enumerate(variants):
        mine = sorted((r for r in rows if r["variant"] == variant), key=lambda r: r["x"])
        x = [r["x"] for r in mine]
        color = f"C{i}"
        _line(
            left,
            x,
            [100 * r["success"] for r in mine],
            [100 * r["success_low"] for r in mine],
            [100 * r["success_high"] for r in mine],
            color,
            variant,
        )
        _line(
            right,
            x,
            [r["pictures_mean"] for r in mine],
            [r["pictures_low"] for r in mine],
            [r["pictures_high"] for r in mine],
            color,
            variant,
        )
    left.set_ylabel(ylabels[0])
    left.set_ylim(-3, 103)
    right.set_ylabel(ylabels[1])
    right.set_ylim(bottom=0)
    for axis in (left, right):
        axis.set_xlabel(definition.xlabel)
        xs = list(definition.xs)
        if definition.log_x and min(xs) > 0:
            axis.set_xscale("log")
        elif definition.log_x:  # 0 among the points: linear up to the smallest positive one
            axis.set_xscale("symlog", linthresh=min(x for x in xs if x > 0))
        _pad_x(axis, xs)
        axis.set_xticks(xs, [f"{x:g}" for x in xs])
        axis.minorticks_off()
        axis.grid(alpha=0.3)
    left.legend(fontsize="small", loc="best")
    figure.suptitle(f"{definition.title} (bands: 95 % confidence intervals)")
    description = json.dumps(record, default=str)
    paths = []
    for suffix, metadata in (
        (
            ".png",
            {"Software": f"anonloc {record['versions']['anonloc']}", "Description": description},
        ),
        (
            ".svg",
            {
                "Creator": f"anonloc {record['versions']['anonloc']}",
                "Description": description,
                "Date": None,
            },
        ),
    ):
        path = stem.with_suffix(suffix)
        with store.atomic_path(path) as tmp:
            figure.savefig(tmp, format=suffix[1:], dpi=120, metadata=metadata)
        paths.append(path)
    plt.close(figure)
    return paths


def _pad_x(axis: Any, xs: list[float], share: float = 0.05) -> None:
    """Limits ``share`` of the axis wider than the points on each side, on the axis' own scale
    (log, symlog or linear), so that the end tick labels stay inside the figure."""
    forward = axis.xaxis.get_transform()
    low, high = forward.transform([min(xs), max(xs)])
    pad = share * (high - low) if high > low else 1.0
    axis.set_xlim(*forward.inverted().transform([low - pad, high + pad]))


def _line(
    axis: Any,
    x: list[float],
    y: list[float],
    low: list[float],
    high: list[float],
    color: str,
    label: str,
) -> None:
    keep = [i for i in range(len(x)) if math.isfinite(y[i])]
    xs = [x[i] for i in keep]
    axis.plot(xs, [y[i] for i in keep], "o-", color=color, label=label, markersize=4)
    axis.fill_between(
        xs, [low[i] for i in keep], [high[i] for i in keep], color=color, alpha=0.18, linewidth=0
    )
