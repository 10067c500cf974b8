"""Identifier.belief_at: one entry per robot, the same numbers as the full belief table."""

from __future__ import annotations

import numpy as np
import pytest
from test_identify_reference import _model, simulate

from anonloc_env.identify import Identifier


@pytest.mark.parametrize(("p_detect", "fp", "robots"), [(1.0, 0.0, 6), (0.85, 2.0, 8)])
def test_belief_at_reads_the_belief_table_exactly(p_detect: float, fp: float, robots: int) -> None:
    model = _model(p_detect=p_detect, n_robots=robots, false_positives=fp)
    for seed in range(4):
        rows, intervals, truths = simulate(model, robots, 5, fp, seed, leg=0.3, margin=0.0)
        ident = Identifier(model, robots)
        for k, picture in enumerate(rows):
            ident.update(picture, intervals[k - 1] if k else None)
            got = ident.belief_at(truths[k])  # -1 where the robot was missed
            table, missing = ident.belief(), ident.missing()
            want = np.where(
                truths[k] >= 0, table[np.arange(robots), np.maximum(truths[k], 0)], missing
            )
            np.testing.assert_array_equal(got, want)
            # Every row of every robot, not only the true ones.
            for row in range(len(picture)):
                np.testing.assert_array_equal(ident.belief_at(np.full(robots, row)), table[:, row])


def test_belief_at_refuses_what_it_cannot_read() -> None:
    model = _model(n_robots=3)
    ident = Identifier(model, 3)
    with pytest.raises(RuntimeError, match="update"):
        ident.belief_at(np.zeros(3, np.int64))
    rows, _, _ = simulate(model, 3, 1, 0.0, 0)
    ident.update(rows[0])
    with pytest.raises(ValueError, match="shape"):
        ident.belief_at(np.zeros(2, np.int64))
    with pytest.raises(ValueError, match="integer"):
        ident.belief_at(np.zeros(3))
    with pytest.raises(ValueError, match=r"\[-1, 3\)"):
        ident.belief_at(np.array([0, 1, 3]))


def test_the_belief_table_is_the_shares_plus_the_uniform_weight_times_the_rows() -> None:
    """Where every row weighs one, the table adds each robot's uniform weight to its row of
    shares without building the ``(R, n)`` product: the same bits as with it."""
    robots = 7
    model = _model(p_detect=0.9, n_robots=robots, false_positives=1.0)
    rows, intervals, _ = simulate(model, robots, 4, 1.0, 3, leg=0.3, margin=0.0)
    ident = Identifier(model, robots)
    checked = 0
    for k, picture in enumerate(rows):
        ident.update(picture, intervals[k - 1] if k else None)
        assert ident.row_bias is None
        slot, row, share, uniform, spread = ident._shares
        n_rows = len(spread)
        want = np.bincount(slot * n_rows + row, weights=share, minlength=robots * n_rows)
        want = want.reshape(robots, n_rows).astype(np.float64)
        want += uniform[:, None] * spread[None, :]
        checked += bool(uniform.any())
        assert ident.belief().tobytes() == want.tobytes()
    assert checked
