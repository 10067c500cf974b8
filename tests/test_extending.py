"""The extension points of docs/extending.md: its worked examples run in an env and do what the
page says; renamed names still work."""

from __future__ import annotations

import re
import runpy
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import anonloc_env
import baselines
from anonloc_env.actions import to_commands
from anonloc_env.rewards import energy
from baselines.excitations import RandomMotion

ROOT = Path(__file__).resolve().parent.parent
PAGE = ROOT / "docs" / "extending.md"


def _example(name: str) -> dict[str, Any]:
    """The namespace of ``examples/<name>.py``, run as a module (not as ``__main__``)."""
    return runpy.run_path(str(ROOT / "examples" / f"{name}.py"), run_name=f"examples.{name}")


def test_the_page_shows_every_example_file() -> None:
    """The code on the page is the examples' files themselves (included, never copied)."""
    included = set(re.findall(r'--8<-- "examples/(\w+\.py)"', PAGE.read_text()))
    assert included == {p.name for p in (ROOT / "examples").glob("*.py")}
    assert len(included) == 3


def test_the_example_localizer_decides_right(capsys: pytest.CaptureFixture[str]) -> None:
    """Seeded episodes: its decisions are right (at least 95 % of at least 20 decisions)."""
    main = _example("custom_localizer")["main"]
    decided = right = 0
    for seed in range(3):
        d, r = main(seed)
        decided, right = decided + d, right + r
    assert decided >= 20
    assert right >= 0.95 * decided
    assert "decisions over" in capsys.readouterr().out


def test_the_example_localizer_is_a_localizer_the_base_class_drives() -> None:
    namespace = _example("custom_localizer")
    config = anonloc_env.make_config(n_robots=3)
    localizer = namespace["DistanceLocalizer"](config, 3)
    assert isinstance(localizer, baselines.localizers.Localizer)
    rows = np.array([[0.0, 0.0, 0.0], [300.0, 0.0, 0.0], [0.0, 300.0, 0.0]])
    localizer.on_picture(rows, None, 0.0)  # one picture: undecided, uniform
    np.testing.assert_array_equal(localizer.estimate, [-1, -1, -1])
    np.testing.assert_allclose(localizer.belief, np.full((3, 3), 1 / 3))


def test_the_example_excitation_lets_bayes_identify_the_robots() -> None:
    """Nine of ten right at the last picture; the tenth, pressed against a wall for four
    intervals, is undecided in its own row (belief 0.967) since pressed robots' pushes are
    mixed (docs/crowds.md, fourth round)."""
    main = _example("custom_excitation")["main"]
    right, robots = main(0)
    assert robots == 10
    assert right >= 9
    still, _ = main(0, "still")  # robots that do not move cannot be told apart
    assert still < 5


def test_the_example_excitation_draws_from_each_robot_s_generator() -> None:
    zigzag = _example("custom_excitation")["Zigzag"]
    first, second = zigzag(), zigzag()
    first.reset([np.random.default_rng(s) for s in (1, 2)])
    second.reset([np.random.default_rng(s) for s in (1, 3)])
    assert first.v[0] == second.v[0]
    assert first.v[1] != second.v[1]
    assert np.all((first.v >= 0.1) & (first.v <= 0.4))


def test_the_example_reward_counts_the_crowd_around_each_robot() -> None:
    namespace = _example("custom_reward")
    reward_fn = namespace["CrowdPenalty"](radius=40.0)
    assert isinstance(reward_fn, anonloc_env.RewardFunction)
    env = anonloc_env.parallel_env(
        n_robots=12, arena_size=(2.0, 2.0), picture_interval=0.1, dt=0.05, reward_fn=reward_fn
    )
    env.reset(seed=3)
    rng = np.random.default_rng(0)
    crowded = 0
    for _ in range(6):
        actions = {a: rng.uniform(-1, 1, 2) for a in env.agents}
        observations, rewards, _, _, infos = env.step(actions)
        got = np.array([rewards[a] for a in env.possible_agents])
        v, w = to_commands(np.array([actions[a] for a in env.possible_agents]), env.config.robot)
        expected = -env.config.reward.energy_weight * energy(env.config, v, w)
        if observations["robot_0"]["new_picture"][0] > 0.5 and env.picture is not None:
            rows = env.picture.detections[:, :2]
            for i, agent in enumerate(env.possible_agents):
                own = infos[agent]["true_index"]
                if own >= 0:
                    near = sum(
                        1
                        for j in range(len(rows))
                        if j != own and np.hypot(*(rows[j] - rows[own])) <= 40.0
                    )
                    expected[i] -= near
                    crowded += near
        np.testing.assert_allclose(got, expected, atol=1e-12)
    assert crowded > 0  # twelve robots in 2 m x 2 m: some are within 0.4 m of another
    totals = namespace["main"](0)
    assert totals.shape == (20,)
    assert np.all(totals < 0)


def test_the_excitation_once_named_motion_is_random_with_a_deprecation_warning() -> None:
    with pytest.warns(DeprecationWarning, match="'motion' is renamed 'random'"):
        team = baselines.make_team("bayes", "paper-motion", 2, excitation="motion")
    assert type(team.excitation) is RandomMotion
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert type(baselines.make_team("motion", "paper-motion", 2).excitation) is RandomMotion
    with pytest.raises(ValueError, match=r"unknown excitation 'randm' \(did you mean 'random'\?\)"):
        baselines.make_team("bayes", "paper-motion", 2, excitation="randm")


def test_the_cli_accepts_the_old_excitation_name_with_a_note(
    capsys: pytest.CaptureFixture[str],
) -> None:
    from anonloc_cli import teams

    assert teams.check_excitation("motion") == "motion"
    assert "excitation 'motion' is renamed 'random'" in capsys.readouterr().err
    assert "motion" not in teams.excitation_names()
