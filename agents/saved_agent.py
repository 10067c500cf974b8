"""A saved agent's file, checked before anything in it is read: sizes, readable weights, and the
run settings recorded beside it.

An ``agent.zip`` is SB3's save: a ``data`` member (JSON, parts of it pickled), ``.pth`` members
(PyTorch weights, read with ``weights_only=True``) and two small text members. Before any member
is read, the sizes the zip declares are checked against :data:`MEMBER_LIMITS` and
:data:`TOTAL_LIMIT` (a 1.3 MB zip may declare a 1 GiB member; Python's ``zipfile`` never
decompresses past a declared size, so the declared sizes bound the memory a load takes). A load
that fails all the same is reported naming the file and the member, never with the advice to
unpickle it (``weights_only=False``). The condition and budget recorded in the run's
``config.json`` (the loaded policy depends on them) are read by :func:`run_settings`, with errors
that name the file.
"""

from __future__ import annotations

import io
import json
import math
import zipfile
from pathlib import Path
from typing import Any

#: The largest declared size (bytes) of each kind of member: ``data`` (JSON; 93 KB in the bundled
#: agent) and a ``.pth`` member (the optimizer state of the widest network ``anonloc train``
#: makes, ``hidden = 4096``, is 537 MB); any other member (SB3's version and system notes).
MEMBER_LIMITS = {"data": 16 << 20, ".pth": 768 << 20, "other": 1 << 20}
#: The largest sum of the declared sizes (bytes), and the most members, of a saved agent.
TOTAL_LIMIT = 2 << 30
MAX_MEMBERS = 64

#: Run conditions a saved agent may record (``mixed`` agents run ``free``).
CONDITIONS = ("free", "swarm", "mixed")


def _limit(name: str) -> int:
    if name == "data":
        return MEMBER_LIMITS["data"]
    return MEMBER_LIMITS[".pth" if name.endswith(".pth") else "other"]


def _size(count: int) -> str:
    return f"{count / (1 << 20):.1f} MiB" if count >= 1 << 20 else f"{count} bytes"


def check_members(path: Path) -> None:
    """Refuse a saved agent whose declared sizes pass the limits, before reading any member.

    Raises:
        ValueError: not a zip, too many members, or a member (or all of them) too large; the
            message names the file, the member and the limit.
    """
    try:
        with zipfile.ZipFile(path) as archive:
            members = archive.infolist()
    except (zipfile.BadZipFile, OSError) as error:
        raise ValueError(f"{path} is not a saved agent (an SB3 zip): {error}") from None
    if len(members) > MAX_MEMBERS:
        raise ValueError(
            f"{path} has {len(members)} members; a saved agent has at most {MAX_MEMBERS}"
        )
    for info in members:
        limit = _limit(info.filename)
        if info.file_size > limit:
            raise ValueError(
                f"{path}: member {info.filename} declares {_size(info.file_size)}, more than "
                f"the {_size(limit)} a saved agent's member may hold; it is not read"
            )
    total = sum(info.file_size for info in members)
    if total > TOTAL_LIMIT:
        raise ValueError(
            f"{path}: its members declare {_size(total)} in all, more than the "
            f"{_size(TOTAL_LIMIT)} a saved agent may hold; it is not read"
        )


def load_failure(path: Path, error: BaseException) -> ValueError:
    """The message for a saved agent that SB3 could not load: the member at fault (each ``.pth``
    member is tried alone, with ``weights_only=True``), never the advice to unpickle it."""
    import torch

    try:
        with zipfile.ZipFile(path) as archive:
            for name in archive.namelist():
                if not name.endswith(".pth"):
                    continue
                try:
                    torch.load(
                        io.BytesIO(archive.read(name)), map_location="cpu", weights_only=True
                    )
                except Exception as bad:  # any failure is this member's fault
                    return ValueError(
                        f"{path}: member {name} is not readable PyTorch weights "
                        f"({type(bad).__name__}); the file is damaged or not a saved agent"
                    )
    except (zipfile.BadZipFile, OSError) as bad:
        return ValueError(f"{path} is not a saved agent (an SB3 zip): {bad}")
    return ValueError(
        f"{path}: member data could not be loaded ({type(error).__name__}); the file is "
        "damaged, or was saved by an incompatible version"
    )


def run_settings(agent: Path) -> dict[str, Any]:
    """The ``condition`` and ``budget`` the run recorded in ``config.json`` beside ``agent``
    (``{}`` without that file; only the keys present).

    Raises:
        ValueError: a ``config.json`` that is not JSON, whose ``train`` is not an object, or whose
            condition or budget is not valid (the message names the file).
    """
    record = agent.parent / "config.json"
    if not record.is_file():
        return {}
    try:
        data = json.loads(record.read_text())
    except (ValueError, UnicodeDecodeError) as error:
        raise ValueError(f"{record} is not JSON ({error}); fix or remove it") from None
    train = data.get("train", {}) if isinstance(data, dict) else None
    if not isinstance(train, dict):
        raise ValueError(
            f"{record}: 'train' must be an object (the run's recorded config, e.g. "
            f'{{"condition": "free"}}), got {json.dumps(train)[:40]}; fix or remove it'
        )
    settings = {k: train[k] for k in ("condition", "budget") if k in train}
    condition = settings.get("condition", "free")
    if condition not in CONDITIONS:
        raise ValueError(
            f"{record}: train.condition must be one of {list(CONDITIONS)}, got {condition!r}"
        )
    budget = settings.get("budget", 0.0)
    if (
        isinstance(budget, bool)
        or not isinstance(budget, (int, float))
        or not (math.isfinite(budget) and 0.0 <= budget <= 1.0)
    ):
        raise ValueError(f"{record}: train.budget must be a number in [0, 1], got {budget!r}")
    return settings
