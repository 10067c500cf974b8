"""``anonloc study`` (one tiny sweep and its plots), ``anonloc render`` and ``anonloc frame``."""

from __future__ import annotations

import json
import sys
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
    from baselines.steps import Step

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


def test_frame_takes_scenario_and_set_and_writes_where_out_says(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("pygame", reason="rendering needs pygame-ce")
    iio = pytest.importorskip("imageio.v3")
    (tmp_path / "cwd").mkdir()
    monkeypatch.chdir(tmp_path / "cwd")
    out = tmp_path / "sub" / "frame.png"
    out.parent.mkdir()
    args = ("frame", "--out", out, "--steps", "3", "--quiet")
    result = invoke(*args, "--scenario", "paper-motion", "--set", "n_robots=3")
    assert result.exit_code == 0, result.output
    assert iio.imread(out).shape[-1] == 3
    result = invoke(*args, "--preset", "paper-motion")  # the deprecated spelling still works
    assert result.exit_code == 0, result.output
    assert "--preset is deprecated" in result.output
    assert invoke("frame", "--out", tmp_path / "f.gif").exit_code == 2  # not a PNG
    assert invoke("frame", "--steps", "3").exit_code == 2  # --out is required
    assert list((tmp_path / "cwd").iterdir()) == []  # nothing written into the working folder


def test_render_human_without_a_display_fails_clearly(monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("pygame", reason="rendering needs pygame-ce")
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.delenv("SDL_VIDEODRIVER", raising=False)  # as a user has it (not the tests' dummy)
    result = invoke("render", "--human", "--steps", "2", "--quiet")
    assert result.exit_code == 2
    assert "--human needs a display" in result.output


@pytest.mark.parametrize("command", ["render", "frame"])
def test_drawing_without_pygame_is_one_line_and_exit_2(
    command: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "pygame" else real(name, *a)
    )
    out = tmp_path / ("x.gif" if command == "render" else "x.png")
    result = invoke(command, "--out", out)
    assert result.exit_code == 2
    assert result.output.strip().splitlines() == [
        "Error: drawing needs pygame-ce, which is not installed: pip install 'anonloc[cli]' "
        "(or pip install pygame-ce)"
    ]


def test_sweep_plot_keeps_its_end_tick_labels_inside_the_figure(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from anonloc_cli import plots
    from anonloc_cli.sweeps import SWEEPS

    kept: list = []
    close = plt.close
    monkeypatch.setattr(plt, "close", kept.append)  # keep the figures to measure them
    for name in ("noise", "robots"):
        sweep = SWEEPS[name]
        rows = [
            {"variant": "bayes", "x": x, "success": 0.9, "success_low": 0.8}
            | {"success_high": 1.0, "pictures_mean": 2.0}
            | {"pictures_low": 1.5, "pictures_high": 2.5}
            for x in sweep.xs
        ]
        plots.sweep(sweep, rows, ("a", "b"), tmp_path / name, {"versions": {"anonloc": "0"}})
    assert len(kept) == 2
    for figure in kept:
        figure.canvas.draw()
        renderer = figure.canvas.get_renderer()
        for axis in figure.axes:
            labels = [t for t in axis.get_xticklabels() if t.get_text()]
            assert labels
            for label in labels:
                box = label.get_window_extent(renderer)
                # within the axes (not half over the edge, where the figure may cut it)
                assert axis.bbox.x0 <= box.x0, label.get_text()
                assert box.x1 <= axis.bbox.x1, label.get_text()
        close(figure)
