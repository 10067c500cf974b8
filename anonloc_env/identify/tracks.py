"""Tracks: the explicit hypotheses of all robots, one flat array per field, grouped by robot.

A track is which row of each picture was the robot (or that it was missed), with a Gaussian
estimate of its image heading and log scale. How a row extends a track is in
:mod:`anonloc_env.identify.likelihood`; the helpers on grouped and shared arrays in
:mod:`anonloc_env.identify.arrays`.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from anonloc_env.geometry import rotate
from anonloc_env.identify.arrays import alike, columns, shared, take_field
from anonloc_env.identify.pool import Pool, empty
from anonloc_env.odometry import Interval

#: ``Tracks.gather`` copies runs of at least this many consecutive tracks as slices.
MIN_RUN = 32
#: ``Tracks.gather`` of at most this many tracks in all concatenates each field and takes the
#: index (two numpy calls a field: planning runs costs more than the copies it saves).
SMALL_GATHER = 4096


@dataclass
class Tracks:
    """Explicit hypotheses of all robots, flat arrays grouped by robot."""

    slot: np.ndarray  # robot of the hypothesis
    row: np.ndarray  # row in the newest picture, -1 if missed there
    pos: np.ndarray  # (H, 2) image position at the newest picture (detection or prediction)
    pos_var: np.ndarray  # variance of that position per component
    theta: np.ndarray  # image heading at the newest picture (nan: unknown)
    p_tt: np.ndarray  # variance of theta
    log_s: np.ndarray  # log scale (nan: unknown)
    p_ts: np.ndarray  # covariance of theta and log s
    p_ss: np.ndarray  # variance of log s
    logw: np.ndarray  # log weight
    # Own motion since the newest detection of a track missed since, before its position could
    # be predicted (heading or scale unknown): (H, 2) displacement in the robot's frame at that
    # detection (m), and the heading change (rad); zero for the others.
    carry: np.ndarray
    turn: np.ndarray

    @classmethod
    def fresh(
        cls,
        slot: np.ndarray,
        row: np.ndarray,
        pos: np.ndarray,
        logw: np.ndarray,
        *,
        pos_var: np.ndarray | float,
        theta: np.ndarray | float,
        p_tt: np.ndarray | float,
        log_s: np.ndarray | float,
        p_ts: np.ndarray | float = 0.0,
        p_ss: np.ndarray | float = 0.0,
        carry: np.ndarray | None = None,
        turn: np.ndarray | None = None,
    ) -> Tracks:
        """New tracks of robots ``slot`` at rows ``row`` (-1: missed) and positions ``pos``,
        log weights ``logw``. A float field given as a number is one that every track holds
        alike (a :func:`~anonloc_env.identify.arrays.shared` field); ``carry`` and ``turn``
        left out mean no carried motion."""
        count = len(slot)

        def field(value: np.ndarray | float) -> np.ndarray:
            if type(value) is np.ndarray and value.ndim:  # most fields (np.ndim costs more)
                return value
            return shared(float(value), count) if np.ndim(value) == 0 else np.asarray(value)

        return cls(
            slot=slot,
            row=row,
            pos=pos,
            pos_var=field(pos_var),
            theta=field(theta),
            p_tt=field(p_tt),
            log_s=field(log_s),
            p_ts=field(p_ts),
            p_ss=field(p_ss),
            logw=logw,
            carry=shared(0.0, count, 2) if carry is None else carry,
            turn=shared(0.0, count) if turn is None else turn,
        )

    @classmethod
    def empty(cls) -> Tracks:
        """No track: a new ``Tracks`` of the zero-length fields built once (nothing can be
        written into an array of no item, and a field set on one leaves the others alone)."""
        if not _EMPTY:
            none = np.zeros(0, np.int64)
            built = cls.fresh(
                none, none, np.zeros((0, 2)), np.zeros(0), pos_var=0.0, theta=0.0, p_tt=0.0,
                log_s=0.0,
            )  # fmt: skip
            _EMPTY.extend(getattr(built, f) for f in FIELDS)
        return cls(*_EMPTY)

    def own_motion(self, interval: Interval) -> tuple[np.ndarray, np.ndarray]:
        """``((H, 2), (H,))``: each track's own displacement (m, robot frame at its newest
        detection or prediction) and heading change up to the end of ``interval``."""
        d = interval.d[self.slot]
        dphi = interval.dphi[self.slot]
        if self.turn.any() or self.carry.any():
            d = self.carry + rotate(d, self.turn)
            dphi = dphi + self.turn
        return d, dphi

    def take(self, index: np.ndarray) -> Tracks:
        """The tracks ``index`` (an index array or mask); shared fields stay shared."""
        slot = self.slot[index]
        return Tracks(
            *(
                slot if f == "slot" else take_field(getattr(self, f), index, len(slot))
                for f in FIELDS
            )
        )

    def select(self, index: np.ndarray) -> Tracks:
        """The tracks ``index`` (increasing, not empty): views where they are a range, else
        :meth:`take`'s copies."""
        if index[-1] - index[0] + 1 == len(index):
            return self.window(int(index[0]), int(index[-1]) + 1)
        return self.take(index)

    def window(self, start: int, stop: int) -> Tracks:
        """Tracks ``start:stop``, as views (nothing copied)."""
        return Tracks(*(getattr(self, f)[start:stop] for f in FIELDS))

    @staticmethod
    def concat(parts: list[Tracks]) -> Tracks:
        """The tracks of ``parts`` one after the other (a lone part itself, not a copy)."""
        parts = [p for p in parts if len(p)]
        if len(parts) < 2:
            return parts[0] if parts else Tracks.empty()
        count = sum(len(p) for p in parts)
        out = []
        for f in FIELDS:
            arrays = [getattr(p, f) for p in parts]
            same = alike(arrays, count)
            out.append(np.concatenate(arrays) if same is None else same)
        return Tracks(*out)

    @staticmethod
    def gather(parts: list[Tracks], index: np.ndarray, pool: Pool | None = None) -> Tracks:
        """``Tracks.concat(parts).take(index)``, without building the concatenation (each
        field is filled part by part: no large array is written twice). Runs of consecutive
        tracks (a part already in order) are copied as slices; a lone part taken whole is
        returned itself. Large outputs are written into a block of ``pool`` where given."""
        parts = [p for p in parts if len(p)]
        if not parts:
            return Tracks.empty().take(index)
        bounds = np.cumsum([0] + [len(p) for p in parts])
        if len(index) == bounds[-1] and len(parts) == 1 and _is_identity(index):
            return parts[0]
        if bounds[-1] <= SMALL_GATHER:  # the same arrays as below, fewer calls
            return _gather_small(parts, index)
        runs, where, local = _plan(bounds, index, pool)
        every = [[getattr(p, f) for p in parts] for f in FIELDS]
        same = [alike(arrays, len(index)) for arrays in every]
        out = [np.empty(0) if a is None else a for a in same]
        written = [f for f, a in enumerate(same) if a is None]
        kinds = [(np.result_type(*every[f]), _width(every[f][0])) for f in written]
        blocks = columns(len(index), kinds) if pool is None else pool.columns(len(index), kinds)
        for f, into in zip(written, blocks, strict=True):  # one allocation
            arrays = every[f]
            for to, k, start, count in runs:
                into[to : to + count] = arrays[k][start : start + count]
            for w, i, arr in zip(where, local, arrays, strict=True):
                if len(w):
                    into[w] = arr[i]
            out[f] = into
        return Tracks(*out)

    def __len__(self) -> int:
        return len(self.slot)


