"""agents.localizer_training: the labels line up with what the MLP reads, the fit learns, and the
documented command writes weights the localizer loads."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from agents.localizer_training import Condition, accuracy, collect, crowd, fit, zero_weights
from baselines.mlp import FEATURES, NEIGHBOUR_FEATURES, load_weights
from tests.helpers import ROOT

#: Columns of the best-fitting previous row's residuals (ring, along, across, turn).
_RESIDUALS = [FEATURES.index(f"{name}_0") for name in NEIGHBOUR_FEATURES[1:5]]


def test_labels_are_the_rows_that_fit_the_own_motion() -> None:
    # Ten robots with headings and 1 px of noise: the labelled (true) row's best previous row
    # misses the robot's own motion by less than 5 tolerances in nearly every sample, the other
    # rows' in few (robots standing still look alike: a single pair cannot always tell).
    condition = Condition("c", crowd(10, True), "random", 2, 6, 10)
    samples = collect(condition, zero_weights(), 0)
    assert len(samples) == 2 * 5 * 10  # episodes x picture pairs x robots
    near = math.log1p(5.0)  # the features are sign(x) log(1 + |x|)
    true_fits, other_fits = [], []
    for x, label in samples:
        fits = np.abs(x[:, _RESIDUALS]).max(axis=1) < near
        if label < len(x):
            true_fits.append(fits[label])
            other_fits += [f for j, f in enumerate(fits) if j != label]
    assert np.mean(true_fits) > 0.95
    assert np.mean(other_fits) < 0.5


def test_fit_learns_a_separable_rule() -> None:
    pytest.importorskip("torch", reason="training needs torch (the rl extra)")
    rng = np.random.default_rng(0)
    column = FEATURES.index("along_0")
    samples = []
    for _ in range(600):
        m = int(rng.integers(3, 12))
        x = rng.normal(size=(m, len(FEATURES)))
        x[:, column] = rng.uniform(1.0, 3.0, size=m)
        label = int(rng.integers(0, m + 1))  # m: not in the picture, every row far off
        if label < m:
            x[label, column] = rng.uniform(0.0, 0.3)
        samples.append((x.astype(np.float32), label))
    before, _ = accuracy(zero_weights(), samples)
    weights = fit(samples[:500], epochs=40, seed=0)
    after, _ = accuracy(weights, samples[500:])
    assert before < 0.2
    assert after > 0.8


@pytest.mark.slow
def test_the_documented_command_writes_weights_the_localizer_loads(tmp_path: Path) -> None:
    pytest.importorskip("torch", reason="training needs torch (the rl extra)")
    out = tmp_path / "mlp.npz"
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "agents.localizer_training",
            "--out",
            str(out),
            "--scale",
            "0.02",
            "--rounds",
            "1",
            "--epochs",
            "1",
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert "round 1" in done.stdout
    assert load_weights(out).layers[0][0].shape[0] == len(FEATURES)
