"""Progress bars on stderr that also read well in a log file (shared by the command line and
``agents.train``; tqdm is imported when a bar is made).

On a terminal a bar is redrawn in place. When stderr is not a terminal (``nohup``, a cluster job,
``2> log``), carriage-return updates would pile up thousands of times in the file: the bar then
writes one plain line every :func:`line_seconds` seconds (30 by default, or the
``ANONLOC_PROGRESS_SECONDS`` environment variable), plus the first and the last.
"""

from __future__ import annotations

import os
import sys
from typing import Any, TextIO

#: Seconds between two progress lines when stderr is not a terminal (default).
LINE_SECONDS = 30.0

#: What a progress line shows when stderr is not a terminal (no bar, nothing redrawn).
LINE_FORMAT = "{desc}: {percentage:3.0f}% {n_fmt}/{total_fmt} [{elapsed}<{remaining}]{postfix}"


def line_seconds() -> float:
    """Seconds between two progress lines in a log (``ANONLOC_PROGRESS_SECONDS``, else 30)."""
    text = os.environ.get("ANONLOC_PROGRESS_SECONDS", "")
    try:
        seconds = float(text)
    except ValueError:
        return LINE_SECONDS
    return seconds if seconds >= 0.0 else LINE_SECONDS


class _Lines:
    """A file for tqdm that turns each redraw (``"\\r" + status + padding``) into one line."""

    def __init__(self, stream: TextIO) -> None:
        self.stream = stream
        self.encoding = getattr(stream, "encoding", "utf-8")
        self._last = ""

    def write(self, text: str) -> int:
        line = text.replace("\r", "").strip()
        if line and line != self._last:
            self.stream.write(line + "\n")
            self._last = line
        return len(text)

    def flush(self) -> None:
        self.stream.flush()


def progress_bar(total: int, description: str, **options: Any) -> Any:
    """A tqdm bar on stderr (``options`` go to tqdm); in a log, one line every
    :func:`line_seconds` seconds instead of a redrawn bar."""
    from tqdm import tqdm

    stream = sys.stderr
    if stream.isatty():
        return tqdm(total=total, desc=description, file=stream, dynamic_ncols=True, **options)
    options.pop("bar_format", None)
    return tqdm(
        total=total,
        desc=description,
        file=_Lines(stream),
        mininterval=line_seconds(),
        maxinterval=max(line_seconds(), 10.0),
        bar_format=LINE_FORMAT,
        **options,
    )
