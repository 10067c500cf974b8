"""The commanded speeds as data, what an excitation is told, and the one registry of names."""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest

import anonloc_env
import baselines
from anonloc_env.odometry import Interval
from baselines import catalog
from baselines.excitations import Excitation
from baselines.localizers import AngularLocalizer, BayesLocalizer
from baselines.policies import Team
from baselines.runner import run_episode
from baselines.steps import BeliefView, Step
from tests.helpers import python_output


class Counting(Excitation):
    """A command that changes at every step (step k: v = 0.01 k, w = -0.001 k), remembering
    the command of each step that brought a picture, and every view it was told."""

    def reset(self, rngs: Sequence[np.random.Generator]) -> None:
        super().reset(rngs)
        self.k = 0
        self.at_pictures: list[tuple[float, float]] = []
        self.views: list[BeliefView] = []

    def on_picture(self, step: Step, view: BeliefView) -> None:
        self.views.append(view)

    def commands(self, step: Step, dt: float) -> tuple[np.ndarray, np.ndarray]:
        self.k += 1
        v, w = np.full(self.n, 0.01 * self.k), np.full(self.n, -0.001 * self.k)
        if step.new_picture:
            self.at_pictures.append((v[0], w[0]))
        return v, w


def test_each_interval_carries_the_command_set_at_its_start() -> None:
    env = anonloc_env.parallel_env("paper-motion", reward_fn=anonloc_env.EnergyCost())
    excitation = Counting()
    team = Team(env.config, BayesLocalizer(env.config, 2), excitation)
    run_episode(env, team, seed=3, max_pictures=4)
    assert len(team.intervals) == 3
    for interval, (v, w) in zip(team.intervals, excitation.at_pictures, strict=False):
        assert interval.command is not None
        np.testing.assert_array_equal(interval.command, [[v, w], [v, w]])


def test_an_excitation_is_told_the_team_localizer_s_belief_not_the_localizer() -> None:
    env = anonloc_env.parallel_env("paper-motion", reward_fn=anonloc_env.EnergyCost())
    excitation = Counting()
    localizer = BayesLocalizer(env.config, 2)
    team = Team(env.config, localizer, excitation)
    run_episode(env, team, seed=3, max_pictures=3)
    first, *_, last = excitation.views
    assert first.interval is None
    assert last.interval is team.intervals[-1]
    assert last.belief is localizer.belief
    assert last.estimate is localizer.estimate
    assert last.model is localizer.model
    assert last.config is env.config


def _angular_pictures(localizer: AngularLocalizer, command: np.ndarray | None) -> None:
    """Two pictures of two robots turning in place: row 1 turned by 0.2 rad, row 0 by 0.05."""
    first = np.array([[100.0, 100.0, 0.0], [300.0, 300.0, 1.0]])
    second = np.array([[100.0, 100.0, 0.05], [300.0, 300.0, 1.2]])
    interval = Interval.exact(np.zeros((1, 2)), [0.2])
    interval = Interval(
        interval.d,
        interval.dphi,
        interval.path,
        interval.sum_ds2,
        interval.sum_dth2,
        command=command,
    )
    localizer.on_picture(first, None, 0.0)
    localizer.on_picture(second, interval, 2.0)


def test_the_faithful_angular_method_reads_the_commanded_rate_from_the_interval() -> None:
    config = anonloc_env.make_config("paper-angular")
    localizer = AngularLocalizer(config, 1, "faithful")
    _angular_pictures(localizer, np.array([[0.0, 0.1]]))  # r dt = 0.1 rad/s * 2 s
    assert localizer.estimate.tolist() == [1]
    _angular_pictures(localizer, np.array([[0.0, 0.025]]))  # r dt = 0.05 rad
    assert localizer.estimate.tolist() == [0]
    with pytest.raises(ValueError, match=r"Interval\.command"):
        _angular_pictures(localizer, None)


def test_a_registered_policy_is_built_by_its_factory(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(catalog, "_registered", {})
    calls = []

    def factory(config, n, mode, excitation, **kwargs):  # type: ignore[no-untyped-def]
        calls.append((n, mode, excitation, kwargs))
        return Team(config, BayesLocalizer(config, n), Counting())

    baselines.register_policy("counting", factory)
    assert baselines.policy_names()[-1] == "counting"
    team = baselines.make_team("counting", "paper-motion", mode="corrected", threshold=0.9)
    assert isinstance(team.excitation, Counting)
    assert calls == [(2, "corrected", None, {"threshold": 0.9})]
    with pytest.raises(ValueError, match="built-in"):
        baselines.register_policy("bayes", factory)


def test_a_policy_registered_by_entry_point_is_found_and_imported_on_use(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    info = tmp_path / "plugin_demo-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: plugin-demo\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text("[anonloc.policies]\ndemo = plugin_demo_policy:team\n")
    (tmp_path / "plugin_demo_policy.py").write_text(
        "from baselines.localizers import BayesLocalizer\n"
        "from baselines.excitations import Still\n"
        "from baselines.policies import Team\n\n"
        "def team(config, n, mode, excitation, **kwargs):\n"
        "    return Team(config, BayesLocalizer(config, n, mode, **kwargs), Still())\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    assert "demo" in baselines.policy_names()
    assert "plugin_demo_policy" not in sys.modules  # listed by name, not imported
    team = baselines.make_team("demo", "paper-motion", threshold=0.95)
    assert team.localizer.threshold == 0.95  # type: ignore[attr-defined]
    assert "plugin_demo_policy" in sys.modules
    monkeypatch.delitem(sys.modules, "plugin_demo_policy")


def test_baselines_lists_every_policy_without_importing_agents() -> None:
    code = (
        "import sys, baselines; baselines.policy_names(); "
        "print(sorted(m for m in sys.modules if m.split('.')[0] == 'agents'))"
    )
    assert python_output(code) == "[]"
