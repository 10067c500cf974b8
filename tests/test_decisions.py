"""Decision rules on the identifier's beliefs (issue 23, sixth round): the plain threshold is
``bayes``'s rule bit for bit; a hold keeps right decisions through the dips of pressed robots;
a decided track's best continuation is the robot's own row; no new decision while jammed."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import anonloc_env
import baselines
from anonloc_env.config import EnvConfig
from anonloc_env.identify import Identifier, SensorModel
from anonloc_env.identify.lineage import continuations, decided_tracks
from baselines.decisions import (
    CONTACT_WINDOW,
    CROWD_KEEP,
    CROWD_PRESSED_KEEP,
    CROWD_RELEASE,
    Decisions,
    in_crowd,
)
from baselines.runner import run_episode
from benchmarks.crowds import RULES, THRESHOLD, load_recorded, play, score_cell
from benchmarks.excitations import scenario
from tests.helpers import lost_decisions, wrong_decisions

DATA = Path(__file__).parent / "data"
#: ``uniform``, N = 100 at 4 per m^2, tuning seed 703 (see tests/test_crowds.py).
FALL = DATA / "crowd_fall.npz"
#: ``greedy``, N = 100 at 4 per m^2, tuning seed 700 (see tests/test_crowds.py).
PRESSED = DATA / "crowd_pressed.npz"
#: ``greedy``, N = 30 at 6 per m^2, tuning seed 700, 16 pictures: ``python -m benchmarks.crowds
#: record tests/data/crowd_pressed6.npz --density 6 --robots 30 --excitation greedy --seed 700
#: --pictures 16``.
PRESSED6 = DATA / "crowd_pressed6.npz"


def _ruled(config: EnvConfig) -> SensorModel:
    """The crowd's model the decision rules were measured on (the sixth to eleventh rounds):
    jammed robots with the wide pushes alone, before the twelfth round's
    ``crowd_jam_tail``, which takes most of their dips away (``test_jammed_robots_...``)."""
    return dataclasses.replace(SensorModel.from_config(config), crowd_jam_tail=None)


def _decide(
    path: Path, rules: dict[str, Decisions], now: bool = False
) -> tuple[dict[str, list[np.ndarray]], list]:
    """Each rule's decisions at every picture of a recorded episode, and its true rows (the
    model of :func:`_ruled`, or with ``now`` the model as it is)."""
    config, result = load_recorded(str(path))
    model = SensorModel.from_config(config) if now else _ruled(config)
    identifier = Identifier(model, result.n_robots)
    out: dict[str, list[np.ndarray]] = {name: [] for name in rules}
    for rows, interval in zip(result.pictures, [None, *result.intervals], strict=False):
        identifier.update(rows, interval)
        belief = identifier.belief()
        for name, rule in rules.items():
            out[name].append(rule.decide(identifier, belief).copy())
    return out, list(result.true_rows)


def test_plain_decisions_are_the_threshold() -> None:
    """Without hold and settle a robot is decided exactly where its top belief is >= 0.99."""
    config, result = load_recorded(str(FALL))
    identifier = Identifier(SensorModel.from_config(config), result.n_robots)
    plain = Decisions()
    assert plain.plain
    for rows, interval in zip(result.pictures, [None, *result.intervals], strict=False):
        identifier.update(rows, interval)
        belief = identifier.belief()
        best = belief.argmax(axis=1)
        expected = np.where(belief.max(axis=1) >= THRESHOLD, best, -1)
        np.testing.assert_array_equal(plain.decide(identifier, belief), expected)


def test_hold_keeps_right_decisions_through_the_dips() -> None:
    """On the recorded ``uniform`` episode the plain rule loses 9 right decisions (pressed
    robots whose belief dipped below 0.99, own row on top); held down to 0.9 along the decided
    track, 1 is lost, 20 decisions are held, and none is wrong either way. On the ``greedy``
    one 7 against 1, none wrong either way (with the detections' noise as stated, before the
    ninth round's ``crowd_noise``: 11 against 2 and 8 against 1, one wrong either way on the
    ``greedy`` one; with tracks anchored at their detections, before the eighth round's
    filtered positions: 11 against none there, 1 wrong against 2, the hold's cost)."""
    rules = {"plain": Decisions(), "hold": Decisions(keep=0.9)}
    found, true = _decide(FALL, rules)
    assert (lost_decisions(found["plain"], true), lost_decisions(found["hold"], true)) == (9, 1)
    assert (wrong_decisions(found["plain"], true), wrong_decisions(found["hold"], true)) == (0, 0)
    assert rules["hold"].held == 20
    rules = {"plain": Decisions(), "hold": Decisions(keep=0.9)}
    found, true = _decide(PRESSED, rules)
    assert (lost_decisions(found["plain"], true), lost_decisions(found["hold"], true)) == (7, 1)
    assert (wrong_decisions(found["plain"], true), wrong_decisions(found["hold"], true)) == (0, 0)


def test_a_decided_track_continues_at_the_robots_own_row() -> None:
    """Every right and decided robot's track, extended to the next picture, fits its own row
    best (1,515 of 1,515 on the recorded ``greedy`` episode): the lineage a hold relies on."""
    config, result = load_recorded(str(PRESSED))
    identifier = Identifier(SensorModel.from_config(config), result.n_robots)
    decided, same, asked = None, 0, 0
    pairs = zip(result.pictures, [None, *result.intervals], strict=False)
    for k, (rows, interval) in enumerate(pairs):
        identifier.update(rows, interval)
        belief, true = identifier.belief(), result.true_rows[k]
        if decided is not None and identifier.interval is not None:
            robots, best = continuations(
                decided, rows, identifier.interval, identifier.pix_var, identifier.scoring
            )
            same += int((best == true[robots]).sum())
            asked += len(robots)
        right = np.flatnonzero((belief.max(axis=1) >= THRESHOLD) & (belief.argmax(axis=1) == true))
        decided = decided_tracks(identifier.tracks, right, true[right])
        assert np.array_equal(decided.slot, right)  # every decided robot has its track there
    assert asked > 1000
    assert same == asked


def test_settle_takes_no_new_decision_while_jammed() -> None:
    """With ``settle=2`` no robot pushed in more than two intervals in a row goes from undecided
    to decided; fewer decisions are taken, none wrong on the recorded ``uniform`` episode."""
    config, result = load_recorded(str(FALL))
    identifier = Identifier(SensorModel.from_config(config), result.n_robots)
    rule, before, decided = Decisions(settle=2), None, 0
    for rows, interval in zip(result.pictures, [None, *result.intervals], strict=False):
        identifier.update(rows, interval)
        now = rule.decide(identifier, identifier.belief())
        if before is not None:
            assert not np.any((now >= 0) & (before < 0) & (identifier.pushed_run > 2))
        before, decided = now.copy(), decided + int((now >= 0).sum())
    found, true = _decide(FALL, {"settle": Decisions(settle=2), "plain": Decisions()})
    assert wrong_decisions(found["settle"], true) == 0
    assert sum(int((e >= 0).sum()) for e in found["plain"]) > decided  # 1,569 against 1,341


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"threshold": 0.5}, "threshold"),
        ({"threshold": 1.0}, "threshold"),
        ({"keep": 0.995}, "keep"),
        ({"keep": 0.5}, "keep"),
        ({"settle": 1}, "settle"),
        ({"release": 0.05}, "release"),
        ({"keep": 0.9, "release": 0.0}, "release"),
        ({"pressed_keep": 0.8}, "pressed_keep"),
        ({"keep": 0.9, "pressed_keep": 0.95}, "pressed_keep"),
        ({"keep": 0.9, "pressed_keep": 0.5}, "pressed_keep"),
        ({"touched": 2}, "touched"),
        ({"keep": 0.9, "touched": 0}, "touched"),
        ({"keep": 0.9, "touched": 1.5}, "touched"),
        ({"keep": 0.9, "only_in_crowd": True, "open_touched": 0}, "open_touched"),
        ({"keep": 0.9, "open_touched": 2}, "open_touched"),
    ],
)
def test_decisions_refuse_bad_settings(kwargs: dict[str, float], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        Decisions(**kwargs)  # type: ignore[arg-type]  # the bad values are the point


def test_bayes_takes_the_rules_when_asked() -> None:
    """``make_team("bayes", env, keep=0.9, settle=6)`` decides by those rules on the env's
    identifier; by default a team's decisions are ``Decisions.crowd``."""
    env = anonloc_env.AnonLocEnv(scenario(30, 8, 4.0), reward_fn=anonloc_env.EnergyCost())
    team = baselines.make_team("bayes", env, excitation="greedy", keep=0.9, settle=6)
    assert (team.localizer.decisions.keep, team.localizer.decisions.settle) == (0.9, 6)
    assert baselines.make_team("bayes", env, excitation="greedy").localizer.decisions.only_in_crowd
    result = run_episode(env, team, 700, max_pictures=8)
    assert any(r.estimate >= 0 for r in result.records)
    with pytest.raises(ValueError, match="keep"):
        baselines.make_team("bayes", env, excitation="greedy", keep=0.999)


def test_the_benchmark_scores_every_rule_on_the_same_episode() -> None:
    """``results --rules``: each rule is scored on the played episode; the plain rule's own
    columns do not change with the rules scored beside it."""
    env = anonloc_env.AnonLocEnv(scenario(30, 8, 4.0), reward_fn=anonloc_env.EnergyCost())
    with_rules = score_cell([play(env, "greedy", 700, pictures=8, rules=list(RULES))])
    alone = score_cell([play(env, "greedy", 700, pictures=8)])
    assert set(with_rules["rules"]) == set(RULES)
    for key in ("decided", "wrong", "share", "pictures"):
        assert with_rules[key] == alone[key]
    for scored in with_rules["rules"].values():
        assert len(scored["share"]) == len(alone["share"])
        assert 0 <= scored["wrong"] <= scored["decided"]


def test_release_holds_only_robots_that_rolled_since_they_decided() -> None:
    """With ``release`` a robot below the threshold is decided only if it was decided at the
    previous picture and its wheels rolled at least ``release`` since it decided (summed over the
    intervals since, the newest included); every robot it holds the hold alone holds too. On the
    recorded ``uniform`` episode it holds 17 decisions and lets go of 3 that the hold keeps."""
    config, result = load_recorded(str(FALL))
    identifier = Identifier(_ruled(config), result.n_robots)
    release = Decisions(keep=0.9, release=0.05)
    hold = Decisions(keep=0.9)
    before, rolled, held, released = None, np.zeros(result.n_robots), 0, 0
    for rows, interval in zip(result.pictures, [None, *result.intervals], strict=False):
        identifier.update(rows, interval)
        belief = identifier.belief()
        now = release.decide(identifier, belief).copy()
        alone = hold.decide(identifier, belief)
        below = (now >= 0) & (belief.max(axis=1) < THRESHOLD)
        if before is not None and interval is not None:
            rolled = np.where(before >= 0, rolled + interval.path, 0.0)
            assert np.all(before[below] >= 0)
            assert np.all(rolled[below] >= 0.05)
        assert np.all(alone[below] == now[below])
        held += int(below.sum())
        released += int(((alone >= 0) & (now < 0)).sum())
        before, rolled = now, np.where(now >= 0, rolled, 0.0)
    assert (held, released) == (17, 3)


def test_bayes_holds_with_the_release_in_a_crowd_only() -> None:
    """``bayes``'s default decisions are ``Decisions.crowd``: the hold with the release where the
    identifier models a crowd; at one robot per m^2 (open space) the same for touched robots
    only (``tests/test_touched.py``: on this short episode none is held); with misses the plain
    threshold's, bit for bit."""
    missing = dataclasses.replace(
        scenario(30, 12, 1.0), camera=dataclasses.replace(scenario(30, 12).camera, p_miss=0.1)
    )
    for config, changes in ((scenario(30, 12, 4.0), 3), (scenario(30, 12, 1.0), 0), (missing, 0)):
        env = anonloc_env.AnonLocEnv(config, reward_fn=anonloc_env.EnergyCost())
        team = baselines.make_team("bayes", env, excitation="uniform")
        rule = team.localizer.decisions
        assert (rule.keep, rule.release, rule.only_in_crowd) == (CROWD_KEEP, CROWD_RELEASE, True)
        assert (rule.pressed_keep, rule.open_touched) == (CROWD_PRESSED_KEEP, CONTACT_WINDOW)
        plain = baselines.make_team("bayes", env, excitation="uniform", keep=THRESHOLD)
        assert plain.localizer.decisions.plain
        ours = run_episode(env, team, 700, max_pictures=12)
        theirs = run_episode(env, plain, 700, max_pictures=12)
        pairs = zip(ours.records, theirs.records, strict=True)
        changed = sum(a.estimate != b.estimate for a, b in pairs)
        assert changed == changes  # 3 of 360 robot-pictures at 4 per m^2


def test_the_crowds_hold_only_where_it_was_measured() -> None:
    """Above one robot per m^2 on clean pictures with a fixed camera; not in open space, not with
    misses, not with a moving camera (its registration), where the plain threshold stays."""
    assert in_crowd(SensorModel.from_config(anonloc_env.make_config("crowd")))
    assert in_crowd(SensorModel.from_config(scenario(30, 30, 2.0)))
    for n in (10, 30, 100):
        assert not in_crowd(SensorModel.from_config(scenario(n, 30, 1.0)))
    missing = anonloc_env.make_config("crowd", camera={"p_miss": 0.1})
    assert not in_crowd(SensorModel.from_config(missing))
    drone = anonloc_env.make_config("drone-hover", n_robots=40, arena_size=(4.0, 4.0))
    assert not in_crowd(SensorModel.from_config(drone))  # 2.5 per m^2, a moving camera


def test_pressed_keep_holds_pressed_robots_lower() -> None:
    """With ``pressed_keep`` a robot held below ``keep`` is pressed now (pushed in the newest
    interval and the one before) and its top belief is at least ``pressed_keep``. On the recorded
    ``greedy`` episode at 6 per m^2 the hold with the release loses 4 right decisions and holds
    6; with the pressed robots held down to 0.8 it loses 2 and holds 11 (3 of them below 0.9),
    1 decision wrong either way. On the two episodes at 4 per m^2 it changes nothing."""
    config, result = load_recorded(str(PRESSED6))
    identifier = Identifier(_ruled(config), result.n_robots)
    rule, low = Decisions(keep=0.9, release=0.05, pressed_keep=0.8), 0
    for rows, interval in zip(result.pictures, [None, *result.intervals], strict=False):
        identifier.update(rows, interval)
        belief = identifier.belief()
        now, top = rule.decide(identifier, belief), belief.max(axis=1)
        below = (now >= 0) & (top < 0.9)
        assert np.all(identifier.pushed_run[below] >= 2)
        assert np.all(top[below] >= 0.8)
        low += int(below.sum())
    assert low == 3
    for path, lost, held in ((PRESSED6, (4, 2), (6, 11)), (FALL, (2, 2), (17, 17))):
        rules = {
            "release": Decisions(keep=0.9, release=0.05),
            "pressed": Decisions(keep=0.9, release=0.05, pressed_keep=0.8),
        }
        found, true = _decide(path, rules)
        found_lost = tuple(lost_decisions(found[name], true) for name in ("release", "pressed"))
        assert found_lost == lost
        assert wrong_decisions(found["release"], true) == wrong_decisions(found["pressed"], true)
        assert (rules["release"].held, rules["pressed"].held) == held
