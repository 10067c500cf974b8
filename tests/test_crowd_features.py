"""agents.crowd_features: the contact risk of candidates and the free space around the believed
self, on pictures built by hand."""

from __future__ import annotations

import numpy as np

import anonloc_env
from agents.crowd_features import believed_heading, contact_risk, free_space
from anonloc_env.identify import Identifier, SensorModel

SIZE = 20.0  # a robot's size in image units (0.2 m at 100 units per m)
VIEW = (0.0, 0.0, 1000.0, 1000.0)


def test_free_space_and_crowding_follow_the_neighbours() -> None:
    rows = np.array([[500.0, 500.0, 0.0], [530.0, 500.0, 0.0], [900.0, 900.0, 0.0]])
    belief = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]])
    free, crowd = free_space(belief, rows, SIZE)
    assert free[0] == np.float64(1.5 / 3.0)  # the nearest row 1.5 sizes away
    assert crowd[0] == SIZE / 30.0
    assert free[1] == 1.0  # alone
    assert crowd[1] == 0.0
    assert free[2] == 1.0  # no belief: unknown counts as free
    assert crowd[2] == 0.0


def test_a_candidate_driving_into_a_neighbour_is_riskier_than_one_driving_away() -> None:
    rows = np.array([[500.0, 500.0, 0.0], [530.0, 500.0, 0.0]])
    belief = np.array([[1.0, 0.0]])
    commands = np.array([[[0.3, 0.0], [-0.3, 0.0]]])  # toward the neighbour (+u), away
    risk = contact_risk(belief, rows, np.array([0.0]), commands, 1.0, 100.0, SIZE, VIEW)
    assert risk[0, 0] == 0.8  # 4 of 5 points within a size of it
    assert risk[0, 1] == 0.0
    unsure = contact_risk(0.5 * belief, rows, np.array([0.0]), commands, 1.0, 100.0, SIZE, VIEW)
    assert unsure[0, 1] == 0.25  # half the weight on "unknown" (0.5)
    unknown = contact_risk(belief, rows, np.array([np.nan]), commands, 1.0, 100.0, SIZE, VIEW)
    assert 0.0 < unknown[0, 0] < risk[0, 0]  # averaged over headings


def test_walls_count_as_contacts() -> None:
    rows = np.array([[10.0, 500.0, 0.0]])
    risk = contact_risk(
        np.ones((1, 1)), rows, np.array([np.pi]), np.array([[[0.3, 0.0]]]), 1.0, 100.0, SIZE, VIEW
    )
    assert risk[0, 0] == 1.0


def test_believed_heading_is_the_heaviest_tracks() -> None:
    config = anonloc_env.make_config(n_robots=2, camera={"orientation": True})
    identifier = Identifier(SensorModel.from_config(config), 2)
    assert np.isnan(believed_heading(identifier)).all()
    identifier.update(np.array([[100.0, 100.0, 0.3], [300.0, 300.0, -1.0]]))
    assert np.isnan(believed_heading(identifier)).all()  # no track before a second picture
