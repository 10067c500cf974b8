"""The uniform weight's candidates dropped before they are scored (their bound below their
robot's floor) are those the identifier would have pruned anyway: same tracks to the bit. The
compiled first step without headings (``identify.first_step``) gives the general path's tracks
to the bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

import anonloc_env
import baselines
from anonloc_env import compiled
from anonloc_env.identify import Identifier, SensorModel, first_step, likelihood
from anonloc_env.identify import children as children_module
from anonloc_env.identify.model import ring_loglik, ring_loglik_bound
from anonloc_env.identify.tracks import FIELDS
from anonloc_env.rewards import EnergyCost


def test_ring_bound_is_above_the_ring_likelihood_and_close_for_long_rings() -> None:
    rho = np.geomspace(1e-3, 1e3, 61)
    r = np.linspace(0.0, 1.2e3, 241)
    var = np.geomspace(1e-2, 1e2, 9)
    rr, pp, vv = (a.ravel() for a in np.meshgrid(r, rho, var, indexing="ij"))
    exact, bound = ring_loglik(rr, pp, vv), ring_loglik_bound(rr, pp, vv)
    assert np.all(bound >= exact)
    long_ring = rr * pp / vv > 100.0
    assert long_ring.sum() > 1000
    assert np.all(bound[long_ring] - exact[long_ring] < 0.2)


def _snapshots(preset: str, n: int, pictures: int) -> tuple[list[dict[str, np.ndarray]], int]:
    """The identifier's tracks after each of a ``bayes`` team's first ``pictures`` pictures
    (N robots at 1 per m^2, no headings, ``distinct`` motion), and how many candidates the
    general path scored."""
    side = math.sqrt(n)
    camera = {"pixel_noise": 1.0, "orientation": False}
    config = anonloc_env.make_config(
        preset, n_robots=n, arena_size=(side, side), camera=camera, max_cycles=4000
    )
    env = anonloc_env.AnonLocEnv(config, reward_fn=EnergyCost())
    team = baselines.make_team("bayes", env, excitation="distinct")
    identifier = team.localizer.identifier
    update, steps = identifier.update, []

    def snapshot(*args, **kwargs):  # type: ignore[no-untyped-def]  # a spy
        update(*args, **kwargs)
        steps.append({f: np.array(getattr(identifier.tracks, f)) for f in FIELDS})
        steps[-1]["unanchored"] = identifier.unanchored.copy()

    identifier.update = snapshot
    scored = [0]
    general = likelihood.children

    def counted(parent, *args, **kwargs):  # type: ignore[no-untyped-def]  # a spy
        scored[0] += len(parent)
        return general(parent, *args, **kwargs)

    children_module.children = counted
    try:
        observations, _ = env.reset(seed=3)
        team.reset(np.random.SeedSequence(3).spawn(n))
        agents = env.possible_agents
        while len(steps) < pictures and env.agents:
            actions = team.act([observations[a] for a in agents])
            observations, *_ = env.step(dict(zip(agents, actions, strict=True)))
    finally:
        children_module.children = general
    return steps, scored[0]


def _general_first_step(monkeypatch: pytest.MonkeyPatch) -> None:
    """The uniform weight's children by the general path (``likelihood.children``)."""
    monkeypatch.setattr(first_step, "applies", lambda fast, scoring: False)


@pytest.mark.parametrize("preset", ["drone-hover", "drone-windy", "default"])
def test_dropping_candidates_below_the_floor_changes_no_track(
    preset: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    _general_first_step(monkeypatch)
    with_bound, fewer = _snapshots(preset, 64, 6)
    monkeypatch.setattr(children_module, "BOUND_SLACK", math.inf)  # nothing dropped
    without, every = _snapshots(preset, 64, 6)
    assert len(with_bound) == len(without) == 6
    for a, b in zip(with_bound, without, strict=True):
        for name in a:
            np.testing.assert_array_equal(a[name], b[name], err_msg=name)
    if preset != "default":  # the robots' chance to come back at the edges keeps many
        assert fewer < 0.8 * every


@pytest.mark.parametrize("general", [False, True])
@pytest.mark.parametrize("preset", ["drone-hover", "default"])
def test_uniform_children_below_the_floor_are_not_built_and_change_no_track(
    preset: str, general: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The uniform weight's children below their robot's floor (scored, but more than
    ``PRUNE_NATS`` below its best other child) are left out, by the compiled first step and
    the general path alike: they would be pruned anyway. With every floor at -inf (nothing
    left out before the prune) every track after every picture is the same, to the bit."""
    if general:
        _general_first_step(monkeypatch)
    built: list[int] = []
    from_uniform = children_module.Builder.from_uniform

    def counted(self, *args, **kwargs):  # type: ignore[no-untyped-def]  # a spy
        out = from_uniform(self, *args, **kwargs)
        built.append(sum(len(part) for part in out))
        return out

    monkeypatch.setattr(children_module.Builder, "from_uniform", counted)
    floored, _ = _snapshots(preset, 64, 6)
    fewer = sum(built)
    built.clear()
    monkeypatch.setattr(Identifier, "_prune_floor", lambda self, parts: np.full(self.n, -np.inf))
    every, _ = _snapshots(preset, 64, 6)
    assert len(floored) == len(every) == 6
    for a, b in zip(floored, every, strict=True):
        for name in a:
            np.testing.assert_array_equal(a[name], b[name], err_msg=name)
    assert fewer < sum(built)


@pytest.mark.parametrize("preset", ["drone-hover", "drone-windy", "default"])
def test_compiled_first_step_gives_the_general_paths_tracks(
    preset: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """With the kernels on, robots of unknown position are anchored by
    ``first_step.ring_leg`` (the bound, the ring and the prune compiled): every track after
    every picture is the general path's, to the bit, the camera moving or not."""
    pytest.importorskip("numba")
    if compiled.mode() is None:
        pytest.skip("kernels off (ANONLOC_JIT=0 or an unknown numpy)")
    calls = [0]
    ring_leg = first_step.ring_leg

    def counted(*args, **kwargs):  # type: ignore[no-untyped-def]  # a spy
        calls[0] += 1
        return ring_leg(*args, **kwargs)

    monkeypatch.setattr(first_step, "ring_leg", counted)
    fast, _ = _snapshots(preset, 64, 6)
    assert calls[0] >= 5  # every picture after the first
    _general_first_step(monkeypatch)
    general, _ = _snapshots(preset, 64, 6)
    assert len(fast) == len(general) == 6
    for a, b in zip(fast, general, strict=True):
        for name in a:
            np.testing.assert_array_equal(a[name], b[name], err_msg=name)


def test_building_an_identifier_loads_the_first_step_passes() -> None:
    """An identifier built with the kernels on has compiled (or loaded from numba's cache) the
    first step's passes for the types ``ring_leg`` gives them: a drone episode's pictures then
    add no signature, so nothing compiles at its first picture without headings."""
    pytest.importorskip("numba")
    if compiled.mode() is None:
        pytest.skip("kernels off (ANONLOC_JIT=0 or an unknown numpy)")
    config = anonloc_env.make_config("drone-hover", n_robots=9, camera={"orientation": False})
    Identifier(SensorModel.from_config(config), config.n_robots)
    names = ("_gated", "_ringed", "_i0_terms", "_pruned")
    loaded = {name: list(getattr(first_step, name).signatures) for name in names}
    assert all(len(signatures) == 1 for signatures in loaded.values())
    _snapshots("drone-hover", 16, 3)
    assert {name: list(getattr(first_step, name).signatures) for name in names} == loaded
