"""``benchmarks.agent_tail``: its variants are the edits its documentation names, and the share
of robots not right is read per picture from the team's own records."""

from __future__ import annotations

import numpy as np
import pytest

from baselines.excitations.base import Still
from baselines.excitations.rest import RestWhenSure
from baselines.runner import EpisodeResult, PictureRecord
from benchmarks.agent_tail import not_right, variant, without_escape


def _record(robot: int, picture: int, correct: bool, localizer: str = "") -> PictureRecord:
    return PictureRecord(
        localizer=localizer,
        robot=robot,
        picture=picture,
        time=float(picture),
        estimate=robot if correct else -1,
        true_index=robot,
        correct=correct,
        belief_true=0.5,
        energy=0.0,
    )


def test_not_right_counts_the_teams_own_records_per_picture() -> None:
    records = [
        _record(0, 2, True),
        _record(1, 2, False),
        _record(0, 3, True),
        _record(1, 3, True),
        _record(1, 3, False, localizer="listener"),  # another localizer's: ignored
    ]
    result = EpisodeResult(seed=0, n_robots=2, records=records)
    assert np.array_equal(not_right(result, (2, 3, 4)), [0.5, 0.0, 0.0])


def test_an_unknown_variant_is_refused_by_name() -> None:
    with pytest.raises(ValueError, match="'agent-bold'"):
        variant("agent-bold")


def test_the_edited_agents_change_only_the_named_weights() -> None:
    pytest.importorskip("stable_baselines3")
    from agents.linear_agent import linear_weights
    from agents.policy import model_spec
    from benchmarks.agent_tail import edited_agent

    bundled = linear_weights("bundled")
    model = edited_agent(lambda term, w: 0.0 if term.endswith("*decided") else 2.0 * w)
    spec = model_spec(model)
    assert spec is not None
    got = dict(zip((t.name for t in spec.terms), model.policy.scorer.weights.tolist(), strict=True))
    for term, w in bundled.items():
        want = 0.0 if term.endswith("*decided") else 2.0 * w
        assert got[term] == pytest.approx(want, rel=1e-6, abs=1e-6), term
    assert any(w != 0.0 for t, w in bundled.items() if t.endswith("*decided"))


def test_a_crawl_outside_zero_to_one_is_refused_before_any_episode() -> None:
    pytest.importorskip("stable_baselines3")
    with pytest.raises(ValueError, match="fraction must be in"):
        variant("agent-crawl-1.5")


def test_a_delay_below_one_picture_is_refused_before_any_episode() -> None:
    pytest.importorskip("stable_baselines3")
    with pytest.raises(ValueError, match="after must be an integer >= 1"):
        variant("agent-delay-0")


class _Constant:
    """An inner excitation that always asks for ``v = 0.3``, ``w = -0.5``."""

    def __init__(self) -> None:
        self.n = 0

    def reset(self, rngs: list[np.random.Generator]) -> None:
        self.n = len(rngs)

    def follow(self, v: np.ndarray, w: np.ndarray, budget: float) -> None:
        pass

    def commands(self, step: object, dt: float) -> tuple[np.ndarray, np.ndarray]:
        return np.full(self.n, 0.3), np.full(self.n, -0.5)

    def reversing(self) -> np.ndarray:
        return np.zeros(self.n, bool)


def test_still_on_duty_opposes_the_shared_command_only_for_resting_robots() -> None:
    """On duty a resting robot's deviation is ``-shared / budget`` clipped to the box; a moving
    robot keeps its own; in free motion (no ``follow``) a resting robot holds still."""
    from benchmarks.agent_tail import StillOnDuty

    still = StillOnDuty(_Constant(), 0.9999, speed=0.5, turn=1.0)  # type: ignore[arg-type]  # a duck-typed inner
    still.reset([np.random.default_rng(k) for k in range(3)])
    still.resting = np.array([True, True, False])
    v, w = still.commands(None, 0.05)  # type: ignore[arg-type]  # reads nothing of the step
    assert np.array_equal(v, [0.0, 0.0, 0.3])
    assert np.array_equal(w, [0.0, 0.0, -0.5])
    still.follow(np.array([0.06, 0.4, 0.4]), np.array([-0.1, 0.5, 0.5]), 0.2)
    v, w = still.commands(None, 0.05)  # type: ignore[arg-type]  # reads nothing of the step
    np.testing.assert_allclose(v, [-0.3, -0.5, 0.3])
    np.testing.assert_allclose(w, [0.5, -1.0, -0.5])


def test_origins_bin_the_robots_not_right_by_their_belief_before() -> None:
    """Each robot not right at picture 4 counts once, in the bin of its belief in its own row
    at picture 3 (a robot with no record there in the lowest); right robots are not counted."""
    from benchmarks.agent_tail import origins

    def rec(robot: int, picture: int, correct: bool, belief: float) -> PictureRecord:
        return PictureRecord("", robot, picture, float(picture), -1, robot, correct, belief, 0.0)

    before = [rec(i, 3, i > 1, b) for i, b in enumerate((0.3, 0.9, 0.995, 0.99995, 0.2, 0.6))]
    after = [rec(i, 4, i == 5, 0.5) for i in (0, 1, 2, 3, 5)] + [rec(6, 4, False, 0.5)]
    result = EpisodeResult(seed=0, n_robots=7, records=before + after)
    assert origins(result, 4).tolist() == [2, 1, 1, 1]


def test_an_added_weight_plays_the_bundled_weights_plus_the_edit() -> None:
    pytest.importorskip("stable_baselines3")
    from agents.linear_agent import linear_weights

    bundled = linear_weights("bundled")
    made = variant("agent+reach*always=0.5,entropy_after*fair=-2,reach*always=0.25")()
    inner = made.inner  # at rest: RestWhenSure around the numpy chooser
    got = dict(zip((t.name for t in inner.terms), inner.weights.tolist(), strict=True))
    assert got["reach*always"] == pytest.approx(bundled["reach*always"] + 0.75, abs=1e-12)
    assert got["entropy_after*fair"] == -2.0  # a term the bundled agent lacks, appended
    assert all(got[t] == w for t, w in bundled.items() if t != "reach*always")
    zero = variant("zero+reach*always=1-norest")()
    assert np.count_nonzero(zero.weights) == 1  # uniform's zeros but the one edit, no rest


def test_an_edit_of_an_unknown_term_is_refused_by_name() -> None:
    pytest.importorskip("stable_baselines3")
    with pytest.raises(ValueError, match="'reach\\*sometimes'"):
        variant("agent+reach*sometimes=1")


def test_noescape_backs_pressed_robots_off_as_after_a_first_bump() -> None:
    made = variant("uniform-rest-noescape")()
    assert isinstance(made, RestWhenSure)
    assert made.inner.backoff.escape is None  # the plain back-off, also for pressed robots
    assert variant("uniform")().backoff.escape is not None  # the default escapes slowly
    with pytest.raises(ValueError, match="candidate excitation"):
        without_escape(RestWhenSure(Still(), 0.9999))
