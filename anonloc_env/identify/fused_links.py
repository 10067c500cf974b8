"""The others' links compiled (numba, the optional ``fast`` extra; see
:mod:`anonloc_env.compiled`): the association graph's components, every exact component's
leave-out sums, and the weights and continuations read from their logarithms, in two calls
around one numpy ``log`` instead of about forty numpy calls per shape of component
(:func:`anonloc_env.identify.others.links_between`, whose numpy form stays the reference).

The same floats to the bit: the components are labelled by their least index, as
``others._components`` labels them; each component's sums are
:func:`anonloc_env.compiled.leave_out_sums` of its own ``(1, rows, columns)`` weights (a batch of
components of one shape adds ``0 * f`` where another component has an edge: nothing); the
logarithms are numpy's, of the same sums; the weights are the same subtractions in the same
order. The pairs come out in the order of their components, rows and columns (the continuations
already sorted as ``others._sorted_links`` sorts them; the caller sorts the keys).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from anonloc_env import compiled
from anonloc_env.compiled import jit


@jit
def _root(parent: np.ndarray, x: int) -> int:
    """The root of ``x`` (path halving)."""
    while parent[x] != x:
        parent[x] = parent[parent[x]]
        x = parent[x]
    return x


@jit
def _labels(n: int, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Each node's component label: the least node of its component (``n`` nodes, edges
    ``u[k] - v[k]``), by union-find that keeps every root the least node of its set."""
    parent = np.arange(n)
    for k in range(u.shape[0]):
        a, b = _root(parent, u[k]), _root(parent, v[k])
        if a < b:
            parent[b] = a
        elif b < a:
            parent[a] = b
    label = np.empty(n, dtype=np.int64)
    for x in range(n):
        label[x] = _root(parent, x)
    return label


@jit
def _members(label: np.ndarray, lo: int, hi: int, slot: np.ndarray, start: np.ndarray) -> Any:
    """Nodes ``lo:hi`` of exact components, grouped by ``slot[label]`` in increasing order of
    node: ``(members, rank)``, ``rank[x - lo]`` the place of node ``x`` in its component."""
    fill = start[:-1].copy()
    members = np.empty(start[-1], dtype=np.int64)
    rank = np.full(hi - lo, -1, dtype=np.int64)
    for x in range(lo, hi):
        s = slot[label[x]]
        if s >= 0:
            members[fill[s]] = x - lo
            rank[x - lo] = fill[s] - start[s]
            fill[s] += 1
    return members, rank


@jit
def association(
    n_a: int,
    n_b: int,
    i: np.ndarray,
    j: np.ndarray,
    w: np.ndarray,
    w_end: float,
    powers: np.ndarray,
    most: int,
) -> Any:
    """The graph of ``others._Graph.of`` and the leave-out sums of its exact components
    (``others._leave_out_sums``; at most ``most`` rows and columns, ``powers[k, :k + 1]`` =
    ``w_new ** np.arange(k + 1)`` as numpy computes it).

    Returns ``(label, size_a, size_b, comps, rows, cols, w_flat, sums)`` where ``label``
    ``(n_a + n_b,)`` is each row's then each column's component (``comp_a``, ``comp_b``),
    ``size_a`` and ``size_b`` count each label's rows and columns; ``comps`` ``(5, C + 1)``:
    the exact labels in increasing order (row 0, ``-1`` at the end) and where each one's
    rows, columns, weights and sums start in ``rows`` and ``cols`` (its rows' and columns'
    indices, increasing), ``w_flat`` (its ``rows x columns`` edge weights, 0: no edge) and
    ``sums`` (its ``(rows + 1) x (columns + 1)`` leave-out sums)."""
    n = n_a + n_b
    label = _labels(n, i, j + n_a)
    size_a = np.zeros(n, dtype=np.int64)
    size_b = np.zeros(n, dtype=np.int64)
    for x in range(n_a):
        size_a[label[x]] += 1
    for x in range(n_a, n):
        size_b[label[x]] += 1
    slot = np.full(n, -1, dtype=np.int64)
    count = 0
    for c in range(n):
        if 0 < size_a[c] <= most and 0 < size_b[c] <= most:
            slot[c] = count
            count += 1
    comps = np.full((5, count + 1), -1, dtype=np.int64)
    comps[1:, 0] = 0
    s = 0
    for c in range(n):
        if slot[c] >= 0:
            na, nb = size_a[c], size_b[c]
            comps[0, s] = c
            comps[1, s + 1] = comps[1, s] + na
            comps[2, s + 1] = comps[2, s] + nb
            comps[3, s + 1] = comps[3, s] + na * nb
            comps[4, s + 1] = comps[4, s] + (na + 1) * (nb + 1)
            s += 1
    rows, rank_a = _members(label, 0, n_a, slot, comps[1])
    cols, rank_b = _members(label, n_a, n, slot, comps[2])
    w_flat = np.zeros(comps[3, count])
    for k in range(i.shape[0]):
        s = slot[label[i[k]]]
        if s >= 0:
            nb = comps[2, s + 1] - comps[2, s]
            w_flat[comps[3, s] + rank_a[i[k]] * nb + rank_b[j[k]]] = w[k]
    sums = np.empty(comps[4, count])
    for s in range(count):
        na, nb = comps[1, s + 1] - comps[1, s], comps[2, s + 1] - comps[2, s]
        one = w_flat[comps[3, s] : comps[3, s + 1]].copy().reshape((1, na, nb))
        out = compiled.leave_out_sums(one, w_end, powers[nb, : nb + 1].copy())
        sums[comps[4, s] : comps[4, s + 1]] = out.ravel()
    return label, size_a, size_b, comps, rows, cols, w_flat, sums


