"""Validation helpers shared by the config dataclasses.

Every message names the parameter and the accepted range, so that a user who mistypes a value
knows what to write instead.
"""

from __future__ import annotations

import difflib
import math
import numbers
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np


def check_number(
    name: str,
    value: Any,
    low: float = -math.inf,
    high: float = math.inf,
    *,
    low_open: bool = False,
    high_open: bool = False,
    integer: bool = False,
) -> None:
    """Raise ``ValueError`` (or ``TypeError``) unless ``value`` is a finite number in range.

    Args:
        name: the parameter's dotted name, e.g. ``"camera.pixel_noise"``.
        value: the value to check.
        low, high: the bounds of the accepted interval.
        low_open, high_open: exclude the bound itself.
        integer: require an ``int`` (``bool`` is refused).
    """
    kind = "an integer" if integer else "a number"
    high_open = high_open or high == math.inf  # infinity itself is never a valid value
    # numbers.Integral and numbers.Real include numpy's scalars (np.int64, np.float32).
    wanted = numbers.Integral if integer else numbers.Real
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, wanted):
        raise TypeError(f"{name} must be {kind}, got {value!r} ({type(value).__name__})")
    unchecked: Any = value  # numpy scalars as Python numbers, compared below
    value = int(unchecked) if integer else float(unchecked)
    if not integer and not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    too_low = value <= low if low_open else value < low
    too_high = value >= high if high_open else value > high
    if too_low or too_high:
        left = "(" if low_open else "["
        right = ")" if high_open else "]"
        raise ValueError(f"{name} must be in {left}{_fmt(low)}, {_fmt(high)}{right}, got {value!r}")


def check_pair(
    name: str, value: Any, *, low: float = 0.0, high: float = math.inf
) -> tuple[float, float]:
    """Return ``value`` as a ``(float, float)`` tuple, or raise naming ``name``.

    Each item must be a number in ``(low, high]`` when ``low`` is 0 (a length), else in
    ``[low, high]``.
    """
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if (
        isinstance(value, str | bytes | bytearray)
        or not isinstance(value, Sequence)
        or len(value) != 2
    ):
        raise TypeError(f"{name} must be a pair (a, b) of numbers, got {value!r}")
    for i, item in enumerate(value):
        check_number(f"{name}[{i}]", item, low, high, low_open=low == 0.0)
    return (float(value[0]), float(value[1]))


def check_choice(name: str, value: Any, choices: Sequence[Any]) -> None:
    """Raise ``ValueError`` unless ``value`` is one of ``choices``."""
    if value not in choices:
        raise ValueError(f"{name} must be one of {list(choices)!r}, got {value!r}")


def did_you_mean(name: str, choices: Iterable[str]) -> str:
    """``" (did you mean 'x'?)"`` for the choice closest to a mistyped ``name``, else ``""``.

    The one spelling of the hint every "unknown ..." message carries (config fields, presets,
    scenarios, policies, excitations).
    """
    close = difflib.get_close_matches(name, list(choices), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _fmt(x: float) -> str:
    if x == math.inf:
        return "inf"
    if x == -math.inf:
        return "-inf"
    return f"{x:g}"
