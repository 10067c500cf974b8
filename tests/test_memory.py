"""``anonloc_env.memory.keep_freed_memory``: arrays of a few hundred KiB reuse the process's
memory instead of faulting in fresh pages at every call (glibc only)."""

from __future__ import annotations

import os
import platform
import subprocess
import sys

import pytest

PROBE = """
import resource, sys
import numpy as np
from anonloc_env.memory import keep_freed_memory
kept = keep_freed_memory()
x = np.random.default_rng(0).random(86_400)  # 675 KiB, like the scoring's largest arrays
np.exp(-x)
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(50):
    np.exp(-x)
print(kept, (resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before) / 50)
"""


def _probe(**env: str) -> tuple[bool, float]:
    out = subprocess.run(
        [sys.executable, "-c", PROBE],
        env={**os.environ, **env},
        capture_output=True,
        text=True,
        check=True,
    )
    kept, faults = out.stdout.split()
    return kept == "True", float(faults)


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="glibc's malloc only")
def test_freed_arrays_are_reused_without_page_faults() -> None:
    kept, faults = _probe()
    assert kept
    assert faults < 10  # each call's two arrays of 169 pages each come from the heap


def test_the_environment_variable_turns_it_off() -> None:
    kept, _ = _probe(ANONLOC_MALLOC="0")
    assert not kept
