"""The least-cost one-to-one pairing of two sets, where leaving an element unpaired has a cost.

The registration (:mod:`anonloc_env.identify.camera_pose`) pairs the rows of a new picture with
the places where it guesses the previous picture's robots are now. Taking mutual nearest
neighbours pairs a row with another robot's place whenever that place is nearest, even where
pairing both rows with their second nearest places explains the picture better as a whole; the
least-cost pairing weighs every pair against the others (``docs/drone.md``, Round 15).

:func:`least_cost_pairs` solves it exactly by the Hungarian method (shortest augmenting paths
with potentials, in Jonker and Volgenant's form), one row at a time, on the candidate pairs
alone: each row has its candidates and a column of its own that stands for leaving it
unpaired, so a search from a row touches only the rows and columns linked to it. The search is
:func:`augment`, compiled where the kernels are (:mod:`anonloc_env.compiled`; a drone's picture
of 1,000 robots in a few milliseconds) and the same function, run as plain Python, elsewhere.
"""

from __future__ import annotations

import numpy as np

from anonloc_env import compiled
from anonloc_env.compiled import jit


def least_cost_pairs(
    i: np.ndarray, j: np.ndarray, cost: np.ndarray, n_rows: int, n_cols: int, unpaired: float
) -> np.ndarray:
    """Which candidate pairs ``(i[k], j[k])`` (rows ``0..n_rows-1``, columns ``0..n_cols-1``)
    to take so that each row and each column is in at most one pair and the total cost is
    least: ``cost[k]`` for each pair taken, plus ``unpaired`` for each row and each column left
    without one (a pair is worth taking only if its cost is under ``2 unpaired``).

    Returns:
        ``(K,)`` bool, the pairs taken.
    """
    i = np.asarray(i, dtype=np.int64)
    j = np.asarray(j, dtype=np.int64)
    taken = np.zeros(len(i), bool)
    # Relative to leaving both unpaired; a pair that does not gain is never taken.
    relative = np.asarray(cost, dtype=np.float64) - 2.0 * unpaired
    worth = np.flatnonzero(relative < 0.0)
    if len(worth) == 0:
        return taken
    worth = worth[np.argsort(i[worth], kind="stable")]
    starts = np.searchsorted(i[worth], np.arange(n_rows + 1))
    compiled.mode()  # the kernels replace augment, if they are used
    owner = augment(starts, j[worth], relative[worth], n_rows, n_cols)
    col_of = np.full(n_rows, -1, np.int64)
    paired = owner[:n_cols] >= 0
    col_of[owner[:n_cols][paired]] = np.flatnonzero(paired)
    taken[worth[col_of[i[worth]] == j[worth]]] = True
    return taken


@jit
def augment(
    starts: np.ndarray, cols: np.ndarray, costs: np.ndarray, n_rows: int, n_cols: int
) -> np.ndarray:
    """The least-cost assignment of every row to a distinct column, row ``r``'s candidates
    ``cols[starts[r]:starts[r + 1]]`` at ``costs`` (< 0) and its own column ``n_cols + r`` at
    0 (unpaired). Returns ``(n_cols + n_rows,)`` each column's row (-1: none)."""
    size = n_cols + n_rows
    # 1-based columns, as in the usual form of the method; column 0 is the search's root.
    u = np.zeros(n_rows + 1)
    v = np.zeros(size + 1)
    owner = np.zeros(size + 1, np.int64)
    way = np.zeros(size + 1, np.int64)
    least = np.full(size + 1, np.inf)
    used = np.zeros(size + 1, np.bool_)
    touched = np.zeros(size + 1, np.int64)
    for row in range(1, n_rows + 1):
        owner[0] = row
        col = 0
        count = 0
        while True:
            used[col] = True
            here = owner[col]
            first, last = starts[here - 1], starts[here]
            for k in range(first, last + 1):
                c = cols[k] + 1 if k < last else n_cols + here
                cost = costs[k] if k < last else 0.0
                if not used[c]:
                    reduced = cost - u[here] - v[c]
                    if reduced < least[c]:
                        if least[c] == np.inf:
                            touched[count] = c
                            count += 1
                        least[c] = reduced
                        way[c] = col
            delta = np.inf
            nxt = 0
            for t in range(count):
                c = touched[t]
                if not used[c] and least[c] < delta:
                    delta = least[c]
                    nxt = c
            u[owner[0]] += delta
            for t in range(count):
                c = touched[t]
                if used[c]:
                    u[owner[c]] += delta
                    v[c] -= delta
                else:
                    least[c] -= delta
            col = nxt
            if owner[col] == 0:
                break
        while col:
            prev = way[col]
            owner[col] = owner[prev]
            col = prev
        used[0] = False
        for t in range(count):
            least[touched[t]] = np.inf
            used[touched[t]] = False
    return owner[1:] - 1
