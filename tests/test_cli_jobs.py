"""The job runner and the store: stable keys, retries of dead workers, atomic files, Ray."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from anonloc_cli import jobs
from anonloc_cli.jobs import Unit
from anonloc_cli.store import Store, StoreBusyError, atomic_path, read_records, write_text
from tests.cli_helpers import invoke, read_csv


def test_unit_keys_are_stable_and_ignore_dict_order() -> None:
    a = Unit(
        "bench",
        {"preset": "default", "camera": {"p_miss": 0.1, "pixel_noise": 1.0}},
        "bayes",
        3,
        {"k": 1},
    )
    b = Unit(
        "bench",
        {"camera": {"pixel_noise": 1.0, "p_miss": 0.1}, "preset": "default"},
        "bayes",
        3,
        {"k": 1},
    )
    assert a.key == b.key
    assert a.key == "6aa6ae4b6ab636886c38"  # the same on every machine and Python version
    assert Unit("bench", a.scenario, "bayes", 4, {"k": 1}).key != a.key
    assert Unit.from_dict(a.to_dict()) == Unit.from_dict(json.loads(json.dumps(a.to_dict())))


def _crash_units(tmp_path: Path, dies: list[str | None]) -> list[Unit]:
    return [
        Unit("tests.cli_units", {}, "none", seed, {"die": die, "marker": str(tmp_path)})
        for seed, die in enumerate(dies)
    ]


def test_a_worker_that_dies_is_retried_and_nothing_is_lost(tmp_path: Path) -> None:
    units = _crash_units(tmp_path, [None, "once", None, "always", None, None])
    with Store(tmp_path / "s.jsonl") as store:
        report = jobs.run_units(units, store, workers=2, quiet=True)
    assert report.failed == [units[3].key]  # given up after 1 + 2 tries
    records = read_records(tmp_path / "s.jsonl")
    assert set(records) == {u.key for i, u in enumerate(units) if i != 3}
    assert records[units[1].key]["result"] == {"seed": 1}


def test_the_store_is_locked_and_files_are_replaced_atomically(tmp_path: Path) -> None:
    path = tmp_path / "s.jsonl"
    with Store(path) as store:
        store.append({"key": "a", "result": 1})
        with pytest.raises(StoreBusyError, match="in use by another anonloc command"), Store(path):
            pass
    target = tmp_path / "table.md"
    write_text(target, "old")

    def fail_halfway() -> None:
        with atomic_path(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("the writer failed")

    with pytest.raises(RuntimeError, match="the writer failed"):
        fail_halfway()
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.jsonl", "table.md"]


def test_ray_backend_gives_the_same_rows_as_the_process_pool(tmp_path: Path) -> None:
    pytest.importorskip("ray", reason="the Ray backend needs the ray extra")
    args = [
        "--scenario",
        "default",
        "--policy",
        "bayes",
        "--pictures",
        "3",
        "--seeds",
        "3",
        "--quiet",
    ]
    ray_out, pool_out = tmp_path / "ray.csv", tmp_path / "pool.csv"
    result = invoke("bench", *args, "--out", ray_out, "--backend", "ray", "--workers", "2")
    assert result.exit_code == 0, result.output
    assert invoke("bench", *args, "--out", pool_out).exit_code == 0
    assert read_csv(ray_out) == read_csv(pool_out)
    worker = json.loads((tmp_path / "ray.units.jsonl").read_text().splitlines()[0])["worker"]
    assert worker  # ran in a Ray worker process


def test_an_edited_store_line_is_not_trusted(tmp_path: Path) -> None:
    path = tmp_path / "s.jsonl"
    with Store(path) as store:
        for key in "abc":
            store.append({"key": key, "result": {"success": 1}})
    lines = path.read_text().splitlines()
    lines[1] = lines[1].replace('"success":1', '"success":0')  # still valid JSON
    path.write_text("\n".join(lines) + "\n")
    records = read_records(path)
    assert sorted(records) == ["a", "c"]  # b runs again
    assert records["a"]["result"] == {"success": 1}
