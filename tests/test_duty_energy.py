"""``benchmarks/duty_energy.py``: how much of ``uniform``'s energy on swarm duty the duty leaves."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.duty_energy import DutyShare, LeastTravel, duty_share


@pytest.fixture(scope="module")
def swarm_ten() -> DutyShare:
    """Swarm N=10 on four seeds (played once for the tests below)."""
    return duty_share("swarm N=10", 4, 920_000, 0.8)


def test_least_travel_opposes_the_shared_command_within_the_limits() -> None:
    """The deviation brings ``shared + budget * own`` to zero where the budget allows, and as
    close as the limits allow elsewhere."""
    least = LeastTravel(v_max=0.5, omega_max=1.0)
    least.reset([np.random.default_rng(k) for k in range(3)])
    least.follow(np.array([0.05, 0.3, -0.4]), np.array([0.1, -0.9, 0.0]), 0.2)
    v, w = least.commands(None, 0.05)  # type: ignore[arg-type]  # reads nothing of the step
    np.testing.assert_allclose(0.05 + 0.2 * v[0], 0.0, atol=1e-12)
    np.testing.assert_allclose(v, [-0.25, -0.5, 0.5])
    np.testing.assert_allclose(w, [-0.5, 1.0, 0.0])


def test_the_least_travel_on_duty_spends_well_under_uniforms_energy(swarm_ten: DutyShare) -> None:
    """Swarm N=10, four seeds. Measured on 30 episodes (``docs/agents.md``): the least travel
    spends 0.63 of ``uniform``'s energy to 99 % by ``uniform``'s picture (0.65 on these four),
    and stays within 0.8 of it until 1.33x those pictures. The test asks for a share below 0.8
    and a last picture past ``uniform``'s: on duty the energy clause of issue 24's first target
    is not out of reach by the duty's own travel."""
    found = swarm_ten
    assert 0.3 < found.least < 0.8, found
    assert found.last > found.pictures, found


def test_the_duty_alone_spends_more_than_the_energy_clause_allows(swarm_ten: DutyShare) -> None:
    """The same four seeds: following the shared command with no deviation (identifying
    nobody) spends 0.88 of ``uniform``'s energy to 99 % by ``uniform``'s picture (0.92 on 48
    selection episodes, ``docs/agents.md``), above the clause's 0.8: a team that keeps up with
    its duty cannot meet it."""
    found = swarm_ten
    assert 0.8 < found.follow < 1.0, found
