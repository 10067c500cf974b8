"""``benchmarks/agent_targets.py``: issue 24's targets judged from ``agent_eval`` rows."""

from __future__ import annotations

from typing import Any

import pytest

from baselines.statistics import Interval95
from benchmarks.agent_targets import table, target_one, target_two


@pytest.mark.parametrize(
    ("pictures", "energy", "verdict"),
    [
        (Interval95(0.95, 0.9, 1.0), Interval95(0.7, 0.6, 0.8), "met"),
        (Interval95(1.0, 0.9, 1.1), Interval95(0.8, 0.7, 0.9), "met"),
        (Interval95(1.05, 0.98, 1.1), Interval95(0.7, 0.6, 0.8), "within the interval"),
        (Interval95(1.05, 1.01, 1.1), Interval95(0.7, 0.6, 0.8), "missed"),
        (Interval95(0.9, 0.8, 1.0), Interval95(0.81, 0.7, 0.9), "missed"),
    ],
)
def test_target_one_needs_no_more_pictures_at_at_most_080_the_energy(
    pictures: Interval95, energy: Interval95, verdict: str
) -> None:
    assert target_one(pictures, energy) == verdict


def row(excitation: str, firsts: list[float], energies: list[float]) -> dict[str, Any]:
    return {"condition": "c", "excitation": excitation, "firsts": firsts, "energies": energies}


def test_target_two_compares_with_the_rival_of_fewer_pictures_on_the_shared_seeds() -> None:
    """The agent played four seeds, the rivals two: only the first two count."""
    agent = row("agent", [3, 3, 9, 9], [1.0, 1.0, 5.0, 5.0])
    greedy, distinct = row("greedy", [4, 4], [0.9, 0.9]), row("distinct", [5, 5], [2.0, 2.0])
    text, verdict = target_two(agent, [distinct, greedy])
    assert text.startswith("`greedy` 4.00 / 0.90 (agent 3.00 / 1.00; ratios 0.75 [0.75, 0.75]")
    assert verdict == "missed"  # fewer pictures but more energy than greedy, on every seed
    _, verdict = target_two(row("agent", [3, 3], [0.5, 0.5]), [distinct, greedy])
    assert verdict == "met"


def test_target_two_is_within_the_interval_where_a_ratio_above_one_reaches_one() -> None:
    """Paired on four seeds: the agent's pictures are 1.1x greedy's on the mean, but below on two
    seeds, so the bootstrap interval of the ratio reaches 1; its energy is below on every seed."""
    greedy = row("greedy", [4, 4, 4, 4], [1.0, 1.0, 1.0, 1.0])
    distinct = row("distinct", [9, 9, 9, 9], [1.0, 1.0, 1.0, 1.0])
    agent = row("agent", [3, 3, 6, 5.6], [0.9, 0.9, 0.9, 0.9])
    text, verdict = target_two(agent, [distinct, greedy])
    assert "ratios 1.1 [" in text
    assert verdict == "within the interval"
    agent = row("agent", [4.4, 4.4, 4.4, 4.4], [0.9, 0.9, 0.9, 0.9])
    assert target_two(agent, [distinct, greedy])[1] == "missed"  # above 1 on every seed


def test_the_table_has_one_line_per_condition_with_agent_and_uniform() -> None:
    rows = [
        row("agent", [3, 4], [0.5, 0.6]),
        row("uniform", [3, 4], [1.0, 1.0]),
        {**row("agent", [3], [0.5]), "condition": "no uniform"},
    ]
    lines = table(rows)
    assert len(lines) == 3
    assert lines[2].startswith("| c | 1 [1, 1] | 0.55 [0.5, 0.6] | met | not run |")
