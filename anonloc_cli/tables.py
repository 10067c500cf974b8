"""Tables for the terminal (rich) and for files (Markdown), and the intervals they print.

Success rates carry their 95 % Wilson interval (:class:`baselines.paper.Rate`); means carry a
95 % normal interval (``mean +- 1.96 * std / sqrt(n)``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from baselines.paper import Rate

Z95 = 1.959964


@dataclass(frozen=True)
class Mean:
    """A sample mean with its 95 % normal interval."""

    value: float
    low: float
    high: float
    count: int

    def __str__(self) -> str:
        if self.count == 0:
            return "n/a"
        return f"{self.value:.3g} [{self.low:.3g}, {self.high:.3g}]"


def mean_interval(values: Sequence[float]) -> Mean:
    """The mean of the finite ``values`` with its 95 % normal interval."""
    finite = [float(v) for v in values if v is not None and math.isfinite(v)]
    n = len(finite)
    if n == 0:
        return Mean(math.nan, math.nan, math.nan, 0)
    mean = sum(finite) / n
    if n == 1:
        return Mean(mean, mean, mean, 1)
    std = math.sqrt(sum((v - mean) ** 2 for v in finite) / (n - 1))
    half = Z95 * std / math.sqrt(n)
    return Mean(mean, mean - half, mean + half, n)


def rate_text(rate: Rate) -> str:
    """``"84.0 % [77.4, 88.9] (168/200)"``."""
    if rate.trials == 0:
        return "n/a"
    return f"{rate} ({rate.successes}/{rate.trials})"


def markdown(headers: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """A Markdown (GitHub) table; ``|`` in cells is escaped."""

    def line(cells: Sequence[str]) -> str:
        return "| " + " | ".join(str(c).replace("|", "\\|") for c in cells) + " |"

    return "\n".join(
        [line(headers), "|" + "|".join("---" for _ in headers) + "|", *map(line, rows)]
    )


#: Widest a printed table gets (columns): it fits a terminal of that width, headers wrapping.
WIDTH = 100


def show(title: str, headers: Sequence[str], rows: Sequence[Sequence[str]]) -> None:
    """Print a table to the terminal with rich."""
    from rich.console import Console
    from rich.table import Table

    console = Console()
    if not console.is_terminal or console.width > WIDTH:  # a pipe, a log file, a wide terminal
        console = Console(width=WIDTH)
    table = Table(title=title, title_justify="left")
    for i, header in enumerate(headers):
        table.add_column(header, justify="left" if i == 0 else "right", no_wrap=i == 0)
    for row in rows:
        table.add_row(*(str(c) for c in row))
    console.print(table)
