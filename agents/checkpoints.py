"""Checkpoints that appear whole: atomic saves, and the newest readable checkpoint of a run.

A kill in the middle of a save must never leave a half-written file where a reader (or
``anonloc train --resume``) looks: every save goes to a temporary file that is then moved into
place, and :func:`latest_checkpoint` skips a damaged newest checkpoint (from an older version,
or a disk that filled up) for the previous good one, and says so.
"""

from __future__ import annotations

import contextlib
import os
import re
import warnings
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any


def checkpoint_path(directory: Path, steps: int) -> Path:
    """Where the checkpoint after ``steps`` robot-steps lives."""
    return directory / "checkpoints" / f"agent_{steps}_steps.zip"


def save_atomic(model: Any, path: Path) -> Path:
    """Save ``model`` to ``path`` through a temporary file: a reader (or a kill mid-save) sees
    the old file or the new one, never half of one."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.tmp.zip")
    try:
        model.save(tmp)
        os.replace(tmp, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
    return path


def latest_checkpoint(directory: Path, *, notify: Callable[[str], None] | None = None) -> Path:
    """The newest readable checkpoint of a run folder; damaged newer ones are skipped, each
    with a message to ``notify`` (default: a warning)."""
    found = sorted(
        (directory / "checkpoints").glob("agent_*_steps.zip"),
        key=lambda p: int(re.findall(r"\d+", p.stem)[-1]),
    )
    if not found:
        raise FileNotFoundError(f"no checkpoint in {directory / 'checkpoints'} to resume from")
    for newest in reversed(found):
        problem = _zip_problem(newest)
        if problem is None:
            return newest
        message = f"checkpoint {newest} is damaged ({problem}); trying the previous one"
        if notify is None:
            warnings.warn(message, stacklevel=2)
        else:
            notify(message)
    raise FileNotFoundError(f"no readable checkpoint in {directory / 'checkpoints'}")


def _zip_problem(path: Path) -> str | None:
    """What is wrong with a saved model file, or None."""
    try:
        with zipfile.ZipFile(path) as archive:
            bad = archive.testzip()
            if bad is not None:
                return f"member {bad} is corrupt"
            if "data" not in archive.namelist():
                return "not a saved model"
    except (zipfile.BadZipFile, OSError, EOFError) as error:
        return str(error) or type(error).__name__
    return None
