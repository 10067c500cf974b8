"""The identifier's compiled kernels (:mod:`anonloc_env.identify.fused`) against the numpy code
they replace: the same tracks and beliefs to the bit, kernels on and off, on recorded env
episodes (headings detected or not, scale known or not, misses, clutter, contacts) and on
episodes drawn from the model (pushes, the others persisting)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from test_identify_paths import DRAWN, RECORDED, Episode, _record

from anonloc_env import compiled, make_config
from anonloc_env.identify import Identifier, SensorModel, fused, fused_calls
from anonloc_env.identify.others import Links, links_between
from anonloc_env.identify.tracks import FIELDS, Tracks

pytest.importorskip("numba")
pytestmark = pytest.mark.skipif(
    compiled.mode() is None, reason="kernels off (ANONLOC_JIT=0 or an unknown numpy)"
)


def _run(model: SensorModel, n: int, episode: Episode, kernels_on: bool) -> list[list[np.ndarray]]:
    """After every picture: every field of every track, the belief and the missing column."""
    out = []
    with pytest.MonkeyPatch.context() as patch:
        if not kernels_on:
            patch.setattr(compiled, "_MODE", [None])
        ident = Identifier(model, n)
        for rows, interval in episode:
            ident.update(rows, interval)
            fields = [np.asarray(getattr(ident.tracks, f)) for f in FIELDS]
            out.append([*fields, ident.uniform, ident.belief(), ident.missing()])
    return out


@contextmanager
def _missed_calls() -> Iterator[list[bool]]:
    """For each call of ``fused_calls.known_compiled``: whether its tracks were missed in the
    previous picture (``Builder.from_missed``) rather than anchored at a row of it."""
    seen: list[bool] = []
    kernel: Callable[..., Any] = fused_calls.known_compiled

    def spy(sub: Any, *args: Any) -> Any:
        seen.append(bool((sub.row < 0).all()))
        return kernel(sub, *args)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(fused_calls, "known_compiled", spy)
        yield seen


@contextmanager
def _calls(name: str) -> Iterator[list[int]]:
    """Count the calls of kernel ``name`` of :mod:`~anonloc_env.identify.fused` (the kernels
    loaded first: ``fused.load`` calls each once when a process builds its first identifier,
    which would count here when this test runs first in its process)."""
    fused.load()
    seen: list[int] = []
    kernel: Callable[..., Any] = getattr(fused, name)

    def spy(*args: Any, **kwargs: Any) -> Any:
        seen.append(1)
        return kernel(*args, **kwargs)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(fused, name, spy)
        yield seen


def _same(a: list[list[np.ndarray]], b: list[list[np.ndarray]]) -> None:
    assert len(a) == len(b)
    for k, (x, y) in enumerate(zip(a, b, strict=True)):
        for f, (u, v) in enumerate(zip(x, y, strict=True)):
            np.testing.assert_array_equal(u, v, err_msg=f"picture {k}, field {f}")


@pytest.mark.parametrize("name", list(RECORDED))
def test_recorded_episodes_are_the_same_to_the_bit(name: str) -> None:
    """Env episodes of 30 to 60 robots with misses, false positives and contacts: every track's
    fields and every belief equal with the kernels on and off, and the kernels ran (the first
    leg where headings are detected and the scale known, the anchored tracks and the tracks
    missed before everywhere: an estimated scale goes through the general Kalman step inside
    the compiled path)."""
    overrides, scale_known, first_leg = RECORDED[name]
    config, episode = _record(3, 15, **overrides)
    model = SensorModel.from_config(config, scale_known=scale_known)
    with _calls("first_leg") as first, _missed_calls() as missed:
        on = _run(model, config.n_robots, episode, kernels_on=True)
    off = _run(model, config.n_robots, episode, kernels_on=False)
    assert (len(first) > 0) == first_leg
    assert True in missed
    assert False in missed
    _same(on, off)


@pytest.mark.parametrize("name", ["no-headings", "scale-unknown"])
def test_mixed_blocks_are_split_by_robot(name: str) -> None:
    """Where some robots' tracks do not know their heading or scale yet, the robots that do take
    the compiled path and the others the general one, in the same call (both ran), and the
    tracks stay those of the numpy path to the bit."""
    overrides, scale_known, _ = RECORDED[name]
    config, episode = _record(3, 15, **overrides)
    model = SensorModel.from_config(config, scale_known=scale_known)
    splits: list[tuple[int, int]] = []
    split: Callable[..., Any] = fused_calls.known_robots

    def spy(tracks: Any, index: np.ndarray) -> Any:
        known, rest = split(tracks, index)
        splits.append((len(known), len(rest)))
        return known, rest

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(fused_calls, "known_robots", spy)
        on = _run(model, config.n_robots, episode, kernels_on=True)
    assert any(known and rest for known, rest in splits)
    _same(on, _run(model, config.n_robots, episode, kernels_on=False))


def test_a_large_crowd_is_the_same_to_the_bit() -> None:
    """300 robots at 4 per m^2 (pushes, the others persisting): the same to the bit."""
    config, episode = _record(
        5, 6, n_robots=300, arena_size=(8.66, 8.66), camera={"pixel_noise": 1.0}
    )
    model = SensorModel.from_config(config)
    assert any(i is not None and i.push is not None and i.push.any() for _, i in episode)
    with _calls("known_children") as anchored:
        on = _run(model, config.n_robots, episode, kernels_on=True)
    assert anchored
    _same(on, _run(model, config.n_robots, episode, kernels_on=False))


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(case=DRAWN)
def test_drawn_episodes_are_the_same_to_the_bit(case: tuple[SensorModel, int, Episode]) -> None:
    """Episodes drawn from the model, headings detected or not, misses, clutter, the others
    persisting or not, unseen pushes (the general Kalman step inside the compiled path)."""
    model, robots, episode = case
    _same(_run(model, robots, episode, True), _run(model, robots, episode, False))


def test_the_stable_order_is_numpys() -> None:
    """The first leg's sort within a robot: ``np.argsort(kind="stable")``, ties included."""
    rng = np.random.default_rng(4)
    for n in (0, 1, 5, 16, 17, 100, 1000):
        key = rng.integers(0, max(n // 3, 1), n).astype(np.float64) + 0.5
        order = np.empty(n, dtype=np.int64)
        fused._stable_order(key, n, order)
        np.testing.assert_array_equal(order, np.argsort(key, kind="stable"))


def test_the_bucket_order_is_the_stable_order() -> None:
    """The first leg's sort by buckets: ``np.argsort(kind="stable")``, ties included, for keys
    spread over the span, bunched in one bucket, outside it, infinite or NaN (the fallbacks)."""
    rng = np.random.default_rng(5)
    base, span = 30.0, 10.0
    for n in (0, 1, 2, 17, 300, 2000):
        spread = base + span * rng.random(n)
        cases = {
            "spread": spread,
            "ties": base + np.floor(span * rng.random(n)),
            "bunched": base + 1e-9 * rng.random(n),
            "outside": base + 3 * span * rng.standard_normal(n),
            "inf": np.where(rng.random(n) < 0.2, np.inf, spread),
            "nan": np.where(rng.random(n) < 0.1, np.nan, spread),
        }
        for name, key in cases.items():
            order = np.empty(n, dtype=np.int64)
            fused._bucket_order(key, n, base, span, order, np.empty(2 * n + 1, dtype=np.int64))
            expected = np.empty(n, dtype=np.int64)
            fused._stable_order(key, n, expected)
            np.testing.assert_array_equal(order, expected, err_msg=name)
            if name != "nan":
                np.testing.assert_array_equal(order, np.argsort(key, kind="stable"), name)


@pytest.mark.skipif(compiled.mode() is None, reason="kernels off")
def test_the_compiled_prune_keeps_numpys_order() -> None:
    """``fused_calls.pruned_order`` against ``Identifier._pruned_order``: the same tracks in
    the same order and the same raised best, with ties, a cap on the tracks per robot, robots
    with no track; None (best untouched) when a robot's best is not finite."""
    rng = np.random.default_rng(6)
    model = SensorModel.from_config(make_config(n_robots=12))
    for cap in (1, 3, 1024):
        ident = Identifier(model, 12, max_tracks=cap)
        sizes = rng.integers(0, 40, 3)
        parts = [
            Tracks.fresh(
                np.sort(rng.integers(0, 12, k)),
                np.zeros(k, np.int64),
                np.zeros((k, 2)),
                np.round(rng.normal(0.0, 20.0, k), 1),  # ties
                pos_var=1.0,
                theta=0.0,
                p_tt=1.0,
                log_s=0.0,
            )
            for k in sizes
        ]
        slot = np.concatenate([p.slot for p in parts])
        logw = np.concatenate([p.logw for p in parts])
        start = np.where(rng.random(12) < 0.5, -np.inf, rng.normal(0.0, 20.0, 12))
        best = start.copy()
        got = fused_calls.pruned_order(slot, logw, best, cap)
        want_best = start.copy()
        want = ident._pruned_order(parts, slot, logw, want_best)
        assert got is not None
        np.testing.assert_array_equal(got, want)
        np.testing.assert_array_equal(best, want_best)
    lost = np.full(12, -np.inf)
    assert fused_calls.pruned_order(slot[:0], logw[:0], lost, 8) is None
    assert np.isneginf(lost).all()


def _links(
    model: SensorModel, on: bool, prev: np.ndarray, rows: np.ndarray, before: Links | None
) -> Links | None:
    with pytest.MonkeyPatch.context() as patch:
        if not on:
            patch.setattr(compiled, "_MODE", [None])
        return links_between(model, prev, rows, 3.0, 0.5, before)


def test_the_others_links_are_the_same_to_the_bit() -> None:
    """:func:`links_between` by the kernels of :mod:`~anonloc_env.identify.fused_links` and by
    numpy: every field equal, on random pictures from sparse (rows alone) to dense (components
    too big to sum), with and without the previous link's continuations."""
    config = make_config(n_robots=30, camera={"p_miss": 0.08, "false_positives": 2.0})
    model = SensorModel.from_config(config)
    rng = np.random.default_rng(1)
    fields = ["ends", "starts", "keys", "extra", "moved_row", "moved", "moved_p"]
    seen = {"exact": 0, "big": 0, "moved": 0}
    for _ in range(200):
        n_a, n_b = rng.integers(0, 40, 2)
        spread = rng.uniform(20.0, 400.0)
        prev, rows = rng.uniform(0, spread, (n_a, 3)), rng.uniform(0, spread, (n_b, 3))
        later = rows + rng.normal(0.0, 3.0, rows.shape)
        on: Links | None = None
        off: Links | None = None
        for frm, to in ((prev, rows), (rows, later)):
            on = _links(model, True, frm, to, on)
            off = _links(model, False, frm, to, off)
            assert on is not None
            assert off is not None
            for f in fields:
                x, y = getattr(on, f), getattr(off, f)
                assert x.dtype == y.dtype, f
                np.testing.assert_array_equal(x, y, err_msg=f)
            seen["exact"] += len(off.keys) > 0
            seen["big"] += bool((off.ends == 0.0).any())
            seen["moved"] += len(off.moved_row) > 0
    assert min(seen.values()) > 10, seen


def test_a_links_weights_are_the_same_to_the_bit() -> None:
    """``Links.detect`` by its kernel and by numpy: the same floats (-0.0 kept) for the links
    of random pictures (exact components, continuations, none), pairs from a row or missed
    before (-1), with and without ends or keys."""
    config = make_config(n_robots=30, camera={"p_miss": 0.08, "false_positives": 2.0})
    model = SensorModel.from_config(config)
    rng = np.random.default_rng(4)
    checked = 0
    for _ in range(60):
        n_a, n_b = rng.integers(1, 30, 2)
        spread = rng.uniform(20.0, 300.0)
        prev, rows = rng.uniform(0, spread, (n_a, 3)), rng.uniform(0, spread, (n_b, 3))
        links = _links(model, True, prev, rows, None)
        assert links is not None
        bare = Links(np.zeros(0), -links.starts, np.zeros(0, np.int64), np.zeros(0))
        a = rng.integers(-1, n_a, 50)
        b = rng.integers(0, n_b, 50)
        a[: len(links.keys)] = links.keys[:50] // n_b  # the pairs of components too
        b[: len(links.keys)] = links.keys[:50] % n_b
        for link in (links, bare):
            fast = link.detect(a, b)
            with pytest.MonkeyPatch.context() as patch:
                patch.setattr(compiled, "_MODE", [None])
                plain = link.detect(a, b)
            np.testing.assert_array_equal(np.signbit(fast), np.signbit(plain))
            np.testing.assert_array_equal(fast, plain)
        checked += len(links.keys) > 0
    assert checked > 10


@pytest.mark.parametrize("orientation", [False, True])
def test_filtered_positions_are_the_same_to_the_bit(orientation: bool) -> None:
    """A clean crowd (100 robots at 4 per m^2, no misses, no false positives), where
    ``from_config`` filters the tracks' positions: the same to the bit, kernels on and off, and
    the compiled children ran."""
    camera = {"pixel_noise": 1.0, "p_miss": 0.0, "false_positives": 0.0}
    config, episode = _record(
        4, 10, n_robots=100, arena_size=(5.0, 5.0), camera={**camera, "orientation": orientation}
    )
    model = SensorModel.from_config(config)
    assert model.filter_position
    with _calls("known_children") as anchored:
        on = _run(model, config.n_robots, episode, kernels_on=True)
    assert anchored
    _same(on, _run(model, config.n_robots, episode, kernels_on=False))
