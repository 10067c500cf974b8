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
