"""Many small dicts, fast: the per-agent observation and info dicts built at every step.

A comprehension that builds each dict from scratch runs its loop in the interpreter. Copying a
template per agent with ``map(dict.copy, ...)`` and then writing the per-agent values with
``map(setitem, ...)`` runs both loops in C, which is about a quarter faster for 100 to 1000
agents. ``collections.deque(iterator, maxlen=0)`` is the standard way to drain an iterator in C
without keeping its items.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable
from itertools import repeat
from operator import setitem
from typing import Any, TypeVar

V = TypeVar("V")


def copy_each(templates: Iterable[dict[str, V]]) -> list[dict[str, V]]:
    """A shallow copy of each dict of ``templates``, in order."""
    return list(map(dict.copy, templates))


def set_each(dicts: Iterable[dict[str, Any]], key: str, values: Iterable[Any]) -> None:
    """``dicts[i][key] = values[i]`` for every i (a key already present keeps its place)."""
    deque(map(setitem, dicts, repeat(key), values), maxlen=0)