@jit
def leave_out_links(
    comps: np.ndarray,
    rows: np.ndarray,
    cols: np.ndarray,
    w_flat: np.ndarray,
    sums: np.ndarray,
    logs: np.ndarray,
    n_b: int,
    ends: np.ndarray,
    starts: np.ndarray,
    floor: float,
) -> Any:
    """``others._leave_out_weights`` and ``others._continuations`` of every exact component
    of :func:`association`, ``logs`` = ``np.log(sums)``: fills ``ends`` and ``starts`` of their
    rows and columns in place; returns ``(key, extra, moves, p)``: every pair's ``a * n_b +
    b`` and extra log weight (by component, row, column), and the continuations ``(2, M)``
    ``(a, b)`` with probability ``p`` at least ``floor``, sorted by component, row, column."""
    count = comps.shape[1] - 1
    total = comps[3, count]
    key = np.empty(total, dtype=np.int64)
    extra = np.empty(total)
    moves = np.empty((2, total), dtype=np.int64)
    p = np.empty(total)
    m = 0
    for s in range(count):
        r0, c0, w0, o = comps[1, s], comps[2, s], comps[3, s], comps[4, s]
        na, nb = comps[1, s + 1] - r0, comps[2, s + 1] - c0
        log_z = logs[o]
        for r in range(na):
            ends[rows[r0 + r]] = logs[o + (r + 1) * (nb + 1)] - log_z
        for q in range(nb):
            starts[cols[c0 + q]] = logs[o + q + 1] - log_z
        for r in range(na):
            a = rows[r0 + r]
            for q in range(nb):
                b = cols[c0 + q]
                at = o + (r + 1) * (nb + 1) + q + 1
                k = w0 + r * nb + q
                key[k] = a * n_b + b
                extra[k] = ((logs[at] - log_z) - ends[a]) - starts[b]
                p_move = (w_flat[k] * sums[at]) / sums[o]
                if p_move >= floor:
                    moves[0, m], moves[1, m], p[m] = a, b, p_move
                    m += 1
    return key, extra, moves[:, :m].copy(), p[:m].copy()


@jit
def detect(
    starts: np.ndarray,
    ends: np.ndarray,
    keys: np.ndarray,
    extra: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
    out: np.ndarray,
) -> None:
    """``others.Links.detect`` into ``out`` (the numpy lines it stands for, element by element:
    ``starts[b]`` plus ``ends[a]`` where ``a >= 0`` (plus 0.0 elsewhere, or where there are no
    ends), plus, where there are keys, ``extra`` of the pair's key where it is one (else 0.0))."""
    n_starts, n_keys, n_ends = starts.shape[0], keys.shape[0], ends.shape[0]
    for k in range(a.shape[0]):
        seen = a[k] >= 0
        a0 = a[k] if seen else 0
        end = ends[a0] if seen and n_ends > 0 else 0.0
        value = starts[b[k]] + end
        if n_keys > 0:
            key = a0 * n_starts + b[k]
            at = min(np.searchsorted(keys, key), n_keys - 1)
            value = value + (extra[at] if seen and keys[at] == key else 0.0)
        out[k] = value


def load() -> None:
    """Compile (or load from numba's cache) the kernels on a tiny graph."""
    one = np.zeros(1, dtype=np.int64)
    powers = np.ones((2, 2))
    out = association(1, 1, one, one, np.ones(1), 1.0, powers, 1)
    _, _, _, comps, rows, cols, w_flat, sums = out
    leave_out_links(comps, rows, cols, w_flat, sums, np.log(sums), 1, np.zeros(1), np.zeros(1), 0.1)
    detect(np.zeros(1), np.zeros(1), one, np.zeros(1), one, one, np.zeros(1))
