"""The bump reflex of the candidate excitations: back off after a first bump, escape as ``gaps``
does when pressed (``baselines.excitations.reflex``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import anonloc_env
import baselines
from baselines.active import GreedyIdentification
from baselines.excitations import (
    BumpReflex,
    DistinctMotion,
    DistinctSettings,
    Excitation,
    GapSettings,
)
from baselines.excitations.candidates import GreedySettings
from baselines.excitations.uniform import UniformChoice
from baselines.runner import run_episode
from baselines.steps import Step
from tests.helpers import RecordedUniform


def _step(bumper: list[bool], new_picture: bool = False) -> Step:
    n = len(bumper)
    return Step(
        np.zeros((0, 3)), new_picture, np.zeros((n, 3)), np.array(bumper), np.zeros((n, 3)), 1.0
    )


def _reflex(n: int = 2, seed: int = 0) -> BumpReflex:
    reflex = GreedySettings().reflex()
    reflex.reset([np.random.default_rng(seed + i) for i in range(n)])
    return reflex


def _drive(reflex: BumpReflex, bumper: list[bool], new_picture: bool = False) -> tuple:
    own = np.full(reflex.n, 0.4), np.full(reflex.n, 0.2)
    return reflex.commands(_step(bumper, new_picture), 0.05, lambda hit: own)


def test_first_bump_backs_off_and_a_pressed_robot_escapes() -> None:
    """Robot 0 bumps in one interval and again in the next: it backs off at 0.3 m/s, then
    escapes at 0.08 m/s turning at the full rate; robot 1 never bumps and drives its own."""
    reflex = _reflex()
    v, w = _drive(reflex, [True, False])
    assert v.tolist() == [-0.3, 0.4]
    assert abs(w[0]) <= 0.5
    assert w[1] == 0.2
    for _ in range(30):  # the back-off ends within 1 s; a picture comes
        _drive(reflex, [False, False])
    assert reflex.pressed(_step([False, False], True)).tolist() == [False, False]
    _drive(reflex, [False, False], new_picture=True)
    v, w = _drive(reflex, [True, False])
    assert v.tolist() == [-0.08, 0.4]
    assert abs(w[0]) == 1.0
    assert reflex.escapes == 1
    for _ in range(30):
        _drive(reflex, [False, False])
    assert reflex.pressed(_step([False, False], True)).tolist() == [True, False]


def test_a_bump_at_a_picture_belongs_to_the_interval_it_ends() -> None:
    """The env takes the picture after the step's physics: a first bump at the picture step
    is not pressed, and a bump in the next interval is."""
    reflex = _reflex(1)
    assert _drive(reflex, [True], new_picture=True)[0].tolist() == [-0.3]
    assert reflex.pressed(_step([False], True)).tolist() == [False]
    for _ in range(30):
        _drive(reflex, [False])
    assert _drive(reflex, [True])[0].tolist() == [-0.08]


def test_both_ways_out_draw_two_numbers_per_bump() -> None:
    """The back-off and the escape each take two numbers from the robot's generator, so the
    robot's later draws (its candidates) do not depend on how it left a bump."""
    pressed, calm = _reflex(1, seed=5), _reflex(1, seed=5)
    pressed.before[:] = True
    pressed.start(np.array([0]))
    calm.start(np.array([0]))
    assert pressed.speed[0] == 0.08
    assert calm.speed[0] == 0.3
    assert pressed.rngs[0].random() == calm.rngs[0].random()


def test_no_escape_keeps_the_plain_back_off() -> None:
    reflex = GreedySettings(escape=None).reflex()
    reflex.reset([np.random.default_rng(0)])
    reflex.before[:] = True
    reflex.start(np.array([0]))
    assert reflex.speed[0] == 0.3
    assert reflex.escapes == 0
    assert GreedySettings().escape == GapSettings().escape()
    assert GreedySettings().escape == DistinctSettings((0.1, 0.3), 1.0, 0.08, (0.7, 1.2))


