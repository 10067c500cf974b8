"""``anonloc train`` as users run it (the console script): nothing trained is ever lost.

Ctrl-C and SIGTERM save a checkpoint and the agent; ``--resume`` continues from them, keeps the
earlier rows of ``tb/progress.csv``, trains to the run's own total (or a new ``--timesteps``),
skips a damaged newest checkpoint, and ``eval`` notices that ``agent.zip`` changed.
"""

from __future__ import annotations

import json
import signal
import subprocess
import time
from pathlib import Path

import pytest

pytest.importorskip("stable_baselines3")

from tests.cli_helpers import run_script, start_script

TINY = [
    "--set", "n_robots=3", "--set", "arena_size=[2.0, 2.0]", "--set", "max_cycles=20",
    "--set", "picture_interval=0.25", "--set", "camera.orientation=false",
]  # fmt: skip
#: One PPO rollout: 128 decisions x 3 robots x 1 copy.
ROLLOUT = 128 * 3


def csv_rows(run: Path) -> list[str]:
    """The data rows of the run's ``tb/progress.csv``."""
    path = run / "tb" / "progress.csv"
    return path.read_text().splitlines()[1:] if path.exists() else []


def checkpoints(run: Path) -> list[Path]:
    return sorted((run / "checkpoints").glob("agent_*_steps.zip"))


def stop_after_two_rollouts(out: Path, name: str, signum: int) -> subprocess.CompletedProcess[str]:
    """Start a long run, and send ``signum`` once it has logged two rollouts."""
    run = out / name
    process = start_script(
        "train", "--timesteps", "1000000", "--n-envs", "1", "--out", out, "--name", name,
        "--quiet", *TINY,
    )  # fmt: skip
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and len(csv_rows(run)) < 2:
            assert process.poll() is None, process.communicate()
            time.sleep(0.1)
        process.send_signal(signum)
        stdout, stderr = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()
    return subprocess.CompletedProcess(process.args, process.returncode, stdout, stderr)


def train_tiny(out: Path, name: str, steps: int) -> subprocess.CompletedProcess[str]:
    """A tiny run ``out/name`` of ``steps`` robot-steps, trained by the console script."""
    done = run_script(
        "train", "--timesteps", steps, "--n-envs", "1", "--out", out, "--name", name,
        "--quiet", *TINY,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    return done


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["ctrl-c", "sigterm"])
def test_a_stopped_run_saves_and_resume_continues_keeping_the_log(
    tmp_path: Path, signum: int
) -> None:
    run = tmp_path / "r"
    stopped = stop_after_two_rollouts(tmp_path, "r", signum)
    assert stopped.returncode == 130, stopped.stderr
    assert "Traceback" not in stopped.stderr
    saved = checkpoints(run)
    assert saved, "no checkpoint was saved on the interrupt"
    assert (run / "agent.zip").is_file()
    assert f"--resume {run}" in stopped.stderr
    earlier = csv_rows(run)
    steps = int(saved[-1].stem.split("_")[1])
    assert steps >= 2 * ROLLOUT

    resumed = run_script(
        "train", "--resume", run, "--timesteps", steps + ROLLOUT, "--quiet", timeout=120
    )
    assert resumed.returncode == 0, resumed.stderr
    assert f"trained {steps + ROLLOUT} robot-steps" in resumed.stdout
    after = csv_rows(run)
    assert after[: len(earlier)] == earlier, "resume lost the earlier rows of progress.csv"
    assert len(after) == len(earlier) + 1


def test_resume_keeps_the_runs_own_budget_and_shows_it(tmp_path: Path) -> None:
    first = train_tiny(tmp_path, "b", ROLLOUT)
    assert f"trained {ROLLOUT} robot-steps" in first.stdout
    again = run_script("train", "--resume", tmp_path / "b", "--quiet", timeout=90)
    assert again.returncode == 0, again.stderr
    assert f"trained {ROLLOUT} robot-steps" in again.stdout  # at its total: no more steps
    extended = run_script("train", "--resume", tmp_path / "b", "--timesteps", 2 * ROLLOUT)
    assert extended.returncode == 0, extended.stderr
    assert f"trained {2 * ROLLOUT} robot-steps" in extended.stdout
    assert f"{2 * ROLLOUT}/{2 * ROLLOUT}" in extended.stderr  # the bar counts the whole run
    assert f"{ROLLOUT}/{2 * ROLLOUT}" in extended.stderr  # and starts at the earlier steps


