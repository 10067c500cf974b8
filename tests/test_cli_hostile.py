"""Hostile files and inputs: each is refused with a message naming it, before any work, or
handled as the user meant (issue: nothing a user does loses work or hangs)."""

from __future__ import annotations

import json
import math
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest

import anonloc_env
from anonloc_env import make_config
from tests.cli_helpers import invoke, read_csv, run_script


def _bench(tmp_path: Path, *extra: str) -> tuple[int, str]:
    out = tmp_path / "b.csv"
    result = invoke("bench", "--policy", "bayes", "--seeds", "1", "--out", out, *extra)
    return result.exit_code, result.output


# -- configs -------------------------------------------------------------------------------


@pytest.mark.parametrize("ppu", [1e-4, 1e-6, 1e-9])
def test_a_tiny_image_pixels_per_unit_is_refused_naming_the_field_and_range(ppu: float) -> None:
    with pytest.raises(ValueError, match=r"camera.image_pixels_per_unit must be in \[0.05, 1000\]"):
        make_config(camera={"source": "image", "image_pixels_per_unit": ppu})


def test_the_smallest_image_pixels_per_unit_accepted_resets() -> None:
    pytest.importorskip("cv2")
    env = anonloc_env.parallel_env(camera={"source": "image", "image_pixels_per_unit": 0.05})
    observations, _ = env.reset(seed=0)
    assert len(observations) == 4


@pytest.mark.parametrize("field", ["energy_weight", "turn_cost", "information_weight"])
def test_reward_weights_are_bounded(field: str) -> None:
    with pytest.raises(ValueError, match=rf"reward.{field} must be in \[0, 1e\+06\], got 1e\+308"):
        make_config(reward={field: 1e308})


def test_rewards_stay_finite_at_the_bounds_of_every_weight() -> None:
    env = anonloc_env.parallel_env(reward={"energy_weight": 1e6, "turn_cost": 1e6})
    env.reset(seed=0)
    for _ in range(3):
        actions = {a: env.action_space(a).high for a in env.agents}
        _, rewards, *_ = env.step(actions)
        assert all(math.isfinite(r) and r < 0 for r in rewards.values()), rewards


@pytest.mark.parametrize("value", [b"\x04\x04", bytearray(b"\x04\x04")])
def test_bytes_are_refused_for_arena_size(value: bytes) -> None:
    with pytest.raises(TypeError, match="arena_size must be a pair"):
        make_config(arena_size=value)


# -- scenario files ------------------------------------------------------------------------


def test_a_yaml_alias_bomb_is_refused_at_once(tmp_path: Path) -> None:
    lines = ['a: &a ["x","x","x","x","x","x","x","x","x"]']
    for i in range(1, 9):
        lines.append(
            f"{'abcdefghi'[i]}: &{'abcdefghi'[i]} [{','.join(['*' + 'abcdefghi'[i - 1]] * 9)}]"
        )
    bomb = tmp_path / "bomb.yaml"
    bomb.write_text("\n".join(lines) + "\n")
    assert bomb.stat().st_size < 500
    code, output = _bench(tmp_path, "--scenario", bomb)
    assert code == 2
    assert "aliases (*name) are not accepted" in output


def test_a_yaml_duplicate_key_is_refused(tmp_path: Path) -> None:
    twice = tmp_path / "twice.yaml"
    twice.write_text("n_robots: 3\nn_robots: 5\n")
    code, output = _bench(tmp_path, "--scenario", twice)
    assert code == 2
    assert "duplicate key 'n_robots'" in output


def test_a_non_utf8_scenario_file_is_a_message(tmp_path: Path) -> None:
    latin = tmp_path / "latin.toml"
    latin.write_bytes("n_robots = 3 # r\xe9glage\n".encode("latin-1"))
    code, output = _bench(tmp_path, "--scenario", latin)
    assert code == 2
    assert "is not UTF-8 text" in output


def test_deeply_nested_set_values_are_a_message(tmp_path: Path) -> None:
    code, output = _bench(tmp_path, "--scenario", "default", "--set", "n_robots=" + "[" * 3000)
    assert code == 2
    assert "nested too deeply" in output


def test_bench_seeds_are_bounded_before_any_work(tmp_path: Path) -> None:
    code, output = _bench(tmp_path, "--scenario", "default", "--seeds", "1000000000")
    assert code == 2
    assert "--seeds" in output
    assert "less than or equal to 100000" in output
    assert not list(tmp_path.iterdir())


# -- what the rows say ---------------------------------------------------------------------


