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


#: Width (columns) of a table printed to a pipe or a file, unless its cells need more.
WIDTH = 100

#: Plain spellings of the signs the tables use, for a terminal that cannot show them.
PLAIN = {"±": "+-", "°": " deg", "≥": ">=", "≤": "<=", "²": "^2", "\u00d7": "x", "\u2013": "-"}


def plain(text: str, encoding: str) -> str:
    """``text`` as ``encoding`` can show it: the signs of :data:`PLAIN` spelled out, anything
    else it lacks as ``?``."""
    try:
        text.encode(encoding)
        return text
    except (UnicodeEncodeError, LookupError):
        pass
    for sign, spelled in PLAIN.items():
        text = text.replace(sign, spelled)
    return text.encode(encoding, errors="replace").decode(encoding, errors="replace")


def column_widths(headers: Sequence[str], rows: Sequence[Sequence[str]]) -> list[int]:
    """The narrowest each column can be with no cell wrapped: its widest cell, or its header's
    longest word (a header may wrap between words)."""
    from rich.cells import cell_len

    widths = [max((cell_len(w) for w in h.split()), default=0) for h in headers]
    for row in rows:
        widths = [max(w, cell_len(str(c))) for w, c in zip(widths, row, strict=True)]
    return widths


def show(title: str, headers: Sequence[str], rows: Sequence[Sequence[str]]) -> None:
    """Print a table with rich: as a grid where it fits the terminal with no cell wrapped
    (headers may wrap between words; to a pipe or a file: a grid as wide as it needs, at least
    :data:`WIDTH`), else as one block of ``header: value`` lines per row, so that no cell is
    wrapped or cut. Signs the output's encoding lacks are spelled out (``±`` as ``+-``, ``°``
    as `` deg``)."""
    from rich.console import Console
    from rich.table import Table

    console = Console()
    encoding = console.encoding
    title, headers = plain(title, encoding), [plain(h, encoding) for h in headers]
    rows = [[plain(str(c), encoding) for c in row] for row in rows]
    widths = column_widths(headers, rows)
    needed = sum(widths) + 3 * len(widths) + 1  # cells, padding and borders
    if not console.is_terminal:  # a pipe, a log file: no width to fit
        console = Console(width=max(WIDTH, needed))
    if needed <= console.width:
        table = Table(title=title, title_justify="left", safe_box=True)
        for i, (header, width) in enumerate(zip(headers, widths, strict=True)):
            table.add_column(header, justify="left" if i == 0 else "right", width=width)
        for row in rows:
            table.add_row(*row)
        console.print(table)
        return
    console.print(title, highlight=False, soft_wrap=True)
    for row in rows:
        first = f"{headers[0]}: {row[0]}" if headers[0] else row[0]
        console.print(f"- {first}", highlight=False, soft_wrap=True)
        for header, cell in zip(headers[1:], row[1:], strict=True):
            console.print(f"  {header}: {cell}", highlight=False, soft_wrap=True)
