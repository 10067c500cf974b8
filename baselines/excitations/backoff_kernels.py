"""Compiled forms of :class:`~baselines.excitations.BackOff`'s numpy work at every control step
(numba, marked with ``anonloc_env.compiled.jit``; used only where
``anonloc_env.compiled.mode()`` is not None): which robots start a back-off, and the commands
with those of the robots reversing replaced. The same floats as the numpy lines they stand for
(``tests/test_backoff_kernels.py`` runs both)."""

from __future__ import annotations

import numpy as np

from anonloc_env import compiled
from anonloc_env.compiled import jit


@jit
def bumped_idle(bumper: np.ndarray, backing: np.ndarray) -> np.ndarray:
    """``np.flatnonzero(bumper & (backing <= 0.0))``: the robots whose bumper fired and that
    are not reversing already."""
    count = 0
    for k in range(bumper.shape[0]):
        if bumper[k] and backing[k] <= 0.0:
            count += 1
    out = np.empty(count, dtype=np.int64)
    count = 0
    for k in range(bumper.shape[0]):
        if bumper[k] and backing[k] <= 0.0:
            out[count] = k
            count += 1
    return out


@jit
def backed_off(
    backing: np.ndarray,
    speed: np.ndarray,
    rate: np.ndarray,
    v: np.ndarray,
    w: np.ndarray,
    dt: float,
    out: np.ndarray,
) -> bool:
    """Whether any robot is reversing (``backing > 0``); ``out`` ``(3, R)``: the commands
    ``np.where(backing > 0, -speed, v)`` and ``np.where(backing > 0, rate, w)``, and the times
    left ``np.maximum(backing - dt, 0.0)``."""
    anyone = False
    for k in range(backing.shape[0]):
        if backing[k] > 0.0:
            anyone = True
            out[0, k] = -speed[k]
            out[1, k] = rate[k]
        else:
            out[0, k] = v[k]
            out[1, k] = w[k]
        out[2, k] = compiled.maximum(backing[k] - dt, 0.0)
    return anyone
