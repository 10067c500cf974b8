"""The other robots persist (``anonloc_env.identify.others``): exact sums; where it is used."""

from __future__ import annotations

import itertools
import math
from dataclasses import replace

import numpy as np
import pytest
from test_identify_reference import _model, simulate

from anonloc_env.identify import Identifier, SensorModel
from anonloc_env.identify.others import (
    CUTOFF_SIGMAS,
    END_FLOOR,
    MOVE_FLOOR,
    NEW_FLOOR,
    _sum_matchings,
    links_between,
    persists,
)


def _brute_z(w: np.ndarray, w_end: float, w_new: float, rows: list[int], cols: list[int]) -> float:
    """Sum over every partial matching of rows ``rows`` to columns ``cols`` (enumerated)."""
    total = 0.0
    for k in range(min(len(rows), len(cols)) + 1):
        for chosen in itertools.combinations(rows, k):
            for target in itertools.permutations(cols, k):
                weight = math.prod(w[a, b] for a, b in zip(chosen, target, strict=True))
                total += weight * w_end ** (len(rows) - k) * w_new ** (len(cols) - k)
    return total


def test_sum_matchings_is_the_enumeration() -> None:
    rng = np.random.default_rng(3)
    w = rng.random((4, 3)) * (rng.random((4, 3)) < 0.7)
    for skip_row, skip_col in [(-1, -1), (1, -1), (-1, 2), (0, 1)]:
        rows = [r for r in range(4) if r != skip_row]
        cols = [q for q in range(3) if q != skip_col]
        expected = _brute_z(w, 0.3, 0.2, rows, cols)
        got = _sum_matchings(w, 0.3, 0.2, skip_row=skip_row, skip_col=skip_col)
        assert math.isclose(got, expected, rel_tol=1e-12)


def test_link_weights_are_leave_out_ratios_of_the_whole_association() -> None:
    """Per component, as returned: equal to Z(-a, -b) / Z, Z(-a) / Z and Z(-b) / Z summed over
    the two whole pictures at once (every pair, every row)."""
    model = _model(p_detect=0.85, n_robots=6, false_positives=1.0, others_sigma=0.4)
    pix_var = 1.0
    rng = np.random.default_rng(7)
    prev = np.column_stack([rng.uniform(0, 300, (5, 2)), np.zeros(5)])
    rows = np.column_stack([prev[:4, :2] + rng.normal(0, 30, (4, 2)), np.zeros(4)])
    links = links_between(model, prev, rows, 0.0, pix_var)
    assert links is not None
    # The association's weights, written out from the module docstring.
    p_d, others = 0.85, 5
    share = others * p_d / (others * p_d + 1.0)
    var = (100.0 * 0.4) ** 2 + 2 * pix_var
    tail = math.exp(-0.5 * CUTOFF_SIGMAS**2)
    w_end = max(1.0 - share * p_d * (1.0 - tail), END_FLOOR)
    w_new = max(1.0 + others * p_d * (1.0 - p_d + tail), NEW_FLOOR) / model.image_area
    dist = np.linalg.norm(prev[:, None, :2] - rows[None, :, :2], axis=-1)
    w = share * p_d * np.exp(-0.5 * dist**2 / var) / (2 * math.pi * var)
    w[dist > CUTOFF_SIGMAS * math.sqrt(var)] = 0.0
    all_a, all_b = list(range(5)), list(range(4))
    z = _brute_z(w, w_end, w_new, all_a, all_b)
    for a in range(5):
        z_a = _brute_z(w, w_end, w_new, [x for x in all_a if x != a], all_b)
        assert math.isclose(links.miss(np.array([a]))[0], math.log(z_a / z), abs_tol=1e-9)
        for b in range(4):
            z_ab = _brute_z(
                w, w_end, w_new, [x for x in all_a if x != a], [y for y in all_b if y != b]
            )
            got = links.detect(np.array([a]), np.array([b]))[0]
            assert math.isclose(got, math.log(z_ab / z), abs_tol=1e-9)
    for b in range(4):
        z_b = _brute_z(w, w_end, w_new, all_a, [y for y in all_b if y != b])
        assert math.isclose(links.detect(np.array([-1]), np.array([b]))[0], math.log(z_b / z))


