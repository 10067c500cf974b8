"""Helpers on the identifier's flat arrays: fields shared by a whole batch, and arrays grouped by
robot (every robot's items in one run, robots in order)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt

_FLOAT64 = np.dtype(np.float64)


def shared(value: float, count: int, width: int = 0) -> np.ndarray:
    """``count`` copies of ``value`` (``(count, width)`` if ``width``), read-only and taking no
    memory (stride 0): a field that every track of a batch holds alike (a first leg's position
    variance, a known scale, no carried motion). ``Tracks.take``, ``concat`` and ``gather`` keep
    such a field shared, so large batches do not write it out."""
    one = np.array(float(value))  # built directly, as ``repeated`` does: no broadcast_to
    if width:
        out = np.ndarray((count, width), np.float64, one, strides=(0, 0))
    else:
        out = np.ndarray((count,), np.float64, one, strides=(0,))
    out.setflags(write=False)
    return out


def repeated(item: np.ndarray | np.generic, count: int) -> np.ndarray:
    """``np.broadcast_to(item, (count, *item.shape))``: ``count`` read-only copies of ``item``
    taking no memory (stride 0). A single number's is built directly, at a third of the cost
    of ``np.broadcast_to`` (which the identifier would call tens of thousands of times a
    minute)."""
    if item.ndim:
        return np.broadcast_to(item, (count, *item.shape))
    one = np.asarray(item)
    out = np.ndarray((count,), one.dtype, one, strides=(0,))
    out.setflags(write=False)
    return out


def is_shared(a: np.ndarray) -> bool:
    """Whether ``a`` is a shared field (see :func:`shared`)."""
    return a.ndim > 0 and a.strides[0] == 0 and len(a) > 0


def take_field(a: np.ndarray, index: np.ndarray, count: int) -> np.ndarray:
    """``a[index]`` (``count`` long); a shared field stays shared."""
    if is_shared(a):
        return repeated(a[0], count)
    return a[index]


def alike(arrays: list[np.ndarray], count: int) -> np.ndarray | None:
    """The ``count``-long shared field that ``arrays`` (one per part) all hold alike, or
    ``None`` if they do not. A part that is not shared holds it too when every item of it is
    the shared value, bit for bit (a few general-path tracks beside a large shared batch), if
    such parts are short (at most half of ``count``: checking them costs less than the copy it
    saves)."""
    held = [a for a in arrays if is_shared(a)]
    if not held:
        return None
    value = held[0][0]
    if not all(_same_value(a[0], value) for a in held[1:]):
        return None
    rest = [a for a in arrays if not is_shared(a) and len(a)]
    if sum(len(a) for a in rest) * 2 > count:
        return None
    if not all(_holds(a, value) for a in rest):
        return None
    return repeated(value, count)


def _holds(a: np.ndarray, value: np.generic | np.ndarray) -> bool:
    """Whether every item of ``a`` equals ``value`` (nan equal to nan) with its sign (0.0 and
    -0.0 are equal, not alike). For float64 the bits are compared first: the same bits pass,
    and other bits fail unless ``value`` holds a nan (a nan of other bits passes)."""
    if a.dtype == _FLOAT64 and value.dtype == _FLOAT64:
        if _same_bits(a, value):
            return True
        if not np.isnan(value).any():
            return False
    if not np.array_equal(a, np.broadcast_to(value, a.shape), equal_nan=True):
        return False
    return not (np.signbit(a) != np.signbit(value)).any()


def _same_value(x: np.generic | np.ndarray, value: np.generic | np.ndarray) -> bool:
    """``np.array_equal(x, value, equal_nan=True)``, with the same bits checked first (the
    common case, at a fraction of the cost)."""
    if x.dtype == value.dtype and x.shape == value.shape and x.tobytes() == value.tobytes():
        return True
    return bool(np.array_equal(x, value, equal_nan=True))


def _same_bits(a: np.ndarray, value: np.generic | np.ndarray) -> bool:
    """Whether every item of the float64 array ``a`` has the bits of the float64 ``value``
    (one comparison of the bits as integers: ``np.array_equal`` costs several calls)."""
    bits = np.asarray(value).view(np.int64)
    return bool((np.ascontiguousarray(a).view(np.int64) == bits).all())


def _new_bytes(nbytes: int) -> np.ndarray:
    """A new ``uint8`` array of ``nbytes`` (what :func:`columns` allocates by default)."""
    return np.empty(nbytes, dtype=np.uint8)


def columns(
    count: int,
    kinds: Sequence[tuple[npt.DTypeLike, int]],
    take: Callable[[int], np.ndarray] = _new_bytes,
) -> list[np.ndarray]:
    """``count``-long arrays, one per ``(dtype, width)`` of ``kinds`` (``width`` 0: ``(count,)``,
    else ``(count, width)``), each contiguous, all views of one allocation, ``take(nbytes)``
    (``uint8``; a new array by default, a pool's block: ``Pool.columns``): numpy backs an
    allocation of 4 MiB or more with huge pages where the system allows, and a fresh array of
    10^5 tracks costs one page fault per 4 KiB otherwise (several ms of a step at N=1000)."""
    sizes = [count * max(width, 1) * np.dtype(kind).itemsize for kind, width in kinds]
    block = take(sum(sizes))
    out, at = [], 0
    for (kind, width), size in zip(kinds, sizes, strict=True):
        view = block[at : at + size].view(kind)
        out.append(view.reshape(count, width) if width else view)
        at += size
    return out


def positions(rows: np.ndarray, index: np.ndarray) -> np.ndarray:
    """``rows[index, :2]`` (a copy, ``(len(index), 2)``) by ``take``: numpy's fancy index of a
    two-column slice is about ten times slower, which counts for the first leg's 10^5 tracks."""
    return rows[:, :2].take(index, axis=0)


def everything(index: np.ndarray, n: int) -> np.ndarray | slice:
    """``index`` (increasing, unique), or a slice when it selects all ``n`` items (no copies)."""
    return slice(None) if len(index) == n else index


def group_starts(slot: np.ndarray) -> np.ndarray:
    """Indices where each run of equal values of ``slot`` starts (``slot`` grouped)."""
    if len(slot) == 0:
        return np.zeros(0, dtype=np.int64)
    new = np.empty(len(slot), dtype=bool)
    new[0] = True
    np.not_equal(slot[1:], slot[:-1], out=new[1:])
    return np.flatnonzero(new)


def group_sizes(slot: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """Length of each run of ``slot`` that starts at ``starts`` (see :func:`group_starts`)."""
    return np.diff(np.append(starts, len(slot)))


def rank_in_group(slot: np.ndarray) -> np.ndarray:
    """Position of each item within its run of equal ``slot`` values (``slot`` grouped)."""
    starts = group_starts(slot)
    return np.arange(len(slot)) - np.repeat(starts, group_sizes(slot, starts))


def add_grouped(total: np.ndarray, slot: np.ndarray, logw: np.ndarray) -> None:
    """``total[i] = logaddexp(total[i], logsumexp(logw[slot == i]))``, ``slot`` grouped."""
    if len(slot) == 0:
        return
    starts = group_starts(slot)
    top = np.maximum.reduceat(logw, starts)
    shift = np.where(np.isfinite(top), top, 0.0)
    sums = np.add.reduceat(np.exp(logw - np.repeat(shift, group_sizes(slot, starts))), starts)
    which = slot[starts]
    total[which] = np.logaddexp(total[which], shift + np.log(sums))


def near_best(slot: np.ndarray, logw: np.ndarray, nats: float) -> tuple[np.ndarray, np.ndarray]:
    """``(keep, floor)``: the indices of the weights ``logw`` at most ``nats`` below the best of
    their robot (``slot`` grouped; never -inf or nan), and each one's floor."""
    starts = group_starts(slot)
    best = np.maximum.reduceat(logw, starts)
    floor = np.repeat(best, group_sizes(slot, starts)) - nats
    return np.flatnonzero(logw >= floor), floor
