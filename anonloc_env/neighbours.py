"""Fixed-radius neighbour search between two point sets, in numpy alone.

A uniform grid (spatial hashing) with cells as wide as the search radius: each point of ``a`` only
looks at the points of ``b`` in its own cell and the 8 around it (three ranges of consecutive cell
keys, one per column). For points spread over an image this costs O((n + m) log m) with no Python
loop over points, like a k-d tree query, and needs no scipy (the environment's reward uses it).
"""

from __future__ import annotations

import numpy as np

from anonloc_env import compiled

#: Up to this many pairs (``len(a) * len(b)``), the compiled search looks at every pair.
_LOOK_AT_ALL = 4096


def expand_ranges(starts: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Concatenate ``range(s, s + c)`` for every ``(s, c)``, vectorised."""
    counts = np.asarray(counts, dtype=np.int64)
    total = int(counts.sum())
    if total == 0:
        return np.zeros(0, dtype=np.int64)
    ends = np.cumsum(counts)
    shift = np.repeat(np.asarray(starts, dtype=np.int64) - (ends - counts), counts)
    return np.arange(total, dtype=np.int64) + shift


def pairs_within(
    a: np.ndarray, b: np.ndarray, radius: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every pair ``(i, j)`` with ``|a[i] - b[j]| <= radius``.

    Args:
        a: ``(n, 2)`` points.
        b: ``(m, 2)`` points.
        radius: search radius (same units), > 0.

    Returns:
        ``(i, j, distance)``: int64, int64 and float64 arrays, sorted by ``i`` then ``j``.
    """
    empty = (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0))
    if len(a) == 0 or len(b) == 0 or not radius > 0.0:
        return empty
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if len(a) * len(b) <= _LOOK_AT_ALL and compiled.mode() is not None:
        # The same arrays in one call (contiguous inputs: one compiled form for every caller).
        return compiled.pairs_within(
            np.ascontiguousarray(a), np.ascontiguousarray(b), float(radius)
        )
    origin = np.minimum(a.min(axis=0), b.min(axis=0)) - radius
    cell_a = np.floor((a - origin) / radius).astype(np.int64)
    cell_b = np.floor((b - origin) / radius).astype(np.int64)
    stride = int(max(cell_a[:, 1].max(), cell_b[:, 1].max())) + 3
    key_b = cell_b[:, 0] * stride + cell_b[:, 1]
    order = np.argsort(key_b, kind="stable")
    sorted_keys = key_b[order]
    key_a = cell_a[:, 0] * stride + cell_a[:, 1]
    found_i, found_j = [], []
    for dx in (-1, 0, 1):  # the three cells of a column are consecutive keys: one range each
        keys = key_a + dx * stride
        lo = np.searchsorted(sorted_keys, keys - 1, side="left")
        hi = np.searchsorted(sorted_keys, keys + 1, side="right")
        counts = hi - lo
        found_i.append(np.repeat(np.arange(len(a)), counts))
        found_j.append(order[expand_ranges(lo, counts)])
    i = np.concatenate(found_i)
    j = np.concatenate(found_j)
    dist = np.hypot(*(b[j] - a[i]).T)
    keep = dist <= radius
    i, j, dist = i[keep], j[keep], dist[keep]
    sort = np.argsort(i * len(b) + j, kind="stable")  # by i, then j (three sorted runs)
    return i[sort], j[sort], dist[sort]


def pairs_within_each(
    a: np.ndarray, b: np.ndarray, radius: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every pair ``(i, j)`` with ``|a[i] - b[j]| <= radius[i]``: :func:`pairs_within` for the
    points of ``a`` grouped by radius (within a factor 2), so that a few wide ones do not widen
    the search of all. Sorted by ``i`` then ``j``, as :func:`pairs_within`. Up to
    :data:`_LOOK_AT_ALL` pairs of finite points and radii, one compiled call
    (``compiled.pairs_within_each``: the same groups, cells and arrays)."""
    radius = np.asarray(radius, dtype=np.float64)
    if len(a) == 0 or len(b) == 0:
        return (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0))
    level = np.floor(np.log2(np.maximum(radius, 1e-9))).astype(np.int64)
    if (
        len(a) * len(b) <= _LOOK_AT_ALL
        and compiled.mode() is not None
        and np.isfinite(radius).all()
        and np.isfinite(a).all()
        and np.isfinite(b).all()
    ):  # the same arrays in one call
        a, b = (np.ascontiguousarray(x, dtype=np.float64) for x in (a, b))
        return compiled.pairs_within_each(a, b, np.ascontiguousarray(radius), level)
    found = []
    for lvl in np.sort(np.asarray(list(set(level.tolist())))).tolist():
        members = np.flatnonzero(level == lvl)
        i, j, dist = pairs_within(a[members], b, float(radius[members].max()))
        near = dist <= radius[members][i]
        found.append((members[i[near]], j[near], dist[near]))
    i = np.concatenate([f[0] for f in found])
    j = np.concatenate([f[1] for f in found])
    dist = np.concatenate([f[2] for f in found])
    sort = np.argsort(i * len(b) + j, kind="stable")
    return i[sort], j[sort], dist[sort]
