"""The identifier's compiled kernels (numba, the optional ``fast`` extra; see
:mod:`anonloc_env.compiled`): loops over candidates that do, element by element and in the same
order, what :mod:`anonloc_env.identify.kernels` does in whole-array numpy calls, so that each
picture costs a few calls instead of a few hundred.

They give the same floats to the bit: only ``+ - * /``, comparisons and ``rint`` happen inside
them (IEEE-exact, whatever the order of the loop), each expression parenthesised as numpy
evaluates it; the transcendentals (``log``, ``exp``, whose vectorised numpy forms differ from the
C library's in the last bit) and the final wrap of the headings stay numpy calls around them.
``tests/test_identify_fused.py`` runs both forms on the same pictures and compares every field.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from anonloc_env import compiled
from anonloc_env.compiled import jit
from anonloc_env.identify import fused_links


@jit
def _wrap_fast(angle: float) -> float:
    """:func:`~anonloc_env.identify.kernels.wrap_fast` of one angle (the same floats)."""
    turns = np.rint(angle * (0.5 / math.pi))
    turns = turns * (2.0 * math.pi)
    return angle - turns


@jit
def _stable_order(key: np.ndarray, n: int, order: np.ndarray) -> None:
    """``order[:n]`` = ``np.argsort(key[:n], kind="stable")`` (no NaN): a quicksort, then each
    run of equal keys put back in the order of its indices."""
    order[:n] = np.argsort(key[:n])
    start = 0
    while start < n:
        end = start + 1
        while end < n and key[order[end]] == key[order[start]]:
            end += 1
        for i in range(start + 1, end):  # ties (rare): by index
            item = order[i]
            j = i
            while j > start and order[j - 1] > item:
                order[j] = order[j - 1]
                j -= 1
            order[j] = item
        start = end


@jit
def _bucket_order(
    key: np.ndarray, n: int, base: float, span: float, order: np.ndarray, work: np.ndarray
) -> None:
    """:func:`_stable_order` (the same order, ties by index) in about linear time when the keys
    spread over ``[base, base + span]``: each index placed, in order, into one of ``n`` buckets by
    its key (a non-decreasing function of the key, so equal keys share a bucket and keep the
    order of their indices), then an insertion sort that moves only keys strictly greater. A NaN
    key, or more moves than a few per key (keys bunched in few buckets), falls back to
    :func:`_stable_order`. ``work``: ``2 n + 1`` integers of scratch."""
    scale = n / span
    counts, bucket = work[: n + 1], work[n + 1 : 2 * n + 1]
    counts[:] = 0
    for m in range(n):
        v = (key[m] - base) * scale
        if v != v:  # NaN
            _stable_order(key, n, order)
            return
        b = n - 1 if v >= n else (int(v) if v > 0.0 else 0)
        bucket[m] = b
        counts[b + 1] += 1
    for b in range(n - 1):
        counts[b + 1] += counts[b]
    for m in range(n):
        b = bucket[m]
        order[counts[b]] = m
        counts[b] += 1
    budget = 8 * n + 64
    for i in range(1, n):
        item = order[i]
        v = key[item]
        j = i
        while j > 0 and key[order[j - 1]] > v:
            order[j] = order[j - 1]
            j -= 1
        order[j] = item
        budget -= i - j
        if budget < 0:  # bunched: the general sort
            _stable_order(key, n, order)
            return


@jit
def _first_leg_robot(
    r: int, lo: int, hi: int, leg: Any, found: tuple[np.ndarray, np.ndarray, np.ndarray]
) -> tuple[int, float]:
    """Robot ``r`` along the pairs ``by_length[lo:hi]`` of ``leg`` (see :func:`first_leg`): the
    gate, the heading Kalman step and the detected heading of ``kernels._first_leg_block``.
    Writes the row (of ``by_length``), log weight and heading (before its wrap) of each
    candidate that passes into ``found``; returns how many passed and the best log weight."""
    by_length, per_robot, frames, per_pair, adds, motion, numbers, _ = leg
    s, scale, theta_var, gate_chi2 = numbers[0], numbers[1], numbers[2], numbers[3]
    pick, logw, theta = found
    dx, dy, dphi = motion[0, r], motion[1, r], motion[2, r]
    a_r, b_r = per_robot[5, r], per_robot[4, r]
    n = 0
    best = -np.inf
    for m in range(lo, hi):
        ex = frames[0, m] - per_robot[0, r]
        ey = frames[1, m] - per_robot[1, r]
        e2 = ex * ex + ey * ey
        turn = _wrap_fast(frames[3, m] - dphi)
        chi2 = e2 / per_robot[2, r] + turn * turn / per_robot[3, r]
        if not chi2 <= gate_chi2:
            continue
        if s != scale:
            ex = frames[0, m] - s * dx
            ey = frames[1, m] - s * dy
            e2 = ex * ex + ey * ey
        h_e = s * (dx * ey - dy * ex)
        maha = (e2 - theta_var * h_e * h_e / a_r) / b_r
        theta1 = frames[2, m] + theta_var * h_e / a_r + dphi
        err = _wrap_fast(frames[4, m] - theta1)
        w = per_robot[9, r] - 0.5 * maha - 0.5 * (err * err / per_robot[7, r])
        if adds[0]:
            w += per_pair[0, m]
        if adds[1]:
            w += per_pair[1, m]
        pick[n], logw[n], theta[n] = by_length[m], w, theta1 + per_robot[8, r] * err
        best = compiled.maximum(best, w)
        n += 1
    return n, best


@jit
def first_leg(
    cuts: np.ndarray,
    robots: np.ndarray,
    start: np.ndarray,
    counts: np.ndarray,
    leg: Any,
    out: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
) -> int:
    """``kernels._first_leg_block`` over every block ``cuts[b]:cuts[b + 1]`` of robots, and
    the tracks ``kernels.first_leg`` builds of what is kept, heaviest first within each robot
    (ties in the order of the candidates): written into ``out`` = ``(slot, row, pos, logw,
    theta, p_tt)`` (each ``counts.sum()`` long at least, ``pos`` ``(., 2)``); returns how many.

    ``leg`` is ``(by_length, per_robot, frames, per_pair, adds, motion, numbers, rows)``: robot
    ``robots[k]``'s candidates are the pairs ``start[k]:start[k] + counts[k]`` of the pairs
    sorted by length, whose rows in the new picture ``rows`` ``(n_rows, 3)`` are
    ``by_length``; ``per_robot`` ``(11, n)``: the fields of ``kernels._Robots`` in their order,
    then the heading variance a track keeps; ``frames`` ``(5, pairs)``: those of
    ``kernels._Frames`` in the sorted order (so that each robot reads a run); ``per_pair``
    ``(2, pairs)``, in that order too: what the links and the row bias add to a pair's weight,
    added in that order where ``adds`` says; ``motion`` ``(3, n)``: the interval's ``dx``,
    ``dy`` and ``dphi``; ``numbers``: the scale a track holds, the model's scale, the detected
    heading's variance, the gate's chi-square and the prune's nats."""
    nats, per_robot, rows = leg[6][4], leg[1], leg[7]
    out_slot, out_row, out_pos, out_logw, out_theta, out_ptt = out
    widest = counts.max() if len(counts) else 0
    found = (np.empty(widest, dtype=np.int64), np.empty(widest), np.empty(widest))
    pick, logw, theta = found
    key = np.empty(widest)
    order = np.empty(widest, dtype=np.int64)
    work = np.empty(2 * widest + 1, dtype=np.int64)
    step = 2.0 * nats + 2.0
    count = 0
    for b in range(len(cuts) - 1):
        group = -1
        for k in range(cuts[b], cuts[b + 1]):
            r = robots[k]
            n, best = _first_leg_robot(r, start[k], start[k] + counts[k], leg, found)
            if n == 0:
                continue
            group += 1
            floor = best - nats
            kept = 0
            for m in range(n):
                if logw[m] >= floor:
                    pick[kept], logw[kept], theta[kept] = pick[m], logw[m], theta[m]
                    key[kept] = group * step + (floor + nats - logw[m])
                    kept += 1
            _bucket_order(key, kept, group * step, nats, order, work)
            for m in range(kept):
                q = order[m]
                row = pick[q]
                out_slot[count], out_row[count] = r, row
                out_pos[count, 0], out_pos[count, 1] = rows[row, 0], rows[row, 1]
                out_logw[count], out_theta[count] = logw[q], _wrap(theta[q])
                out_ptt[count] = per_robot[10, r]
                count += 1
    return count


