"""``anonloc reproduce`` with tiny run counts."""

from __future__ import annotations

from pathlib import Path

from tests.cli_helpers import invoke, read_csv


def test_reproduce_two_runs_writes_the_table_and_resumes(tmp_path: Path) -> None:
    out = tmp_path / "results"
    result = invoke("reproduce", "--runs", "2", "--out", out, "--quiet")
    assert result.exit_code == 0, result.output
    for label in ("Success, faithful", "Success, corrected", "Bayes at 4th picture", "96.9 %"):
        assert label in result.output
    assert "wall time" in result.output
    text = (out / "reproduce.md").read_text()
    assert "| Runs (ours / paper) | 2 / 65 | 2 / 100 | 2 / 118 |" in text
    assert "numpy" in text
    assert "pymunk" in text
    assert "Command: `anonloc" in text
    assert '"n_robots": 2' in text  # the resolved configs
    rows = read_csv(out / "reproduce.csv")
    assert len(rows) == 3 * 2 * 2  # methods x runs x robots
    assert {r["method"] for r in rows} == {"angular", "linear", "motion"}
    assert (out / "reproduce.meta.json").exists()
    again = invoke("reproduce", "--runs", "2", "--out", out, "--quiet")
    assert again.exit_code == 0
    assert "0 runs executed, 6 reused" in again.output
    assert read_csv(out / "reproduce.csv") == rows
