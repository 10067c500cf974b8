"""The RLlib snippet of docs/rllib.md, run as printed (one iteration instead of 20).

It crashed after training: ``save_to_path("runs/rllib")`` handed pyarrow a relative path
("URI has empty scheme") and the trained algorithm was lost.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.helpers import ROOT

DOC = ROOT / "docs" / "rllib.md"


def rllib_snippet() -> str:
    """The python block under "The same agent in RLlib"."""
    section = DOC.read_text().split("## The same agent in RLlib", 1)[1]
    found = re.search(r"```python\n(.*?)```", section, re.S)
    assert found is not None, "the RLlib section lost its snippet"
    return found.group(1)


def test_the_docs_rllib_snippet_runs_and_saves(tmp_path: Path) -> None:
    pytest.importorskip("ray.rllib", reason="needs ray[rllib] (the ray extra)")
    code = rllib_snippet()
    assert "iterations=20" in code
    assert 'checkpoint_dir="runs/rllib"' in code
    code = code.replace("iterations=20", "iterations=1")  # the only change: a short run
    done = subprocess.run(
        [sys.executable, "-c", code],
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        capture_output=True,
        text=True,
        timeout=400,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    saved = tmp_path / "runs" / "rllib"
    assert saved.is_dir(), "the trained algorithm was not saved"
    assert any(saved.iterdir()), "the trained algorithm was not saved"
    assert (saved / "agent.zip").is_file(), "export_agent wrote no agent"
