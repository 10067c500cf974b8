"""``anonloc bench --excitation uniform-rest`` and ``anonloc train --rest``, run as a user runs them
(the console script)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from baselines.excitations.rest import SURE
from tests.cli_helpers import read_csv, run_script


def test_anonloc_bench_runs_uniform_rest_as_a_user_does(tmp_path: Path) -> None:
    """The real console script, in a subprocess: a robot sure at a picture (belief in its true
    row >= 0.999, all robots here are right) holds still until the next one, except to back out
    of a bump (``RestWhenSure``'s yield): most rests spend nothing, none more than the longest
    back-off (1.2 s at 0.3 m/s turning at 1 rad/s: 1.2 x (0.3 + 0.1 x 1) = 0.48 m of wheel
    travel). Four robots in 2 m x 2 m bump often."""
    out = tmp_path / "b.csv"
    done = run_script(
        "bench", "--scenario", "default", "--policy", "bayes", "--excitation", "uniform-rest",
        "--seeds", "2", "--out", out, "--pictures", "4", "--workers", "1", "--quiet",
        "--set", "n_robots=4", "--set", "arena_size=[2.0, 2.0]",
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    rows = read_csv(out)
    assert {r["excitation"] for r in rows} == {"uniform-rest"}
    rests = []
    for row in rows:
        belief, spent = json.loads(row["belief_true"]), json.loads(row["energy_by_picture"])
        rests += [spent[k + 1] - spent[k] for k in range(len(belief) - 1) if belief[k] >= SURE]
    assert len(rests) > 0
    assert max(rests) <= 0.48
    assert sum(r == pytest.approx(0.0, abs=1e-6) for r in rests) >= len(rests) / 2, rests


def test_anonloc_train_rest_is_saved_with_the_agent(tmp_path: Path) -> None:
    """``anonloc train --rest`` as the real console script: the saved agent's spec records the
    belief, and the loaded agent rests there; a belief outside (0.5, 1] is refused, naming
    ``rest``, before anything is written."""
    pytest.importorskip("torch")
    from agents.policy import load_agent
    from agents.spec import saved_spec
    from baselines.excitations.rest import RestWhenSure

    done = run_script(
        "train", "--timesteps", "64", "--n-envs", "1", "--n-steps", "16", "--batch-size", "16",
        "--eval-episodes", "0", "--set", "n_robots=3", "--rest", "0.9999",
        "--out", tmp_path, "--name", "r", "--quiet", timeout=300,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    agent = tmp_path / "r" / "agent.zip"
    spec = saved_spec(agent)
    assert spec is not None
    assert spec.rest == 0.9999
    loaded = load_agent(agent)
    assert isinstance(loaded, RestWhenSure)
    assert loaded.sure == 0.9999
    bad = run_script("train", "--rest", "0.3", "--out", tmp_path, "--name", "bad")
    assert bad.returncode != 0
    assert "rest must be in (0.5, 1]" in bad.stderr
    assert not (tmp_path / "bad").exists()