def _play(excitation: Excitation, seed: int, density: float, n: int, pictures: int) -> list:
    side = math.sqrt(n / density)
    config = anonloc_env.make_config(
        n_robots=n,
        arena_size=(side, side),
        camera={"pixel_noise": 1.0, "orientation": False},
        max_cycles=400,
    )
    env = anonloc_env.AnonLocEnv(config, reward_fn=anonloc_env.EnergyCost())
    team = baselines.make_team("bayes", env, excitation=excitation)
    return run_episode(env, team, seed, max_pictures=pictures).rows()


def test_uniform_is_unchanged_in_open_space_where_no_robot_is_pressed() -> None:
    """8 robots in an 8 m arena, 6 pictures, seed 8: five bumps, none pressed; the episode is
    bit for bit that of the plain back-off. Seed 0 has pressed robots: the commands are the
    same until the first escape, and differ after."""
    new, old = RecordedUniform(), RecordedUniform(GreedySettings(escape=None))
    assert _play(new, 8, 1 / 8, 8, 6) == _play(old, 8, 1 / 8, 8, 6)
    assert new.backoff.escapes == 0
    assert len(new.given) == len(old.given)
    for (v, w), (v0, w0) in zip(new.given, old.given, strict=True):
        assert np.array_equal(v, v0)
        assert np.array_equal(w, w0)
    assert any((v == -0.3).any() for v, _ in new.given)  # some robot did bump
    _play(new, 0, 1 / 8, 8, 6)
    _play(old, 0, 1 / 8, 8, 6)
    assert new.backoff.escapes > 0
    first = next(k for k, (v, _) in enumerate(new.given) if (v == -0.08).any())
    for (v, w), (v0, w0) in zip(new.given[:first], old.given[:first], strict=True):
        assert np.array_equal(v, v0)
        assert np.array_equal(w, w0)
    assert not np.array_equal(new.given[first][0], old.given[first][0])


def test_in_a_crowd_pressed_robots_escape_in_the_box_and_replay_from_the_seed() -> None:
    """30 robots at 4 per m^2: robots escape, every command stays in the box
    ``[-0.3, 0.5] m/s x [-1, 1] rad/s``, and the same seed replays bit for bit."""
    runs = [RecordedUniform() for _ in range(2)]
    rows = [_play(r, 11, 4.0, 30, 4) for r in runs]
    assert rows[0] == rows[1]
    assert runs[0].backoff.escapes > 10
    v = np.concatenate([v for v, _ in runs[0].given])
    w = np.concatenate([w for _, w in runs[0].given])
    assert (v >= -0.3).all()
    assert (v <= 0.5).all()
    assert (np.abs(w) <= 1.0).all()
    assert (v == -0.08).any()
    assert (v == -0.3).any()
    for (a, b), (c, d) in zip(runs[0].given, runs[1].given, strict=True):
        assert np.array_equal(a, c)
        assert np.array_equal(b, d)


@pytest.mark.parametrize("make", [UniformChoice, GreedyIdentification])
def test_candidate_excitations_hold_the_reflex(make: type) -> None:
    assert isinstance(make().backoff, BumpReflex)
    assert make(GreedySettings(escape=None)).backoff.escape is None


def test_distinct_holds_the_reflex_and_is_unchanged_where_no_robot_is_pressed() -> None:
    """``distinct`` escapes jams as the candidate excitations do (``escape=False``: the plain
    back-off). 8 robots in an 8 m arena, seed 8: no robot pressed, the episode is bit for bit
    that of the plain back-off; at 4 robots per m^2 robots escape and the episode differs."""
    new, old = DistinctMotion(), DistinctMotion(escape=False)
    assert isinstance(new.backoff, BumpReflex)
    assert new.backoff.escape is not None
    assert not isinstance(old.backoff, BumpReflex)
    assert _play(new, 8, 1 / 8, 8, 6) == _play(old, 8, 1 / 8, 8, 6)
    assert new.backoff.escapes == 0
    crowded = _play(new, 0, 4.0, 30, 6)
    assert new.backoff.escapes > 0
    assert crowded != _play(DistinctMotion(escape=False), 0, 4.0, 30, 6)
