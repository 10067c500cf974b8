"""The back-off's compiled step (``baselines.excitations.backoff_kernels``) gives the numpy
lines' floats to the bit: the commands of every step and the times, speeds and rates left."""

from __future__ import annotations

import numpy as np
import pytest

from anonloc_env import compiled
from baselines.excitations import BackOff, DistinctSettings, backoff_kernels
from baselines.excitations.candidates import GreedySettings
from baselines.steps import Step

pytest.importorskip("numba")
pytestmark = pytest.mark.skipif(
    compiled.mode() is None, reason="kernels off (ANONLOC_JIT=0 or an unknown numpy)"
)


def _drive(backoff: BackOff, steps: int, seed: int) -> list[bytes]:
    """A random episode: bumpers fired by a third of the robots at each step, a picture every
    tenth step, the excitation's own commands random (a scalar command now and then, which the
    compiled step leaves to numpy); every command and the state after each step, as bytes."""
    n = len(backoff.backing)
    rng = np.random.default_rng(seed)
    record = []
    for k in range(steps):
        bumper = rng.random(n) < 1.0 / 3.0
        step = Step(np.zeros((0, 3)), k % 10 == 9, np.zeros((n, 3)), bumper, np.zeros((n, 3)), 1.0)
        own = rng.normal(size=(2, n))
        if k % 7 == 3:
            own = (np.float64(own[0, 0]), own[1])
        v, w = backoff.commands(step, 0.05, lambda hit, own=own: (own[0], own[1]))
        for x in (v, w, backoff.backing, backoff.speed, backoff.rate):
            record.append(np.asarray(x, np.float64).tobytes())
    return record


@pytest.mark.parametrize("reflex", [False, True])
@pytest.mark.parametrize("seed", range(3))
def test_the_back_off_is_the_same_to_the_bit(
    reflex: bool, seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A plain back-off and the candidates' bump reflex (pressed robots escape), 12 robots, 200
    steps: the compiled step and numpy's give the same commands and state at every step."""

    def make() -> BackOff:
        backoff = GreedySettings().reflex() if reflex else BackOff(DistinctSettings())
        backoff.reset([np.random.default_rng(seed * 100 + i) for i in range(12)])
        return backoff

    calls: list[int] = []
    original = backoff_kernels.backed_off

    def counted(*args: object) -> bool:
        calls.append(1)
        return bool(original(*args))

    monkeypatch.setattr(backoff_kernels, "backed_off", counted)
    fast = _drive(make(), 200, seed)
    assert len(calls) > 150  # the compiled step took most steps (not the scalar commands)
    monkeypatch.setattr(compiled, "_MODE", [None])  # every kernel off: numpy's lines
    assert _drive(make(), 200, seed) == fast
    assert len(calls) <= 200
