"""``anonloc bench`` killed with ``kill -9``: its pool workers die with it and the rerun resumes.

A worker that outlived its parent kept running (and, forked, kept the store locked, so the rerun
refused to resume) until it was killed by hand. Workers are spawned now; they and the spawn
context's resource tracker must still go with their parent. Linux only: the workers
are found through ``/proc`` and the fix is the kernel's ``PR_SET_PDEATHSIG``.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from anonloc_cli.bench import store_path
from tests.cli_helpers import ROOT, invoke, read_csv

pytestmark = pytest.mark.skipif(
    not Path(f"/proc/self/task/{os.getpid()}/children").exists(),
    reason="finds the workers through /proc/PID/task/TID/children (Linux)",
)

SEEDS = 12
ROBOTS = 4  # the default scenario's
#: How long the workers may outlive their parent (s): the kernel signals them at once.
WORKERS_GONE_WITHIN = 10.0


def children(pid: int) -> set[int]:
    """The pids of the live children of process ``pid`` (every thread's list)."""
    found: set[int] = set()
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            found.update(int(c) for c in (task / "children").read_text().split())
        except (FileNotFoundError, ProcessLookupError):  # the thread ended meanwhile
            continue
    return {c for c in found if alive(c)}


def cmdline(pid: int) -> str:
    """The command line of ``pid`` ("" once it has gone)."""
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except (FileNotFoundError, ProcessLookupError):
        return ""


def alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie, dead but not yet reaped by its new parent, does not)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except (FileNotFoundError, ProcessLookupError):
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def test_kill_9_takes_the_workers_down_and_the_rerun_resumes(tmp_path: Path) -> None:
    out = tmp_path / "bench.csv"
    args = ["bench", "--scenario", "default", "--policy", "bayes", "--seeds", str(SEEDS)]
    args += ["--workers", "2", "--quiet", "--out", str(out)]
    parent = subprocess.Popen(
        [sys.executable, "-m", "anonloc_cli", *args],
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    store = store_path(out)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not (store.exists() and store.stat().st_size > 0):
            assert parent.poll() is None, "the bench ended before it stored a result"
            time.sleep(0.01)
        workers = children(parent.pid)  # the pool's and the spawn context's resource tracker
        pool = {w for w in workers if "resource_tracker" not in cmdline(w)}
        assert len(pool) == 2, f"expected the pool's 2 workers, found {workers}"
        os.kill(parent.pid, signal.SIGKILL)
        parent.wait(timeout=10)
    finally:
        if parent.poll() is None:
            parent.kill()
    deadline = time.monotonic() + WORKERS_GONE_WITHIN
    while time.monotonic() < deadline and any(alive(w) for w in workers):
        time.sleep(0.05)
    survivors = {w for w in workers if alive(w)}
    for pid in survivors:  # leave no process behind, then fail
        os.kill(pid, signal.SIGKILL)
    assert not survivors, f"workers {survivors} outlived their killed parent"

    kept = [json.loads(line) for line in store.read_text().splitlines() if line.endswith("}")]
    assert 1 <= len(kept) < SEEDS, "the kill must come in the middle of the job"
    resumed = invoke(*args)  # the store's lock was freed with its last holder
    assert resumed.exit_code == 0, resumed.output
    assert f"{len(kept)} reused" in resumed.output
    rows = read_csv(out)
    assert len(rows) == SEEDS * ROBOTS
    assert sorted({int(r["seed"]) for r in rows}) == list(range(SEEDS))
