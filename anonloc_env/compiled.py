"""Compiled forms of the env's small, hot numpy loops (numba; the optional ``fast`` extra): the
physics sub-step, odometry, the neighbour search of small point sets, and the identifier's
leave-out sums over the others' matchings.

A physics sub-step of :class:`anonloc_env.world.World` around pymunk's step is a few dozen numpy
calls on arrays of N robots (the move by the solved velocities, the headings and arena limits,
the clamp, the position correction's pass over the neighbour list, the wheel travel). At the N
that agents learn on (3 to 40 robots) numpy's cost per call, not the work, is most of a step.
These kernels do the same arithmetic, element by element in the same order, in one compiled call
each, and give the same floats to the bit (``tests/test_compiled.py`` steps worlds both
ways and compares every pose). numba is optional: without it, or with ``ANONLOC_JIT=0`` in the
environment, :func:`mode` is None and every caller runs its numpy code.

Bit for bit: numba's ``math.cos``/``math.sin`` call the C library, as numpy's float64 loops do
here; complex products are written out as numpy computes them, ``(a c - b d) + i (a d + b c)``
with fused multiply-adds (``fma(a, c, -b d)``, ``fma(a, d, b c)``: numpy's SIMD loops on a CPU
with FMA) or without, a real operand promoted to ``x + 0i``; maxima keep numpy's NaN rule; the
sums of the pushes follow ``np.bincount``'s order. :func:`mode` checks numpy's products and
transcendentals once and turns the kernels off where neither form matches. The complex modulus
is not numpy's (``np.abs`` of a complex number and ``hypot`` differ in the last bit), so circles,
whose separation needs it, keep the numpy pass, and the neighbour list is always built by numpy.

numba is imported, and the kernels compiled, when :func:`mode` is first asked (the first world
built), not at import: about four seconds once per installation (``cache=True`` keeps the
machine code next to this file), then about 0.7 s per process to load them at the first step.
"""

from __future__ import annotations

import math
import os
import sys
from typing import Any

import numpy as np

#: The kernels, as ``(module, name)``, in the order they are marked (callees first): those below
#: and those of other modules marked with :func:`jit` (the identifier's, in
#: :mod:`anonloc_env.identify.fused`).
_KERNELS: list[tuple[str, str]] = []
#: :func:`mode`'s answer, once asked.
_MODE: list[bool | None] = []


def jit(function: Any) -> Any:
    """Mark ``function`` as a kernel: :func:`mode` replaces it, in its module, with its compiled
    form (``numba.njit(cache=True)``) when the kernels are first asked for; until then, and
    without numba, it stays the plain function, which nothing calls (the callers check
    :func:`mode`). A module that marks kernels must be imported before :func:`mode` is first
    asked, or its kernels are compiled as they are marked."""
    _KERNELS.append((function.__module__, function.__name__))
    if _MODE and _MODE[0] is not None:  # the kernels already started: compile it now
        import numba

        return numba.njit(cache=True, nogil=True, error_model="numpy")(function)
    return function


def _fma_intrinsic(numba: Any) -> Any:
    """``fma(a, b, c)``: ``a * b + c`` rounded once (LLVM's ``llvm.fma.f64``), for compiled code."""
    from llvmlite import ir  # type: ignore[import-untyped]  # llvmlite ships no type hints
    from numba.core import types

    def fma(typingctx: Any, a: Any, b: Any, c: Any) -> Any:
        signature = types.float64(types.float64, types.float64, types.float64)

        def codegen(context: Any, builder: Any, sig: Any, args: Any) -> Any:
            double = ir.DoubleType()
            kind = ir.FunctionType(double, [double, double, double])
            function = builder.module.declare_intrinsic("llvm.fma", [double], kind)
            return builder.call(function, args)

        return signature, codegen

    return numba.extending.intrinsic(fma)


def _fma(a: float, b: float, c: float) -> float:
    """Replaced by :func:`_fma_intrinsic`'s when the kernels are compiled."""
    raise RuntimeError("anonloc_env.compiled: the kernels are not compiled (see mode())")