def test_clutter_model_kept_without_misses_or_false_positives() -> None:
    """Every robot seen and no false positive: the others' model is not used (beliefs are the
    clutter model's, bit for bit); with misses it is, and the beliefs differ."""
    clean = _model(n_robots=4, others_sigma=0.4)
    assert not persists(clean)
    assert persists(replace(clean, p_detect=0.9))
    assert persists(replace(clean, false_positives=0.5))
    assert not persists(replace(clean, p_detect=0.9, others_sigma=None))
    rows, intervals, _ = simulate(clean, 4, 4, 0.0, 0)
    beliefs = []
    for model in (clean, replace(clean, others_sigma=None)):
        ident = Identifier(model, 4)
        for k, picture in enumerate(rows):
            ident.update(picture, intervals[k - 1] if k else None)
        beliefs.append(ident.belief().copy())
    np.testing.assert_array_equal(beliefs[0], beliefs[1])


def test_persisting_others_make_fewer_confident_mistakes() -> None:
    """8 robots, 15 % misses, legs drawn as the model says (80 seeds, 6 pictures): confident
    decisions (>= 0.99) on another row than the robot's own. Measured: 10 with the clutter
    model, 3 with the others persisting; asserted: at most half (seeded, so exact; the
    calibration of the same cases is in ``test_identify_calibration``)."""
    counts = []
    for sigma in (None, 0.3):
        model = _model(p_detect=0.85, pixel_noise=2.0, n_robots=8, others_sigma=sigma)
        counts.append(_confident_mistakes(model, model, seeds=80))
    assert counts[1] <= 0.5 * counts[0], counts


def _confident_mistakes(truth: SensorModel, model: SensorModel, seeds: int) -> int:
    """Decisions at >= 0.99 on another row than the robot's own, 8 robots and 6 pictures drawn
    from ``truth`` (legs of 0.3 m), identified under ``model``."""
    wrong = 0
    for seed in range(seeds):
        rows, intervals, truths = simulate(truth, 8, 6, 0.0, seed, leg=0.3, margin=0.0)
        ident = Identifier(model, 8)
        for k, picture in enumerate(rows):
            ident.update(picture, intervals[k - 1] if k else None)
            if len(picture) == 0:
                continue
            belief = ident.belief()
            sure = belief.max(axis=1) >= 0.99
            wrong += int((sure & (belief.argmax(axis=1) != truths[k])).sum())
    return wrong


