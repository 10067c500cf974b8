"""The identifier's pool: blocks reused only once nothing refers to them, and the same beliefs to
the bit whether the large arrays come from the pool or from fresh memory."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest
from test_identify_paths import RECORDED, Episode, _record

from anonloc_env import compiled
from anonloc_env.identify import Identifier, SensorModel, pool
from anonloc_env.identify.pool import Pool
from anonloc_env.identify.tracks import FIELDS


def _address(a: np.ndarray) -> int:
    return int(a.__array_interface__["data"][0])


def test_a_block_is_reused_only_once_nothing_refers_to_it() -> None:
    blocks = Pool()
    size = pool.MIN_BYTES
    a = blocks.take(size)
    b = blocks.take(size)  # a is alive: another block
    assert not np.shares_memory(a, b)
    view = a[10:20].view(np.uint16)  # a view of a view still holds the block
    del a
    c = blocks.take(size)
    assert not np.shares_memory(c, view)
    del view
    d = blocks.take(size)  # a's block, free again
    assert len(blocks) == 3
    del b, c, d
    assert len(blocks.free()) == 3
    copied = blocks.take(size).copy()  # a copy holds nothing
    assert len(blocks.free()) == 3
    assert len(copied) == size


def test_a_copied_pool_starts_empty() -> None:
    blocks = Pool()
    held = blocks.take(pool.MIN_BYTES)
    assert len(copy.deepcopy(blocks)) == 0
    assert len(pickle.loads(pickle.dumps(blocks))) == 0
    assert len(blocks) == 1
    assert len(held) == pool.MIN_BYTES


def test_the_smallest_free_block_that_fits_is_taken() -> None:
    blocks = Pool()
    big, small = pool.MIN_BYTES * 4, pool.MIN_BYTES
    a, b = blocks.take(big), blocks.take(small)
    at_big, at_small = _address(a), _address(b)
    del a, b
    assert _address(blocks.take(small)) == at_small
    too_big = int(small * pool.HEADROOM) + 1  # for the small block, headroom included
    assert _address(blocks.take(too_big)) == at_big
    assert _address(blocks.take(big)) == at_big


def test_small_arrays_are_not_kept_and_the_pool_is_bounded() -> None:
    blocks = Pool()
    assert len(blocks.take(pool.MIN_BYTES - 1)) == pool.MIN_BYTES - 1
    assert len(blocks) == 0
    held = [blocks.take(pool.MIN_BYTES) for _ in range(pool.MOST_BLOCKS + 3)]
    assert len(blocks) == pool.MOST_BLOCKS  # the rest handed out, not kept
    assert all(len(h) == pool.MIN_BYTES for h in held)
    del held
    larger = blocks.take(2 * pool.MIN_BYTES)  # in place of a smaller free one
    assert len(blocks) == pool.MOST_BLOCKS
    assert larger.base is not None


def test_reserve_writes_one_block_per_size() -> None:
    blocks = Pool()
    sizes = [3 * pool.MIN_BYTES, pool.MIN_BYTES, pool.MIN_BYTES, pool.MIN_BYTES // 2]
    blocks.reserve(sizes)
    assert sorted(blocks.free()) == sorted(sizes[:3])  # the one under MIN_BYTES left out
    blocks.reserve(sizes[:2])  # held free already: nothing new
    assert len(blocks) == 3
    table = blocks.array((3, 5))
    assert table.shape == (3, 5)
    assert table.dtype == np.float64
    assert table.flags.c_contiguous
    assert pool.empty(None, (2, 4), np.int64).shape == (2, 4)


def _episode(
    model: SensorModel, n: int, episode: Episode, pooled: bool
) -> tuple[list[list[np.ndarray]], list[list[np.ndarray]], Identifier]:
    """After every picture, copies of every track field, the belief and the missing column, and
    the arrays themselves (held to the end); pooled: every array of the pool's callers taken
    from the pool (``MIN_BYTES`` of 1), else none (``_pooled`` off: the numpy belief table)."""
    copies, held = [], []
    with pytest.MonkeyPatch.context() as patch:
        if pooled:
            patch.setattr(pool, "MIN_BYTES", 1)
        else:
            patch.setattr(Identifier, "_pooled", lambda self: None)
        ident = Identifier(model, n)
        for rows, interval in episode:
            ident.update(rows, interval)
            now = [getattr(ident.tracks, f) for f in FIELDS]
            now += [ident.uniform, ident.belief(), ident.missing()]
            held.append(now)
            copies.append([np.array(a) for a in now])
    return copies, held, ident


@pytest.mark.skipif(compiled.mode() is None, reason="kernels off: the identifier has no pool")
@pytest.mark.parametrize("name", ["headings", "headings-dense", "scale-unknown"])
def test_pooled_arrays_give_the_same_bits_and_held_ones_stay(name: str) -> None:
    """Env episodes of 30 to 60 robots with misses, false positives and contacts: every track's
    fields, every belief and missing column to the bit with and without the pool. Arrays a
    caller holds (every picture's, here) are never written again; where the caller holds
    nothing, the pool's blocks are taken again from picture to picture."""
    overrides, scale_known, _ = RECORDED[name]
    config, episode = _record(3, 12, **overrides)
    model = SensorModel.from_config(config, scale_known=scale_known)
    fresh, _, _ = _episode(model, config.n_robots, episode, pooled=False)
    pooled, held, ident = _episode(model, config.n_robots, episode, pooled=True)
    for k, (x, y, z) in enumerate(zip(fresh, pooled, held, strict=True)):
        for f, (u, v, w) in enumerate(zip(x, y, z, strict=True)):
            assert (u.dtype, u.shape) == (v.dtype, v.shape), f"picture {k}, field {f}"
            assert u.tobytes() == v.tobytes(), f"picture {k}, field {f}"
            assert np.asarray(w).tobytes() == v.tobytes(), f"picture {k}, field {f} overwritten"
    assert len(ident.pool) <= pool.MOST_BLOCKS

    # Holding only copies, the same blocks serve picture after picture.
    taken = []
    original = Pool.take

    def counting(self: Pool, nbytes: int, headroom: float = pool.HEADROOM) -> np.ndarray:
        taken.append(nbytes)
        return original(self, nbytes, headroom)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(pool, "MIN_BYTES", 1)
        patch.setattr(Pool, "take", counting)
        ident = Identifier(model, config.n_robots)
        got = []
        for rows, interval in episode:
            ident.update(rows, interval)
            got.append(np.array(ident.belief()))
    assert len(taken) > 4 * len(ident.pool)
    for k, (want, table) in enumerate(zip(fresh, got, strict=True)):
        assert want[-2].tobytes() == table.tobytes(), f"picture {k}"