def numpy_fuses() -> bool | None:
    """Whether numpy's complex multiply uses fused multiply-adds on this machine (True), plain
    products (False), or neither form (None: the kernels cannot match it, so they are not
    used). Checked on values where the two forms differ."""
    from fractions import Fraction

    rng = np.random.default_rng(1)
    a, b = rng.normal(size=(2, 64, 2)).view(np.complex128)[..., 0]
    product = a * b
    plain = fused = True
    for x, y, got in zip(a.tolist(), b.tolist(), product.tolist(), strict=True):
        ar, ai, br, bi = x.real, x.imag, y.real, y.imag
        plain &= got == complex(ar * br - ai * bi, ar * bi + ai * br)
        once_re = float(Fraction(ar) * Fraction(br) + Fraction(-(ai * bi)))
        once_im = float(Fraction(ar) * Fraction(bi) + Fraction(ai * br))
        fused &= got == complex(once_re, once_im)
    return True if fused and not plain else False if plain and not fused else None


@jit
def maximum(a: float, b: float) -> float:
    """``np.maximum`` of two floats: NaN if either is."""
    if a != a:
        return a
    if b != b:
        return b
    return a if a >= b else b


@jit
def _minimum(a: float, b: float) -> float:
    """``np.minimum`` of two floats: NaN if either is."""
    if a != a:
        return a
    if b != b:
        return b
    return a if a <= b else b


@jit
def actions_of(
    v: np.ndarray, w: np.ndarray, v_max: float, omega_max: float, out: np.ndarray
) -> None:
    """``anonloc_env.actions.to_actions`` of ``(N,)`` commands ``v``, ``w`` into ``out``
    ``(N, 2)`` float32: each divided by its limit, clipped to ``[-1, 1]`` with numpy's NaN rule,
    rounded to float32 as ``astype`` rounds."""
    for k in range(v.shape[0]):
        out[k, 0] = _minimum(maximum(v[k] / v_max, -1.0), 1.0)
        out[k, 1] = _minimum(maximum(w[k] / omega_max, -1.0), 1.0)


@jit
def actions_and_speed(
    v: np.ndarray,
    w: np.ndarray,
    v_max: float,
    omega_max: float,
    out: np.ndarray,
    speed: np.ndarray,
) -> None:
    """:func:`actions_of` into ``out``, and into ``speed`` ``(N,)`` the forward speed the
    actions send, ``np.abs(out[:, 0].astype(np.float64)) * v_max`` (m/s)."""
    actions_of(v, w, v_max, omega_max, out)
    for k in range(v.shape[0]):
        speed[k] = abs(np.float64(out[k, 0])) * v_max


@jit
def checked_actions(actions: np.ndarray, out: np.ndarray) -> int:
    """``anonloc_env.actions.check_action_array``'s work on ``(N, 2)`` float actions: ``out``
    ``(N, 2)`` float64 their values, clipped to ``[-1, 1]`` where every value is finite (returns
    -1), else unclipped and the first row holding a non-finite value is returned."""
    for k in range(actions.shape[0]):
        out[k, 0] = actions[k, 0]
        out[k, 1] = actions[k, 1]
    for k in range(out.shape[0]):
        if not (math.isfinite(out[k, 0]) and math.isfinite(out[k, 1])):
            return k
    for k in range(out.shape[0]):
        out[k, 0] = _minimum(maximum(out[k, 0], -1.0), 1.0)
        out[k, 1] = _minimum(maximum(out[k, 1], -1.0), 1.0)
    return -1


@jit
def energy_rewards(
    v: np.ndarray, w: np.ndarray, cost: float, duration: float, factor: float, out: np.ndarray
) -> None:
    """``EnergyCost``'s rewards of ``(N,)`` commands ``v``, ``w`` into ``out``: the wheel
    travel as ``anonloc_env.rewards.wheel_travel`` computes it (``|w| cost``, plus ``|v|``,
    times ``duration``), times ``factor`` (minus the energy weight), rounded at each step."""
    for k in range(v.shape[0]):
        travel = abs(w[k]) * cost
        travel = travel + abs(v[k])
        travel = travel * duration
        out[k] = travel * factor