#: The fields of :class:`Tracks`, in order.
FIELDS = tuple(f.name for f in fields(Tracks))
#: :meth:`Tracks.empty`'s fields, once built.
_EMPTY: list[np.ndarray] = []


def _gather_small(parts: list[Tracks], index: np.ndarray) -> Tracks:
    """``Tracks.gather`` of few tracks: each field concatenated, then taken (or shared)."""
    out = []
    for f in FIELDS:
        arrays = [getattr(p, f) for p in parts]
        same = alike(arrays, len(index))
        out.append(np.concatenate(arrays)[index] if same is None else same)
    return Tracks(*out)


def _width(a: np.ndarray) -> int:
    """A field's columns: 0 for ``(H,)``, else its second dimension."""
    return a.shape[1] if a.ndim > 1 else 0


def _is_identity(index: np.ndarray) -> bool:
    return bool(index[0] == 0 and (np.diff(index) == 1).all()) if len(index) else True


def _plan(
    bounds: np.ndarray, index: np.ndarray, pool: Pool | None
) -> tuple[list[tuple[int, int, int, int]], list[np.ndarray], list[np.ndarray]]:
    """How :meth:`~anonloc_env.identify.tracks.Tracks.gather` fills its output from parts
    whose tracks start at ``bounds``: ``(runs, where, local)``, the runs copied as slices
    ``(to, part, start, count)``, and per part the output positions ``where`` filled one by one
    from its tracks ``local``. A run is where ``index`` steps by one, within one part, for at
    least :data:`MIN_RUN` tracks (its large temporaries in blocks of ``pool``, where given)."""
    step = np.subtract(index[1:], index[:-1], out=empty(pool, max(len(index) - 1, 0), np.int64))
    brk = step != 1  # np.diff(index) != 1
    del step
    for bound in bounds[1:-1].tolist():
        brk |= index[1:] == bound
    first = np.concatenate([[0], np.flatnonzero(brk) + 1])
    size = np.diff(np.append(first, len(index)))
    long = size >= MIN_RUN
    n_parts = len(bounds) - 1
    if int(size[long].sum()) * 2 < len(index):  # mostly scattered: by index alone
        first, size = first[:0], size[:0]
        part = np.searchsorted(bounds, index, side="right") - 1
        where = [np.flatnonzero(part == k) for k in range(n_parts)]
    else:
        first, size = first[long], size[long]
        # Outside every run (they do not overlap): where the count of runs begun and not ended
        # is zero (no (H,) integer temporaries, as expand_ranges of the runs would build).
        edges = np.zeros(len(index) + 1, dtype=np.int8)
        edges[first] += 1  # each index once per statement; a run may end where one begins
        edges[first + size] -= 1
        at = np.flatnonzero(np.cumsum(edges[:-1], dtype=np.int8) == 0)
        part = np.searchsorted(bounds, index[at], side="right") - 1
        where = [at[part == k] for k in range(n_parts)]
    local = [index[w] - bounds[k] for k, w in enumerate(where)]
    src_part = np.searchsorted(bounds, index[first], side="right") - 1
    runs = list(
        zip(
            first.tolist(),
            src_part.tolist(),
            (index[first] - bounds[src_part]).tolist(),
            size.tolist(),
            strict=True,
        )
    )
    return runs, where, local
