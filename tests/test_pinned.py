"""Pinned robots decide later (issue 23, fourteenth round): in a crowd, ``bayes``'s decisions
(``Decisions.crowd``) let a robot pushed in most of its newest intervals that hardly rolled in
them (``CROWD_PINNED``) take a new decision only at a higher belief; elsewhere nothing changes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from anonloc_env.identify import Identifier, SensorModel
from baselines.decisions import CROWD_PINNED, Decisions, in_crowd
from benchmarks.crowds import load_recorded
from tests.helpers import lost_decisions, wrong_decisions

#: ``random``, N = 30 at 4 robots per m^2, seed 90003 of the thirteenth grid (robot 28, pressed
#: against the arena's wall, took a far still robot's row for 9 pictures), 30 pictures, played
#: at ``b491fec``: ``python -m benchmarks.crowds record tests/data/crowd_pinned.npz --density 4
#: --robots 30 --excitation random --seed 90003 --pictures 30``.
PINNED = Path(__file__).parent / "data" / "crowd_pinned.npz"


def _thirteenth() -> Decisions:
    """``Decisions.crowd`` as it was before the pinned robots' guard."""
    return Decisions.crowd(pinned=None)


def _played(rules: dict[str, Decisions]) -> tuple[dict[str, list[np.ndarray]], list, list, list]:
    """Each rule's decisions on the recorded episode, its true rows, top beliefs and whether
    each robot was pinned (by ``CROWD_PINNED``'s measure)."""
    config, result = load_recorded(str(PINNED))
    model = SensorModel.from_config(config)
    assert in_crowd(model)
    identifier = Identifier(model, result.n_robots)
    out: dict[str, list[np.ndarray]] = {name: [] for name in rules}
    window, pushes, path, _ = CROWD_PINNED
    tops, pinned, pushed, rolled = [], [], [], []
    for rows, interval in zip(result.pictures, [None, *result.intervals], strict=False):
        identifier.update(rows, interval)
        belief = identifier.belief()
        if interval is not None:
            pushed.append(identifier.pushed_run >= 1)
            rolled.append(interval.path)
        full = len(pushed) >= window
        pinned.append(
            full
            & (np.sum(pushed[-window:], axis=0) >= pushes)
            & (np.sum(rolled[-window:], axis=0) < path)
        )
        tops.append(belief.max(axis=1))
        for name, rule in rules.items():
            out[name].append(rule.decide(identifier, belief).copy())
    return out, list(result.true_rows), tops, pinned


def test_a_pinned_robot_no_longer_takes_a_far_robots_row() -> None:
    """On the recorded episode the thirteenth round's decisions (and the threshold's) were wrong
    at 9 robot-pictures (robot 28, pictures 17 to 25, beliefs 0.990 to 0.9989); ``bayes``'s
    default is wrong at none: robot 28 stays undecided, and 8 right robot-pictures wait."""
    rules = {"bayes": Decisions.crowd(), "thirteenth": _thirteenth(), "threshold": Decisions()}
    found, true, _, _ = _played(rules)
    wrong = {name: wrong_decisions(found[name], true) for name in rules}
    assert wrong == {"bayes": 0, "thirteenth": 9, "threshold": 9}
    decided = {name: int(sum((e >= 0).sum() for e in found[name])) for name in rules}
    assert decided == {"bayes": 656, "thirteenth": 673, "threshold": 665}
    assert lost_decisions(found["bayes"], true) == lost_decisions(found["thirteenth"], true) == 1
    assert all(e[28] < 0 for e in found["bayes"])
    before, rows = np.array(found["thirteenth"]), np.array(true)
    wrong_at = (before[:, 28] >= 0) & (before[:, 28] != rows[:, 28])
    assert np.flatnonzero(wrong_at).tolist() == list(range(17, 26))


def test_a_pinned_robot_decides_only_at_the_higher_threshold() -> None:
    """No robot pinned now goes from undecided to decided below ``CROWD_PINNED``'s threshold;
    robots not pinned decide as the thirteenth round's rule does at each picture where the two
    agreed on the picture before."""
    rules = {"bayes": Decisions.crowd(), "thirteenth": _thirteenth()}
    found, _, tops, pinned = _played(rules)
    ours, theirs = found["bayes"], found["thirteenth"]
    for k in range(1, len(ours)):
        new = (ours[k] >= 0) & (ours[k - 1] < 0)
        assert np.all(tops[k][new & pinned[k]] >= CROWD_PINNED[3])
        same = ours[k - 1] == theirs[k - 1]
        free = same & ~pinned[k]
        assert np.array_equal(ours[k][free], theirs[k][free])
    assert sum(int(p.sum()) for p in pinned) > 100  # pinned robot-pictures on this episode


@pytest.mark.parametrize(
    "pinned",
    [(5, 6, 0.15, 0.999), (5, 0, 0.15, 0.999), (5, 4, 0.0, 0.999), (5, 4, 0.15, 0.5), (5, 4, 0.15)],
)
def test_pinned_refuses_bad_settings(pinned: tuple) -> None:
    with pytest.raises(ValueError, match="pinned"):
        Decisions(pinned=pinned)


def test_bayes_guards_pinned_robots_in_a_crowd_only() -> None:
    """``Decisions.crowd`` carries ``CROWD_PINNED``; a ``Decisions`` without it is unchanged."""
    assert Decisions.crowd().pinned == CROWD_PINNED
    assert Decisions().pinned is None
    assert Decisions().plain
    assert not Decisions(pinned=CROWD_PINNED).plain
