"""Tracks.gather and take against the plain concatenation they stand for."""

from __future__ import annotations

import numpy as np
import pytest

from anonloc_env.identify import tracks
from anonloc_env.identify.arrays import shared
from anonloc_env.identify.tracks import FIELDS, Tracks


def _part(rng: np.random.Generator, count: int, slot0: int) -> Tracks:
    """A part of ``count`` random tracks; half its fields shared, as a first leg's are."""
    return Tracks(
        slot=np.sort(rng.integers(slot0, slot0 + 5, count)),
        row=rng.integers(-1, 40, count),
        pos=rng.normal(size=(count, 2)),
        pos_var=shared(2.5, count),
        theta=rng.normal(size=count),
        p_tt=rng.random(count),
        log_s=shared(np.log(100.0), count),
        p_ts=shared(0.0, count),
        p_ss=shared(0.0, count),
        logw=rng.normal(size=count),
        carry=shared(0.0, count, 2),
        turn=shared(0.0, count),
    )


def _index(rng: np.random.Generator, total: int, kind: str) -> np.ndarray:
    if kind == "scattered":
        return rng.permutation(total)[: total // 2]
    if kind == "identity":
        return np.arange(total)
    # Long runs (slices), some crossing from one part into the next, and scattered tracks.
    pieces, at = [], 0
    while at < total:
        size = int(rng.integers(1, 90))
        if rng.random() < 0.5:
            pieces.append(np.arange(at, min(at + size, total)))
        else:
            pieces.append(rng.permutation(np.arange(at, min(at + size, total))))
        at += size
    order = rng.permutation(len(pieces))
    return np.concatenate([pieces[k] for k in order])


@pytest.mark.parametrize("small", [True, False])
@pytest.mark.parametrize("kind", ["runs", "scattered", "identity"])
@pytest.mark.parametrize("seed", range(5))
def test_gather_is_concat_then_take(
    kind: str, seed: int, small: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Both ways of gathering (few tracks: each field concatenated and taken; many: planned
    runs and scattered copies into one allocation) give the concatenation's tracks."""
    if not small:
        monkeypatch.setattr(tracks, "SMALL_GATHER", 0)
    rng = np.random.default_rng(seed)
    parts = [_part(rng, int(n), 5 * k) for k, n in enumerate(rng.integers(1, 400, 3))]
    index = _index(rng, sum(len(p) for p in parts), kind)
    got = Tracks.gather(parts, index)
    want = Tracks.concat(parts).take(index)
    for f in FIELDS:
        np.testing.assert_array_equal(getattr(got, f), getattr(want, f), err_msg=f)
    # Fields every part holds alike stay shared: no memory per track.
    assert got.pos_var.strides[0] == 0
    assert got.carry.strides == (0, 0)


def test_shared_fields_that_differ_between_parts_are_written_out() -> None:
    rng = np.random.default_rng(1)
    a, b = _part(rng, 10, 0), _part(rng, 7, 5)
    b.pos_var = shared(4.0, 7)
    got = Tracks.gather([a, b], np.arange(17)[::-1])
    np.testing.assert_array_equal(got.pos_var, np.r_[np.full(7, 4.0), np.full(10, 2.5)])
    assert got.pos_var.strides[0] != 0


def test_a_short_part_written_out_with_the_shared_value_stays_shared() -> None:
    """A few general-path tracks that hold a batch's shared value in full: the gathered field
    stays shared (the same floats); a differing item, a -0.0 for 0.0, or a part too long to be
    worth checking, writes it out."""
    rng = np.random.default_rng(2)
    a, b = _part(rng, 300, 0), _part(rng, 20, 5)
    b.log_s, b.p_ts = np.full(20, np.log(100.0)), np.zeros(20)
    b.p_ss = np.zeros(20)
    b.p_ss[3] = -0.0
    b.pos_var = np.full(20, 2.5)
    b.pos_var[7] = np.nextafter(2.5, 3.0)
    index = rng.permutation(320)
    got = Tracks.gather([a, b], index)
    want = Tracks.concat([a, b]).take(index)
    for f in FIELDS:
        np.testing.assert_array_equal(getattr(got, f), getattr(want, f), err_msg=f)
    assert got.log_s.strides[0] == 0
    assert got.p_ts.strides[0] == 0
    assert np.signbit(got.p_ss).sum() == 1  # written out: the -0.0 kept
    assert got.pos_var.strides[0] != 0
    long = _part(rng, 400, 5)
    long.log_s = np.full(400, np.log(100.0))
    assert Tracks.gather([a, long], np.arange(700)).log_s.strides[0] != 0


def test_a_nan_of_other_bits_is_alike_and_other_values_are_not() -> None:
    """The shared value nan: a part holding nans of other bits (another payload) holds it alike
    (``np.array_equal`` with ``equal_nan``), as does one holding the same bits; a part with a
    number among its nans does not."""
    rng = np.random.default_rng(3)
    a, b, c = _part(rng, 300, 0), _part(rng, 20, 5), _part(rng, 20, 10)
    a.log_s = shared(np.nan, 300)
    quiet = np.array([0x7FF8000000000001], np.int64).view(np.float64)[0]
    b.log_s = np.full(20, quiet)
    c.log_s = np.full(20, np.nan)
    index = rng.permutation(340)
    got = Tracks.gather([a, b, c], index)
    assert got.log_s.strides[0] == 0
    assert np.isnan(got.log_s).all()
    c.log_s[4] = 1.0
    got = Tracks.gather([a, b, c], index)
    assert got.log_s.strides[0] != 0
    np.testing.assert_array_equal(got.log_s, Tracks.concat([a, b, c]).take(index).log_s)


def test_empty_tracks_are_new_objects_of_no_track() -> None:
    """``Tracks.empty`` hands out a new ``Tracks`` each time (its zero-length fields built
    once): no track in any field, each field of its dtype and width, and a field set on one
    leaves the next alone."""
    first, second = Tracks.empty(), Tracks.empty()
    assert first is not second
    for f in FIELDS:
        assert len(getattr(first, f)) == 0, f
    assert first.slot.dtype == first.row.dtype == np.int64
    assert first.pos.shape == first.carry.shape == (0, 2)
    assert first.logw.dtype == first.theta.dtype == np.float64
    first.logw = np.zeros(3)
    assert len(second.logw) == 0
    assert len(Tracks.empty().logw) == 0
    assert len(Tracks.concat([first.take(np.zeros(0, np.int64)), second])) == 0
