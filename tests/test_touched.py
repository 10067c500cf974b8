"""Touched robots held in open space (issue 23, thirteenth round): at one robot per m^2 on clean
pictures with a fixed camera, ``bayes``'s decisions (``Decisions.crowd``) hold a decided robot
through a dip only if a contact pushed it in the newest ``CONTACT_WINDOW`` intervals; with
misses, false positives or a moving camera they stay the plain threshold's."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

import anonloc_env
from anonloc_env.identify import Identifier, SensorModel
from baselines.decisions import CONTACT_WINDOW, CROWD_PRESSED_KEEP, Decisions, in_contact, in_crowd
from benchmarks.crowds import THRESHOLD, load_recorded
from benchmarks.excitations import scenario
from tests.helpers import lost_decisions, wrong_decisions

#: ``random``, N = 30 at one robot per m^2, seed 80001 of the twelfth grid (where the share
#: right fell by 1.1 pt), 30 pictures, played at ``dfeb8ce``: ``python -m benchmarks.crowds
#: record tests/data/open_touched.npz --density 1 --robots 30 --excitation random --seed 80001
#: --pictures 30``.
OPEN = Path(__file__).parent / "data" / "open_touched.npz"


def _played(rules: dict[str, Decisions]) -> tuple[dict[str, list[np.ndarray]], list, list, list]:
    """Each rule's decisions on the recorded episode, its true rows, top beliefs and each
    robot's intervals since it was last pushed."""
    config, result = load_recorded(str(OPEN))
    model = SensorModel.from_config(config)
    assert in_contact(model)
    assert not in_crowd(model)
    identifier = Identifier(model, result.n_robots)
    out: dict[str, list[np.ndarray]] = {name: [] for name in rules}
    tops, since, last = [], [], np.full(result.n_robots, 10**6)
    for rows, interval in zip(result.pictures, [None, *result.intervals], strict=False):
        identifier.update(rows, interval)
        belief = identifier.belief()
        if interval is not None:
            last = np.where(identifier.pushed_run >= 1, 0, last + 1)
        tops.append(belief.max(axis=1))
        since.append(last.copy())
        for name, rule in rules.items():
            out[name].append(rule.decide(identifier, belief).copy())
    return out, list(result.true_rows), tops, since


def test_touched_robots_keep_their_decisions_in_open_space() -> None:
    """On the recorded episode the threshold loses 8 right decisions (each went undecided, none
    wrong); ``bayes``'s default loses 1 and holds 13, none wrong: as many as the crowd's hold on
    every robot would; touched in the newest interval alone it would lose 4. Every robot it holds
    below the threshold was pushed in one of the newest two intervals, at a belief of at least
    0.8, and was decided at the picture before."""
    rules = {
        "threshold": Decisions(),
        "bayes": Decisions.crowd(),
        "every robot": Decisions(keep=0.9, release=0.05, pressed_keep=0.8),
        "newest only": Decisions(keep=0.9, release=0.05, pressed_keep=0.8, touched=1),
    }
    found, true, tops, since = _played(rules)
    lost = {name: lost_decisions(found[name], true) for name in rules}
    assert lost == {"threshold": 8, "bayes": 1, "every robot": 1, "newest only": 4}
    assert all(wrong_decisions(found[name], true) == 0 for name in rules)
    assert (rules["bayes"].held, rules["every robot"].held) == (13, 13)
    before = None
    for now, top, untouched in zip(found["bayes"], tops, since, strict=True):
        below = (now >= 0) & (top < THRESHOLD)
        assert np.all(untouched[below] < CONTACT_WINDOW)
        assert np.all(top[below] >= CROWD_PRESSED_KEEP)
        if before is not None:
            assert np.all(before[below] >= 0)
        before = now


def test_the_open_hold_only_where_the_identifier_models_contacts() -> None:
    """Clean pictures and a fixed camera, at any density; not with misses, not with false
    positives, not with a moving camera (the plain threshold stays there)."""
    for density in (0.25, 1.0, 4.0):
        assert in_contact(SensorModel.from_config(scenario(30, 30, density)))
    missing = anonloc_env.make_config("crowd", camera={"p_miss": 0.1})
    assert not in_contact(SensorModel.from_config(missing))
    clutter = anonloc_env.make_config("crowd", camera={"false_positives": 2.0})
    assert not in_contact(SensorModel.from_config(clutter))
    drone = anonloc_env.make_config("drone-hover", n_robots=10, arena_size=(4.0, 4.0))
    assert not in_contact(SensorModel.from_config(drone))


def test_untouched_robots_decide_at_the_threshold_in_open_space() -> None:
    """With ``open_touched`` but no robot ever pushed (a rule asked only on the pictures, the
    pushes taken out of the intervals), the decisions are the plain threshold's, bit for bit."""
    config, result = load_recorded(str(OPEN))
    identifier = Identifier(SensorModel.from_config(config), result.n_robots)
    ours, plain = Decisions.crowd(), Decisions()
    for rows, interval in zip(result.pictures, [None, *result.intervals], strict=False):
        if interval is not None:
            interval = dataclasses.replace(interval, push=None, push_sum=None)
        identifier.update(rows, interval)
        belief = identifier.belief()
        np.testing.assert_array_equal(
            ours.decide(identifier, belief), plain.decide(identifier, belief)
        )
    assert ours.held == 0
