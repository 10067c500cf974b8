"""The other robots persist: what a robot's own link between two pictures says about the others.

The clutter model weighs "row ``b`` is me" by ``P_D f / lambda`` and "I was missed" by
``1 - P_D`` whatever the other rows are: the other detections are drawn afresh at every picture.
But the other robots persist. With misses, a rival track that fits my odometry (another robot
standing still, say) gains ``P_D f / lambda`` at a picture where my own row was missed, about a
thousand times what my true track keeps (``1 - P_D``): the model explains the rival's row as
fresh clutter, not as a robot that was there one picture ago. Under persistence, claiming the
rival's row leaves the rival robot gone and my own previous row without a continuation.

Model of the others between consecutive pictures ``k - 1`` and ``k`` (an association): every row
``a`` of ``k - 1`` continues to one row ``b`` of ``k`` (weight ``W(a, b) = share P_D g(b - a)``,
``g`` an isotropic Gaussian of the others' displacement, cut at :data:`CUTOFF_SIGMAS`; ``share``
the expected fraction of rows that are robots) or ends (``W_end = 1 - share P_D (1 - tail)``:
a false positive, a robot missed now, or a robot whose move fell beyond the cut, ``tail`` the
Gaussian's mass there); every row ``b`` not continued is new (density ``W_new``: false positives,
robots missed before, and the moves beyond the cut). ``Z`` sums the weights of every such
association. My link ``a -> b`` leaves the others the association without ``a`` and ``b``, so it
weighs ``Z(-a, -b) / Z`` in place of the clutter model's ``1 / lambda``; ``a -> missed`` weighs
``Z(-a) / Z`` instead of ``1``; a track missed at ``k - 1`` (but seen before) and seen at ``b``
weighs ``Z(-b) / Z``. A robot whose position was never known ("nothing known", the filter's
implicit weights) keeps the clutter model: ``1 / lambda`` for a row, ``1`` for a miss. A track is
weighed link by link (a chain over consecutive pictures, not the exact joint over all of them).
The weights are functions of the pictures alone, so the exact reference
(:mod:`anonloc_env.identify.reference`) takes the very same ones.

The others' displacement repeats (``model.others_repeat``, with ``before``, the previous pair
of pictures' links): robots keep their commands for a while, and one that turns in place after
a bump stays put. Row ``a`` of ``k - 1`` continued row ``a'`` of ``k - 2`` with probability
``p(a', a)`` in the previous association (``W(a', a) Z(-a', -a) / Z``, kept above
:data:`MOVE_FLOOR`); with probability ``others_repeat p(a', a)`` it now repeats that displacement
(a Gaussian about ``a + (a - a')``, ``others_jitter`` plus ``others_turn`` of its length wide per
component, plus six pixel variances), and with the rest it is drawn afresh as above. Why: on the
clutter benchmark the broad Gaussian (0.25 m from the top speed) treats a robot that has stood
still for five pictures as one that could be anywhere within its reach, so where my own row was
missed, a rival track that fits my odometry (both nearly still) still outweighed the others'
continuation. With the repeats (fitted on true tracks:
:data:`anonloc_env.identify.model.OTHERS_REPEAT`), confident decisions wrong fell from
127 / 12046 (1.05 %) to 58 / 11896 (0.49 %; the linked bound: 0.39 %), right at the 10th
picture 95.1 -> 95.3 % (60 episodes). The chain stays a chain: a
row's history enters only through its previous link's marginal, so it remains a function of
the pictures alone, the same in the identifier and the reference. An online estimate of
``others_sigma`` from the association's own displacements was not tried: the displacements are
heavy-tailed (a quarter nearly still, the rest up to the top speed), which one Gaussian width
cannot describe, and the repeats already say it per row.

``Z`` is a sum over the partial matchings of a sparse bipartite graph: it factors over the
graph's connected components, each summed exactly by dynamic programming over its columns. A
component with more than :data:`MAX_COMPONENT` rows or columns keeps the clutter model for its
rows (rare where the model is used: see below).

Where it is used (:func:`persists`): only when the robot count and the others' motion are known
and a picture can miss a robot or hold a false positive (``p_detect < 1`` or
``false_positives > 0``). With every robot seen and no false positives the association is nearly
a perfect matching: a single pair of the others that moved beyond the modelled reach (a push)
then makes the true hypothesis as unlikely as a wrong one, and measured on the ``dense``
benchmark (N = 100) an earlier version of this model made 291 of 3819 confident decisions
wrong. There the clutter model is already at the linked bound, so nothing is lost by keeping it.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from anonloc_env import compiled
from anonloc_env.identify import fused_links
from anonloc_env.identify.model import SensorModel
from anonloc_env.neighbours import pairs_within

#: Largest component (rows or columns) summed exactly; larger ones keep the clutter model.
MAX_COMPONENT = 8
#: The others' displacement density is cut at this many standard deviations (its mass beyond
#: the cut, 4.4 %, is counted as a row that ends and one that is new).
CUTOFF_SIGMAS = 2.5
#: Least weight of "a row of the previous picture ends" and of "a new row" (relative to the
#: expected count of new rows): no association of the others is ever ruled out.
END_FLOOR = 1e-3
NEW_FLOOR = 0.05
#: Least probability of a row's continuation kept for the next link (``Links.moved``).
MOVE_FLOOR = 1e-3
_INT64 = np.dtype(np.int64)
_FLOAT64 = np.dtype(np.float64)


def persists(model: SensorModel) -> bool:
    """Whether ``model`` lets the other robots persist (see the module docstring)."""
    return (
        model.n_robots is not None
        and model.others_sigma is not None
        and (model.p_detect < 1.0 or model.false_positives > 0.0)
    )


@dataclass(frozen=True)
class Links:
    """Log weights of my link between the previous picture and the newest one, in place of the
    clutter model's ``-log lambda`` for a detection and ``0`` for a miss:

    * ``a -> b``: ``ends[a] + starts[b] + pair(a, b)`` (``pair`` is zero unless ``a`` and ``b``
      share a component);
    * ``a -> missed``: ``ends[a]``; missed before (position known) ``-> b``: ``starts[b]``.

    Attributes:
        ends: ``(n_prev,)``, ``log Z(-a) / Z``.
        starts: ``(n,)``, ``log Z(-b) / Z``.
        keys: sorted ``a * n + b`` of the pairs that share a component; ``extra`` their
            ``log Z(-a, -b) Z / (Z(-a) Z(-b))``.
        moved_row, moved, moved_p: how the newest picture's rows moved, for the next link
            (:data:`MOVE_FLOOR`): row ``moved_row[m]`` continues a row of the previous picture
            that lies ``moved[m]`` (image units) behind it with probability ``moved_p[m]`` in
            the association of the others.
    """

    ends: np.ndarray
    starts: np.ndarray
    keys: np.ndarray
    extra: np.ndarray
    moved_row: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    moved: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    moved_p: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def detect(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """``(K,)`` log weight of links ``a[k] -> b[k]`` (``a[k] < 0``: missed before); one
        compiled call (``fused_links.detect``, the same floats) for int64 ``a`` and ``b``."""
        a = np.asarray(a)
        b = np.asarray(b)
        if (
            a.dtype == _INT64
            and b.dtype == _INT64
            and a.ndim == 1
            and a.shape == b.shape
            and self.keys.dtype == _INT64
            and self.starts.dtype == self.ends.dtype == self.extra.dtype == _FLOAT64
            and compiled.mode() is not None
        ):
            out = np.empty(len(a))
            fused_links.detect(self.starts, self.ends, self.keys, self.extra, a, b, out)
            return out
        seen = a >= 0
        a0 = np.where(seen, a, 0)
        out = self.starts[b] + np.where(seen, self.ends[a0] if len(self.ends) else 0.0, 0.0)
        if len(self.keys):
            key = a0.astype(np.int64) * len(self.starts) + b
            at = np.minimum(np.searchsorted(self.keys, key), len(self.keys) - 1)
            hit = seen & (self.keys[at] == key)
            out = out + np.where(hit, self.extra[at], 0.0)
        return out

    def miss(self, a: np.ndarray) -> np.ndarray:
        """``(K,)`` log weight of "row ``a[k]`` was me, now missed" (``a[k] < 0``: 0)."""
        a = np.asarray(a)
        if len(self.ends) == 0:
            return np.zeros(len(a))
        return np.where(a >= 0, self.ends[np.maximum(a, 0)], 0.0)


def links_between(
    model: SensorModel,
    prev: np.ndarray,
    rows: np.ndarray,
    log_bg: float,
    pix_var: float,
    before: Links | None = None,
) -> Links | None:
    """The :class:`Links` between pictures ``prev`` and ``rows`` (``(n, >= 2)`` image rows), or
    ``None`` where the model keeps the clutter model (:func:`persists` is false).

    Args:
        model: the sensor model.
        prev, rows: the previous picture and the newest one.
        log_bg: ``log lambda`` of the newest picture (the clutter model, for big components).
        pix_var: pixel variance per component (image units^2).
        before: the links between the picture before ``prev`` and ``prev`` (``None``: none):
            how ``prev``'s rows moved, repeated with ``model.others_repeat``.

    Raises:
        ValueError: ``before`` does not end at ``prev`` (its ``starts`` are not one per row).
    """
    if not persists(model):
        return None
    n_a, n_b = len(prev), len(rows)
    if before is not None and len(before.starts) != n_a:
        raise ValueError(f"before must link to prev ({n_a} rows), got {len(before.starts)} starts")
    ends, starts = np.zeros(n_a), np.full(n_b, -log_bg)
    empty = Links(ends, starts, np.zeros(0, np.int64), np.zeros(0))  # ends, starts filled below
    if n_a == 0 or n_b == 0:
        return empty
    w_move, w_end, w_new = _association_weights(model)
    i, j, w_pair = _edges(model, prev, rows, pix_var, before)
    if compiled.mode() is not None:  # the same floats, two calls
        return _links_compiled(n_a, i, j, w_move * w_pair, (w_end, w_new, log_bg), prev, rows)
    graph = _Graph.of(n_a, n_b, i, j, w_move * w_pair)
    sizes = (graph.comp_a, graph.comp_b, graph.size_a, graph.size_b)
    exact = _lone_and_big_weights(sizes, w_end, w_new, log_bg, ends, starts)
    if not exact.any():
        return empty
    keys, extra, moved = [], [], []
    shapes = graph.size_a[exact] * (MAX_COMPONENT + 1) + graph.size_b[exact]
    for shape in _distinct(shapes)[0].tolist():
        comps = np.flatnonzero(exact)[shapes == shape]  # increasing labels
        ra, cb, w = graph.stacked(comps, *divmod(shape, MAX_COMPONENT + 1))
        sums = _leave_out_sums(w, w_end, w_new)
        key, value = _leave_out_weights(sums, ra, cb, n_b, ends, starts)
        keys.append(key)
        extra.append(value)
        moved.append(_continuations(w, sums, ra, cb, comps))
    return _sorted_links(ends, starts, keys, extra, moved, prev, rows)


def _association_weights(model: SensorModel) -> tuple[float, float, float]:
    """``(share P_D, W_end, W_new)``: a continuation's weight per unit of ``g``, a row's that
    ends, and a new row's density (see the module docstring)."""
    assert model.n_robots is not None
    p_d = min(model.p_detect, 1.0 - 1e-6)
    others = model.n_robots - 1
    robots = others * p_d
    share = robots / max(robots + model.false_positives, 1e-12)
    tail = math.exp(-0.5 * CUTOFF_SIGMAS**2)
    w_end = max(1.0 - share * p_d * (1.0 - tail), END_FLOOR)
    new = model.false_positives + others * p_d * ((1.0 - p_d) + tail)
    w_new = max(new, NEW_FLOOR) / model.image_area
    return share * p_d, w_end, w_new


