"""Pinned robots decide later (issue 23, fourteenth round): in a crowd, ``bayes``'s decisions
(``Decisions.crowd``) let a robot pushed in most of its newest intervals that hardly rolled in
them (``CROWD_PINNED``) take a new decision only at a higher belief; since the fifteenth round in
a crowd with misses or false positives too (``in_cluttered_crowd``: the guard, no hold, and no
row decided twice); elsewhere nothing changes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import anonloc_env
from anonloc_env.identify import Identifier, SensorModel
from baselines.decisions import CROWD_PINNED, Decisions, in_cluttered_crowd, in_crowd
from benchmarks.crowds import load_recorded
from tests.helpers import lost_decisions, wrong_decisions

#: ``random``, N = 30 at 4 robots per m^2, seed 90003 of the thirteenth grid (robot 28, pressed
#: against the arena's wall, took a far still robot's row for 9 pictures), 30 pictures, played
#: at ``b491fec``: ``python -m benchmarks.crowds record tests/data/crowd_pinned.npz --density 4
#: --robots 30 --excitation random --seed 90003 --pictures 30``.
PINNED = Path(__file__).parent / "data" / "crowd_pinned.npz"
#: ``random``, N = 50 at 4 robots per m^2, 8 % misses and 2 false positives per picture, tuning
#: seed 707 (34 robot-pictures decided wrong at the threshold; robots 35, 20 and 46 took the row
#: of robot 37, pinned against the wall), 30 pictures, played at ``241d8b1``: ``python -m
#: benchmarks.crowds record tests/data/crowd_cluttered.npz --density 4 --robots 50 --excitation
#: random --seed 707 --pictures 30 --p-miss 0.08 --false-positives 2``.
CLUTTERED = Path(__file__).parent / "data" / "crowd_cluttered.npz"


def _thirteenth() -> Decisions:
    """``Decisions.crowd`` as it was before the pinned robots' guard."""
    return Decisions.crowd(pinned=None)


def _played(
    rules: dict[str, Decisions], path: Path = PINNED
) -> tuple[dict[str, list[np.ndarray]], list, list, list]:
    """Each rule's decisions on the recorded episode at ``path`` (a clean crowd's by default),
    its true rows, top beliefs and whether each robot was pinned (by ``CROWD_PINNED``'s
    measure)."""
    config, result = load_recorded(str(path))
    model = SensorModel.from_config(config)
    assert in_crowd(model) == (path == PINNED)
    assert in_cluttered_crowd(model) == (path == CLUTTERED)
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
        pinned.append(
            (np.sum(pushed[-window:], axis=0) >= pushes) & (np.sum(rolled[-window:], axis=0) < path)
            if len(pushed) >= window
            else np.zeros(result.n_robots, bool)
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


def test_a_cluttered_crowd_guards_pinned_robots_and_decides_a_row_once() -> None:
    """In a crowd with misses and false positives ``bayes``'s decisions are the threshold's but
    for the pinned robots' guard (no hold there) and exclusive rows: robots that would decide
    the same row at a picture are all undecided. On the recorded episode the threshold (and the
    fourteenth round's ``Decisions.crowd``) decided wrong at 34 robot-pictures, the guard alone
    at 11, ``bayes`` at 1; no row is decided twice at a picture."""
    guard = Decisions(
        keep=0.9,
        release=0.05,
        only_in_crowd=True,
        pressed_keep=0.8,
        open_touched=2,
        pinned=CROWD_PINNED,
        cluttered_pinned=True,
    )
    rules = {
        "bayes": Decisions.crowd(),
        "guard": guard,
        "fourteenth": Decisions.crowd(cluttered=False),
        "threshold": Decisions(),
    }
    found, true, tops, pinned = _played(rules, CLUTTERED)
    wrong = {name: wrong_decisions(found[name], true) for name in rules}
    assert wrong == {"bayes": 1, "guard": 11, "fourteenth": 34, "threshold": 34}
    decided = {name: int(sum((e >= 0).sum() for e in found[name])) for name in rules}
    assert decided == {"bayes": 752, "guard": 770, "fourteenth": 863, "threshold": 863}
    ours, theirs = found["bayes"], found["threshold"]
    for k in range(len(ours)):
        kept = ours[k - 1] >= 0 if k else np.zeros(len(ours[k]), bool)
        waits = pinned[k] & ~kept & (tops[k] < CROWD_PINNED[3])
        guarded = (theirs[k] >= 0) & ~waits
        rows, counts = np.unique(theirs[k][guarded], return_counts=True)
        once = guarded & ~np.isin(theirs[k], rows[counts > 1])
        assert np.array_equal(ours[k], np.where(once, theirs[k], -1))
        assert len(np.unique(ours[k][ours[k] >= 0])) == int((ours[k] >= 0).sum())


def test_the_guard_spreads_to_cluttered_crowds_only() -> None:
    """``in_cluttered_crowd``: above one robot per m^2 with misses or false positives and a
    fixed camera; not on clean pictures (``in_crowd``'s), not in open space, not with a moving
    camera. ``Decisions.crowd(cluttered=False)`` and ``pinned=None`` leave it out."""
    make = anonloc_env.make_config
    cases = {
        "misses": (make("crowd", camera={"p_miss": 0.1}), True),
        "false positives": (make("crowd", camera={"false_positives": 1.0}), True),
        "clean": (make("crowd"), False),
        "open space": (make("default", camera={"p_miss": 0.1}), False),
        "drone": (make("drone-hover", n_robots=40, arena_size=(4.0, 4.0)), False),
    }
    for name, (config, expected) in cases.items():
        model = SensorModel.from_config(config)
        area = config.arena_size[0] * config.arena_size[1]
        assert model.density == pytest.approx(config.n_robots / area), name
        assert in_cluttered_crowd(model) == expected, name
    assert Decisions.crowd().cluttered_pinned
    assert not Decisions.crowd(cluttered=False).cluttered_pinned
    assert Decisions.crowd().exclusive
    assert not Decisions.crowd(cluttered=False).exclusive
    assert not Decisions.crowd(pinned=None).cluttered_pinned
    with pytest.raises(ValueError, match="cluttered_pinned"):
        Decisions(cluttered_pinned=True)
    with pytest.raises(ValueError, match="exclusive"):
        Decisions(exclusive=True)