@jit
def scaled(v: np.ndarray, w: np.ndarray, inv_h: float, h: float, out: np.ndarray) -> None:
    """``World.step``'s sub-step quantities of the commands ``v``, ``w`` ``(N,)`` into ``out``
    ``(3, N)``: the force ``v / h`` (as ``v * inv_h``), the free move ``v h``, the turn ``w h``."""
    for k in range(v.shape[0]):
        out[0, k] = v[k] * inv_h
        out[1, k] = v[k] * h
        out[2, k] = w[k] * h


@jit
def bumped(worst: np.ndarray, tolerance: float) -> np.ndarray:
    """``World._bumped``: ``(N,)`` whether the larger of each row of ``worst`` ``(N, 2)`` exceeds
    ``tolerance`` (NaN does not)."""
    out = np.empty(worst.shape[0], dtype=np.bool_)
    for k in range(worst.shape[0]):
        out[k] = maximum(worst[k, 0], worst[k, 1]) > tolerance
    return out


@jit
def _clamp(state: np.ndarray, n: int, low: np.ndarray, high: np.ndarray) -> None:
    """``World._clamp_to_arena``: every centre within its limits (``low`` ``(N, 1)``, ``high``
    ``(N, 2)``)."""
    for k in range(n):
        bottom = low[k, 0]
        state[k, 0] = _minimum(maximum(state[k, 0], bottom), high[k, 0])
        state[k, 1] = _minimum(maximum(state[k, 1], bottom), high[k, 1])


@jit
def move(
    read: np.ndarray,
    state: np.ndarray,
    n: int,
    h: float,
    turn: np.ndarray,
    heading: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    half: float,
    slack: float,
    width: float,
    height: float,
    square: bool,
) -> None:
    """The move of a sub-step: centres by the solved velocities (``read``: pymunk's ``(N, 5)``
    rows ``(x, y, theta, vx, vy)``) over ``h`` s, headings by ``turn`` (rad), into ``state``'s
    first three columns; the unit headings into ``heading``, the arena limits of the centres at
    them into ``low`` and ``high`` (``World._set_headings``), then the clamp."""
    for k in range(n):
        vx, vy = read[k, 3], read[k, 4]
        # (vx + i vy) * (h + 0i), then + (x + iy), as np.multiply and np.add compute them.
        state[k, 0] = (vx * h - vy * 0.0) + read[k, 0]
        state[k, 1] = (vx * 0.0 + vy * h) + read[k, 1]
        theta = read[k, 2] + turn[k]
        state[k, 2] = theta
        c, s = math.cos(theta), math.sin(theta)
        heading[k] = complex(c, s)
        extent = (abs(c) + abs(s)) * half if square else half
        bottom = extent - slack
        low[k, 0] = bottom
        high[k, 0] = width - bottom
        high[k, 1] = height - bottom
    _clamp(state, n, low, high)


@jit
def record(
    read: np.ndarray,
    state: np.ndarray,
    n: int,
    heading: np.ndarray,
    travel: np.ndarray,
    forward: np.ndarray,
    turned: np.ndarray,
    worst: np.ndarray,
    fused: bool,
) -> None:
    """The wheel travel of a sub-step: the move from ``read``'s start to ``state`` in the robot's
    frame at the start (``heading``, unit complex), its part along the heading into ``forward``,
    the turn into ``turned``, and the gap between the move and the free move ``travel`` (m)
    along and across the heading into ``worst`` ``(N, 2)`` where it is larger."""
    for k in range(n):
        a = state[k, 0] - read[k, 0]
        b = state[k, 1] - read[k, 1]
        along, across = _cmul(a, b, heading[k].real, -heading[k].imag, fused)  # * conj(e)
        forward[k] = along
        turned[k] = state[k, 2] - read[k, 2]
        worst[k, 0] = maximum(worst[k, 0], abs(along - travel[k]))
        worst[k, 1] = maximum(worst[k, 1], abs(across - 0.0))


@jit
def _cmul(a: float, b: float, c: float, d: float, fused: bool) -> tuple[float, float]:
    """``(a + ib) (c + id)`` as numpy's complex multiply computes it: with fused multiply-adds
    (``fused``: ``fma(a, c, -b d)``, ``fma(a, d, b c)``, numpy's SIMD loops on x86-64 with FMA)
    or without."""
    if fused:
        return _fma(a, c, -(b * d)), _fma(a, d, b * c)
    return a * c - b * d, a * d + b * c


