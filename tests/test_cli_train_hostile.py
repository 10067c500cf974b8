"""``anonloc train`` as a new user and a script run it (issue 26): Ctrl-C in a background job, a
progress display that fits 80 columns and says how the run ended, and a kill -9 before the first
checkpoint that loses no log."""

from __future__ import annotations

import re
import signal
import subprocess
import time
from pathlib import Path

import pytest

pytest.importorskip("stable_baselines3")

from tests.cli_helpers import run_in_terminal, run_script, start_script
from tests.test_cli_train_script import ROLLOUT, TINY, csv_rows


def _wait_for_rows(process: subprocess.Popen[str], run: Path, rows: int) -> None:
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and len(csv_rows(run)) < rows:
        assert process.poll() is None, process.communicate()
        time.sleep(0.1)
    assert len(csv_rows(run)) >= rows, "the run logged nothing in 120 s"


def _ignore_sigint() -> None:  # what a shell does to a job started with `&`
    signal.signal(signal.SIGINT, signal.SIG_IGN)


@pytest.mark.slow  # a run of one rollout or two: about 10 s on 2 idle cores
def test_ctrl_c_stops_a_run_started_in_the_background(tmp_path: Path) -> None:
    process = start_script(
        "train", "--timesteps", "1000000", "--n-envs", "1", "--out", tmp_path, "--name", "bg",
        "--quiet", *TINY, preexec_fn=_ignore_sigint,
    )  # fmt: skip
    try:
        _wait_for_rows(process, tmp_path / "bg", 1)
        process.send_signal(signal.SIGINT)
        _, stderr = process.communicate(timeout=30)
    finally:
        if process.poll() is None:  # SIGINT ignored: it would train for ever
            process.kill()
            process.communicate()
    assert process.returncode == 130, stderr
    assert "Continue with: anonloc train --resume" in stderr


@pytest.mark.slow  # about 15 s of training and two short evaluations
def test_train_in_an_80_column_terminal_shows_its_figures_and_how_it_ended(
    tmp_path: Path,
) -> None:
    code, text = run_in_terminal(
        "train", "--timesteps", "1000000", "--n-envs", "1", "--out", tmp_path, "--name", "t",
        "--minutes", "0.2", *TINY,
    )  # fmt: skip
    assert code == 0, text
    drawn = [re.sub(r"\x1b\[[0-9;]*[A-Za-z]", "", s).rstrip() for s in re.split(r"[\r\n]", text)]
    shown = [s for s in drawn if s.startswith(("train ", "train:", "at the end"))]  # the bar
    assert len(shown) > 3, text
    assert max(len(s) for s in shown) <= 80, max(shown, key=len)
    figures = [s for s in drawn if re.search(r"ret=\S+ id=\d+% pic99=\d+\.\d\d$", s)]
    assert figures, text  # the figures appear whole, long before 50,000 steps
    assert re.search(
        r"stopped at \d+ % of the run's 1000000 robot-steps: the --minutes budget", text
    )
    assert f"Continue with: anonloc train --resume {tmp_path / 't'}" in text.replace("\r\n", " ")
    closing = re.search(r"\((\d+ % (fewer|more) pictures|as many as) (than )?random\)", text)
    assert closing, text
    assert "+" not in closing.group(0)


@pytest.mark.slow  # a rollout, a kill, a resumed rollout: about 15 s on 2 idle cores
def test_a_run_killed_before_its_first_checkpoint_keeps_its_logs_apart(tmp_path: Path) -> None:
    run = tmp_path / "k"
    process = start_script(
        "train", "--timesteps", "1000000", "--n-envs", "1", "--out", tmp_path, "--name", "k",
        "--quiet", *TINY,
    )  # fmt: skip
    try:
        _wait_for_rows(process, run, 1)
        process.kill()  # kill -9 before the first checkpoint (every 50,000 steps)
        process.communicate(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
    killed = csv_rows(run)
    assert not list((run / "checkpoints").glob("*.zip"))
    resumed = run_script("train", "--resume", run, "--timesteps", ROLLOUT)
    assert resumed.returncode == 0, resumed.stderr
    assert f"the earlier logs are kept in {run / 'tb.restart-1'}" in resumed.stderr
    kept = (run / "tb.restart-1" / "progress.csv").read_text().splitlines()[1:]
    assert kept[: len(killed)] == killed  # nothing of the killed attempt is overwritten
    assert len(list((run / "tb").glob("events.out.tfevents.*"))) == 1
    assert "\r" not in resumed.stderr  # the progress, in a log: plain lines
