"""The Markdown tables of ``docs/`` and the README render as tables: every row has its header's
number of cells, and no row holds a literal ``\\n`` where a line break was meant (the seventh
round's targets table was one line of text for that reason)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [*sorted((ROOT / "docs").glob("*.md")), ROOT / "README.md"]
CODE_SPAN = re.compile(r"`[^`]*`")


def cells(line: str) -> int:
    """The cells of a table row: its pipes outside code spans and escapes, less one."""
    bare = CODE_SPAN.sub("", line.replace("\\|", ""))
    return bare.count("|") - 1


def tables(text: str) -> list[list[tuple[int, str]]]:
    """Each table's ``(line number, line)`` pairs: runs of lines that start with ``|`` outside
    fenced code blocks."""
    out: list[list[tuple[int, str]]] = []
    fenced, current = False, []
    for number, line in enumerate(text.splitlines(), 1):
        if line.lstrip().startswith("```"):
            fenced = not fenced
        if not fenced and line.startswith("|"):
            current.append((number, line))
            continue
        if current:
            out.append(current)
        current = []
    if current:
        out.append(current)
    return out


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_every_table_row_has_its_headers_cells(page: Path) -> None:
    bad = []
    for table in tables(page.read_text(encoding="utf-8")):
        width = cells(table[0][1])
        bad += [
            f"{page.name}:{number}: {cells(line)} cells, header {width}"
            for number, line in table[1:]
            if cells(line) != width
        ]
        bad += [f"{page.name}:{n}: a literal \\n" for n, line in table if "\\n|" in line]
    assert not bad, "\n".join(bad)


def test_cells_ignores_pipes_in_code_spans_and_escapes() -> None:
    assert cells("| a | `x|y` | b \\| c |") == 3
    assert tables("| a |\n|---|\n\n```\n| not | a | table |\n```\n| b |") == [
        [(1, "| a |"), (2, "|---|")],
        [(7, "| b |")],
    ]
