"""A training run's folder: its lock, its recorded config, and SIGTERM as Ctrl-C.

:mod:`agents.train` trains in ``out/<run name>/``; this module keeps that folder in order. A
folder is locked (``.lock``) while a process trains it, so two processes never train one run;
``config.json`` records the run's config and its scenario's full ``EnvConfig``, written to a
temporary file and moved into place; and SIGTERM (a scheduler ending the job, ``kill``) stops
training as Ctrl-C does, so the run saves what it has. The checkpoints inside the folder are
:mod:`agents.checkpoints`' job.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from anonloc_env.config import EnvConfig
from anonloc_env.presets import config_to_dict


class RunBusyError(RuntimeError):
    """Another process trains the same run folder."""


class RunLock:
    """An exclusive lock on a run folder (``.lock``): two processes never train one run.

    Raises:
        RunBusyError: on entry, when another process holds the lock.
    """

    def __init__(self, directory: Path) -> None:
        self.path = directory / ".lock"
        self._fd: int | None = None

    def __enter__(self) -> RunLock:
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            import fcntl

            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except ImportError:  # pragma: no cover - Windows: no advisory locks
            pass
        except BlockingIOError:
            os.close(fd)
            raise RunBusyError(
                f"run folder {self.path.parent} is being trained by another process; "
                "wait for it to finish"
            ) from None
        self._fd = fd
        return self

    def __exit__(self, *exc: object) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None


def write_config(directory: Path, train: dict[str, Any], env: EnvConfig) -> None:
    """Record a run's config in ``directory/config.json``, atomically: ``{"train": train,
    "env": <env as a dict>}`` (numpy scalars in ``train`` become plain numbers)."""
    record = {"train": json.loads(json.dumps(train, default=_jsonable)), "env": config_to_dict(env)}
    write_text_atomic(directory / "config.json", json.dumps(record, indent=2, default=_jsonable))


def write_text_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file moved into place: a reader, or a kill
    in the middle, sees the old file or the new one, never half of one."""
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(text)
    tmp.replace(path)


def read_config(directory: Path) -> dict[str, Any]:
    """The ``train`` part of the config recorded in ``directory/config.json``.

    Raises:
        FileNotFoundError: no ``config.json`` there.
        ValueError: a ``config.json`` that is not a run's.
    """
    path = directory / "config.json"
    if not path.exists():
        raise FileNotFoundError(f"{path} not found: nothing to resume")
    try:
        return dict(json.loads(path.read_text())["train"])
    except (ValueError, KeyError, TypeError) as error:
        raise ValueError(
            f"{path} is not a run's config ({type(error).__name__}: {error})"
        ) from None


def set_aside_logs(directory: Path) -> Path | None:
    """Move a run's ``tb/`` (TensorBoard events and ``progress.csv``) to ``tb.restart-K/`` (the
    first free K) before the run trains again from step 0: the killed attempt's logs are kept,
    and TensorBoard never shows two curves over the same steps in one folder. None when there
    was no ``tb/``."""
    logs = directory / "tb"
    if not logs.is_dir():
        return None
    k = 1
    while (directory / f"tb.restart-{k}").exists():
        k += 1
    kept = directory / f"tb.restart-{k}"
    logs.rename(kept)
    return kept


@contextlib.contextmanager
def interrupt_on_sigterm() -> Iterator[None]:
    """SIGTERM (a scheduler ending the job, ``kill``) stops training as Ctrl-C does: inside the
    block it raises ``KeyboardInterrupt`` (on the main thread only; elsewhere nothing changes)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def stop(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, stop)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _jsonable(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON: {value!r}")
