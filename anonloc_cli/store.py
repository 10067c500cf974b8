"""Results on disk: a resumable JSON-lines store of finished units, and atomic exports.

The store holds one line per finished work unit, ``{"key", "unit", "result", ...}``. A line is
written in one ``write`` of the complete line followed by ``fsync``, so an interrupted command
(Ctrl-C, a killed process, a power cut) leaves every finished unit on disk and at worst one
incomplete last line, which the next run drops before appending. Re-running a command skips the
units whose keys are already in its store. Each line carries a checksum of its record
(``"sha256"``): a line edited by hand is not trusted, and its unit runs again.

Final files (CSV, Parquet, Markdown, plots) are written to a temporary file in the same folder and
moved into place with ``os.replace``: a reader sees the old file or the new one, never half of one.
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import io
import json
import logging
import os
import tempfile
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

log = logging.getLogger(__name__)

#: The field of a store line holding the checksum of the rest of its record.
CHECKSUM = "sha256"


class StoreBusyError(RuntimeError):
    """Another process is writing to the same store."""


class Store:
    """An append-only JSON-lines file of finished units, locked while open.

    Use as a context manager: ``with Store(path) as store: store.append(record)``.
    """

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        self._fd: int | None = None

    def __enter__(self) -> Store:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_APPEND, 0o644)
        try:
            _lock(fd, self.path)
            _drop_incomplete_tail(fd, self.path)
        except BaseException:
            os.close(fd)
            raise
        self._fd = fd
        return self

    def __exit__(self, *exc: object) -> None:
        if self._fd is not None:
            if os.fstat(self._fd).st_size == 0:  # nothing finished: leave no empty store behind
                with contextlib.suppress(FileNotFoundError):
                    self.path.unlink()
            os.close(self._fd)  # also releases the lock
            self._fd = None

    def load(self) -> dict[str, dict[str, Any]]:
        """The finished units' records by key (the last one wins if a key repeats)."""
        return read_records(self.path)

    def append(self, record: dict[str, Any]) -> None:
        """Write one record as one complete line, and make it durable before returning."""
        if self._fd is None:
            raise RuntimeError("open the store with 'with Store(path) as store:' first")
        sealed = {**record, CHECKSUM: _checksum(record)}
        line = (json.dumps(sealed, separators=(",", ":")) + "\n").encode()
        written = 0
        while written < len(line):  # a single write for any realistic line; loop for safety
            written += os.write(self._fd, line[written:])
        os.fsync(self._fd)


def _checksum(record: dict[str, Any]) -> str:
    """SHA-256 of the record's canonical JSON (keys sorted), first 16 hex digits."""
    text = json.dumps(record, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def read_records(path: Path) -> dict[str, dict[str, Any]]:
    """The records of a store file by key; an unreadable line, or one whose checksum does not
    match (edited by hand, or written by another program), is skipped with a warning: its unit
    runs again."""
    records: dict[str, dict[str, Any]] = {}
    if not Path(path).exists():
        return records
    with open(path, "rb") as file:
        for number, raw in enumerate(file, 1):
            if not raw.endswith(b"\n"):
                break  # an incomplete last line: the unit will run again
            try:
                record = json.loads(raw)
                if record.pop(CHECKSUM, None) != _checksum(record):
                    log.warning(
                        "skipping a line whose checksum does not match (edited?); its unit will "
                        "run again",
                        extra={"store": str(path), "line": number},
                    )
                    continue
                records[record["key"]] = record
            except (ValueError, KeyError, TypeError):
                log.warning(
                    "skipping an unreadable line", extra={"store": str(path), "line": number}
                )
    return records


def _lock(fd: int, path: Path) -> None:
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows: no advisory locks, trust the user
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError as error:
        raise StoreBusyError(
            f"{path} is in use by another anonloc command; wait for it to finish "
            "(or choose another output)"
        ) from error


def _drop_incomplete_tail(fd: int, path: Path) -> None:
    size = os.fstat(fd).st_size
    if size == 0 or os.pread(fd, 1, size - 1) == b"\n":
        return
    keep, end, chunk = 0, size, 1 << 16
    while end > 0:  # search backwards for the end of the last complete line
        start = max(0, end - chunk)
        cut = os.pread(fd, end - start, start).rfind(b"\n")
        if cut >= 0:
            keep = start + cut + 1
            break
        end = start
    os.ftruncate(fd, keep)
    os.fsync(fd)
    log.warning(
        "dropped an incomplete last line (an interrupted write); that unit will run again",
        extra={"store": str(path), "bytes": size - keep},
    )


# -- atomic files -----------------------------------------------------------------------------


@contextlib.contextmanager
def atomic_path(path: Path) -> Iterator[Path]:
    """A temporary path next to ``path`` (same extension) moved onto ``path`` on success.

    For writers that want a file name (matplotlib, pyarrow, imageio). On error the temporary file
    is removed and ``path`` is left as it was.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=path.suffix)
    os.close(fd)
    tmp = Path(name)
    os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes it private; a result file should not be
    try:
        yield tmp
        with open(tmp, "rb") as file:
            os.fsync(file.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def write_json(path: Path, data: Any) -> None:
    """Write ``data`` as indented JSON to ``path`` atomically."""
    write_text(path, json.dumps(data, indent=1, default=str) + "\n")


def meta_path(path: Path) -> Path:
    """Where the provenance of data file ``path`` goes: ``name.meta.json`` beside it."""
    path = Path(path)
    return path.with_name(f"{path.stem}.meta.json")


def write_csv(path: Path, rows: Sequence[dict[str, Any]], columns: Sequence[str]) -> None:
    """Rows to CSV atomically; lists are JSON-encoded, None is an empty cell."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(columns)
    for row in rows:
        writer.writerow([_cell(row.get(column)) for column in columns])
    write_text(path, buffer.getvalue())


def _cell(value: Any) -> Any:
    if value is None:
        return ""
    if isinstance(value, (list, tuple)):
        return json.dumps(list(value))
    return value


def write_parquet(
    path: Path,
    rows: Sequence[dict[str, Any]],
    types: dict[str, str],
    metadata: dict[str, Any],
) -> None:
    """Rows to Parquet atomically; ``metadata`` goes into the schema as JSON.

    Args:
        path: the file.
        rows: dicts with the keys of ``types``.
        types: column -> ``"string"``, ``"int64"``, ``"float64"``, ``"bool"``,
            ``"list<float64>"`` or ``"list<bool>"`` (lists stay lists).
        metadata: the provenance record.
    """
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError as error:  # pragma: no cover - depends on the installed extras
        raise ImportError(
            "writing Parquet needs pyarrow: pip install 'anonloc[cli]' (or write a .csv)"
        ) from error
    arrow = {
        "string": pa.string(),
        "int64": pa.int64(),
        "float64": pa.float64(),
        "bool": pa.bool_(),
        "list<float64>": pa.list_(pa.float64()),
        "list<bool>": pa.list_(pa.bool_()),
    }
    schema = pa.schema([(name, arrow[kind]) for name, kind in types.items()])
    schema = schema.with_metadata({"anonloc": json.dumps(metadata, default=str)})
    table = pa.Table.from_pylist([{c: row.get(c) for c in types} for row in rows], schema=schema)
    with atomic_path(path) as tmp:
        pq.write_table(table, tmp)