@jit
def _moved(state: np.ndarray, n: int, before: np.ndarray) -> float:
    """``separation._moved``: the largest move along either axis from ``before`` ``(N, 2)``."""
    largest = 0.0
    first = True
    for k in range(n):
        for axis in range(2):
            step = abs(state[k, axis] - before[k, axis])
            largest = step if first else maximum(largest, step)
            first = False
    return largest


@jit
def _coords(
    state: np.ndarray, i: int, j: int, frames: np.ndarray, p: int, out: np.ndarray, fused: bool
) -> float:
    """``Separator._extent`` of pair ``p`` (robots ``i``, ``j``; ``frames`` ``(P, 4)``: the
    conjugate headings as ``re, im`` of i, then of j): the offset in both frames into ``out``
    ``(4,)``; returns the largest of their sizes."""
    dx = state[j, 0] - state[i, 0]
    dy = state[j, 1] - state[i, 1]
    out[0], out[1] = _cmul(dx, dy, frames[p, 0], frames[p, 1], fused)
    out[2], out[3] = _cmul(dx, dy, frames[p, 2], frames[p, 3], fused)
    wide0 = maximum(abs(out[0]), abs(out[2]))
    wide1 = maximum(abs(out[1]), abs(out[3]))
    return maximum(wide0, wide1)


@jit
def separate(
    state: np.ndarray,
    n: int,
    heading: np.ndarray,
    pairs: np.ndarray,
    anchor: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    params: np.ndarray,
    most: int,
    fused: bool,
    check: bool,
) -> int:
    """One pass of ``Separator.separate`` for squares, from the neighbour check to the drift
    test, on the positions in ``state``'s first two columns.

    ``params``: half size, allowed overlap (m), stop, margin, stale and drift bounds. Returns
    -1 if ``check`` and the neighbour list is stale (rebuild it and call again), 0 when the pass
    is done, else the number of projections made (call again with that many fewer left).
    """
    half, allowed, stop, margin, stale, drift = params
    if check and not _moved(state, n, anchor) <= stale:
        return -1
    count = len(pairs)
    if count == 0:
        return 0
    frames = np.empty((count, 4))
    limit = np.empty(count)
    push = np.empty(count)
    coords = np.empty(4)
    offset = half - allowed
    top = 0.0
    for p in range(count):
        i, j = pairs[p, 0], pairs[p, 1]
        frames[p, 0], frames[p, 1] = heading[i].real, -heading[i].imag
        frames[p, 2], frames[p, 3] = heading[j].real, -heading[j].imag
        # exp(i (theta_j - theta_i)) = conj(e_i) * conj(conj(e_j))
        re, im = _cmul(frames[p, 0], frames[p, 1], frames[p, 2], -frames[p, 3], fused)
        limit[p] = (abs(re) + abs(im)) * half + offset
        push[p] = limit[p] - _coords(state, i, j, frames, p, coords, fused)
        top = push[p] if p == 0 else maximum(top, push[p])
    if not top > stop:
        return 0
    near = np.flatnonzero(push > margin)
    start = state[:n, :2].copy()
    chosen_pairs, chosen_frames, chosen_limit = pairs[near], frames[near], limit[near]
    done = _project(
        state, n, chosen_pairs, chosen_frames, chosen_limit, low, high, stop, most, fused
    )
    if _moved(state, n, start) <= drift:
        return 0
    return done


