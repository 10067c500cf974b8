"""Terminal output shared by the commands: structured logging, progress bars, messages.

Logging goes to stderr as one JSON object per line (``-v``: INFO, ``-vv``: DEBUG); extra fields
given to a log call (``log.info("unit done", extra={"key": k})``) become fields of that object.
Without ``-v`` only warnings and errors are logged. Progress bars (tqdm) also write to stderr and
are off with ``--quiet``; when stderr is not a terminal (a log file, ``nohup``) they write one
line every 30 s instead (:mod:`anonloc_env._progress`). Results and tables go to stdout.
"""

from __future__ import annotations

import json
import logging
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

#: Attributes every ``LogRecord`` has; anything else on a record came from ``extra=``.
_STANDARD = set(vars(logging.makeLogRecord({}))) | {"message", "asctime", "taskName"}


class JsonFormatter(logging.Formatter):
    """One JSON object per record: time, level, logger, message and the ``extra`` fields."""

    def format(self, record: logging.LogRecord) -> str:
        entry: dict[str, Any] = {
            "time": time.strftime("%Y-%m-%dT%H:%M:%S", time.localtime(record.created))
            + f".{int(record.msecs):03d}",
            "level": record.levelname.lower(),
            "logger": record.name,
            "message": record.getMessage(),
        }
        entry.update(
            {k: v for k, v in vars(record).items() if k not in _STANDARD and not k.startswith("_")}
        )
        if record.exc_info:
            entry["exception"] = self.formatException(record.exc_info)
        return json.dumps(entry, default=str)


def setup_logging(verbose: int) -> None:
    """Log to stderr as JSON lines: warnings only, INFO with ``verbose=1``, DEBUG with 2."""
    level = logging.WARNING if verbose <= 0 else logging.INFO if verbose == 1 else logging.DEBUG
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(JsonFormatter())
    root = logging.getLogger("anonloc_cli")
    root.handlers[:] = [handler]
    root.setLevel(level)
    root.propagate = False


class Progress:
    """A progress bar (tqdm on stderr; in a log, a line every 30 s) that can be switched off;
    ``update(n)`` in either case."""

    def __init__(
        self, total: int, description: str, *, quiet: bool, initial: int = 0, unit: str = "unit"
    ) -> None:
        self.bar: Any = None
        if not quiet:
            from anonloc_env._progress import progress_bar

            self.bar = progress_bar(total, description, initial=initial, unit=unit)

    def update(self, n: int = 1) -> None:
        if self.bar is not None:
            self.bar.update(n)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


@contextmanager
def progress(
    total: int, description: str, *, quiet: bool, initial: int = 0, unit: str = "unit"
) -> Iterator[Progress]:
    """A :class:`Progress` closed on exit."""
    bar = Progress(total, description, quiet=quiet, initial=initial, unit=unit)
    try:
        yield bar
    finally:
        bar.close()


def echo(message: str = "", *, err: bool = False) -> None:
    """Print a line to stdout (or stderr)."""
    print(message, file=sys.stderr if err else sys.stdout, flush=True)
