"""Hostile cases on this turn's additions (issue 26's own pass) that found something: a landmark
list is counted before its entries are checked, landmarks at one place are refused, and the
learned localizer's weights file is size-checked and read only for the arrays it uses."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

import anonloc_env


def test_a_huge_landmark_list_is_refused_after_reading_50_entries() -> None:
    pulled = 0

    def landmarks() -> Iterator[tuple[float, float]]:
        nonlocal pulled
        while True:  # a million, or never ending
            pulled += 1
            yield (1.0, 1.0)

    with pytest.raises(ValueError, match=r"camera.landmarks must hold at most 49 positions"):
        anonloc_env.make_config(camera={"landmarks": landmarks()})
    assert pulled <= 50


@pytest.mark.parametrize(
    "points", [[[1, 1]] * 4, [[1.0, 1.0], [1.1, 1.0], [3.0, 3.0]]], ids=["same", "overlapping"]
)
def test_landmarks_closer_than_a_marker_are_refused(points: list[list[float]]) -> None:
    # four landmarks at one place made bayes decide 3 of 11 robots wrongly on drone-windy
    with pytest.raises(ValueError, match=r"camera.landmarks\[1\] .* is within robot.size = 0.2 m"):
        anonloc_env.make_config("drone-windy", camera={"landmarks": points})


def test_landmarks_a_marker_apart_are_accepted() -> None:
    points = ((1.0, 1.0), (1.25, 1.0), (3.0, 3.0))
    config = anonloc_env.make_config("drone-windy", camera={"landmarks": points})
    assert config.camera.landmarks == points


# -- the learned localizer's weights -------------------------------------------------------


def _weights(tmp_path: Path, **changes: np.ndarray) -> Path:
    from baselines.mlp import WEIGHTS

    arrays = {**dict(np.load(WEIGHTS, allow_pickle=False)), **changes}
    path = tmp_path / "w.npz"
    np.savez_compressed(path, **arrays)
    return path


def test_mlp_weights_declaring_a_huge_array_are_refused_before_reading_it(tmp_path: Path) -> None:
    from baselines.mlp import load_weights

    path = _weights(tmp_path, W0=np.zeros(9_000_000))  # 72 MB of zeros in a small file
    assert path.stat().st_size < 1 << 20
    with pytest.raises(ValueError, match=r"array W0.npy declares 72000128 bytes, more than"):
        load_weights(path)


def test_mlp_weights_never_read_a_member_they_do_not_use(tmp_path: Path) -> None:
    from baselines.mlp import load_weights

    # an object array cannot even be read without unpickling; an extra member is left unread
    path = _weights(tmp_path, extra=np.array([{"a": 1}], dtype=object))
    assert load_weights(path).absent == load_weights().absent


def test_mlp_weights_with_a_non_scalar_absent_score_name_the_file(tmp_path: Path) -> None:
    from baselines.mlp import load_weights

    path = _weights(tmp_path, absent=np.array([1.0, 2.0]))
    with pytest.raises(ValueError, match=r"w.npz is not an MLP .* 'absent' score has shape"):
        load_weights(path)


def test_a_misspelt_sweep_gets_a_suggestion(tmp_path: Path) -> None:
    pytest.importorskip("typer", reason="the command line needs the cli extra")
    from tests.cli_helpers import run_script

    done = run_script("study", "--sweep", "densty", "--seeds", "1", "--out", tmp_path / "s")
    assert done.returncode == 2
    assert "unknown sweep 'densty' (did you mean 'density'?)" in done.stderr


@pytest.mark.parametrize("field", ["timesteps", "batch_size", "checkpoint_every"])
def test_train_step_counts_are_bounded(field: str) -> None:
    pytest.importorskip("stable_baselines3")
    from agents.train import TrainConfig

    # --timesteps 10**30 once started a run that would never end
    with pytest.raises(ValueError, match=rf"{field} must be in \[\d, 1e\+10\], got 10+$"):
        TrainConfig(**{field: 10**30})


def test_a_benchmarl_task_name_in_the_wrong_case_is_refused() -> None:
    benchmarl = pytest.importorskip("agents.benchmarl")
    with pytest.raises(ValueError, match=r"unknown task 'belief'; valid: \['RAW', 'BELIEF'\]"):
        benchmarl.settings("belief", {"condition": "swarm"})
    assert benchmarl.settings("BELIEF", {"condition": "swarm"}).condition == "swarm"
