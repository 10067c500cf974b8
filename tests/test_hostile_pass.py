"""Hostile cases on this turn's additions (issue 26's own pass) that found something: a landmark
list is counted before its entries are checked, and landmarks at one place are refused."""

from __future__ import annotations

from collections.abc import Iterator

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