@jit
def _project(
    state: np.ndarray,
    n: int,
    pairs: np.ndarray,
    frames: np.ndarray,
    limit: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    stop: float,
    most: int,
    fused: bool,
) -> int:
    """``Separator._project for squares; returns how many projections were made."""
    count = len(pairs)
    coords = np.empty((count, 4))
    push = np.empty(count)
    moves = np.empty((count, 2))
    total = np.empty((n, 2))
    for done in range(most):
        top = 0.0
        for p in range(count):
            i, j = pairs[p, 0], pairs[p, 1]
            push[p] = limit[p] - _coords(state, i, j, frames, p, coords[p], fused)
            top = push[p] if p == 0 else maximum(top, push[p])
        if not top > stop:
            return done
        for p in range(count):
            best = 0
            for c in range(1, 4):  # np.argmax: the first largest
                if abs(coords[p, c]) > abs(coords[p, best]):
                    best = c
            # The edge normals e_i, i e_i, e_j, i e_j (e = conj(frame)), the i-th by 1j.
            side = 2 * (best // 2)
            re, im = frames[p, side], -frames[p, side + 1]
            if best % 2 == 1:
                re, im = _cmul(re, im, 0.0, 1.0, fused)
            sign = -0.5 if coords[p, best] < 0.0 else 0.5
            re, im = _cmul(re, im, sign, 0.0, fused)
            moves[p, 0], moves[p, 1] = _cmul(maximum(push[p], 0.0), 0.0, re, im, fused)
        # np.bincount's order: every pair's move of i (negated), then every pair's move of j.
        total[:] = 0.0
        for p in range(count):
            i = pairs[p, 0]
            total[i, 0] += -moves[p, 0]
            total[i, 1] += -moves[p, 1]
        for p in range(count):
            j = pairs[p, 1]
            total[j, 0] += moves[p, 0]
            total[j, 1] += moves[p, 1]
        for k in range(n):
            state[k, 0] += total[k, 0]
            state[k, 1] += total[k, 1]
        _clamp(state, n, low, high)
    return most


@jit
def substep(
    read: np.ndarray,
    state: np.ndarray,
    turn: np.ndarray,
    heading: np.ndarray,
    spare: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    sizes: np.ndarray,
    pairs: np.ndarray,
    anchor: np.ndarray,
    params: np.ndarray,
    most: int,
    travel: np.ndarray,
    forward: np.ndarray,
    turned: np.ndarray,
    worst: np.ndarray,
    fused: bool,
) -> int:
    """A sub-step of square robots after pymunk's, in one call: :func:`move` (the new headings
    into ``spare``; ``sizes`` holds ``h``, half size, wall slack, width and height), the
    position correction's first pass (:func:`separate` with its list check, at most ``most``
    projections) and, when that pass finished the correction, :func:`record`
    (the move against the start's ``heading``). Returns the pass's answer: 0 when the sub-step
    is complete; else -1 (the list is stale) or the projections made, and the caller goes on
    with the correction and then records, as the three calls one by one would."""
    n = len(read)
    h, half, slack, width, height = sizes[0], sizes[1], sizes[2], sizes[3], sizes[4]
    move(read, state, n, h, turn, spare, low, high, half, slack, width, height, True)
    done = separate(state, n, spare, pairs, anchor, low, high, params, most, fused, True)
    if done == 0:
        record(read, state, n, heading, travel, forward, turned, worst, fused)
    return done


def mode() -> bool | None:
    """None when the kernels are not used (no numba, ``ANONLOC_JIT=0``, or a numpy whose complex
    multiply neither form matches); else whether they fuse their complex products, as this
    machine's numpy does (checked once)."""
    if not _MODE:
        _MODE.append(_start())
    return _MODE[0]


def _start() -> bool | None:
    """Import numba and prepare the kernels (each compiles at its first call, or loads from the
    cache), if they are wanted and can match numpy; return :func:`mode`'s answer."""
    if os.environ.get("ANONLOC_JIT", "1") == "0":
        return None
    try:  # the optional extra ``fast``; the lowest-pins job has no numba
        import numba
        import numba.extending
    except ImportError:
        return None
    fused = numpy_fuses() if _same_cos_sin() else None
    if fused is None:
        return None
    globals()["_fma"] = _fma_intrinsic(numba)
    for module, name in _KERNELS:
        names = sys.modules[module].__dict__
        names[name] = numba.njit(cache=True, nogil=True, error_model="numpy")(names[name])
    return fused


def _same_cos_sin() -> bool:
    """Whether numpy's float64 ``cos`` and ``sin`` are the C library's (which compiled code
    calls), on angles where vectorised forms tend to differ."""
    angles = np.random.default_rng(2).uniform(-50.0, 50.0, 4096)
    cos, sin = np.cos(angles).tolist(), np.sin(angles).tolist()
    return cos == [math.cos(a) for a in angles.tolist()] and sin == [
        math.sin(a) for a in angles.tolist()
    ]


@jit
def integrate(
    odo: np.ndarray,
    forward: np.ndarray,
    turned: np.ndarray,
    normals: np.ndarray,
    noise: float,
    noisy: bool,
    sums: np.ndarray,
    stats: bool,
) -> None:
    """``Odometry.integrate``'s dead reckoning: ``odo`` ``(N, 3)`` own-frame ``(x, y, phi)``
    advanced by each sub-step's ``forward`` and ``turned`` ``(S, N)`` (if ``noisy``, times the
    noise factors ``1 + noise * z`` of the standard normals ``normals`` ``(2, N)``: distance,
    then turn). With ``stats``, the step's absolute distance ``ds`` and turn ``dth`` (summed over
    the sub-steps) go into ``IntervalStatistics.sums`` ``(4, N)`` as ``add_step`` adds them:
    ``path += ds``, ``sum_ds2 += ds * ds``, ``sum_dth2 += dth * dth``."""
    n = odo.shape[0]
    for k in range(n):
        distance_factor = 1.0 + noise * normals[0, k] if noisy else 1.0
        turn_factor = 1.0 + noise * normals[1, k] if noisy else 1.0
        step_ds = 0.0
        step_dth = 0.0
        for s in range(forward.shape[0]):
            ds, dth = forward[s, k], turned[s, k]
            if noisy:
                ds = ds * distance_factor
                dth = dth * turn_factor
            step_ds += abs(ds)
            step_dth += dth
            phi = odo[k, 2]
            odo[k, 0] += math.cos(phi) * ds
            odo[k, 1] += math.sin(phi) * ds
            odo[k, 2] = phi + dth
        if stats:
            sums[0, k] += step_ds
            sums[1, k] += step_ds * step_ds
            sums[2, k] += step_dth * step_dth


@jit
def pairs_within(
    a: np.ndarray, b: np.ndarray, radius: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``neighbours.pairs_within`` by looking at every pair: the pairs whose grid cells (``radius``
    wide, from the same origin) touch and whose distance (``hypot``) is at most ``radius``, in
    the order ``i`` then ``j``, as the grid search finds and sorts them."""
    n, m = a.shape[0], b.shape[0]
    x0 = min(a[:, 0].min(), b[:, 0].min()) - radius
    y0 = min(a[:, 1].min(), b[:, 1].min()) - radius
    cells_b = np.empty((m, 2), dtype=np.int64)
    for j in range(m):
        cells_b[j, 0] = np.int64(math.floor((b[j, 0] - x0) / radius))
        cells_b[j, 1] = np.int64(math.floor((b[j, 1] - y0) / radius))
    found_i = np.empty(n * m, dtype=np.int64)
    found_j = np.empty(n * m, dtype=np.int64)
    found_d = np.empty(n * m)
    count = 0
    for i in range(n):
        cx = np.int64(math.floor((a[i, 0] - x0) / radius))
        cy = np.int64(math.floor((a[i, 1] - y0) / radius))
        for j in range(m):
            if abs(cells_b[j, 0] - cx) > 1 or abs(cells_b[j, 1] - cy) > 1:
                continue
            dist = math.hypot(b[j, 0] - a[i, 0], b[j, 1] - a[i, 1])
            if dist <= radius:
                found_i[count], found_j[count], found_d[count] = i, j, dist
                count += 1
    return found_i[:count].copy(), found_j[:count].copy(), found_d[:count].copy()


@jit
def pairs_within_each(
    a: np.ndarray, b: np.ndarray, radius: np.ndarray, level: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``neighbours.pairs_within_each`` (finite points and radii) in one call: the points of
    ``a`` grouped by ``level`` (numpy's ``floor(log2(radius))``), each group searched as
    :func:`pairs_within` searches it (its widest radius ``r``, its cells from the origin of its
    points and ``b`` less ``r``), each pair kept where its distance is within its own radius
    too. In the order ``i`` then ``j``, as the grouped search sorts them."""
    n, m = a.shape[0], b.shape[0]
    widest = np.empty(n)
    x0 = np.empty(n)
    y0 = np.empty(n)
    bx, by = b[:, 0].min(), b[:, 1].min()
    for i in range(n):  # each group's radius and origin, per point (groups are small)
        r, ax, ay = radius[i], a[i, 0], a[i, 1]
        for k in range(n):
            if level[k] == level[i]:
                r = max(r, radius[k])
                ax = min(ax, a[k, 0])
                ay = min(ay, a[k, 1])
        widest[i] = r
        x0[i] = min(ax, bx) - r
        y0[i] = min(ay, by) - r
    found_i = np.empty(n * m, dtype=np.int64)
    found_j = np.empty(n * m, dtype=np.int64)
    found_d = np.empty(n * m)
    count = 0
    for i in range(n):
        r = widest[i]
        if not r > 0.0:  # pairs_within finds nothing
            continue
        cx = np.int64(math.floor((a[i, 0] - x0[i]) / r))
        cy = np.int64(math.floor((a[i, 1] - y0[i]) / r))
        for j in range(m):
            if abs(np.int64(math.floor((b[j, 0] - x0[i]) / r)) - cx) > 1:
                continue
            if abs(np.int64(math.floor((b[j, 1] - y0[i]) / r)) - cy) > 1:
                continue
            dist = math.hypot(b[j, 0] - a[i, 0], b[j, 1] - a[i, 1])
            if dist <= r and dist <= radius[i]:
                found_i[count], found_j[count], found_d[count] = i, j, dist
                count += 1
    return found_i[:count].copy(), found_j[:count].copy(), found_d[:count].copy()


@jit
def forward_pairs(xy: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """``separation.pairs_within_self``'s grid search for points ``xy`` ``(n, 2)``, ``n >= 2``:
    the same cells, keys, stable order and forward ranges, each listed pair ``(i, j)`` (``i <
    j``) in the grid search's order. A pair whose squared distance is clearly within the radius
    (or clearly beyond it: dropped) is decided here; ``unsure`` lists those within a millionth
    of the radius, which the caller decides by numpy's complex modulus, as the grid search
    does. Returns ``(pairs (P, 2), unsure)``."""
    n = xy.shape[0]
    x, y = xy[:, 0], xy[:, 1]
    x0, y0 = x.min(), y.min()
    key = np.empty(n, dtype=np.int64)
    top = np.int64(0)
    for p in range(n):
        row = np.int64(math.floor((y[p] - y0) / radius)) + 1
        if row > top:
            top = row
        key[p] = row
    stride = top + 2
    for p in range(n):
        key[p] += np.int64(math.floor((x[p] - x0) / radius)) * stride
    order = np.argsort(key, kind="mergesort")  # stable, as numpy's
    keys = key[order]
    inside, outside = radius * radius * (1.0 - 1e-6), radius * radius * (1.0 + 1e-6)
    # The same column first, for every point (the rest of its cell and the cell above); then
    # the next column (the cells beside, below-beside and above-beside).
    lo, hi = np.empty((2, n), dtype=np.int64), np.empty((2, n), dtype=np.int64)
    total = 0
    for p in range(n):
        lo[0, p], hi[0, p] = p + 1, np.searchsorted(keys, keys[p] + 1, side="right")
        lo[1, p] = np.searchsorted(keys, keys[p] + (stride - 1), side="left")
        hi[1, p] = np.searchsorted(keys, keys[p] + (stride + 1), side="right")
        total += (hi[0, p] - lo[0, p]) + (hi[1, p] - lo[1, p])
    pairs = np.empty((total, 2), dtype=np.int64)
    unsure = np.empty(total, dtype=np.int64)
    count, doubt = 0, 0
    for part in range(2):
        for p in range(n):
            a = order[p]
            for q in range(lo[part, p], hi[part, p]):
                b = order[q]
                dx, dy = x[b] - x[a], y[b] - y[a]
                d2 = dx * dx + dy * dy
                if d2 > outside:
                    continue
                if not d2 < inside:
                    unsure[doubt] = count
                    doubt += 1
                pairs[count, 0], pairs[count, 1] = min(a, b), max(a, b)
                count += 1
    return pairs[:count].copy(), unsure[:doubt].copy()


@jit
def interval_step(
    before: np.ndarray,
    now: np.ndarray,
    bumper: np.ndarray,
    speed: np.ndarray,
    bounds: np.ndarray,
    sums: np.ndarray,
    push_sum: np.ndarray,
) -> bool:
    """``odometry.IntervalStatistics.add_motion``: one control step of the robots' own odometry
    ``(R, 3)`` from ``before`` to ``now``, contacts ``bumper`` (bool) at commanded ``speed``;
    ``bounds``: ``v_max`` and ``dt``. Adds into ``sums`` ``(4, R)`` (path, squared distances,
    squared turns, pushes) and ``push_sum`` ``(R, 2)``; returns whether any robot touched."""
    quarter, dt = 0.25 * bounds[0], bounds[1]
    touched = False
    for i in range(now.shape[0]):
        if bumper[i]:  # push_bound and lateral, at the heading before the step
            touched = True
            bound = (abs(speed[i]) + quarter) * dt
            sums[3, i] += bound
            push_sum[i, 0] += bound * -math.sin(before[i, 2])
            push_sum[i, 1] += bound * math.cos(before[i, 2])
        distance = math.hypot(now[i, 0] - before[i, 0], now[i, 1] - before[i, 1])
        turn = now[i, 2] - before[i, 2]
        sums[0, i] += distance
        sums[1, i] += distance * distance
        sums[2, i] += turn * turn
    return touched


@jit
def _block_sum(a: np.ndarray, start: int, n: int) -> float:
    """numpy's pairwise sum of ``a[start:start + n]``, ``n <= 128``: in order below 8 items,
    else eight running sums combined as a tree, then the rest in order."""
    if n < 8:
        res = -0.0
        for i in range(n):
            res += a[start + i]
        return res
    r = a[start : start + 8].copy()
    i, end = 8, n - n % 8
    while i < end:
        for k in range(8):
            r[k] += a[start + i + k]
        i += 8
    res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
    while i < n:
        res += a[start + i]
        i += 1
    return res


@jit
def _sum(a: np.ndarray) -> float:
    """``a.sum()`` as numpy adds a row of at most 256 items: blocks of 128, halves above."""
    n = len(a)
    if n <= 128:
        return _block_sum(a, 0, n)
    half = n // 2
    half -= half % 8
    return _block_sum(a, 0, half) + _block_sum(a, half, n - half)


@jit
def leave_out_sums(w: np.ndarray, w_end: float, powers: np.ndarray) -> np.ndarray:
    """``identify.others._leave_out_sums`` (its dynamic programme over the sets of used columns,
    every leave-out at once) for ``w`` ``(C, rows, columns)``, at most 8 columns; ``powers``
    ``(columns + 1,)``: ``w_new ** k`` as numpy computes it. ``(C, rows + 1, columns + 1)``."""
    n_c, n_a, n_b = w.shape
    n_v, n_m = (n_a + 1) * (n_b + 1), 1 << n_b
    f = np.zeros((n_c, n_v, n_m))
    f[:, :, 0] = 1.0
    g = np.empty_like(f)
    for r in range(n_a):
        for v in range(n_v):
            active = v // (n_b + 1) - 1 != r
            for c in range(n_c):
                for m in range(n_m):
                    g[c, v, m] = f[c, v, m] * w_end if active else f[c, v, m]
        for q in range(n_b):
            edge = False
            for c in range(n_c):
                edge |= w[c, r, q] != 0.0
            if not edge:
                continue
            bit = 1 << q
            for v in range(n_v):
                on = v // (n_b + 1) - 1 != r and v % (n_b + 1) - 1 != q
                for c in range(n_c):
                    weight = w[c, r, q] * (1.0 if on else 0.0)
                    for m in range(n_m):
                        if m & bit:
                            g[c, v, m] += f[c, v, m ^ bit] * weight
        f, g = g, f
    total = np.empty((n_c, n_v))
    terms = np.empty(n_m)
    for v in range(n_v):
        skip_col = v % (n_b + 1) - 1
        for c in range(n_c):
            for m in range(n_m):
                used = 0
                for q in range(n_b):
                    used += (m >> q) & 1
                left = 1 if skip_col >= 0 else 0
                skipped = left == 1 and (m >> skip_col) & 1 > 0
                value = 0.0 if skipped else f[c, v, m]
                terms[m] = value * powers[max(n_b - used - left, 0)]
            total[c, v] = _sum(terms)
    return total.reshape(n_c, n_a + 1, n_b + 1)
