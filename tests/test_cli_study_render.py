"""``anonloc study`` (one tiny sweep) and ``anonloc render``."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.cli_helpers import invoke, read_csv


def test_a_study_sweep_writes_png_svg_csv(tmp_path: Path) -> None:
    out = tmp_path / "study"
    result = invoke("study", "--sweep", "blackout", "--seeds", "1", "--out", out, "--quiet")
    assert result.exit_code == 0, result.output
    assert (out / "blackout.png").read_bytes()[:4] == b"\x89PNG"
    assert b"<svg" in (out / "blackout.svg").read_bytes()[:2000]
    rows = read_csv(out / "blackout.csv")
    assert {r["variant"] for r in rows} == {"bayes", "motion (corrected)"}
    assert len(rows) == 5 * 2
    assert all(
        0.0 <= float(r["success_low"]) <= float(r["success"]) <= float(r["success_high"]) <= 1.0
        for r in rows
    )
    meta = json.loads((out / "blackout.meta.json").read_text())
    assert meta["configs"]["blackout=5"]["schedule"]["blackouts"] == [[5.0, 10.0]]


def test_the_swarm_excitation_gives_identical_commands_without_jitter() -> None:
    import numpy as np

    from baselines.excitations import SwarmMotion
    from baselines.observations import Step

    swarm = SwarmMotion(0.0, common_seed=3)
    swarm.reset([np.random.default_rng(i) for i in range(3)])
    step = Step(np.zeros((3, 3)), False, np.zeros((3, 3)), np.zeros(3, bool), np.zeros((3, 3)), 1.0)
    for _ in range(100):
        v, w = swarm.commands(step, 0.05)
        assert np.all(v == v[0])
        assert np.all(w == w[0])
    jittered = SwarmMotion(1.0, common_seed=3)
    jittered.reset([np.random.default_rng(i) for i in range(3)])
    v, _ = jittered.commands(step, 0.05)
    assert len(set(v.tolist())) == 3


def test_render_writes_a_gif(tmp_path: Path) -> None:
    pytest.importorskip("pygame", reason="rendering needs the render extra (pygame-ce)")
    iio = pytest.importorskip("imageio.v3", reason="the GIF writer is imageio's")
    out = tmp_path / "episode.gif"
    result = invoke("render", "--out", out, "--steps", "30", "--fps", "10", "--quiet")
    assert result.exit_code == 0, result.output
    frames = iio.imread(out, index=None)
    assert frames.shape[0] == 16
    assert frames.shape[-1] == 3


def test_render_mp4_without_ffmpeg_suggests_gif(tmp_path: Path) -> None:
    import importlib.util

    if any(importlib.util.find_spec(m) for m in ("imageio_ffmpeg", "av")):
        pytest.skip("an ffmpeg plugin is installed here")
    result = invoke("render", "--out", tmp_path / "x.mp4")
    assert result.exit_code == 2
    assert ".gif" in result.output
    assert "imageio-ffmpeg" in result.output
