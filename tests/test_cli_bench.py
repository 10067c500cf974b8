"""``anonloc bench``: CSV and Parquet outputs, resuming, interruption."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from anonloc_cli.bench import COLUMNS, store_path
from tests.cli_helpers import ROOT, invoke, read_csv

FAST = ["--scenario", "default", "--policy", "bayes", "--pictures", "3", "--quiet"]


def test_bench_csv(tmp_path: Path) -> None:
    out = tmp_path / "bench.csv"
    result = invoke("bench", *FAST, "--policy", "motion", "--seeds", "2", "--out", out)
    assert result.exit_code == 0, result.output
    rows = read_csv(out)
    assert list(rows[0]) == COLUMNS
    assert len(rows) == 2 * 2 * 4  # policies x seeds x robots
    beliefs = json.loads(rows[0]["belief_true"])
    assert len(beliefs) == 3
    assert all(0.0 <= b <= 1.0 for b in beliefs)
    summary = out.with_suffix(".md").read_text()
    assert "success (95 % CI)" in summary
    assert "| bayes | default | 8 |" in summary
    meta = json.loads((tmp_path / "bench.meta.json").read_text())
    assert meta["configs"]["default"]["n_robots"] == 4
    assert set(meta["versions"]) >= {"anonloc", "python", "numpy", "pymunk"}


def test_bench_parquet_keeps_lists_and_provenance(tmp_path: Path) -> None:
    pq = pytest.importorskip("pyarrow.parquet", reason="Parquet output needs pyarrow")
    out = tmp_path / "bench.parquet"
    result = invoke("bench", *FAST, "--seeds", "2", "--out", out)
    assert result.exit_code == 0, result.output
    table = pq.read_table(out)
    assert table.column_names == COLUMNS
    assert table.num_rows == 2 * 4
    row = table.slice(0, 1).to_pylist()[0]
    assert isinstance(row["belief_true"], list)
    assert len(row["belief_true"]) == 3
    meta = json.loads(table.schema.metadata[b"anonloc"])
    assert meta["configs"]["default"]["camera"]["pixel_noise"] == 1.0


def test_a_partial_run_resumed_gives_the_same_rows(tmp_path: Path) -> None:
    whole = tmp_path / "whole.csv"
    parts = tmp_path / "parts.csv"
    assert invoke("bench", *FAST, "--seeds", "4", "--out", whole).exit_code == 0
    assert invoke("bench", *FAST, "--seeds", "2", "--out", parts).exit_code == 0  # "interrupted"
    # A kill in the middle of a write leaves an incomplete last line: it must be dropped.
    with open(store_path(parts), "a") as file:
        file.write('{"key": "cut short')
    resumed = invoke("bench", *FAST, "--seeds", "4", "--out", parts)
    assert resumed.exit_code == 0, resumed.output
    assert "2 episodes executed, 2 reused" in resumed.output
    assert read_csv(parts) == read_csv(whole)
    lines = store_path(parts).read_text().splitlines()
    assert len(lines) == 4
    assert all(json.loads(line)["key"] for line in lines)


def test_ctrl_c_leaves_a_consistent_store_and_the_rerun_completes(tmp_path: Path) -> None:
    out = tmp_path / "bench.csv"
    args = ["bench", "--scenario", "default", "--policy", "bayes", "--seeds", "6"]
    args += ["--workers", "1", "--quiet", "--out", str(out)]
    env_path = {"PYTHONPATH": str(ROOT)}
    process = subprocess.Popen(
        [sys.executable, "-m", "anonloc_cli", *args],
        cwd=ROOT,
        env={**__import__("os").environ, **env_path},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    store = store_path(out)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not (store.exists() and store.stat().st_size > 0):
        time.sleep(0.02)
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 130, stderr
    assert "run the same command again to resume" in stderr
    kept = store.read_text().splitlines()
    assert 1 <= len(kept) < 6
    assert all(json.loads(line)["result"] for line in kept)
    assert not out.exists()  # the export is written only at the end
    resumed = invoke(*args)
    assert resumed.exit_code == 0, resumed.output
    assert f"{6 - len(kept)} episodes executed, {len(kept)} reused" in resumed.output
    fresh = tmp_path / "fresh.csv"
    assert invoke(*args[:-1], str(fresh)).exit_code == 0
    assert read_csv(out) == read_csv(fresh)


def test_scenario_files_and_set_overrides(tmp_path: Path) -> None:
    toml = tmp_path / "three.toml"
    toml.write_text("n_robots = 3\n[camera]\npixel_noise = 2.0\n")
    yaml = tmp_path / "tilted.yaml"
    yaml.write_text("preset: default\ncamera:\n  tilt_deg: 10\n")
    out = tmp_path / "files.csv"
    args = ["--scenario", toml, "--scenario", yaml, "--set", "camera.p_miss=0.1"]
    result = invoke(
        "bench", *args, "--policy", "bayes", "--seeds", "1", "--pictures", "2", "--out", out
    )
    assert result.exit_code == 0, result.output
    rows = read_csv(out)
    assert [(r["scenario"], r["n_robots"]) for r in rows] == [("three", "3")] * 3 + [
        ("tilted", "4")
    ] * 4
    configs = json.loads((tmp_path / "files.meta.json").read_text())["configs"]
    assert configs["three"]["camera"]["pixel_noise"] == 2.0
    assert configs["three"]["camera"]["p_miss"] == 0.1
    assert configs["tilted"]["camera"]["tilt_deg"] == 10.0
