"""benchmarks.agent_conditions and benchmarks.plot_agents: the evaluation conditions, and the
plot of every excitation beside the limits."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from agents.conditions import TRAINING_ROBOTS, ConditionRanges
from baselines.limit import picture_limit
from benchmarks.agent_conditions import beyond_conditions, evaluation_conditions
from benchmarks.plot_agents import check_rows, limits, plot


def test_the_ten_conditions() -> None:
    conditions = evaluation_conditions()
    assert list(conditions) == [
        "free N=10",
        "free N=30",
        "free N=100",
        "free N=300",
        "free N=1000",
        "swarm N=10",
        "swarm N=100",
        "clutter N=20",
        "clutter N=50",
        "headings N=100",
    ]
    for config, _, budget in conditions.values():
        side = config.n_robots**0.5
        assert config.arena_size == pytest.approx((side, side))  # one robot per m^2
        assert config.camera.pixel_noise == 1.0
        assert config.picture_interval == 1.0
        assert budget == 0.2
    clutter = conditions["clutter N=20"][0].camera
    assert (clutter.p_miss, clutter.false_positives, clutter.orientation) == (0.1, 3.0, False)
    assert conditions["headings N=100"][0].camera.orientation
    assert not conditions["free N=100"][0].camera.orientation
    swarm = [name for name, (_, condition, _) in conditions.items() if condition == "swarm"]
    assert swarm == ["swarm N=10", "swarm N=100"]
    with pytest.raises(ValueError, match="pictures must be an integer >= 1"):
        evaluation_conditions(0)


def test_the_conditions_beyond_change_one_thing_each_beyond_the_training_draws() -> None:
    beyond = beyond_conditions()
    base = evaluation_conditions()["free N=30"][0]
    ranges = ConditionRanges()
    two, _, _ = beyond["free N=2"]
    assert two.n_robots == 2
    assert two.n_robots not in TRAINING_ROBOTS
    sparse, _, _ = beyond["sparse N=30"]
    assert 30 / (sparse.arena_size[0] * sparse.arena_size[1]) == pytest.approx(0.25)
    assert ranges.density[0] > 0.25
    noisy = beyond["noise 3 px N=30"][0].camera
    assert noisy.pixel_noise == 3.0 > ranges.pixel_noise[1]
    clutter = beyond["heavy clutter N=30"][0].camera
    assert clutter.p_miss > ranges.p_miss[1]
    assert clutter.false_positives > ranges.false_positives[1]
    odometry = beyond["odometry N=30"][0]
    assert odometry.robot.odometry_noise == 0.05
    assert base.robot.odometry_noise == 0.0
    config, condition, budget = beyond["swarm N=30, budget 0.05"]
    assert (condition, budget) == ("swarm", 0.05)
    assert budget < ranges.budget[0]
    assert config == base
    for name in ("noise 3 px N=30", "heavy clutter N=30"):
        assert beyond[name][0].robot == base.robot
        assert beyond[name][0].n_robots == 30
    with pytest.raises(ValueError, match="pictures must be an integer >= 1"):
        beyond_conditions(0)


def test_bad_rows_and_names_are_refused() -> None:
    with pytest.raises(ValueError, match="JSON list of objects"):
        check_rows({"condition": "free N=10"})
    with pytest.raises(ValueError, match=r"row 0 lacks \['low', 'high'"):
        check_rows([{"condition": "free N=10", "excitation": "x", "pictures": 3.0}])
    with pytest.raises(ValueError, match="unknown conditions"):
        limits(["free N=7"])


def test_plot_writes_a_png(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    row = {"excitation": "greedy", "pictures": 3.5, "low": 3.1, "high": 3.9, "reached": 10}
    rows = [
        {**row, "condition": "free N=10", "episodes": 10, "energy": 0.8, "wrong": 0.0},
        {**row, "condition": "swarm N=10", "episodes": 10, "energy": 1.1, "wrong": 0.0},
    ]
    (tmp_path / "rows.json").write_text(json.dumps(rows))
    out = tmp_path / "agents.png"
    plot(json.loads((tmp_path / "rows.json").read_text()), str(out))
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    config, condition, budget = evaluation_conditions()["swarm N=10"]
    assert limits(["swarm N=10"])["swarm N=10"] == picture_limit(config, condition, budget)


def test_the_crowded_conditions() -> None:
    from benchmarks.agent_conditions import CROWD_DENSITY, crowded_conditions

    conditions = crowded_conditions()
    assert list(conditions) == ["crowd N=20", "crowd N=100"]
    for config, condition, _ in conditions.values():
        width, height = config.arena_size
        assert config.n_robots / (width * height) == pytest.approx(CROWD_DENSITY)
        assert condition == "free"
        assert not config.camera.orientation
    with pytest.raises(ValueError, match="pictures must be an integer >= 1"):
        crowded_conditions(0)