@jit
def pruned_order(
    slot: np.ndarray, logw: np.ndarray, best: np.ndarray, nats: float, cap: int, into: np.ndarray
) -> tuple[np.ndarray, bool]:
    """``Identifier._normalise_and_prune``'s order (see :mod:`anonloc_env.identify.filter`):
    each robot's best raised to its tracks' (``best`` ``(R,)``, in place), the tracks ``slot``,
    ``logw`` ``(H,)`` at most ``nats`` below it kept, sorted by robot and by the key
    ``slot * (2 nats + 2) + (best - logw)`` (ties by index, as ``np.argsort(kind="stable")``),
    at most ``cap`` per robot. Returns ``(index, ok)``, ``index`` the start of ``into`` (at
    least ``(H,)``); ``ok`` False, and ``index`` empty, when a robot's best is not finite (the
    caller's numpy path starts it over)."""
    n, h_count = best.shape[0], slot.shape[0]
    for k in range(h_count):
        i = slot[k]
        best[i] = compiled.maximum(best[i], logw[k])
    for i in range(n):
        if not np.isfinite(best[i]):
            return into[:0], False
    # The kept tracks by robot, each robot's in the order of their index (a counting sort).
    start = np.zeros(n + 1, dtype=np.int64)
    for k in range(h_count):
        if logw[k] >= best[slot[k]] - nats:
            start[slot[k] + 1] += 1
    widest = 0
    for i in range(n):
        widest = max(widest, start[i + 1])
        start[i + 1] += start[i]
    index = into[: start[n]]
    fill = start[:n].copy()
    for k in range(h_count):
        if logw[k] >= best[slot[k]] - nats:
            index[fill[slot[k]]] = k
            fill[slot[k]] += 1
    # Each robot's run sorted by its key (the keys of different robots never overlap), the
    # first ``cap`` of it moved to the front (over runs already read).
    step = 2.0 * nats + 2.0
    key = np.empty(widest)
    run = np.empty(widest, dtype=np.int64)
    order = np.empty(widest, dtype=np.int64)
    work = np.empty(2 * widest + 1, dtype=np.int64)
    count = 0
    for i in range(n):
        lo, size = start[i], start[i + 1] - start[i]
        for j in range(size):
            k = index[lo + j]
            run[j] = k
            key[j] = slot[k] * step + (best[i] - logw[k])
        _bucket_order(key, size, i * step, nats, order, work)
        for j in range(min(size, cap)):
            index[count] = run[order[j]]
            count += 1
    return index[:count], True