def test_resume_skips_a_truncated_checkpoint_and_says_so(tmp_path: Path) -> None:
    train_tiny(tmp_path, "t", 2 * ROLLOUT)
    run = tmp_path / "t"
    good = checkpoints(run)[-1]
    damaged = run / "checkpoints" / f"agent_{3 * ROLLOUT}_steps.zip"
    damaged.write_bytes(good.read_bytes()[:1000])  # a kill in the middle of a save
    resumed = run_script(
        "train", "--resume", run, "--timesteps", 3 * ROLLOUT, "--quiet", timeout=120
    )
    assert resumed.returncode == 0, resumed.stderr
    assert f"checkpoint {damaged} is damaged" in resumed.stderr
    assert f"trained {3 * ROLLOUT} robot-steps" in resumed.stdout


def test_eval_runs_again_when_agent_zip_changed(tmp_path: Path) -> None:
    train_tiny(tmp_path, "e", ROLLOUT)
    run, out = tmp_path / "e", tmp_path / "e.csv"
    args = ["eval", "--agent", run, "--seeds", "1", "--out", out, "--workers", "1", "--quiet"]
    assert run_script(*args, timeout=120).returncode == 0
    more = run_script("train", "--resume", run, "--timesteps", 2 * ROLLOUT, "--quiet")
    assert more.returncode == 0, more.stderr
    again = run_script(*args, timeout=120)
    assert again.returncode == 0, again.stderr
    assert "(1 episodes executed, 1 reused)" not in again.stdout
    assert "(1 episodes executed, 0 reused)" in again.stdout


def test_a_run_killed_before_its_first_checkpoint_resumes_from_step_0(tmp_path: Path) -> None:
    run = tmp_path / "k"
    process = start_script(
        "train", "--timesteps", "1000000", "--n-envs", "1", "--out", tmp_path, "--name", "k",
        "--quiet", *TINY,
    )  # fmt: skip
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not (run / "config.json").exists():
            time.sleep(0.02)
        process.kill()  # kill -9: nothing can be saved
        process.communicate(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
    assert not checkpoints(run)
    resumed = run_script("train", "--resume", run, "--timesteps", ROLLOUT, "--quiet")
    assert resumed.returncode == 0, resumed.stderr
    assert "training the run from step 0" in resumed.stderr
    assert f"trained {ROLLOUT} robot-steps" in resumed.stdout


def test_a_second_train_on_a_run_being_trained_is_refused(tmp_path: Path) -> None:
    from agents.run_folder import RunLock

    run = tmp_path / "r"
    train_tiny(tmp_path, "r", ROLLOUT)
    with RunLock(run):  # another process training it
        second = run_script("train", "--resume", run, "--timesteps", 2 * ROLLOUT, "--quiet")
    assert second.returncode == 2
    assert "is being trained by another process" in second.stderr
    assert [p.name for p in checkpoints(run)] == [f"agent_{ROLLOUT}_steps.zip"]


def test_resume_honours_minutes(tmp_path: Path) -> None:
    train_tiny(tmp_path, "m", ROLLOUT)
    resumed = run_script(
        "train", "--resume", tmp_path / "m", "--timesteps", "10000000", "--minutes", "0.01",
        "--quiet", timeout=90,
    )  # fmt: skip
    assert resumed.returncode == 0, resumed.stderr
    trained = int(resumed.stdout.split("trained ", 1)[1].split(" ", 1)[0])
    assert ROLLOUT < trained < 10_000_000  # stopped by the 0.6 s budget, not the total


def test_train_imitates_greedy_and_ends_against_random(tmp_path: Path) -> None:
    """``--imitation`` through the console script: the run starts from greedy's choices and its
    last line compares it with random motion on the evaluation seeds."""
    done = run_script(
        "train", "--timesteps", ROLLOUT, "--imitation", "60", "--n-envs", "1", "--out", tmp_path,
        "--name", "i", "--quiet", *TINY,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "pictures to 99 % on the evaluation seeds: this agent" in done.stdout
    assert "random motion" in done.stdout
    assert json.loads((tmp_path / "i" / "config.json").read_text())["train"]["imitation"] == 60


def test_train_refuses_overrides_with_mixed_conditions(tmp_path: Path) -> None:
    done = run_script(
        "train", "--condition", "mixed", "--out", tmp_path, "--name", "x", "--quiet", *TINY
    )
    assert done.returncode == 2
    assert "condition 'mixed' draws its scenarios" in done.stderr
    assert not (tmp_path / "x").exists()
