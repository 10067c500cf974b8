"""Pure numpy helpers shared by the localizers: matching, chaining, scoring, deciding.

Every function takes arrays and returns arrays; none reads an environment.
"""

from __future__ import annotations

import numpy as np

from anonloc_env.geometry import rotate, wrap_angle
from anonloc_env.neighbours import expand_ranges, pairs_within

__all__ = [
    "chain_triples",
    "decide",
    "match_nearest",
    "min_per_column",
    "pairs_within",
    "rotate",
    "scores_to_belief",
    "wrap_angle",
]


def match_nearest(first: np.ndarray, second: np.ndarray, max_distance: float) -> np.ndarray:
    """For each point of ``second`` ``(m, 2)``, the index of the nearest point of ``first``
    ``(n, 2)`` within ``max_distance``, or -1. Near-linear (spatial hashing)."""
    i, j, dist = pairs_within(first, second, max_distance)
    match = np.full(len(second), -1, dtype=np.int64)
    if len(i):
        order = np.lexsort((dist, j))  # by second point, nearest first
        first_of = np.ones(len(order), bool)
        first_of[1:] = j[order][1:] != j[order][:-1]
        best = order[first_of]
        match[j[best]] = i[best]
    return match


def chain_triples(
    p0: np.ndarray, p1: np.ndarray, p2: np.ndarray, reach01: float, reach12: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """All index triples ``(a, b, c)`` with ``|p1[b] - p0[a]| <= reach01`` and
    ``|p2[c] - p1[b]| <= reach12``: tracks across three pictures, found in near-linear time."""
    a, b, _ = pairs_within(p0, p1, reach01)
    b2, c, _ = pairs_within(p1, p2, reach12)
    if len(a) == 0 or len(b2) == 0:
        empty = np.zeros(0, np.int64)
        return empty, empty, empty
    start = np.searchsorted(b2, b, side="left")
    stop = np.searchsorted(b2, b, side="right")
    counts = stop - start
    second = expand_ranges(start, counts)
    return np.repeat(a, counts), np.repeat(b, counts), c[second]


def min_per_column(values: np.ndarray, columns: np.ndarray, n_columns: int) -> np.ndarray:
    """``(R, n_columns)``: for every robot the smallest of ``values[:, k]`` over the ``k`` with
    ``columns[k] == c`` (``inf`` for a column no ``k`` reaches). One sort and one
    ``minimum.reduceat`` (``np.minimum.at`` is far slower on large arrays)."""
    out = np.full((values.shape[0], n_columns), np.inf)
    if values.shape[1] == 0:
        return out
    order = np.argsort(columns, kind="stable")
    sorted_columns = columns[order]
    starts = np.flatnonzero(np.r_[True, sorted_columns[1:] != sorted_columns[:-1]])
    out[:, sorted_columns[starts]] = np.minimum.reduceat(values[:, order], starts, axis=1)
    return out


def scores_to_belief(chi2: np.ndarray) -> np.ndarray:
    """Rows' beliefs from chi-square scores ``(R, n)`` (inf: impossible): ``exp(-chi2 / 2)``,
    normalised per robot; all-impossible rows give a uniform belief."""
    chi2 = np.atleast_2d(np.asarray(chi2, dtype=np.float64))
    if chi2.shape[1] == 0:
        return chi2.copy()
    best = np.min(chi2, axis=1, keepdims=True)
    finite = np.isfinite(best)
    weights = np.where(finite, np.exp(-0.5 * (chi2 - np.where(finite, best, 0.0))), 1.0)
    return weights / weights.sum(axis=1, keepdims=True)


def decide(chi2: np.ndarray, threshold: float, margin: float = 0.0) -> np.ndarray:
    """Per robot, the row with the smallest score if it is at most ``threshold`` and every other
    row scores at least ``margin`` more (0: the smallest wins however close), else -1."""
    chi2 = np.atleast_2d(np.asarray(chi2, dtype=np.float64))
    if chi2.shape[1] == 0:
        return np.full(len(chi2), -1, dtype=np.int64)
    best = np.argmin(chi2, axis=1)
    lowest = chi2[np.arange(len(chi2)), best]
    ok = lowest <= threshold
    if margin > 0.0 and chi2.shape[1] > 1:
        runner_up = np.partition(chi2, 1, axis=1)[:, 1]
        ok &= runner_up - lowest >= margin
    return np.where(ok, best, -1)
