"""The ``uniform`` excitation: chance among the learned agent's candidates."""

from __future__ import annotations

import math

import numpy as np
import pytest

import anonloc_env
import baselines
from baselines.active import GreedySettings
from baselines.excitations import SwarmDuty
from baselines.excitations.uniform import UniformChoice
from baselines.registry import EXCITATIONS, make_excitation
from baselines.runner import run_episode
from tests.helpers import RecordedUniform


def _config(n: int = 8) -> anonloc_env.EnvConfig:
    side = math.sqrt(n)
    return anonloc_env.make_config(
        n_robots=n, arena_size=(side, side), camera={"pixel_noise": 1.0}, max_cycles=200
    )


def _run(excitation: object, seed: int, n: int = 8, pictures: int = 8) -> list[tuple]:
    env = anonloc_env.AnonLocEnv(_config(n), reward_fn=anonloc_env.EnergyCost())
    team = baselines.make_team("bayes", env, excitation=excitation)  # type: ignore[arg-type]
    return run_episode(env, team, seed, max_pictures=pictures).rows()


def test_registered_by_name() -> None:
    assert isinstance(EXCITATIONS["uniform"](), UniformChoice)
    assert isinstance(make_excitation("uniform"), UniformChoice)


def test_same_seed_same_episode_bit_for_bit() -> None:
    assert _run(UniformChoice(), seed=3) == _run(UniformChoice(), seed=3)
    assert _run(UniformChoice(), seed=3) != _run(UniformChoice(), seed=4)
    duty = [SwarmDuty(UniformChoice(), 0.2, common_seed=9) for _ in range(2)]
    assert _run(duty[0], seed=9) == _run(duty[1], seed=9)


@pytest.mark.parametrize("swarm", [False, True])
def test_commands_stay_in_the_candidate_box(swarm: bool) -> None:
    """Free: every command the robot drives on its own is in the agent's box ``v`` in
    [0.1, 0.5] m/s, ``w`` in [-1, 1] rad/s; on duty the deviation has ``v`` in [-0.5, 0.5]. A
    robot backing out of a bump reverses at the back-off speed, or the escape's when pressed
    (and turns within the box)."""
    box = GreedySettings()
    own = RecordedUniform()
    _run(SwarmDuty(own, 0.2, common_seed=2) if swarm else own, seed=2, n=12, pictures=10)
    v, w = (np.concatenate(x) for x in zip(*own.given, strict=True))
    assert box.escape is not None
    # A drawn candidate is never exactly one of the reverse speeds.
    driving = (v != -box.back.back_speed) & (v != -box.escape.back_speed)
    low = -box.speed[1] if swarm else box.speed[0]
    assert driving.mean() > 0.5
    assert np.all((v[driving] >= low) & (v[driving] <= box.speed[1]))
    assert np.all(np.abs(w) <= box.turn)
    # Spread over the box, not one corner: the picks are uniform.
    drawn = v[driving]
    assert drawn.min() < low + 0.1
    assert drawn.max() > box.speed[1] - 0.1
    assert own.following is swarm
