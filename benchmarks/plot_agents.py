"""Pictures to 99 % of every excitation, per evaluation condition, beside the two limits.

Reads a JSON results file: a list of rows, one per condition and excitation, each
``{"condition": str, "excitation": str, "pictures": float, "low": float, "high": float,
"reached": int, "episodes": int, "energy": float, "wrong": float}`` (``pictures`` the censored
mean picture index at which 99 % of the robots are identified, ``low`` and ``high`` its 95 %
interval). Draws one panel per condition: each excitation's mean with its interval, and the
condition's information bound (solid) and union estimate for random codes (dashed) from
:func:`baselines.limit.picture_limit`, computed from the condition's definition in
:func:`benchmarks.agent_conditions.evaluation_conditions`. Needs matplotlib
(``pip install anonloc[cli]``).

Usage: ``python benchmarks/plot_agents.py results.json out.png``
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Mapping
from typing import Any

from baselines.limit import PictureLimit, picture_limit
from benchmarks.agent_conditions import evaluation_conditions

#: Keys every row of the results file must have.
FIELDS = ("condition", "excitation", "pictures", "low", "high", "reached", "episodes")


def limits(names: list[str]) -> dict[str, PictureLimit]:
    """The limits of the named evaluation conditions.

    Raises:
        ValueError: a name that is not an evaluation condition (the message lists them).
    """
    conditions = evaluation_conditions()
    unknown = [name for name in names if name not in conditions]
    if unknown:
        raise ValueError(f"unknown conditions {unknown}; valid: {list(conditions)}")
    return {name: picture_limit(*conditions[name]) for name in names}


def check_rows(rows: Any) -> list[Mapping[str, Any]]:
    """The rows of a results file, checked.

    Raises:
        ValueError: not a list of objects with the keys of :data:`FIELDS`.
    """
    if not isinstance(rows, list) or not all(isinstance(row, Mapping) for row in rows):
        raise ValueError("the results file must hold a JSON list of objects (one per row)")
    for i, row in enumerate(rows):
        missing = [key for key in FIELDS if key not in row]
        if missing:
            raise ValueError(f"row {i} lacks {missing}; every row needs {list(FIELDS)}")
    return rows


def plot(rows: list[Mapping[str, Any]], out: str) -> None:
    """Draw one panel per condition of ``rows`` (in the order of first appearance) into ``out``
    (PNG)."""
    try:
        import matplotlib
    except ImportError as error:  # pragma: no cover - depends on the install
        raise ImportError("the plot needs matplotlib: pip install anonloc[cli]") from error
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = check_rows(rows)
    names = list(dict.fromkeys(row["condition"] for row in rows))
    bounds = limits(names)
    columns = min(len(names), 4)
    lines = math.ceil(len(names) / columns)
    figure, axes = plt.subplots(
        lines, columns, figsize=(3.2 * columns, 3.0 * lines), squeeze=False, constrained_layout=True
    )
    for axis in axes.flat[len(names) :]:
        axis.set_visible(False)
    for axis, name in zip(axes.flat, names, strict=False):
        mine = [row for row in rows if row["condition"] == name]
        x = list(range(len(mine)))
        means = [row["pictures"] for row in mine]
        below = [row["pictures"] - row["low"] for row in mine]
        above = [row["high"] - row["pictures"] for row in mine]
        axis.errorbar(x, means, yerr=[below, above], fmt="o", color="C0", capsize=3)
        for xi, row in zip(x, mine, strict=True):
            axis.annotate(
                f"{row['reached']}/{row['episodes']}",
                (xi, row["high"]),
                textcoords="offset points",
                xytext=(0, 3),
                ha="center",
                fontsize=7,
            )
        limit = bounds[name]
        axis.axhline(limit.information, color="C3", lw=1.2, label="information bound")
        if math.isfinite(limit.union):
            axis.axhline(limit.union, color="C2", lw=1.2, ls="--", label="union (random codes)")
        axis.set_xticks(x, [row["excitation"] for row in mine], rotation=30, ha="right")
        axis.set_xlim(-0.6, len(mine) - 0.4)
        marks = [row["high"] for row in mine] + [limit.information, limit.union]
        axis.set_ylim(0.0, 1.2 * max(mark for mark in marks if math.isfinite(mark)))
        axis.set_title(name, fontsize=10)
        axis.set_ylabel("pictures to 99 %")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    figure.legend(handles, labels, loc="outside lower center", ncols=2, fontsize=8)
    figure.savefig(out, dpi=120)
    plt.close(figure)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", help="JSON list of rows (see the module docstring)")
    parser.add_argument("out", help="PNG to write")
    args = parser.parse_args()
    with open(args.results, encoding="utf-8") as handle:
        plot(json.load(handle), args.out)


if __name__ == "__main__":
    main()