@jit
def _wrap(angle: float) -> float:
    """:func:`~anonloc_env.geometry.wrap_angle` of one angle (the same floats: ``np.mod`` and
    Python's ``%`` both take ``fmod`` and move its result into the divisor's sign)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


@jit
def _at(a: np.ndarray, k: int) -> float:
    """``a[k]``, or ``a[0]`` for a field held alike by every track (passed as one item)."""
    return a[k] if a.shape[0] > 1 else a[0]


@jit
def known_children(
    track: np.ndarray,
    fields: np.ndarray,
    pos_var: np.ndarray,
    scale: np.ndarray,
    robot: np.ndarray,
    d: np.ndarray,
    cand: np.ndarray,
    rows: np.ndarray,
    numbers: np.ndarray,
    orientation: bool,
    index: np.ndarray,
    out: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The gate and the Kalman step of tracks that all know their heading and scale and carry
    no motion: ``Gate.of`` (its ``_all_known``), ``Gate.passes`` and
    :func:`~anonloc_env.identify.kernels.known_children`'s arithmetic up to its ``log``.

    Tracks ``track`` ``(3, H)``: each one's robot, and the range ``track[1, h]:track[2, h]`` of
    ``cand`` that holds its candidate rows of the new picture ``rows``; ``fields``
    ``(4, H)``: its ``pos`` x and y, ``theta`` and ``p_tt``; ``pos_var`` and ``scale``
    ``(H,)``, or ``(1,)`` where every track holds them alike. Per robot, ``robot`` ``(4, n)``:
    ``dphi``, the gate's worst variance, ``var_d`` and ``var_dphi``; ``d`` ``(n, 2)``.
    ``numbers``: the pixel variance, the scale spread, the detected heading's variance and the
    gate's chi-square.

    Returns ``(index, out)``, the first ``K`` columns of ``index`` ``(2, C)`` and ``out``
    ``(4, C)`` (``C`` the candidates, ``sum(hi - lo)``): ``index`` each candidate's track and
    place in ``cand``; ``out``: ``b a`` (whose ``log`` the caller takes), the Mahalanobis
    term, the heading and its variance after the step."""
    pix_var, spread_s, theta_var, gate_chi2 = numbers[0], numbers[1], numbers[2], numbers[3]
    slot_of, lo, hi = track[0], track[1], track[2]
    h_count = slot_of.shape[0]
    rho = np.empty(d.shape[0])  # each robot's path, once per robot (not per track)
    for i in range(d.shape[0]):
        rho[i] = math.hypot(d[i, 0], d[i, 1])
    k = 0
    for h in range(h_count):
        i = slot_of[h]
        s, th, ptt = _at(scale, h), fields[2, h], fields[3, h]
        d0, d1 = d[i, 0], d[i, 1]
        rho0 = rho[i]
        c, sn = math.cos(th), math.sin(th)
        m0 = s * (c * d0 - sn * d1)
        m1 = s * (sn * d0 + c * d1)
        c0, c1 = fields[0, h] + m0, fields[1, h] + m1
        sr = s * rho0
        spread = (robot[1, i] + _at(pos_var, h)) + sr * sr * ptt
        turn_c = th + robot[0, i]
        turn_var = ptt + robot[3, i] + theta_var
        for q in range(lo[h], hi[h]):
            j = cand[q]
            dx = rows[j, 0] - c0
            dy = rows[j, 1] - c1
            chi2 = dx * dx + dy * dy
            chi2 /= spread
            if not chi2 <= gate_chi2:
                continue
            if orientation:
                turn = _wrap(rows[j, 2] - turn_c)
                if not chi2 + turn * turn / turn_var <= gate_chi2:
                    continue
            # known_children's Kalman step (kalman_heading).
            ss = spread_s * s * rho0
            b = pix_var + _at(pos_var, h) + s * s * robot[2, i] + ss * ss
            ex = (rows[j, 0] - fields[0, h]) - m0
            ey = (rows[j, 1] - fields[1, h]) - m1
            h_e = m0 * ey - m1 * ex
            a = b + ptt * (m0 * m0 + m1 * m1)
            index[0, k], index[1, k] = h, q
            out[0, k] = b * a
            out[1, k] = (ex * ex + ey * ey - ptt * h_e * h_e / a) / b
            out[2, k] = th + ptt * h_e / a + robot[0, i]
            out[3, k] = compiled.maximum(ptt * b / a, 1e-14) + robot[3, i]
            k += 1
    return index[:, :k], out[:, :k]  # each row contiguous (callers read rows)


