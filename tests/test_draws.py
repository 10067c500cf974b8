"""The excitations' uniform draws (``baselines.excitations.draws``) are ``Generator.uniform``'s
numbers to the bit, and leave each generator where ``uniform`` leaves it."""

from __future__ import annotations

import numpy as np
import pytest

from baselines.excitations import draws
from baselines.excitations.candidates import candidate_commands


def _rngs(seed: int, n: int) -> list[np.random.Generator]:
    return [np.random.default_rng(seed * 1000 + i) for i in range(n)]


def _states(rngs: list[np.random.Generator]) -> list[object]:
    return [rng.bit_generator.state for rng in rngs]


@pytest.mark.parametrize("affine", [True, False])
@pytest.mark.parametrize("seed", range(4))
def test_draws_are_uniforms(seed: int, affine: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    """Candidates (speeds then turns, per robot) and single numbers in boxes of every sign,
    a box of one value included: the same bits and generator states as ``uniform``, by the
    scaled ``random`` draws (where the probe passes) and by ``uniform`` itself."""
    if not affine:
        monkeypatch.setattr(draws, "affine_uniform", lambda: False)
    boxes = [(0.1, 0.3), (-0.5, 0.5), (-0.3, 0.3), (0.5, 1.0), (-1.7, 2.9e-3), (0.25, 0.25)]
    ours, theirs = _rngs(seed, 9), _rngs(seed, 9)
    got = draws.uniform_rows(ours, boxes, 8)
    want = np.array([[rng.uniform(lo, hi, 8) for lo, hi in boxes] for rng in theirs])
    assert got.tobytes() == want.tobytes()
    assert _states(ours) == _states(theirs)
    for lo, hi in boxes:
        for a, b in zip(ours, theirs, strict=True):
            assert draws.uniform(a, lo, hi) == b.uniform(lo, hi)
    assert _states(ours) == _states(theirs)


def test_the_candidates_are_drawn_as_before() -> None:
    """``candidate_commands``: each robot's C speeds, then its C turn rates, from its own
    generator (deviations on swarm duty)."""
    for deviation in (False, True):
        ours, theirs = _rngs(7, 5), _rngs(7, 5)
        got = candidate_commands(ours, 6, (0.1, 0.3), 0.5, deviation)
        low = -0.3 if deviation else 0.1
        want = np.empty((5, 6, 2))
        for i, rng in enumerate(theirs):
            want[i, :, 0] = rng.uniform(low, 0.3, 6)
            want[i, :, 1] = rng.uniform(-0.5, 0.5, 6)
        assert got.tobytes() == want.tobytes()
        assert got.flags.c_contiguous
        assert _states(ours) == _states(theirs)


def test_the_probe_tells_what_this_numpy_does() -> None:
    """The probe's answer is what ``uniform`` does on other draws in another box (a fused
    multiply-add would round differently on many of them)."""
    drawn = np.random.default_rng(9).uniform(-0.7, 0.9, 10000)
    ours = -0.7 + (0.9 - -0.7) * np.random.default_rng(9).random(10000)
    assert draws.affine_uniform() == bool(np.array_equal(drawn, ours))
