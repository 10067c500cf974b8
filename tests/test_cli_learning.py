"""``anonloc train`` and ``anonloc eval``: a tiny run end to end, and inputs refused up front."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

pytest.importorskip("stable_baselines3")

from tests.cli_helpers import invoke, read_csv

TINY = [
    "--set",
    "n_robots=3",
    "--set",
    "arena_size=[2.0, 2.0]",
    "--set",
    "max_cycles=20",
    "--set",
    "picture_interval=0.25",
    "--set",
    "camera.orientation=false",
]


def test_train_then_eval_against_baselines(tmp_path: Path) -> None:
    result = invoke(
        "train", "--timesteps", "120", "--n-envs", "2", "--out", tmp_path, "--name", "tiny",
        "--quiet", *TINY,
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    run = tmp_path / "tiny"
    assert (run / "agent.zip").is_file()
    recorded = json.loads((run / "config.json").read_text())
    assert recorded["train"]["overrides"]["n_robots"] == 3
    assert recorded["env"]["n_robots"] == 3
    again = invoke("train", "--timesteps", "120", "--out", tmp_path, "--name", "tiny", *TINY)
    assert again.exit_code == 2
    assert "exists" in again.output

    out = tmp_path / "eval.csv"
    result = invoke(
        "eval", "--agent", run, "--seeds", "2", "--against", "random", "--out", out,
        "--workers", "1", "--quiet",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    rows = read_csv(out)
    assert {r["policy"] for r in rows} == {"agent", "random"}
    assert len(rows) == 2 * 2 * 3  # contenders x seeds x robots
    summary = out.with_suffix(".md").read_text()
    assert "Pictures until 99 % of the robots present are identified" in summary
    assert "| agent | tiny | 2 |" in summary


def test_eval_refuses_a_missing_agent_before_any_work(tmp_path: Path) -> None:
    out = tmp_path / "e.csv"
    result = invoke("eval", "--agent", tmp_path / "nothing", "--seeds", "1", "--out", out)
    assert result.exit_code == 2
    assert "no saved agent" in result.output
    assert not out.exists()


def test_train_refuses_a_bad_option_before_any_work(tmp_path: Path) -> None:
    result = invoke("train", "--condition", "wander", "--out", tmp_path, *TINY)
    assert result.exit_code == 2
    assert "condition must be one of" in result.output
    assert not list(tmp_path.iterdir())
