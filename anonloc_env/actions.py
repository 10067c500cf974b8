"""Actions (what a policy outputs) and commands (what the robot does).

The action of one robot is a float32 vector in ``[-1, 1]^2``: ``(v / v_max, w / omega_max)``. Use
:func:`to_commands` and :func:`to_actions` to convert either way.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from anonloc_env import compiled
from anonloc_env.config import RobotConfig

_FLOAT64 = np.dtype(np.float64)


def to_commands(actions: np.ndarray, robot: RobotConfig) -> tuple[np.ndarray, np.ndarray]:
    """Map actions ``(..., 2)`` in ``[-1, 1]`` to commands ``v`` (m/s) and ``w`` (rad/s)."""
    a = np.asarray(actions, dtype=np.float64)
    return a[..., 0] * robot.v_max, a[..., 1] * robot.omega_max


def _team_commands(v: Any, w: Any) -> bool:
    """Whether ``v`` and ``w`` are a team's ``(R,)`` float64 commands and the compiled kernels
    are on: what the one-call paths of :func:`to_actions` and :func:`to_actions_and_speed`
    take."""
    return (
        type(v) is np.ndarray
        and type(w) is np.ndarray
        and v.dtype == _FLOAT64
        and w.dtype == _FLOAT64
        and v.ndim == 1
        and v.shape == w.shape
        and compiled.mode() is not None
    )


def to_actions(v: Any, w: Any, robot: RobotConfig) -> np.ndarray:
    """Map commands ``v`` (m/s) and ``w`` (rad/s) to float32 actions ``(..., 2)``, clipped to
    ``[-1, 1]`` (a command beyond the robot's limits is saturated, as the env would)."""
    if _team_commands(v, w):  # every control step: one compiled call, the same floats
        out = np.empty((len(v), 2), np.float32)
        compiled.actions_of(v, w, robot.v_max, robot.omega_max, out)
        return out
    v = np.asarray(v, dtype=np.float64)
    a = np.empty((*v.shape, 2))
    np.divide(v, robot.v_max, out=a[..., 0])
    np.divide(w, robot.omega_max, out=a[..., 1])
    np.maximum(a, -1.0, out=a)  # np.clip is slow on small arrays
    np.minimum(a, 1.0, out=a)
    return a.astype(np.float32)


def to_actions_and_speed(
    v: np.ndarray, w: np.ndarray, robot: RobotConfig
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`to_actions` of ``(N,)`` commands, and the forward speed ``(N,)`` (m/s, float64)
    those float32 actions send: ``|a_v| v_max``. One compiled call where the kernels are on."""
    if _team_commands(v, w):
        out = np.empty((len(v), 2), np.float32)
        speed = np.empty(len(v))
        compiled.actions_and_speed(v, w, robot.v_max, robot.omega_max, out, speed)
        return out, speed
    actions = to_actions(v, w, robot)
    return actions, np.abs(actions[:, 0].astype(np.float64)) * robot.v_max


def stack_actions(actions: Mapping[str, Any], agents: Sequence[str]) -> np.ndarray:
    """Validate a PettingZoo action dict and return an ``(N, 2)`` float64 array, clipped to
    ``[-1, 1]``.

    Raises:
        TypeError: ``actions`` is not a mapping.
        ValueError: a live agent has no action, an unknown agent is named, or an action has the
            wrong shape or a non-finite value (the message names the agent).
    """
    if not isinstance(actions, dict) and not isinstance(actions, Mapping):
        raise TypeError(f"actions must be a dict {{agent: action}}, got {type(actions).__name__}")
    try:
        rows = _rows_of(actions, agents)
    except KeyError as missing:
        raise ValueError(
            f"actions has no entry for live agent {missing.args[0]!r}; every agent in env.agents "
            "needs an action"
        ) from None
    if len(actions) != len(agents):
        unknown = sorted(set(actions) - set(agents))
        raise ValueError(
            f"actions names agents that are not live: {unknown}; live agents are env.agents"
        )
    stacked = _stack_vectors(rows)
    if stacked is None or stacked.shape != (len(agents), 2):
        for agent, row in zip(agents, rows, strict=True):
            if not _is_numeric(row) or np.shape(row) != (2,):
                raise ValueError(
                    f"action of {agent!r} must be 2 numbers (v, w) scaled to [-1, 1], got {row!r}"
                )
        raise ValueError(f"actions must be 2 numbers per agent, got {actions!r}")
    return _checked_copy(stacked, lambda i: repr(agents[i]))


def _rows_of(actions: Mapping[str, Any], agents: Sequence[str]) -> Sequence[Any]:
    """Each agent's entry of ``actions``, in the order of ``agents`` (one loop in C for a
    team); a missing agent raises ``KeyError`` naming it."""
    if len(agents) > 1:
        return operator.itemgetter(*agents)(actions)  # a tuple
    return [actions[agent] for agent in agents]


def check_action_array(actions: Any, n: int) -> np.ndarray:
    """Validate an ``(N, 2)`` array of actions in robot order and return it as a new float64
    array, clipped to ``[-1, 1]`` (what :func:`stack_actions` returns for the same values).

    Raises:
        ValueError: ``actions`` is not an ``(n, 2)`` numeric array, or holds a non-finite value
            (the message names the robot).
    """
    array = np.asarray(actions)
    if array.shape != (n, 2) or array.dtype.kind not in "fiub":
        raise ValueError(
            f"actions must be an ({n}, 2) numeric array (v, w) scaled to [-1, 1], got shape "
            f"{array.shape} of {array.dtype}"
        )
    return _checked_copy(array, lambda i: f"robot {i}")


def _checked_copy(stacked: np.ndarray, name: Callable[[int], str]) -> np.ndarray:
    """A new float64 array of the ``(N, 2)`` numeric ``stacked``, clipped to ``[-1, 1]``, after
    checking that it is finite (``name(i)`` names row ``i`` in the error): one compiled call for
    float32 and float64 (:func:`anonloc_env.compiled.checked_actions`), else
    :func:`_finite_clipped` on a float64 copy. The caller's array is never changed."""
    if stacked.dtype in _JOINABLE and compiled.mode() is not None:
        out = np.empty(stacked.shape)
        bad = compiled.checked_actions(stacked, out)
        if bad >= 0:
            raise ValueError(f"action of {name(bad)} is not finite: {out[bad].tolist()}")
        return out
    return _finite_clipped(stacked.astype(np.float64), name)


def _finite_clipped(stacked: np.ndarray, name: Callable[[int], str]) -> np.ndarray:
    """``stacked`` ``(N, 2)`` float64 clipped to ``[-1, 1]`` in place, after checking that it is
    finite (``name(i)`` names row ``i`` in the error)."""
    # A NaN or inf anywhere makes the sum of squares non-finite (huge finite values may too:
    # the exact check below then passes). One BLAS call, cheaper than ``sum``'s Python wrapper.
    if not math.isfinite(np.vdot(stacked, stacked)):
        finite = np.isfinite(stacked).all(axis=1)
        if not finite.all():
            bad = int(np.flatnonzero(~finite)[0])
            raise ValueError(f"action of {name(bad)} is not finite: {stacked[bad].tolist()}")
    # np.clip is slow on small arrays; two in-place ufuncs do the same.
    np.maximum(stacked, -1.0, out=stacked)
    np.minimum(stacked, 1.0, out=stacked)
    return stacked


def _stack_vectors(rows: Sequence[Any]) -> np.ndarray | None:
    """``(N, 2)`` array of ``rows``, or None if they are not all length-2 vectors: their own
    dtype where they are all contiguous float32 or all float64 arrays (read-only), else float64.

    Every row has length 2, and their concatenation is flat (``np.concatenate`` refuses rows of
    different dimensions, and scalars), so every row has shape ``(2,)``. Casting to float64 is
    refused for strings, complex numbers and objects ("same_kind" casting), as it should be. On a
    list of small arrays this is faster than ``np.array(rows)``, and gives the same values.
    """
    try:
        if set(map(len, rows)) != {2}:
            return None
        flat = _joined(rows)
        if flat is None:
            flat = np.concatenate(rows, dtype=np.float64)
    except (TypeError, ValueError):
        return None
    return flat.reshape(len(rows), 2) if flat.ndim == 1 else None


#: The dtypes whose rows :func:`_joined` reads as bytes (native byte order).
_JOINABLE = frozenset((np.dtype(np.float32), np.dtype(np.float64)))
_DTYPE = operator.attrgetter("dtype")


def _joined(rows: Sequence[Any]) -> np.ndarray | None:
    """``np.concatenate(rows)`` (read-only) for rows (each of length 2) that are all contiguous
    numpy arrays of one dtype, float32 or float64, by joining their bytes: on a hundred rows
    about a third of ``np.concatenate``'s cost, and the same values. None for anything else
    (the caller concatenates, as float64). The joined length is two items a row exactly only
    where every row is ``(2,)``."""
    try:
        kinds = set(map(_DTYPE, rows))
    except AttributeError:  # not arrays (lists, tuples)
        return None
    if len(kinds) != 1 or not kinds <= _JOINABLE:
        return None
    kind = kinds.pop()
    try:
        data = b"".join(rows)
    except (TypeError, ValueError, BufferError):  # not contiguous, or not a buffer
        return None
    if len(data) != 2 * kind.itemsize * len(rows):
        return None
    return np.frombuffer(data, kind)


def _is_numeric(row: Any) -> bool:
    """Whether ``row`` holds numbers (not strings, None or other objects)."""
    try:
        return np.asarray(row).dtype.kind in "fiub"
    except (ValueError, TypeError):
        return False
