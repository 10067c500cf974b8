"""Jammed robots in a crowd (issue 23, twelfth round): their likelihood mixes the wide pushes
with narrow ones as a pressed robot's does (``SensorModel.crowd_jam_tail``), so the belief of a
robot decided and jammed for many intervals no longer drifts down along its own track."""

from __future__ import annotations

import dataclasses
import itertools
from pathlib import Path

import numpy as np
import pytest

import anonloc_env
from anonloc_env import compiled
from anonloc_env.identify import Identifier, SensorModel
from anonloc_env.identify.contact import CROWD_JAM_TAIL, JAM
from baselines.decisions import Decisions
from benchmarks.crowds import largest_fall, load_recorded
from benchmarks.excitations import scenario

#: ``uniform``, N = 30 at 6 robots per m^2, seed 70008 (of the eleventh round's held-out grid,
#: where the cell fell by 1.7 points), 30 pictures, played by ``bayes`` with the eleventh round's
#: identifier (main at c57739c): ``python -m benchmarks.crowds record
#: tests/data/crowd_jammed6.npz --density 6 --robots 30 --excitation uniform --seed 70008
#: --pictures 30``.
JAMMED6 = Path(__file__).parent / "data" / "crowd_jammed6.npz"


def _play(model: SensorModel) -> tuple[list[tuple[int, int]], list[float], int, list[int]]:
    """``bayes``'s crowd decisions on the recorded episode replayed through ``model``: the right
    decisions lost ``(picture, robot)``, the share right at each picture, the decisions wrong,
    and the lost robots' intervals pushed in a row."""
    _, result = load_recorded(str(JAMMED6))
    identifier, rule = Identifier(model, result.n_robots), Decisions.crowd()
    right, wrong, runs = [], 0, []
    intervals = [None, *result.intervals]
    for k, (rows, interval) in enumerate(zip(result.pictures, intervals, strict=True)):
        identifier.update(rows, interval)
        decided = rule.decide(identifier, identifier.belief())
        true = result.true_rows[k]
        right.append((decided >= 0) & (decided == true))
        wrong += int(((decided >= 0) & (decided != true)).sum())
        if k:
            runs += identifier.pushed_run[right[-2] & ~right[-1]].tolist()
    lost = [
        (k + 1, int(i))
        for k, (a, b) in enumerate(itertools.pairwise(right))
        for i in np.flatnonzero(a & ~b)
    ]
    return lost, [float(r.mean()) for r in right], wrong, runs


def test_jammed_robots_keep_their_decision() -> None:
    """With jammed robots' wide pushes alone (the eleventh round) six right decisions of robots
    jammed for 11 to 22 intervals are lost from picture 15 on and the share right falls from
    all 30 robots to 26; with the mixture one is lost, at picture 15, and found again at the
    next, and every robot is right from picture 16 on. No decision is wrong either way."""
    config, _ = load_recorded(str(JAMMED6))
    model = SensorModel.from_config(config)
    assert model.crowd_jam_tail == CROWD_JAM_TAIL
    lost, share, wrong, runs = _play(dataclasses.replace(model, crowd_jam_tail=None))
    assert lost == [(15, 22), (19, 28), (20, 2), (20, 16), (24, 21), (25, 19)]
    assert min(runs) > JAM
    assert share[14] == 1.0
    assert share[25] == 26 / 30
    assert wrong == 0
    lost, share, wrong, _ = _play(model)
    assert lost == [(15, 22)]
    assert share[16:] == [1.0] * 14
    assert largest_fall(share) == pytest.approx(1 / 30)  # the one robot, at picture 15
    assert wrong == 0


def test_jammed_robots_mixed_only_in_a_crowd_with_a_fixed_camera() -> None:
    """Above one robot per m^2 on clean pictures with a fixed camera; in open space, with misses
    and with a moving camera jammed robots keep the wide pushes alone, as before."""
    assert SensorModel.from_config(anonloc_env.make_config("crowd")).crowd_jam_tail == 0.05
    assert SensorModel.from_config(scenario(30, 30, 2.0)).crowd_jam_tail == CROWD_JAM_TAIL
    for n in (10, 30, 100):
        assert SensorModel.from_config(scenario(n, 30, 1.0)).crowd_jam_tail is None
    missing = anonloc_env.make_config("crowd", camera={"p_miss": 0.1})
    assert SensorModel.from_config(missing).crowd_jam_tail is None
    drone = anonloc_env.make_config("drone-hover", n_robots=40, arena_size=(4.0, 4.0))
    assert SensorModel.from_config(drone).crowd_jam_tail is None


def test_jammed_mixture_is_the_same_with_the_kernels_on_and_off() -> None:
    """The compiled general step and the numpy path mix a jammed robot's pushes alike: on the
    recorded episode (jammed robots from picture 12 on) every belief is equal to the bit."""
    config, result = load_recorded(str(JAMMED6))
    model = SensorModel.from_config(config)
    found = []
    for off in (False, True):
        with pytest.MonkeyPatch.context() as patch:
            if off:
                patch.setattr(compiled, "_MODE", [None])
            identifier, beliefs, jammed = Identifier(model, result.n_robots), [], 0
            intervals = [None, *result.intervals][:20]
            for rows, interval in zip(result.pictures[:20], intervals, strict=True):
                identifier.update(rows, interval)
                beliefs.append(identifier.belief())
                jammed += int((identifier.pushed_run > JAM).sum())
        found.append(beliefs)
    assert jammed > 0
    for on, off in zip(*found, strict=True):
        np.testing.assert_array_equal(on, off)