def test_repeated_displacements_are_a_mixture_over_the_previous_association() -> None:
    """With ``others_repeat``, the association between pictures 1 and 2 weighs each pair by the
    mixture of the module docstring: each row of picture 1 repeats the displacement from each row
    of picture 0 it continued, with ``others_repeat`` times that continuation's probability in
    the association between pictures 0 and 1 (enumerated here), else drawn afresh. Every link
    weight equals the leave-out ratio of the whole association, enumerated."""
    model = _model(
        p_detect=0.85,
        n_robots=6,
        false_positives=1.0,
        others_sigma=0.4,
        others_repeat=0.8,
        others_jitter=0.03,
        others_turn=0.3,
    )
    pix_var, scale = 1.0, 100.0
    rng = np.random.default_rng(11)
    first = rng.uniform(0, 60, (5, 2))
    step = rng.normal(0, 15, (5, 2))
    pictures = [first, first + step, first + 2 * step + rng.normal(0, 3, (5, 2))]
    pictures = [
        np.column_stack([p[:4] if k else p, np.zeros(4 if k else 5)])
        for k, p in enumerate(pictures)
    ]
    before = links_between(model, pictures[0], pictures[1], 0.0, pix_var)
    links = links_between(model, pictures[1], pictures[2], 0.0, pix_var, before)
    assert before is not None
    assert links is not None
    p_d, others = 0.85, 5
    share = others * p_d / (others * p_d + 1.0)
    tail = math.exp(-0.5 * CUTOFF_SIGMAS**2)
    w_end = max(1.0 - share * p_d * (1.0 - tail), END_FLOOR)
    w_new = max(1.0 + others * p_d * (1.0 - p_d + tail), NEW_FLOOR) / model.image_area

    def gauss(e: np.ndarray, var: np.ndarray | float) -> np.ndarray:
        d2 = (e**2).sum(-1)
        return np.where(
            d2 <= CUTOFF_SIGMAS**2 * var, np.exp(-0.5 * d2 / var) / (2 * math.pi * var), 0.0
        )

    var = (scale * 0.4) ** 2 + 2 * pix_var
    a0, a1, a2 = (p[:, :2] for p in pictures)
    w01 = share * p_d * gauss(a1[None] - a0[:, None], var)
    rows0, cols1 = list(range(5)), list(range(4))
    z01 = _brute_z(w01, w_end, w_new, rows0, cols1)
    move = np.zeros((5, 4))  # P(row x of picture 0 -> row y of picture 1)
    for x in rows0:
        for y in cols1:
            rest = _brute_z(
                w01, w_end, w_new, [r for r in rows0 if r != x], [c for c in cols1 if c != y]
            )
            move[x, y] = w01[x, y] * rest / z01
    kept = move >= MOVE_FLOOR
    got = {
        (int(b), tuple(np.round(d, 9))): p
        for b, d, p in zip(before.moved_row, before.moved, before.moved_p, strict=True)
    }
    assert len(got) == int(kept.sum())
    for x, y in zip(*np.nonzero(kept), strict=True):
        assert math.isclose(
            got[(int(y), tuple(np.round(a1[y] - a0[x], 9)))], move[x, y], rel_tol=1e-9
        )
    # The mixture between pictures 1 and 2.
    w12 = np.zeros((4, 4))
    for a in range(4):
        afresh = 1.0 - 0.8 * move[kept[:, a], a].sum()
        w12[a] = afresh * gauss(a2 - a1[a], var)
        for x in np.flatnonzero(kept[:, a]).tolist():
            d = a1[a] - a0[x]
            var_e = (scale * 0.03) ** 2 + (0.3 * np.hypot(*d)) ** 2 + 6 * pix_var
            w12[a] += 0.8 * move[x, a] * gauss(a2 - (a1[a] + d), var_e)
    w12 *= share * p_d
    assert np.count_nonzero(w12) > 8  # the test has pairs to sum
    # The repeats matter: each robot's continuation weighs more than drawn afresh alone.
    afresh_only = share * p_d * gauss(a2 - a1, var)
    assert np.all(np.diag(w12) > 2.0 * afresh_only)
    all4 = list(range(4))
    z = _brute_z(w12, w_end, w_new, all4, all4)
    for a in all4:
        for b in all4:
            z_ab = _brute_z(
                w12, w_end, w_new, [x for x in all4 if x != a], [y for y in all4 if y != b]
            )
            assert math.isclose(
                links.detect(np.array([a]), np.array([b]))[0], math.log(z_ab / z), abs_tol=1e-9
            )
    with pytest.raises(ValueError, match="before must link to prev"):
        links_between(model, pictures[0], pictures[1], 0.0, pix_var, before)


def test_others_repeat_is_validated() -> None:
    for name, value in [
        ("others_repeat", 1.0),
        ("others_repeat", -0.1),
        ("others_jitter", -1.0),
        ("others_turn", math.nan),
    ]:
        with pytest.raises(ValueError, match=name):
            _model(**{name: value})


def test_repeating_others_make_fewer_confident_mistakes() -> None:
    """8 robots, 15 % misses; the others' displacements repeat as the model says (0.85, 60
    seeds, 6 pictures). Confident decisions (>= 0.99) on another row than the robot's own:
    measured 9 with every displacement drawn afresh in the model, and 3 with the repeats;
    asserted: at most half (seeded, so exact)."""
    truth = _model(
        p_detect=0.85,
        pixel_noise=2.0,
        n_robots=8,
        others_sigma=0.3,
        others_repeat=0.85,
        others_jitter=0.02,
        others_turn=0.3,
    )
    counts = [
        _confident_mistakes(truth, model, seeds=60)
        for model in (replace(truth, others_repeat=0.0), truth)
    ]
    assert counts[1] <= 0.5 * counts[0], counts
