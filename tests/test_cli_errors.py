"""Bad input stops a command before any work, with a message naming it and the valid choices."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from tests.cli_helpers import invoke


def _bench(tmp_path: Path, *extra: str) -> tuple[int, str]:
    out = tmp_path / "b.csv"
    args = ["--scenario", "default", "--policy", "bayes", "--seeds", "1", "--out", str(out)]
    result = invoke("bench", *args, *extra)
    assert not out.exists(), "work was done"
    assert not (tmp_path / "b.units.jsonl").exists(), "work was done"
    return result.exit_code, result.output


@pytest.mark.parametrize(
    ("extra", "expected"),
    [
        (
            ["--scenario", "defualt"],
            ["unknown scenario 'defualt'", "did you mean 'default'", "paper-motion"],
        ),
        (["--policy", "bayse"], ["unknown policy 'bayse'", "motion3"]),
        (["--set", "camera.pixl_noise=1"], ["unknown field camera.pixl_noise", "pixel_noise"]),
        (["--set", "camra.pixel_noise=1"], ["unknown override 'camra'", "camera"]),
        (["--set", "camera.pixel_noise=-1"], ["camera.pixel_noise must be in [0, 1e+06], got -1"]),
        (["--set", "n_robots=0"], ["n_robots must be in [1, 100000]"]),
        (["--set", "oops"], ["--set takes key=value"]),
        (["--excitation", "wiggle"], ["unknown excitation 'wiggle'", "swarm"]),
        (["--mode", "faithful"], ["bayes", "faithful"]),
        (["--address", "auto"], ["--address only applies to --backend ray"]),
    ],
)
def test_bench_refuses_bad_input_before_any_work(
    tmp_path: Path, extra: list[str], expected: list[str]
) -> None:
    code, output = _bench(tmp_path, *extra)
    assert code == 2, output
    for text in expected:
        assert text in output


def test_a_scenario_file_is_checked_before_any_work(tmp_path: Path) -> None:
    good = tmp_path / "ten.toml"
    good.write_text('preset = "paper-motion"\nn_robots = 10\n[camera]\npixel_noise = 1.0\n')
    bad = tmp_path / "bad.yaml"
    bad.write_text("preset: default\ncamera:\n  p_mis: 0.1\n")
    code, output = _bench(tmp_path, "--scenario", str(good), "--scenario", str(bad))
    assert code == 2
    assert "scenario 'bad'" in output
    assert "unknown field camera.p_mis" in output
    code, output = _bench(tmp_path, "--scenario", str(tmp_path / "missing.toml"))
    assert code == 2
    assert "not found" in output


def test_study_refuses_an_unknown_sweep(tmp_path: Path) -> None:
    result = invoke("study", "--sweep", "robot", "--out", tmp_path / "s")
    assert result.exit_code == 2
    assert "unknown sweep 'robot'" in result.output
    assert "blackout" in result.output
    assert not (tmp_path / "s").exists()


def test_render_refuses_an_unknown_format_and_policy(tmp_path: Path) -> None:
    result = invoke("render", "--out", tmp_path / "x.png")
    assert result.exit_code == 2
    assert "'.gif', '.mp4'" in result.output
    result = invoke("render", "--out", tmp_path / "x.gif", "--policy", "nope")
    assert result.exit_code == 2
    assert "unknown policy 'nope'" in result.output


def test_ray_backend_without_ray_names_the_extra(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray -> ImportError
    args = ["--policy", "bayes", "--seeds", "1", "--out", tmp_path / "b.csv", "--backend", "ray"]
    result = invoke("bench", "--scenario", "default", *args)
    assert result.exit_code == 2
    assert "pip install 'anonloc[ray]'" in result.output


def test_reproduce_refuses_zero_runs(tmp_path: Path) -> None:
    result = invoke("reproduce", "--runs", "0", "--out", tmp_path)
    assert result.exit_code == 2
    assert "--runs" in result.output


@pytest.mark.parametrize(
    ("out", "message"),
    [
        ("{tmp}", "is a folder"),
        ("/proc/b.csv", "cannot write in /proc"),
        ("{tmp}/b.csv/x.csv", "is not a folder"),
        ("{tmp}/b.md", ".md files are written beside the output"),
    ],
)
def test_bench_out_is_checked_before_any_work(tmp_path: Path, out: str, message: str) -> None:
    (tmp_path / "b.csv").write_text("")
    target = out.format(tmp=tmp_path)
    result = invoke(
        "bench", "--scenario", "default", "--policy", "bayes", "--seeds", "1", "--out", target
    )
    assert result.exit_code == 2
    assert message in result.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.csv"]  # nothing left behind


def test_missing_cli_extra_prints_the_install_line() -> None:
    import subprocess

    code = "import sys; sys.modules['typer'] = None; import anonloc_cli.app"
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=False, cwd=Path.cwd()
    )
    assert done.returncode == 1
    assert "pip install 'anonloc[cli]'" in done.stderr
    assert "Traceback" not in done.stderr
