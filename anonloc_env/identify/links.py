"""The other robots persist: what a robot's link between two pictures says about everyone else.

Without this, the other detections of each picture are clutter drawn afresh (the weight of "row
``q`` is me" is ``P_D f / lambda``, whatever ``q`` is). But the other robots persist: a row that is
plainly the continuation of another robot's row is unlikely to be mine, and a track of mine that
jumps onto it leaves that robot's track broken. With the robot count known
(``SensorModel.n_robots``) and how far a robot can drive between two pictures
(``SensorModel.others_reach``), the others are modelled between consecutive pictures ``k - 1`` and
``k`` as an association: every row ``a`` of ``k - 1`` continues to a row ``b`` of ``k`` (weight
``W(a, b) = share P_D g(b - a)``, ``g`` uniform over the disc a robot can reach, ``share`` the
expected fraction of rows that are robots) or ends (missed, or a false positive:
``W(a, end) = share (1 - P_D) + 1 - share``); every row ``b`` not continued is new (density
``W(new, b)``: false positives and robots missed before). ``Z`` sums the weights of all such
associations: it is the likelihood of picture ``k`` given picture ``k - 1``. My link ``a -> b``
leaves the others the association without ``a`` and ``b``, so it weighs ``Z(-a, -b) / Z``
(``a`` missed now: ``Z(-a) / Z``; unknown or missed before and seen at ``b``: ``Z(-b) / Z``) in
place of the clutter model's ``1 / lambda`` (and ``1`` for a miss). A track is weighed link by
link (each link's first picture is clutter to the one before: a chain, not the exact joint).

``Z`` is a sum over the matchings of a sparse bipartite graph: it factors over the graph's
connected components, which are small (a robot reaches few rows in one interval), and each is
summed exactly by dynamic programming over its columns. A component with more than
:data:`MAX_COMPONENT` rows or columns falls back to the clutter model there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from anonloc_env.identify.model import SensorModel, log_background
from anonloc_env.neighbours import pairs_within

#: Largest component (rows or columns) summed exactly; larger ones use the clutter model.
MAX_COMPONENT = 8
#: A row of the previous picture always has some chance to end (a robot leaving the view).
END_FLOOR = 1e-6


@dataclass(frozen=True)
class Links:
    """Log weights of a link between the previous picture and the newest one, in place of the
    clutter model's ``-log lambda`` for a detection and ``0`` for a miss:

    * ``a -> b``: ``ends[a] + starts[b] + pair(a, b)`` (``pair`` is zero unless ``a`` and ``b``
      share a component);
    * ``a -> missed``: ``ends[a]``; unknown or missed before ``-> b``: ``starts[b]``.

    Attributes:
        ends: ``(n_prev,)``.
        starts: ``(n,)``.
        keys: sorted ``a * n + b`` of the pairs that share a component; ``extra`` their
            ``pair(a, b)``.
    """

    ends: np.ndarray
    starts: np.ndarray
    keys: np.ndarray
    extra: np.ndarray

    @classmethod
    def clutter(cls, n_prev: int, log_bg: float, n_rows: int) -> Links:
        """The clutter model: ``-log lambda`` for every detection, nothing for a miss."""
        return cls(np.zeros(n_prev), np.full(n_rows, -log_bg), np.zeros(0, np.int64), np.zeros(0))

    def pair(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """``(K,)`` log weight of the links ``a[k] -> b[k]`` (rows of the previous picture and
        of the newest one)."""
        out = self.ends[a] + self.starts[b]
        if len(self.keys):
            key = a.astype(np.int64) * len(self.starts) + b
            at = np.minimum(np.searchsorted(self.keys, key), len(self.keys) - 1)
            hit = self.keys[at] == key
            out = out + np.where(hit, self.extra[at], 0.0)
        return out


def persists(model: SensorModel) -> bool:
    """Whether ``model`` knows enough to let the other robots persist."""
    return model.n_robots is not None and model.others_reach is not None


def links_between(model: SensorModel, prev: np.ndarray, rows: np.ndarray) -> Links:
    """The :class:`Links` between pictures ``prev`` and ``rows`` (``(n, >= 2)`` image rows)."""
    n_a, n_b = len(prev), len(rows)
    log_bg = log_background(model, n_b)
    if not persists(model) or n_a == 0 or n_b == 0:
        return Links.clutter(n_a, log_bg, n_b)
    assert model.n_robots is not None
    assert model.others_reach is not None
    area = model.image_area
    p_d = min(model.p_detect, 1.0 - 1e-6)
    robots = model.n_robots * p_d
    share = min(1.0, robots / max(robots + model.false_positives, 1e-12))
    reach = model.scale_bounds[1] * model.others_reach + 3.0 * model.pixel_noise
    w_pair = share * p_d / (math.pi * reach * reach)
    w_end = share * (1.0 - p_d) + (1.0 - share) + END_FLOOR
    new = model.false_positives + p_d * (1.0 - p_d) * model.n_robots
    w_new = max(new, 0.5) / area
    i, j, _ = pairs_within(prev[:, :2], rows[:, :2], reach)
    ends = np.zeros(n_a)
    starts = np.zeros(n_b)
    comp_a, comp_b = _components(n_a, n_b, i, j)
    keys: list[np.ndarray] = []
    extra: list[np.ndarray] = []
    # Rows and columns alone in their component: closed forms.
    size_a = np.bincount(comp_a, minlength=n_a + n_b)
    size_b = np.bincount(comp_b, minlength=n_a + n_b)
    lone_a = (size_b[comp_a] == 0) & (size_a[comp_a] == 1)
    lone_b = (size_a[comp_b] == 0) & (size_b[comp_b] == 1)
    ends[lone_a] = -math.log(w_end)  # Z = w_end, Z(-a) = 1
    starts[lone_b] = -math.log(w_new)
    # One row and one column joined by their pair.
    one = (size_a == 1) & (size_b == 1)
    pa = np.flatnonzero(one[comp_a])
    pb = np.flatnonzero(one[comp_b])
    if len(pa):
        order_a = np.argsort(comp_a[pa], kind="stable")
        order_b = np.argsort(comp_b[pb], kind="stable")
        a1, b1 = pa[order_a], pb[order_b]
        log_z = math.log(w_pair + w_end * w_new)
        ends[a1] = math.log(w_new) - log_z  # Z(-a) = w_new
        starts[b1] = math.log(w_end) - log_z  # Z(-b) = w_end
        # Z(-a, -b) = 1
        keys.append(a1.astype(np.int64) * n_b + b1)
        extra.append(-log_z - ends[a1] - starts[b1])
    # Larger components.
    big = np.flatnonzero((size_a + size_b > 2) & ((size_a > 0) | (size_b > 0)))
    if len(big):
        edge_w = {(int(x), int(y)): w_pair for x, y in zip(i, j, strict=True)}
        rows_of = _members(comp_a, big)
        cols_of = _members(comp_b, big)
        for c in big:
            ra, cb = rows_of[int(c)], cols_of[int(c)]
            if len(ra) > MAX_COMPONENT or len(cb) > MAX_COMPONENT:
                ends[ra] = 0.0
                starts[cb] = -log_bg
                continue
            w = np.array([[edge_w.get((int(x), int(y)), 0.0) for y in cb] for x in ra])
            log_z = math.log(_sum_matchings(w, w_end, w_new))
            z_a = np.array([_sum_matchings(w, w_end, w_new, skip_row=r) for r in range(len(ra))])
            z_b = np.array([_sum_matchings(w, w_end, w_new, skip_col=q) for q in range(len(cb))])
            ends[ra] = np.log(z_a) - log_z
            starts[cb] = np.log(z_b) - log_z
            for r, x in enumerate(ra):
                z_ab = np.array(
                    [
                        _sum_matchings(w, w_end, w_new, skip_row=r, skip_col=q)
                        for q in range(len(cb))
                    ]
                )
                keys.append(int(x) * n_b + cb)
                extra.append(np.log(z_ab) - log_z - ends[x] - starts[cb])
    if keys:
        key = np.concatenate(keys)
        value = np.concatenate(extra)
        order = np.argsort(key, kind="stable")
        return Links(ends, starts, key[order], value[order])
    return Links(ends, starts, np.zeros(0, np.int64), np.zeros(0))


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
            break
        label = new
    return label[:n_a], label[n_a:]


def _members(label: np.ndarray, which: np.ndarray) -> dict[int, np.ndarray]:
    """Indices carrying each label in ``which``."""
    order = np.argsort(label, kind="stable")
    sorted_label = label[order]
    out = {}
    for c in which:
        lo, hi = np.searchsorted(sorted_label, [c, c + 1])
        out[int(c)] = order[lo:hi]
    return out


def _sum_matchings(
    w: np.ndarray, w_end: float, w_new: float, skip_row: int = -1, skip_col: int = -1
) -> float:
    """Sum over partial matchings of ``w`` (rows x columns) of the product of the matched
    weights, ``w_end`` per unmatched row and ``w_new`` per unmatched column; row ``skip_row``
    and column ``skip_col`` left out (dynamic programming over the set of used columns)."""
    n_a, n_b = w.shape
    f = np.zeros(1 << n_b)
    f[0] = 1.0
    for r in range(n_a):
        if r == skip_row:
            continue
        g = f * w_end
        for q in range(n_b):
            if q == skip_col or w[r, q] == 0.0:
                continue
            bit = 1 << q
            free = (np.arange(1 << n_b) & bit) == 0
            g[np.flatnonzero(free) | bit] += f[free] * w[r, q]
        f = g
    used = np.array([bin(m).count("1") for m in range(1 << n_b)])
    n_free = n_b - used - (0 if skip_col < 0 else 1)
    if skip_col >= 0:
        f = np.where((np.arange(1 << n_b) >> skip_col) & 1, 0.0, f)
    return float((f * w_new ** n_free.clip(min=0)).sum())
