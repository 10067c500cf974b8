"""``anonloc bench --excitation uniform-rest``, run as a user runs it (the console script)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from baselines.excitations.rest import SURE
from tests.cli_helpers import read_csv, run_script


def test_anonloc_bench_runs_uniform_rest_as_a_user_does(tmp_path: Path) -> None:
    """The real console script, in a subprocess: every robot sure at a picture (belief in its
    true row >= 0.999, all robots here are right) spends no energy until the next one."""
    out = tmp_path / "b.csv"
    done = run_script(
        "bench", "--scenario", "default", "--policy", "bayes", "--excitation", "uniform-rest",
        "--seeds", "2", "--out", out, "--pictures", "4", "--workers", "1", "--quiet",
        "--set", "n_robots=4", "--set", "arena_size=[2.0, 2.0]",
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    rows = read_csv(out)
    assert {r["excitation"] for r in rows} == {"uniform-rest"}
    rested = 0
    for row in rows:
        belief, spent = json.loads(row["belief_true"]), json.loads(row["energy_by_picture"])
        for k in range(len(belief) - 1):
            if belief[k] >= SURE:
                assert spent[k + 1] == pytest.approx(spent[k], abs=1e-6), row
                rested += 1
    assert rested > 0
