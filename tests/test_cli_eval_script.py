"""``anonloc eval`` run as users run it: the real console script, in a subprocess.

The hang these guard against is invisible to Typer's CliRunner: the parent loads the agent
(torch starts its threads) and a forked pool worker then deadlocked inside ``PPO.load``.
"""

from __future__ import annotations

import signal
import subprocess
import time
from pathlib import Path

import pytest

pytest.importorskip("stable_baselines3")

from anonloc_cli.bench import store_path
from tests.cli_helpers import read_csv, run_script, start_script

TINY = [
    "--set", "n_robots=3", "--set", "arena_size=[2.0, 2.0]", "--set", "max_cycles=20",
    "--set", "picture_interval=0.25", "--set", "camera.orientation=false",
]  # fmt: skip
#: Far more than a finished eval of 1 tiny episode needs, far less than forever.
EVAL_LIMIT = 120


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A tiny agent trained by the console script."""
    out = tmp_path_factory.mktemp("runs")
    done = run_script(
        "train", "--timesteps", "120", "--n-envs", "1", "--out", out, "--name", "tiny",
        "--quiet", *TINY,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    return out / "tiny"


def test_eval_on_the_process_pool_finishes(run: Path, tmp_path: Path) -> None:
    out = tmp_path / "e.csv"
    done = run_script(
        "eval", "--agent", run, "--seeds", "2", "--out", out, "--workers", "1", "--quiet",
        timeout=EVAL_LIMIT,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    rows = read_csv(out)
    assert len(rows) == 2 * 3
    assert {r["policy"] for r in rows} == {"agent"}


def test_ctrl_c_during_eval_stops_it_and_leaves_no_empty_store(run: Path, tmp_path: Path) -> None:
    out = tmp_path / "e.csv"
    process = start_script(
        "eval", "--agent", run, "--seeds", "50", "--out", out, "--workers", "1", "--quiet",
    )  # fmt: skip
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not _has_children(process.pid):
            assert process.poll() is None, process.communicate()
            time.sleep(0.05)
        time.sleep(0.5)  # let the worker start loading the agent
        process.send_signal(signal.SIGINT)
        _, stderr = process.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        process.kill()
        process.communicate()
        pytest.fail("eval kept running after Ctrl-C")
    assert process.returncode == 130, stderr
    assert "Interrupted" in stderr
    assert "Traceback" not in stderr
    store = store_path(out)
    assert not store.exists() or store.stat().st_size > 0, "an empty store was left behind"


def _has_children(pid: int) -> bool:
    tasks = Path(f"/proc/{pid}/task")
    if not tasks.exists():  # pragma: no cover - not Linux: only wait for the start-up
        time.sleep(3)
        return True
    return any((t / "children").read_text().split() for t in tasks.iterdir() if t.exists())


def test_the_learned_agent_acts_the_same_on_one_or_two_workers(run: Path, tmp_path: Path) -> None:
    outputs = []
    for workers in ("1", "2"):
        out = tmp_path / f"w{workers}.csv"
        done = run_script(
            "eval", "--agent", run, "--seeds", "2", "--out", out, "--workers", workers, "--quiet",
            timeout=EVAL_LIMIT,
        )  # fmt: skip
        assert done.returncode == 0, done.stderr
        outputs.append(sorted(read_csv(out), key=lambda r: (int(r["seed"]), int(r["robot"]))))
    assert outputs[0] == outputs[1]


def test_a_damaged_agent_file_is_one_clear_message(tmp_path: Path) -> None:
    bad = tmp_path / "agent.zip"
    bad.write_text("not a zip")
    done = run_script(
        "eval", "--agent", bad, "--scenario", "default", "--seeds", "1", "--out", tmp_path / "e.csv"
    )
    assert done.returncode == 2
    assert "Error: policy 'agent':" in done.stderr
    assert "is not a saved agent" in done.stderr
    assert "Error: Error" not in done.stderr