def test_same_named_scenarios_from_two_folders_stay_apart(tmp_path: Path) -> None:
    for folder, n in (("a", 2), ("b", 3)):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "ten.toml").write_text(f"n_robots = {n}\nmax_cycles = 30\n")
    out = tmp_path / "b.csv"
    result = invoke(
        "bench", "--scenario", tmp_path / "a" / "ten.toml", "--scenario",
        tmp_path / "b" / "ten.toml", "--policy", "bayes", "--seeds", "1", "--out", out,
        "--workers", "1", "--quiet", "--pictures", "2",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    names = {r["scenario"]: int(r["n_robots"]) for r in read_csv(out)}
    assert names == {str(tmp_path / "a" / "ten"): 2, str(tmp_path / "b" / "ten"): 3}
    meta = json.loads(out.with_name("b.meta.json").read_text())
    assert len(meta["configs"]) == 2, meta["configs"].keys()


def test_set_preset_names_the_preset_that_ran(tmp_path: Path) -> None:
    out = tmp_path / "b.csv"
    result = invoke(
        "bench", "--scenario", "default", "--set", "preset=paper-motion", "--policy", "bayes",
        "--seeds", "1", "--out", out, "--workers", "1", "--quiet", "--pictures", "2",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert {r["scenario"] for r in read_csv(out)} == {"paper-motion"}
    assert "| paper-motion |" in out.with_suffix(".md").read_text()


# -- eval on a damaged run, detect on hostile frames ------------------------------------------


@pytest.mark.parametrize("text", ["", "{", '{"env": {}}', "[1, 2]"])
def test_eval_with_a_corrupt_config_json_is_a_message(tmp_path: Path, text: str) -> None:
    run = tmp_path / "run"
    run.mkdir()
    (run / "agent.zip").write_bytes(b"PK")
    (run / "config.json").write_text(text)
    done = run_script("eval", "--agent", run, "--seeds", "1", "--out", tmp_path / "e.csv")
    assert done.returncode == 2, done.stderr
    assert "is not a run's config" in done.stderr
    assert "Traceback" not in done.stderr


def _png_header(width: int, height: int) -> bytes:
    """A PNG's signature and IHDR chunk claiming ``width`` x ``height`` (8-bit grey)."""
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    chunk = b"IHDR" + ihdr
    return (
        b"\x89PNG\r\n\x1a\n" + struct.pack(">I", 13) + chunk + struct.pack(">I", zlib.crc32(chunk))
    )


CAMERA = """preset = "default"
[camera]
source = "image"
image_pixels_per_unit = 1.0
image_size = [64, 48]
principal_point = [32, 24]
"""


def _frames(tmp_path: Path) -> tuple[Path, Path]:
    cv2 = pytest.importorskip("cv2")
    camera = tmp_path / "camera.toml"
    camera.write_text(CAMERA)
    folder = tmp_path / "frames"
    folder.mkdir()
    cv2.imwrite(str(folder / "a.png"), np.full((48, 64), 150, np.uint8))
    return camera, folder


def test_detect_refuses_a_huge_header_before_decoding(tmp_path: Path) -> None:
    camera, folder = _frames(tmp_path)
    (folder / "b.png").write_bytes(_png_header(30000, 30000) + b"\0" * 1000)
    out = tmp_path / "d.csv"
    result = invoke("detect", folder, "--camera", camera, "--out", out)
    assert result.exit_code == 2
    assert "b.png is 30000 x 30000 pixels but the camera file describes a 64 x 48 image" in (
        result.output
    )
    assert not out.exists()


def test_detect_skip_bad_skips_and_names_bad_frames_and_other_files(tmp_path: Path) -> None:
    camera, folder = _frames(tmp_path)
    (folder / "b.png").write_bytes(b"not an image")
    (folder / "notes.txt").write_text("hello")
    out = tmp_path / "d.csv"
    stopped = invoke("detect", folder, "--camera", camera, "--out", out)
    assert stopped.exit_code == 2
    assert "--skip-bad" in stopped.output
    result = invoke("detect", folder, "--camera", camera, "--out", out, "--skip-bad")
    assert result.exit_code == 0, result.output
    assert "in 1 frames" in result.output
    assert "skipped frame: b.png" in result.output
    assert "skipped 1 files that are not .png/.jpg/.jpeg: notes.txt" in result.output


# -- frictions -----------------------------------------------------------------------------


def test_eval_has_defaults_for_seeds_and_out() -> None:
    from anonloc_cli.app import EVAL_SEEDS

    result = invoke("eval", "--help")
    assert result.exit_code == 0
    assert "[default: 20; 1<=x<=100000]" in result.output
    assert "[default: eval.csv]" in result.output
    assert EVAL_SEEDS == 20


def test_study_names_the_files_it_wrote(tmp_path: Path) -> None:
    from anonloc_cli import jobs, study

    report = jobs.Report(total=1, skipped=1)
    names = [s.name for s in study.check_sweeps(["robots"])]
    assert names == ["robots"]
    result = invoke(
        "study", "--sweep", "robots", "--seeds", "1", "--out", tmp_path, "--workers", "1",
        "--quiet",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert f"to {tmp_path}: robots.{{png,svg,csv,meta.json}}" in result.output
    for suffix in ("png", "svg", "csv", "meta.json"):
        assert (tmp_path / f"robots.{suffix}").is_file()
    assert report.ran == 0


def test_printed_tables_never_wrap_a_cell(tmp_path: Path) -> None:
    out = tmp_path / "b.csv"
    result = invoke(
        "bench", "--scenario", "default", "--policy", "bayes", "--policy", "motion",
        "--seeds", "1", "--pictures", "2", "--out", out, "--workers", "1", "--quiet",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    body = [line for line in result.output.splitlines() if line[:1] == "│"]
    # both tables (success, pictures to 99 %): one line per row
    assert [line.split()[1] for line in body] == ["bayes", "motion", "bayes", "motion"]
    assert "100.0 % [51.0, 100.0] (4/4)" in body[0]


def test_the_readme_table_uses_the_labels_reproduce_prints() -> None:
    from anonloc_cli.reproduce import table
    from tests.cli_helpers import ROOT

    headers, rows = table({m: [] for m in ("angular", "linear", "motion")})
    readme = (ROOT / "README.md").read_text()
    section = readme.split("## The paper's table, reproduced", 1)[1].split("\n\n", 3)[2]
    lines = [line for line in section.splitlines() if line.startswith("|")]
    assert lines[0] == "| " + " | ".join(headers) + " |"
    assert [line.split(" | ")[0].lstrip("| ") for line in lines[2:]] == [r[0] for r in rows]


def test_the_default_frame_shows_a_wrong_guess(tmp_path: Path) -> None:
    pytest.importorskip("pygame")
    from anonloc_cli.app import _shown
    from anonloc_cli.options import SHOW_SETS

    scenario = _shown(None, [])
    assert scenario.config.n_robots == 12
    assert SHOW_SETS == ("n_robots=12",)
    out = tmp_path / "b.csv"
    result = invoke(
        "bench", "--scenario", "default", *(f"--set={s}" for s in SHOW_SETS), "--policy",
        "bayes", "--seeds", "1", "--pictures", "2", "--out", out, "--workers", "1", "--quiet",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    second = [json.loads(r["correct_by_picture"])[1] for r in read_csv(out)]
    assert 0 < sum(second) < len(second)  # some right, some not yet, at the second picture


# -- found by the hostile pass ---------------------------------------------------------------


def test_a_full_disk_is_a_message_and_keeps_what_was_stored(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import errno

    from anonloc_cli.store import Store

    real = Store.append
    calls = []

    def fill_up(self: Store, record: dict) -> None:
        calls.append(record["key"])
        if len(calls) > 1:
            raise OSError(errno.ENOSPC, "No space left on device", str(self.path))
        real(self, record)

    monkeypatch.setattr(Store, "append", fill_up)
    out = tmp_path / "b.csv"
    result = invoke(
        "bench", "--scenario", "default", "--policy", "bayes", "--seeds", "3", "--pictures", "2",
        "--out", out, "--workers", "1", "--quiet",
    )  # fmt: skip
    assert result.exit_code == 1
    assert "No space left on device" in result.output
    assert "run the same command again" in result.output
    stored = out.with_name("b.units.jsonl").read_text().splitlines()
    assert len(stored) == 1


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_calibration_refuses_non_finite_points(bad: float) -> None:
    pytest.importorskip("cv2")
    from anonloc_env.images.calibration import estimate_homography

    square = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    image = square * 100.0
    image[2, 1] = bad
    with pytest.raises(ValueError, match="the points must be finite numbers"):
        estimate_homography(square, image)


@pytest.mark.parametrize(("robots", "pictures"), [(3, 0), (0, 5), (2, 1.5)])
def test_calibration_refuses_no_pictures_or_robots(robots: int, pictures: int) -> None:
    from anonloc_env.images.calibration import calibrate

    with pytest.raises(ValueError, match=r"(robots|pictures) must be an integer >= 1"):
        calibrate(make_config(), robots=robots, pictures=pictures)


def test_calibration_refuses_collinear_points() -> None:
    pytest.importorskip("cv2")
    from anonloc_env.images.calibration import estimate_homography

    line = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]])
    with pytest.raises(ValueError, match="degenerate"):
        estimate_homography(line, line * 100.0)


def test_detect_names_an_empty_frame_once(tmp_path: Path) -> None:
    camera, folder = _frames(tmp_path)
    (folder / "b.png").write_bytes(b"")
    result = invoke("detect", folder, "--camera", camera, "--out", tmp_path / "d.csv")
    assert result.exit_code == 2
    assert "Error: b.png: not a PNG or JPEG file" in result.output


@pytest.mark.parametrize(
    ("name", "text"),
    [("nan.toml", "[camera]\nscale = nan\n"), ("inf.toml", "[camera]\npixel_noise = inf\n")],
)
def test_a_non_finite_camera_file_is_refused(tmp_path: Path, name: str, text: str) -> None:
    camera = tmp_path / name
    camera.write_text(text)
    code, output = _bench(tmp_path, "--scenario", camera)
    assert code == 2
    assert "must be a finite number" in output