@dataclass(frozen=True)
class _Graph:
    """The association's bipartite graph: edges ``i[k] - j[k]`` of weight ``w[k]`` (sorted by
    ``i`` then ``j``), the component label of every row (``comp_a``) and column (``comp_b``),
    and each label's count of rows (``size_a``) and columns (``size_b``)."""

    i: np.ndarray
    j: np.ndarray
    w: np.ndarray
    comp_a: np.ndarray
    comp_b: np.ndarray
    size_a: np.ndarray
    size_b: np.ndarray

    @classmethod
    def of(cls, n_a: int, n_b: int, i: np.ndarray, j: np.ndarray, w: np.ndarray) -> _Graph:
        """The graph of ``n_a`` rows and ``n_b`` columns with edges ``i - j`` weighing ``w``."""
        comp_a, comp_b = _components(n_a, n_b, i, j)
        size_a = np.bincount(comp_a, minlength=n_a + n_b)
        size_b = np.bincount(comp_b, minlength=n_a + n_b)
        return cls(i, j, w, comp_a, comp_b, size_a, size_b)

    def stacked(
        self, comps: np.ndarray, na: int, nb: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(rows, columns, w)`` of components ``comps`` (increasing labels), each of ``na``
        rows and ``nb`` columns: ``(C, na)`` and ``(C, nb)`` indices by label then index, and
        the ``(C, na, nb)`` edge weights (0: no edge)."""
        comp_a, comp_b, i, j = self.comp_a, self.comp_b, self.i, self.j
        slot = np.full(len(comp_a) + len(comp_b), -1)
        slot[comps] = np.arange(len(comps))
        in_a = np.flatnonzero(slot[comp_a] >= 0)
        ra = in_a[np.lexsort((in_a, comp_a[in_a]))].reshape(len(comps), na)
        in_b = np.flatnonzero(slot[comp_b] >= 0)
        cb = in_b[np.lexsort((in_b, comp_b[in_b]))].reshape(len(comps), nb)
        w = np.zeros((len(comps), na, nb))
        e = np.flatnonzero(slot[comp_a[i]] >= 0)
        rank_a, rank_b = self.rank_a, self.rank_b
        w[slot[comp_a[i[e]]], rank_a[i[e]], rank_b[j[e]]] = self.w[e]
        return ra, cb, w

    @cached_property
    def rank_a(self) -> np.ndarray:
        """Each row's position among its component's rows, in increasing order."""
        return _rank_in_label(self.comp_a)

    @cached_property
    def rank_b(self) -> np.ndarray:
        """Each column's position among its component's columns, in increasing order."""
        return _rank_in_label(self.comp_b)


def _lone_and_big_weights(
    sizes: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    w_end: float,
    w_new: float,
    log_bg: float,
    ends: np.ndarray,
    starts: np.ndarray,
) -> np.ndarray:
    """Fill ``ends`` and ``starts`` (in place) for every row and column, exact for those alone
    and the clutter model's in components too big; return which labels are summed exactly.
    ``sizes``: the graph's ``comp_a``, ``comp_b``, ``size_a`` and ``size_b`` (:class:`_Graph`)."""
    comp_a, comp_b, size_a, size_b = sizes
    # A row alone: Z = w_end, Z(-a) = 1. A column alone: Z(-b) / Z = 1 / w_new.
    ends[:] = -math.log(w_end)
    starts[:] = -math.log(w_new)
    joined = (size_a > 0) & (size_b > 0)
    big = joined & ((size_a > MAX_COMPONENT) | (size_b > MAX_COMPONENT))
    # A component too big to sum exactly keeps the clutter model for its rows.
    ends[big[comp_a]] = 0.0
    starts[big[comp_b]] = -log_bg
    return joined & ~big


def _links_compiled(
    n_a: int,
    i: np.ndarray,
    j: np.ndarray,
    w: np.ndarray,
    weights: tuple[float, float, float],
    prev: np.ndarray,
    rows: np.ndarray,
) -> Links:
    """:func:`links_between` from the graph's edges ``i - j`` of weight ``w`` on, by the
    kernels of :mod:`~anonloc_env.identify.fused_links` (the same floats); ``weights``: ``W_end``,
    ``W_new`` and ``log lambda``."""
    w_end, w_new, log_bg = weights
    n_b = len(rows)
    ends, starts = np.zeros(n_a), np.zeros(n_b)
    out = fused_links.association(n_a, n_b, i, j, w, w_end, _powers(w_new), MAX_COMPONENT)
    label, size_a, size_b, comps, ra, cb, w_flat, sums = out
    sizes = (label[:n_a], label[n_a:], size_a, size_b)
    _lone_and_big_weights(sizes, w_end, w_new, log_bg, ends, starts)
    if comps.shape[1] == 1:  # no component summed exactly
        return Links(ends, starts, np.zeros(0, np.int64), np.zeros(0))
    logs = np.log(sums)
    key, extra, moves, p = fused_links.leave_out_links(
        comps, ra, cb, w_flat, sums, logs, n_b, ends, starts, MOVE_FLOOR
    )
    order = np.argsort(key, kind="stable")
    frm, to = moves
    moved = rows[to, :2] - prev[frm, :2]
    return Links(ends, starts, key[order], extra[order], moved_row=to, moved=moved, moved_p=p)


@functools.lru_cache(maxsize=64)
def _powers(w_new: float) -> np.ndarray:
    """``(MAX_COMPONENT + 1, MAX_COMPONENT + 1)``: row ``k`` starts with ``w_new **
    np.arange(k + 1)``, the table :func:`_leave_out_sums` takes for ``k`` columns."""
    table = np.zeros((MAX_COMPONENT + 1, MAX_COMPONENT + 1))
    for k in range(MAX_COMPONENT + 1):
        table[k, : k + 1] = w_new ** np.arange(k + 1)
    table.flags.writeable = False
    return table


def _leave_out_weights(
    sums: np.ndarray, ra: np.ndarray, cb: np.ndarray, n_b: int, ends: np.ndarray, starts: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Fill ``ends`` and ``starts`` (in place) of rows ``ra`` and columns ``cb`` from their
    components' leave-out ``sums``; return their pairs' keys ``a * n_b + b`` and ``extra``."""
    z, z_a, z_b, z_ab = sums[:, 0, 0], sums[:, 1:, 0], sums[:, 0, 1:], sums[:, 1:, 1:]
    log_z = np.log(z)[:, None]
    ends[ra] = np.log(z_a) - log_z
    starts[cb] = np.log(z_b) - log_z
    key = (ra[:, :, None] * n_b + cb[:, None, :]).ravel()
    extra = np.log(z_ab) - log_z[:, :, None] - ends[ra][:, :, None] - starts[cb][:, None, :]
    return key, extra.ravel()


def _continuations(
    w: np.ndarray, sums: np.ndarray, ra: np.ndarray, cb: np.ndarray, comps: np.ndarray
) -> np.ndarray:
    """``(M, 4)`` rows ``(label, a, b, p)``: each continuation ``a -> b`` of components
    ``comps`` whose probability ``p = W(a, b) Z(-a, -b) / Z`` in the association is at least
    :data:`MOVE_FLOOR`."""
    p_move = (w * sums[:, 1:, 1:] / sums[:, 0, 0][:, None, None]).ravel()
    frm = np.broadcast_to(ra[:, :, None], w.shape).ravel()
    to = np.broadcast_to(cb[:, None, :], w.shape).ravel()
    label = np.broadcast_to(comps[:, None, None], w.shape).ravel()
    keep = p_move >= MOVE_FLOOR
    return np.stack([label[keep], frm[keep], to[keep], p_move[keep]], 1)


def _sorted_links(
    ends: np.ndarray,
    starts: np.ndarray,
    keys: list[np.ndarray],
    extra: list[np.ndarray],
    moved: list[np.ndarray],
    prev: np.ndarray,
    rows: np.ndarray,
) -> Links:
    """The :class:`Links` of the exact sums: the pairs sorted by key, the continuations by
    component, row and column."""
    key = np.concatenate(keys).astype(np.int64)
    value = np.concatenate(extra)
    order = np.argsort(key, kind="stable")
    move = np.concatenate(moved)
    move = move[np.lexsort((move[:, 2], move[:, 1], move[:, 0]))]  # by component, row, column
    frm, to = move[:, 1].astype(np.int64), move[:, 2].astype(np.int64)
    return Links(
        ends,
        starts,
        key[order],
        value[order],
        moved_row=to,
        moved=rows[to, :2] - prev[frm, :2],
        moved_p=move[:, 3],
    )


def _edges(
    model: SensorModel, prev: np.ndarray, rows: np.ndarray, pix_var: float, before: Links | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(a, b, g)``: the pairs of the association's graph and the others' displacement density
    ``g(b - a)`` (image units^-2) of each, sorted by ``a`` then ``b``.

    Drawn afresh, ``g`` is an isotropic Gaussian of ``others_sigma``; with ``others_repeat``, a
    row that continued row ``a'`` of the picture before with probability ``p`` (``before``)
    repeats that displacement with probability ``others_repeat p``: a Gaussian about it,
    ``others_jitter`` plus ``others_turn`` of its length wide (plus the six pixel variances of
    three positions). Each part is cut at :data:`CUTOFF_SIGMAS` (the same mass beyond the cut).
    """
    assert model.others_sigma is not None
    scale = model.scale_bounds[1]
    n_b = len(rows)
    var = (scale * model.others_sigma) ** 2 + 2.0 * pix_var
    i, j, dist = pairs_within(prev[:, :2], rows[:, :2], CUTOFF_SIGMAS * math.sqrt(var))
    g = np.exp(-0.5 * dist**2 / var) / (2.0 * math.pi * var)
    if before is None or model.others_repeat == 0.0 or len(before.moved_row) == 0:
        return i, j, g
    at, d = before.moved_row, before.moved
    repeat = model.others_repeat * before.moved_p
    var_e = (
        (scale * model.others_jitter) ** 2
        + (model.others_turn * np.hypot(d[:, 0], d[:, 1])) ** 2
        + 6.0 * pix_var
    )
    cut = CUTOFF_SIGMAS * np.sqrt(var_e)
    e, j_e, dist_e = pairs_within(prev[at, :2] + d, rows[:, :2], float(cut.max()))
    near = dist_e <= cut[e]
    e, j_e, dist_e = e[near], j_e[near], dist_e[near]
    g_e = repeat[e] * np.exp(-0.5 * dist_e**2 / var_e[e]) / (2.0 * math.pi * var_e[e])
    afresh = 1.0 - np.bincount(at, weights=repeat, minlength=len(prev))
    key, where = _distinct(np.concatenate([i * n_b + j, at[e] * n_b + j_e]))
    total = np.bincount(where, weights=np.concatenate([afresh[i] * g, g_e]), minlength=len(key))
    return key // n_b, key % n_b, total


def _components(n_a: int, n_b: int, i: np.ndarray, j: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Component label of every row (``n_a``) and column (``n_b``) of the bipartite graph with
    edges ``i[k] - j[k]`` (labels index ``0 .. n_a + n_b - 1``)."""
    label = np.arange(n_a + n_b)
    u, v = i, j + n_a
    while True:
        low = np.minimum(label[u], label[v])
        new = label.copy()
        np.minimum.at(new, u, low)
        np.minimum.at(new, v, low)
        new = new[new]  # jump to the label's label
        if np.array_equal(new, label):
            return label[:n_a], label[n_a:]
        label = new


def _distinct(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(values, return_inverse=True)``, without ``np.unique``: its first call in a
    process imports ``numpy.ma`` (15 ms)."""
    order = np.argsort(values, kind="stable")
    ordered = values[order]
    new = np.empty(len(values), dtype=bool)
    new[:1] = True
    np.not_equal(ordered[1:], ordered[:-1], out=new[1:])
    where = np.empty(len(values), dtype=np.int64)
    where[order] = np.cumsum(new) - 1
    return ordered[new], where


def _rank_in_label(label: np.ndarray) -> np.ndarray:
    """Position of each index among the indices that carry its label, in increasing order."""
    order = np.argsort(label, kind="stable")
    sorted_label = label[order]
    start = np.searchsorted(sorted_label, sorted_label, side="left")
    rank = np.empty(len(label), dtype=np.int64)
    rank[order] = np.arange(len(label)) - start
    return rank


def _sum_matchings(
    w: np.ndarray, w_end: float, w_new: float, skip_row: int = -1, skip_col: int = -1
) -> float:
    """Sum over the partial matchings of ``w`` (rows x columns, 0: no edge) of the product of
    the matched weights, ``w_end`` per unmatched row and ``w_new`` per unmatched column; row
    ``skip_row`` and column ``skip_col`` left out. One entry of :func:`_leave_out_sums`."""
    return float(_leave_out_sums(w[None], w_end, w_new)[0, skip_row + 1, skip_col + 1])


def _leave_out_sums(w: np.ndarray, w_end: float, w_new: float) -> np.ndarray:
    """``(C, rows + 1, columns + 1)``: for each of the ``C`` components ``w`` (``(C, rows,
    columns)``, 0: no edge), the sum over its partial matchings of the product of the matched
    weights, ``w_end`` per unmatched row and ``w_new`` per unmatched column, with row ``r`` and
    column ``q`` left out at ``[c, r + 1, q + 1]`` (index 0: none left out).

    Dynamic programming over the set of used columns, every component and every leave-out at
    once: a left-out row adds neither ``w_end`` nor edges, a left-out column takes no edge and
    counts for no ``w_new``."""
    n_c, n_a, n_b = w.shape
    if n_b <= 8 and compiled.mode() is not None:  # the same floats, one call
        powers = w_new ** np.arange(n_b + 1)
        return compiled.leave_out_sums(np.ascontiguousarray(w, np.float64), float(w_end), powers)
    skip_row = np.repeat(np.arange(-1, n_a), n_b + 1)  # one variant per (row, column) left out
    skip_col = np.tile(np.arange(-1, n_b), n_a + 1)
    masks = np.arange(1 << n_b)
    n_v = len(skip_row)
    f = np.zeros((n_c, n_v, 1 << n_b))
    f[:, :, 0] = 1.0
    for r in range(n_a):
        active = skip_row != r
        g = np.where(active[None, :, None], f * w_end, f)
        for q in np.flatnonzero(w[:, r, :].any(axis=0)).tolist():  # columns with an edge
            # The masks without bit q and the same with it, as views: mask = (high, bit, low).
            shape = (n_c, n_v, 1 << (n_b - q - 1), 2, 1 << q)
            weight = w[:, r, q][:, None] * (active & (skip_col != q))[None, :]
            g.reshape(shape)[:, :, :, 1] += f.reshape(shape)[:, :, :, 0] * weight[:, :, None, None]
        f = g
    used = np.zeros(1 << n_b, dtype=np.int64)
    for q in range(n_b):
        used += (masks >> q) & 1
    left = skip_col >= 0
    n_free = n_b - used[None, :] - left[:, None]
    has_skipped = left[:, None] & (((masks[None, :] >> np.maximum(skip_col, 0)[:, None]) & 1) > 0)
    f = np.where(has_skipped[None], 0.0, f)
    total = (f * w_new ** np.maximum(n_free, 0)[None]).sum(axis=2)
    return total.reshape(n_c, n_a + 1, n_b + 1)
