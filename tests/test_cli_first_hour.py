"""The first hour of a new user, and the failures of a hostile one (issue 26), through the real
``anonloc`` script: outputs refused rather than mislabelled, limits checked before any work,
readable frames and tables, progress that suits a log, and documentation that runs."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.cli_helpers import SCRIPT, run_in_terminal, run_script, script_env
from tests.helpers import ROOT

# -- outputs and limits, before any work ---------------------------------------------------


@pytest.mark.parametrize(
    "command",
    [
        ("bench", "--scenario", "default", "--policy", "bayes", "--seeds", "1"),
        ("eval", "--agent", "bundled", "--seeds", "1"),
        ("detect", str(ROOT / "docs" / "assets"), "--camera", "default"),
    ],
    ids=["bench", "eval", "detect"],
)
def test_a_table_output_of_another_format_is_refused_by_every_command(
    tmp_path: Path, command: tuple[str, ...]
) -> None:
    done = run_script(*command, "--out", tmp_path / "results.xlsx")
    assert done.returncode == 2, done.stderr
    assert "tables are written as .csv (CSV) or .parquet (Parquet)" in done.stderr
    assert "a .xlsx file" in done.stderr
    assert list(tmp_path.iterdir()) == []


def test_a_huge_max_cycles_is_refused_before_any_work(tmp_path: Path) -> None:
    done = run_script(
        "bench", "--scenario", "default", "--policy", "bayes", "--seeds", "1", "--out",
        tmp_path / "b.csv", "--set", "max_cycles=99999999999999999999999", timeout=60,
    )  # fmt: skip
    assert done.returncode == 2, done.stderr
    assert "max_cycles must be in [1, 1e+06]" in done.stderr
    assert list(tmp_path.iterdir()) == []


def test_render_refuses_more_steps_than_the_episode_lasts(tmp_path: Path) -> None:
    done = run_script("render", "--steps", "800", "--out", tmp_path / "e.gif")
    assert done.returncode == 2, done.stderr
    assert "--steps 800 is more than scenario 'default' lasts" in done.stderr
    assert "--set max_cycles=800" in done.stderr
    assert list(tmp_path.iterdir()) == []


def _max_rss_mb(*args: object) -> float:
    """Peak resident memory (MB) of ``anonloc ARGS`` (it must succeed)."""
    process = subprocess.Popen(
        [str(SCRIPT), *map(str, args)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        env=script_env(), cwd=ROOT,
    )  # fmt: skip
    _, status, usage = os.wait4(process.pid, 0)
    _, err = process.communicate()
    assert os.waitstatus_to_exitcode(status) == 0, err.decode()
    return usage.ru_maxrss / 1024.0


@pytest.mark.slow  # two episodes drawn frame by frame: about 15 s on 2 idle cores
def test_render_memory_does_not_grow_with_the_frames(tmp_path: Path) -> None:
    args = ("render", "--set", "n_robots=2", "--fps", "20", "-q")  # a frame every step
    short = _max_rss_mb(*args, "--steps", "20", "--out", tmp_path / "short.gif")
    long = _max_rss_mb(*args, "--steps", "300", "--out", tmp_path / "long.gif")
    # 280 more frames of 640 x 690 RGB held in memory would be 370 MB more
    assert long - short < 60, (short, long)
    import imageio.v3 as iio

    assert iio.improps(tmp_path / "long.gif").shape[0] == 301


# -- what a new user sees ------------------------------------------------------------------


def test_the_default_frame_marks_undecided_robots_and_when_the_picture_was_taken(
    tmp_path: Path,
) -> None:
    import imageio.v3 as iio

    out = tmp_path / "frame.png"
    done = run_script("frame", "--out", out, "-q")
    assert done.returncode == 0, done.stderr
    # the frame is drawn at the moment of the newest picture: crosses on the robots
    assert "after 20 steps (t = 1.00 s), 2 pictures, the newest taken at t = 1.00 s" in (
        done.stdout
    )
    image = iio.imread(out)[..., :3].astype(int)
    amber = np.all(np.abs(image - np.array([230, 150, 0])) <= 10, axis=-1)
    legend = amber[-26:]
    assert legend.any(), "no 'undecided' entry in the legend"
    assert amber[:-26].sum() > 100, "no robot is marked undecided"


def test_tables_fit_an_80_column_terminal_without_cutting_a_cell(tmp_path: Path) -> None:
    code, text = run_in_terminal("reproduce", "--runs", "1", "--out", tmp_path, "-q")
    assert code == 0, text
    lines = [re.sub(r"\x1b\[[0-9;]*[A-Za-z]", "", line) for line in text.split("\r\n")]
    table = [line for line in lines if not line.startswith("wrote ")]  # paths may be long
    assert max(len(line.rstrip()) for line in table) <= 80, text
    assert "…" not in text
    assert "  Motion (II.C): 100.0 % [34.2, 100.0]" in lines  # one cell, one line
    assert "- Second row, ours (mean ± std)" in lines


def test_a_terminal_without_unicode_gets_the_table_spelled_out(tmp_path: Path) -> None:
    env = {**script_env(), "PYTHONIOENCODING": "ascii"}
    done = subprocess.run(
        [str(SCRIPT), "reproduce", "--runs", "1", "--out", str(tmp_path), "-q"],
        capture_output=True, text=True, env=env, cwd=ROOT, timeout=180,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr
    assert re.search(r"\d \+- [\d.]+ deg", done.stdout), done.stdout  # 1.2 +- 0.3 deg


def test_progress_in_a_log_file_is_a_few_plain_lines(tmp_path: Path) -> None:
    done = run_script(
        "bench", "--scenario", "default", "--policy", "bayes", "--seeds", "6", "--pictures",
        "2", "--workers", "1", "--out", tmp_path / "b.csv",
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "\r" not in done.stderr
    lines = [line for line in done.stderr.splitlines() if line.startswith("bench:")]
    assert 2 <= len(lines) <= 3, done.stderr  # the first, the last (and one every 30 s)
    assert lines[-1].startswith("bench: 100% 6/6")


# -- documentation that runs ---------------------------------------------------------------


def _installed(tmp_path: Path) -> str:
    """A folder holding only what ``pip install`` installs (links to the four packages)."""
    site = tmp_path / "site"
    site.mkdir()
    for package in ("anonloc_env", "baselines", "agents", "anonloc_cli"):
        (site / package).symlink_to(ROOT / package)
    return str(site)


def _blocks(page: str, language: str, after: str = "") -> list[str]:
    text = (ROOT / "docs" / page).read_text()
    if after:
        assert after in text, f"docs/{page} has no section {after!r}"
        text = text.split(after, 1)[1]
    return re.findall(rf"```{language}\n(.*?)```", text, re.S)


def _python(code: str, cwd: Path, site: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": site}
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=cwd, env=env,
        timeout=120,
    )  # fmt: skip


def test_the_limit_snippet_runs_outside_the_repository(tmp_path: Path) -> None:
    done = _python(_blocks("limit.md", "python")[0], tmp_path, _installed(tmp_path))
    assert done.returncode == 0, done.stderr
    free, swarm = (line.split() for line in done.stdout.splitlines())
    assert (free[0], swarm[0]) == ("free", "swarm")
    assert 0 < float(free[1]) <= float(free[2])  # the bound is below the estimate


def test_images_doc_shows_how_to_get_frames_for_detect(tmp_path: Path) -> None:
    pytest.importorskip("cv2")
    section = "### Frames to try it on"
    (toml,) = _blocks("images.md", "toml", after=section)[:1]
    (code,) = _blocks("images.md", "python", after=section)[:1]
    (tmp_path / "camera.toml").write_text(toml)
    done = _python(code, tmp_path, _installed(tmp_path))
    assert done.returncode == 0, done.stderr
    assert "wrote 5 frames to frames/" in done.stdout
    detected = run_script("detect", tmp_path / "frames", "--camera", tmp_path / "camera.toml",
                          "--out", tmp_path / "d.csv", "-q")  # fmt: skip
    assert detected.returncode == 0, detected.stderr
    assert "20 detections in 5 frames" in detected.stdout  # 4 robots in each


def test_the_readme_timing_of_reproduce_covers_the_measured_runs() -> None:
    readme = " ".join((ROOT / "README.md").read_text().split())
    match = re.search(r"about (\d+) s of CPU time", readme)
    assert match, "the README does not say how much work reproduce is"
    cpu = int(match.group(1))
    measured = " ".join((ROOT / "docs" / "cli.md").read_text().split())
    # the measurements docs/cli.md records: CPU seconds of the whole run
    runs = [float(x) for x in re.findall(r"([\d.]+) s of CPU in all", measured)]
    assert runs, "docs/cli.md records no measured run"
    assert all(abs(r - cpu) <= 0.2 * cpu for r in runs), (cpu, runs)
    assert "the wall time is that CPU time divided by the free cores" in readme


# -- the library ---------------------------------------------------------------------------


def test_a_team_fed_an_env_of_another_size_says_so() -> None:
    import anonloc_env
    import baselines

    team = baselines.make_team("bayes", config=anonloc_env.make_config(n_robots=6))
    env = anonloc_env.parallel_env(n_robots=4)
    observations, _ = env.reset(seed=0)
    team.reset(list(range(6)))
    with pytest.raises(ValueError, match="a team of 6 robots was given 4 observations"):
        team.act([observations[a] for a in env.agents])
