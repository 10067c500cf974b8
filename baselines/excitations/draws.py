"""Uniform draws of the robots' own generators, as ``Generator.uniform`` makes them, for less.

``Generator.uniform(low, high)`` draws ``low + (high - low) * u`` with ``u`` the generator's next
double (``Generator.random``'s), one multiply and one add. Where numpy was built that way (the
probe :func:`affine_uniform`; a build that fuses them into one rounding fails it, and the draws
then go through ``uniform`` itself), the excitations draw ``u`` by ``random`` and scale it
themselves: the same numbers to the bit, the generators left in the same state, at a third of
the cost of ``uniform``'s argument handling (which the candidates paid 2 R times a picture)."""

from __future__ import annotations

import functools
from collections.abc import Sequence

import numpy as np


@functools.cache
def affine_uniform() -> bool:
    """Whether ``Generator.uniform`` gives ``low + (high - low) * random()`` to the bit here
    (checked once, on draws where a fused multiply-add would differ)."""
    low, high = 0.1, 0.3
    drawn = np.random.default_rng(0).uniform(low, high, 4096)
    ours = low + (high - low) * np.random.default_rng(0).random(4096)
    one = np.random.default_rng(1)
    scalar = low + (high - low) * one.random()
    return bool(np.array_equal(drawn, ours)) and scalar == np.random.default_rng(1).uniform(
        low, high
    )


def uniform(rng: np.random.Generator, low: float, high: float) -> float:
    """``rng.uniform(low, high)``: one number."""
    if affine_uniform():
        return low + (high - low) * rng.random()
    return float(rng.uniform(low, high))


def uniform_rows(
    rngs: Sequence[np.random.Generator], boxes: Sequence[tuple[float, float]], count: int
) -> np.ndarray:
    """``(R, B, count)``: from each generator in turn, ``count`` numbers uniform in each box
    ``(low, high)`` of ``boxes`` in turn (what ``rng.uniform(low, high, count)`` per box
    draws)."""
    out = np.empty((len(rngs), len(boxes), count))
    if not affine_uniform():
        for row, rng in zip(out, rngs, strict=True):
            for k, (low, high) in enumerate(boxes):
                row[k] = rng.uniform(low, high, count)
        return out
    for row, rng in zip(out, rngs, strict=True):
        rng.random(out=row)
    for k, (low, high) in enumerate(boxes):
        box = out[:, k]
        box *= high - low
        box += low
    return out