@jit
def finish_known(
    slot: np.ndarray,
    detected: np.ndarray,
    loglik: np.ndarray,
    theta: np.ndarray,
    p_tt: np.ndarray,
    log_var: np.ndarray,
    base: np.ndarray,
    bg: np.ndarray,
    numbers: np.ndarray,
    orientation: bool,
    keep: np.ndarray,
    logw: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`~anonloc_env.identify.likelihood.orientation`, the weight and
    :func:`~anonloc_env.identify.likelihood.pruned`'s prune of the candidates of
    :func:`~anonloc_env.identify.kernels.known_children` (robots ``slot``, grouped):
    ``loglik``, ``theta`` and ``p_tt`` ``(K,)`` are updated in place; ``log_var`` ``(K,)`` is
    numpy's ``log(p_tt + var_z)``; ``base`` ``(K,)`` the parents' log weights; ``bg`` ``(K,)``
    or ``(1,)`` what each is divided by (a log); ``numbers``: the detected heading's variance,
    ``log(2 pi)``, ``log P_D`` and the prune's nats.

    Returns ``(keep, logw)``: the candidates kept (in order, the start of ``keep``) and every
    candidate's log weight (``logw``); ``keep`` and ``logw`` ``(K,)`` are written."""
    var_z, log_2pi, log_pd, nats = numbers[0], numbers[1], numbers[2], numbers[3]
    n = slot.shape[0]
    for k in range(n):
        if orientation:
            err = _wrap(detected[k] - theta[k])
            var = p_tt[k] + var_z
            loglik[k] += -0.5 * (log_2pi + log_var[k] + err * err / var)
            gain = p_tt[k] / var
            theta[k] += gain * err
            p_tt[k] *= 1 - gain
        logw[k] = base[k] + log_pd + loglik[k] - _at(bg, k)
    kept = 0
    start = 0
    while start < n:
        end = start + 1
        best = logw[start]
        while end < n and slot[end] == slot[start]:
            best = compiled.maximum(best, logw[end])
            end += 1
        floor = best - nats
        for k in range(start, end):
            if logw[k] >= floor:
                keep[kept] = k
                kept += 1
        start = end
    return keep[:kept], logw


@jit
def general_inputs(
    parents: np.ndarray,
    fields: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    log_s: np.ndarray,
    s: np.ndarray,
    pos: np.ndarray,
    slot: np.ndarray,
    robots: np.ndarray,
    cov: np.ndarray,
    z: np.ndarray,
) -> np.ndarray:
    """The ``(17, K)`` input of :func:`general_kalman` for candidates of parent tracks
    ``parents`` at rows ``z`` ``(K, >= 2)``: ``fields`` are the tracks' ``theta``, ``p_tt``,
    ``p_ts``, ``p_ss`` and ``pos_var`` (each ``(H,)``, or ``(1,)`` where shared); ``log_s``
    and ``s = exp(log_s)`` (numpy's) per candidate (or ``(1,)``); ``pos`` ``(H, 2)``, ``slot``
    ``(H,)``; per robot ``robots`` ``(5, n)``: ``d`` (two rows), ``var_d``, ``dphi`` and
    ``var_dphi``, and ``cov`` ``(n, 2, 2)`` the push covariance. Gathers what
    ``fused_calls.general_step`` gathered in numpy (the same values)."""
    theta, p_tt, p_ts, p_ss, pos_var = fields
    count = parents.shape[0]
    x = np.empty((17, count))
    for k in range(count):
        h = parents[k]
        i = slot[h]
        x[0, k], x[1, k], x[2, k] = _at(theta, h), _at(log_s, k), _at(p_tt, h)
        x[3, k], x[4, k], x[5, k] = _at(p_ts, h), _at(p_ss, h), _at(s, k)
        x[6, k], x[7, k] = robots[0, i], robots[1, i]
        x[8, k], x[9, k] = z[k, 0] - pos[h, 0], z[k, 1] - pos[h, 1]
        x[10, k], x[11, k], x[12, k] = cov[i, 0, 0], cov[i, 0, 1], cov[i, 1, 1]
        x[13, k], x[14, k] = _at(pos_var, h), robots[2, i]
        x[15, k], x[16, k] = robots[3, i], robots[4, i]
    return x


@jit
def general_kalman(x: np.ndarray, pix_var: float, spread: float) -> np.ndarray:
    """:func:`~anonloc_env.identify.likelihood.kalman`'s general step (heading known, scale
    known or estimated, unseen pushes) of candidates ``x`` ``(17, K)``: the parent's ``theta``,
    ``log s``, ``p_tt``, ``p_ts``, ``p_ss`` and ``s = exp(log s)`` (numpy's), the robot's own
    displacement ``d``, the displacement to the row, the push covariance ``(xx, xy, yy)``
    (robot frame, m^2), the parent's position variance, the robot's ``var_d``, ``dphi`` and
    ``var_dphi``. ``pix_var`` and ``spread`` (the model's scale spread) complete
    ``Geometry.base_var``.

    Returns ``(7, K)``: ``det S`` (whose ``log`` the caller takes), the Mahalanobis term, and
    the new ``theta``, ``p_tt``, ``log s``, ``p_ts`` and ``p_ss``."""
    count = x.shape[1]
    out = np.empty((7, count))
    quarter_c, quarter_s = math.cos(math.pi / 2.0), math.sin(math.pi / 2.0)
    for k in range(count):
        th, ls, ptt, pts, pss, s = x[0, k], x[1, k], x[2, k], x[3, k], x[4, k], x[5, k]
        d0, d1, e_0, e_1 = x[6, k], x[7, k], x[8, k], x[9, k]
        rho0 = math.hypot(d0, d1)
        ss = spread * s * rho0
        base = pix_var + x[13, k] + s * s * x[14, k] + ss * ss
        cxx, cxy, cyy = x[10, k] * (s * s), x[11, k] * (s * s), x[12, k] * (s * s)
        c, sn = math.cos(th), math.sin(th)
        q11 = c * c * cxx - 2 * c * sn * cxy + sn * sn * cyy
        q12 = c * sn * (cxx - cyy) + (c * c - sn * sn) * cxy
        q22 = sn * sn * cxx + 2 * c * sn * cxy + c * c * cyy
        p0 = (c * d0 - sn * d1) * s  # h(x) = s R(theta) d
        p1 = (sn * d0 + c * d1) * s
        t0 = quarter_c * p0 - quarter_s * p1  # dh/dtheta: h turned a quarter
        t1 = quarter_s * p0 + quarter_c * p1
        e0, e1 = e_0 - p0, e_1 - p1
        a0, a1 = t0 * ptt + p0 * pts, t1 * ptt + p1 * pts  # H P, first column
        b0, b1 = t0 * pts + p0 * pss, t1 * pts + p1 * pss  # second column
        s11 = base + q11 + a0 * t0 + b0 * p0
        s12 = q12 + a0 * t1 + b0 * p1
        s22 = base + q22 + a1 * t1 + b1 * p1
        det = s11 * s22 - s12 * s12
        i11, i12, i22 = s22 / det, -s12 / det, s11 / det
        out[0, k] = det
        out[1, k] = e0 * e0 * i11 + 2 * e0 * e1 * i12 + e1 * e1 * i22
        f0, f1 = i11 * e0 + i12 * e1, i12 * e0 + i22 * e1
        at0, at1 = i11 * a0 + i12 * a1, i12 * a0 + i22 * a1
        as0, as1 = i11 * b0 + i12 * b1, i12 * b0 + i22 * b1
        out[2, k] = th + (a0 * f0 + a1 * f1) + x[15, k]
        out[3, k] = compiled.maximum(ptt - (a0 * at0 + a1 * at1), 1e-14) + x[16, k]
        out[4, k] = ls + (b0 * f0 + b1 * f1)
        out[5, k] = pts - (a0 * as0 + a1 * as1)
        out[6, k] = compiled.maximum(pss - (b0 * as0 + b1 * as1), 0.0)
    return out


@jit
def belief_table(
    slot: np.ndarray, row: np.ndarray, share: np.ndarray, uniform: np.ndarray, table: np.ndarray
) -> None:
    """``Identifier.belief``'s table with no row bias, written into ``table`` ``(R, n)``: the
    shares ``share`` of tracks ``slot``, ``row`` summed in their order from zero (as
    ``np.bincount`` sums them), then each robot's uniform weight ``uniform`` added to its row
    where any is not zero (as ``belief += uniform[:, None]``)."""
    n_robots, n_rows = table.shape
    for i in range(n_robots):
        for r in range(n_rows):
            table[i, r] = 0.0
    for k in range(slot.shape[0]):
        table[slot[k], row[k]] += share[k]
    if np.any(uniform != 0.0):
        for i in range(n_robots):
            u = uniform[i]
            for r in range(n_rows):
                table[i, r] += u


_LOADED: list[bool] = []


def load() -> None:
    """Compile, or load from numba's cache, every kernel the identifier calls (those of this
    module, of :mod:`~anonloc_env.identify.fused_links` and :mod:`anonloc_env.compiled`'s
    neighbour search and leave-out sums), once per
    process, by calling each on a tiny input of the types the identifier passes: the time goes
    to building the identifier, not to its first pictures."""
    if _LOADED:
        return
    compiled.pairs_within(np.zeros((1, 2)), np.zeros((1, 2)), 1.0)
    compiled.leave_out_sums(np.ones((1, 1, 1)), 1.0, np.ones(2))
    compiled.pairs_within_each(
        np.zeros((1, 2)), np.zeros((1, 2)), np.ones(1), np.zeros(1, np.int64)
    )
    one, two = np.zeros(1, dtype=np.int64), np.array([0, 1], dtype=np.int64)
    ones = np.ones
    leg = (
        one, ones((11, 1)), ones((5, 1)), ones((2, 1)), (True, True), ones((3, 1)), ones(5),
        ones((1, 3)),
    )  # fmt: skip
    floats = ones(1)
    first_leg(two, one, one, one + 1, leg, (one, one, ones((1, 2)), floats, floats, floats))
    known_children(
        np.array([[0], [0], [1]]), ones((4, 1)), ones(1), ones(1), ones((4, 1)), ones((1, 2)),
        one, ones((1, 3)), ones(4), True, np.zeros((2, 1), np.int64), ones((4, 1)),
    )  # fmt: skip
    finish_known(
        one, ones(1), ones(1), ones(1), ones(1), ones(1), ones(1), ones(1), ones(4), True,
        one.copy(), ones(1),
    )  # fmt: skip
    general_kalman(ones((17, 1)), 1.0, 1.0)
    pruned_order(one, ones(1), ones(1), 30.0, 8, one.copy())
    belief_table(one, one, ones(1), ones(1), ones((1, 1)))
    fields = (ones(1), ones(1), ones(1), ones(1), ones(1))
    general_inputs(
        one,
        fields,
        ones(1),
        ones(1),
        ones((1, 2)),
        one,
        ones((5, 1)),
        ones((1, 2, 2)),
        ones((1, 3)),
    )
    fused_links.load()
    _LOADED.append(True)
