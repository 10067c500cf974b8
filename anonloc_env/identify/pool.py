"""The identifier's large arrays, kept from picture to picture: blocks of memory it reuses once
nothing else holds them, so that a step writes into pages it has written before.

At N = 1000 a picture writes some 60 MB of arrays (the first leg's tracks, the gathered tracks,
the belief table, the per-track temporaries). Fresh memory costs a page fault per 4 KiB at its
first write: in a process's first episode, before glibc's allocator has learned to keep freed
memory for reuse, the second picture faulted in 3,800 pages (15 to 60 ms of a 40 ms step on
the shared machine). :func:`anonloc_env.memory.keep_freed_memory` would change the whole
process, which only the learning path does; a pool belongs to one identifier.

A :class:`Pool` keeps up to :data:`MOST_BLOCKS` blocks alive (about 80 MB at N = 1000, less the
fewer the robots) and hands one out again only when no array still refers to it (its reference
count is the pool's own): a caller that keeps an array the identifier gave it (the belief table
of the previous picture, the tracks a decision holds) keeps that block out of the pool, so reuse
never writes into an array someone can still read. Its ``reserve`` writes the blocks the first
pictures will need before they are needed (at the identifier's first picture, which has nothing
to update yet).
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from anonloc_env.identify import arrays

#: Blocks smaller than this are left to numpy's allocator: glibc's heap serves them (128 KiB is
#: its starting ``M_MMAP_THRESHOLD``, from which it maps fresh memory).
MIN_BYTES = 1 << 17
#: A new block holds this much more than asked, so that a need growing slowly from picture to
#: picture is met by the same block.
HEADROOM = 1.25
#: Most blocks a pool keeps (the identifier holds about a dozen at once at N = 1000).
MOST_BLOCKS = 24


def _refs(blocks: list[np.ndarray], k: int) -> int:
    """The reference count of ``blocks[k]`` as ``Pool.take`` reads it."""
    return sys.getrefcount(blocks[k])


def _free_count() -> int:
    """What :func:`_refs` reads of a block only the pool's list holds (measured, not assumed:
    interpreters differ in the references a call adds)."""
    probe = [np.empty(1, np.uint8)]
    return _refs(probe, 0)


_FREE = _free_count()


class Pool:
    """Blocks of memory (``uint8``, contiguous) reused once nothing else refers to them.

    An array taken from a block is a view of it, and so is any view of that array: while one
    lives, the block is not free. Copies made from a block hold no reference to it.
    """

    def __init__(self) -> None:
        self._blocks: list[np.ndarray] = []

    def __len__(self) -> int:
        return len(self._blocks)

    def __reduce__(self) -> tuple[type[Pool], tuple[()]]:
        """A copied or pickled pool starts empty (its blocks are memory, not state)."""
        return (Pool, ())

    @property
    def nbytes(self) -> int:
        """Bytes the pool keeps."""
        return sum(b.nbytes for b in self._blocks)

    def free(self) -> list[int]:
        """Sizes of the blocks nothing else holds now (for tests and benchmarks)."""
        blocks = self._blocks
        return [len(blocks[k]) for k in range(len(blocks)) if _refs(blocks, k) <= _FREE]

    def take(self, nbytes: int, headroom: float = HEADROOM) -> np.ndarray:
        """``nbytes`` bytes no other array refers to: the smallest free block that holds them,
        or a new block of ``headroom`` times that (kept in the pool if it has room, or in place
        of a smaller free one). Below :data:`MIN_BYTES`, a new array, not kept."""
        if nbytes < MIN_BYTES:
            return np.empty(nbytes, np.uint8)
        blocks = self._blocks
        best = -1
        for k in range(len(blocks)):
            size = len(blocks[k])
            smaller = best < 0 or size < len(blocks[best])
            if size >= nbytes and smaller and _refs(blocks, k) <= _FREE:
                best = k
        if best >= 0:
            return blocks[best][:nbytes]
        block = np.empty(int(nbytes * headroom), np.uint8)
        self._keep(block)
        return block[:nbytes]

    def _keep(self, block: np.ndarray) -> None:
        """Keep ``block``: in a free place, or in place of the smallest free block smaller than
        it, or not at all."""
        blocks = self._blocks
        if len(blocks) < MOST_BLOCKS:
            blocks.append(block)
            return
        free = [k for k in range(len(blocks)) if _refs(blocks, k) <= _FREE]
        if free:
            smallest = min(free, key=lambda k: len(blocks[k]))
            if len(blocks[smallest]) < len(block):
                blocks[smallest] = block

    def reserve(self, sizes: Sequence[int]) -> None:
        """Blocks of at least ``sizes`` bytes each (those under :data:`MIN_BYTES` left out),
        written once now so that their pages are mapped: the pool's free blocks large enough,
        else new blocks of just that size."""
        held: list[np.ndarray] = []  # taken for the time of the call, so each is another block
        for nbytes in sorted(sizes, reverse=True):
            if nbytes >= MIN_BYTES:
                held.append(self.take(nbytes, headroom=1.0))
                block = held[-1].base
                assert block is not None  # a view of a block
                block.fill(0)  # the whole block, its headroom too

    def columns(self, count: int, kinds: Sequence[tuple[npt.DTypeLike, int]]) -> list[np.ndarray]:
        """:func:`anonloc_env.identify.arrays.columns` in a block of the pool."""
        return arrays.columns(count, kinds, self.take)

    def array(self, shape: int | tuple[int, ...], dtype: npt.DTypeLike = np.float64) -> np.ndarray:
        """``np.empty(shape, dtype)`` (C order) in a block of the pool: its values are left as
        they were."""
        shape = (shape,) if isinstance(shape, int) else shape
        kind = np.dtype(dtype)
        nbytes = kind.itemsize
        for size in shape:  # not np.prod: this is asked for small arrays at every picture
            nbytes *= size
        if nbytes < MIN_BYTES:
            return np.empty(shape, kind)
        return self.take(nbytes).view(kind).reshape(shape)


def first_picture_blocks(table: int) -> list[int]:
    """What ``Pool.reserve`` is asked for at an identifier's first picture, its belief table
    ``table`` bytes (``R n`` float64): the blocks the next two pictures take at N = 1000 with
    the default camera (the first leg's candidates, about three tables; the gathered tracks,
    two; the belief tables of this picture and the next; the anchored tracks' candidates, one
    and a half; ten per-track arrays of a quarter or an eighth), about ten tables in all,
    written before they are needed (``benchmarks/bench_identify.py``'s first episode: see
    ``docs/benchmarks.md``, issue 25's fourteenth round)."""
    return (
        [3 * table, 2 * table, table, table, table, table // 2]
        + [table // 4] * 4
        + [table // 8] * 6
    )


def empty(
    pool: Pool | None, shape: int | tuple[int, ...], dtype: npt.DTypeLike = np.float64
) -> np.ndarray:
    """``np.empty(shape, dtype)``, in a block of ``pool`` where given and the array is at least
    :data:`MIN_BYTES` (checked first: small arrays, asked for at every picture, cost what
    ``np.empty`` costs)."""
    if pool is None:
        return np.empty(shape, dtype)
    size = _ITEMSIZE.get(dtype) or np.dtype(dtype).itemsize
    nbytes = size * (shape if isinstance(shape, int) else math.prod(shape))
    if nbytes < MIN_BYTES:
        return np.empty(shape, dtype)
    return pool.array(shape, dtype)


def taken(values: np.ndarray, index: np.ndarray, pool: Pool | None) -> np.ndarray:
    """``values[index]`` (``values`` 1-D, ``index`` valid indices), in a block of ``pool`` where
    given and the array is at least :data:`MIN_BYTES`."""
    if pool is None or len(index) * values.itemsize < MIN_BYTES:
        return values[index]
    return values.take(index, out=pool.array(len(index), values.dtype), mode="clip")  # clip:
    # not buffered


#: Item sizes of the dtypes the identifier asks for (``np.dtype`` costs more than the lookup).
_ITEMSIZE: dict[npt.DTypeLike, int] = {np.float64: 8, np.int64: 8}
