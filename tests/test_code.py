"""The centralized reference: each robot drives its own codeword of a designed code."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

import anonloc_env
import baselines
from baselines.active import unicycle
from baselines.excitations.code import CentralizedCode, alphabet, codewords
from baselines.runner import run_episode
from baselines.scoring import pictures_to_identify


def test_two_codewords_agree_at_fewer_pictures_than_their_digits() -> None:
    """Reed-Solomon: robots differ at every picture while N <= q, and at all but m - 1 of q
    pictures otherwise (m base-q digits)."""
    small = codewords(11, 11, 11)
    assert all(len(set(small[t])) == 11 for t in range(11))
    large = codewords(300, 11, 11)  # m = 3 digits
    agree = max(
        int((large[:, a] == large[:, b]).sum())
        for a, b in itertools.combinations(range(0, 300, 7), 2)
    )
    assert agree <= 2
    assert codewords(300, 11, 11).max() < 11


def test_the_alphabet_is_spread_and_in_the_box() -> None:
    letters = alphabet(11, (0.1, 0.5), 1.0, deviation=False, duration=1.0)
    assert letters.shape == (11, 2)
    assert np.all((letters[:, 0] >= 0.1) & (letters[:, 0] <= 0.5))
    assert np.all(np.abs(letters[:, 1]) <= 1.0)
    moved = unicycle(letters[:, 0], letters[:, 1], 1.0)
    gaps = [np.linalg.norm(moved[a] - moved[b]) for a, b in itertools.combinations(range(11), 2)]
    assert min(gaps) > 0.08  # metres apart over one interval: 8 px at 100 px/m
    swarm = alphabet(11, (0.1, 0.5), 1.0, deviation=True, duration=1.0)
    assert swarm[:, 0].min() < 0.0


def test_refuses_an_alphabet_that_is_not_prime() -> None:
    with pytest.raises(ValueError, match="prime"):
        CentralizedCode(symbols=12)


def test_a_team_with_identities_is_identified_quickly_and_reproducibly() -> None:
    n = 10
    side = math.sqrt(n)
    config = anonloc_env.make_config(
        n_robots=n, arena_size=(side, side), camera={"pixel_noise": 1.0}, max_cycles=300
    )
    env = anonloc_env.AnonLocEnv(config, reward_fn=anonloc_env.EnergyCost())

    def episode(seed: int) -> list[tuple]:
        team = baselines.make_team("bayes", env, excitation=CentralizedCode())
        return run_episode(env, team, seed, max_pictures=12).rows()

    assert episode(3) == episode(3)
    team = baselines.make_team("bayes", env, excitation=CentralizedCode())
    firsts = [pictures_to_identify(run_episode(env, team, s, max_pictures=12))[0] for s in range(4)]
    assert all(f is not None and f <= 6 for f in firsts)
