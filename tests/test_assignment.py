"""The least-cost pairing the registration matches rows with (anonloc_env.identify.assignment)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from anonloc_env.identify.assignment import least_cost_pairs


def _brute_force(
    i: np.ndarray, j: np.ndarray, cost: np.ndarray, n_rows: int, n_cols: int, unpaired: float
) -> float:
    """The least total cost over every set of candidate pairs that shares no row or column."""
    best = (n_rows + n_cols) * unpaired
    for size in range(1, min(n_rows, n_cols, len(i)) + 1):
        for chosen in itertools.combinations(range(len(i)), size):
            rows, cols = i[list(chosen)], j[list(chosen)]
            if len(set(rows)) < size or len(set(cols)) < size:
                continue
            total = cost[list(chosen)].sum() + (n_rows + n_cols - 2 * size) * unpaired
            best = min(best, float(total))
    return best


def test_second_nearest_places_for_both_rows_beat_one_nearest_pair() -> None:
    """Row 0 is nearest place 1 (cost 1) but row 1 has only place 1 (cost 2); pairing row 0
    with place 0 (cost 3) and row 1 with place 1 costs 5, less than 1 plus two rows and two
    places left unpaired; mutual nearest neighbours would take (0, 1) alone."""
    i, j = np.array([0, 0, 1]), np.array([0, 1, 1])
    taken = least_cost_pairs(i, j, np.array([3.0, 1.0, 2.0]), 2, 2, unpaired=4.0)
    assert taken.tolist() == [True, False, True]


def test_no_pair_costs_more_than_leaving_its_row_and_place_unpaired() -> None:
    i, j = np.array([0, 1]), np.array([0, 1])
    taken = least_cost_pairs(i, j, np.array([7.9, 8.1]), 2, 2, unpaired=4.0)
    assert taken.tolist() == [True, False]


def test_nothing_to_pair() -> None:
    empty = np.zeros(0, np.int64)
    assert least_cost_pairs(empty, empty, np.zeros(0), 3, 2, 1.0).tolist() == []


@pytest.mark.parametrize("seed", range(4))
def test_pairing_is_one_to_one_and_of_least_total_cost(seed: int) -> None:
    """Seeded random problems (up to 5 rows and 5 columns, some costs tied) against every
    possible set of pairs."""
    rng = np.random.default_rng(seed)
    for _ in range(60):
        n_rows, n_cols = int(rng.integers(0, 6)), int(rng.integers(0, 6))
        i, j = np.nonzero(rng.random((n_rows, n_cols)) < rng.random())
        cost = np.round(rng.random(len(i)) * 8.0, int(rng.integers(0, 3)))
        unpaired = float(rng.random() * 5.0)
        taken = least_cost_pairs(i, j, cost, n_rows, n_cols, unpaired)
        assert len(set(i[taken])) == len(set(j[taken])) == int(taken.sum())
        total = cost[taken].sum() + (n_rows + n_cols - 2 * int(taken.sum())) * unpaired
        assert total == pytest.approx(_brute_force(i, j, cost, n_rows, n_cols, unpaired))


def test_the_compiled_search_gives_the_plain_ones_pairs() -> None:
    """With the kernels compiled, :func:`augment` is numba's; its plain Python form (run where
    numba is not installed) gives the same columns on seeded random problems."""
    from anonloc_env import compiled
    from anonloc_env.identify import assignment

    if compiled.mode() is None or not hasattr(assignment.augment, "py_func"):
        pytest.skip("the kernels are not compiled here")
    rng = np.random.default_rng(7)
    for _ in range(100):
        n_rows, n_cols = int(rng.integers(1, 30)), int(rng.integers(1, 30))
        i, j = np.nonzero(rng.random((n_rows, n_cols)) < 0.2)
        costs = -rng.random(len(i)) * 9.0
        starts = np.searchsorted(i, np.arange(n_rows + 1))
        fast = assignment.augment(starts, j, costs, n_rows, n_cols)
        plain = assignment.augment.py_func(starts, j, costs, n_rows, n_cols)
        assert np.array_equal(fast, plain)
