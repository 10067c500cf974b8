"""baselines.limit: the information bound and the union estimate of pictures to 99 %."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import pytest
from scipy import integrate, stats

import anonloc_env
from baselines.limit import (
    displacement_capacity,
    interval_capacity,
    nats_needed,
    picture_limit,
)
from benchmarks.excitations import scenario

H_1PC = -0.99 * math.log(0.99) - 0.01 * math.log(0.01)  # binary entropy of 1 %, nats


def _with_camera(config: anonloc_env.EnvConfig, **changes: Any) -> anonloc_env.EnvConfig:
    return dataclasses.replace(config, camera=dataclasses.replace(config.camera, **changes))


def test_nats_needed_by_hand() -> None:
    assert nats_needed(1) == 0.0
    # Two robots, both must be identified: ln 2! less two robots' doubt h(0.01), per robot.
    assert nats_needed(2) == pytest.approx((math.log(2.0) - 2 * H_1PC) / 2, rel=1e-12)
    # A hundred: 99 identified (doubt h + 0.01 ln 99 each), one left open (ln 100).
    doubt = 99 * (H_1PC + 0.01 * math.log(99)) + math.log(100)
    assert nats_needed(100) == pytest.approx((math.lgamma(101) - doubt) / 100, rel=1e-12)


def _uniform_interval_information(width: float, noise: float) -> float:
    """Mutual information (nats) of a uniform input on [0, width] plus Gaussian noise."""

    def density(y: float) -> float:
        mass = stats.norm.cdf(y / noise) - stats.norm.cdf((y - width) / noise)
        return float(mass) / width

    h_out = integrate.quad(
        lambda y: -density(y) * math.log(max(density(y), 1e-300)),
        -10 * noise,
        width + 10 * noise,
        limit=200,
    )[0]
    return h_out - 0.5 * math.log(2 * math.pi * math.e * noise**2)


def _uniform_disc_information(radius: float, noise: float) -> float:
    """Mutual information (nats) of a uniform input on the disc plus 2-D Gaussian noise."""

    def density(r: float) -> float:
        inside = stats.ncx2.cdf(radius**2 / noise**2, 2, r**2 / noise**2)
        return float(inside) / (math.pi * radius**2)

    h_out = integrate.quad(
        lambda r: -density(r) * math.log(max(density(r), 1e-300)) * 2 * math.pi * r,
        0.0,
        radius + 10 * noise,
        limit=200,
    )[0]
    return h_out - math.log(2 * math.pi * math.e * noise**2)


@pytest.mark.parametrize(("width", "noise"), [(1.0, 1.0), (5.0, 1.0), (50.0, 1.0), (50.0, 10.0)])
def test_uniform_length_never_beats_the_interval_bound(width: float, noise: float) -> None:
    # A uniform input's information is achievable: the capacity bound must lie above it.
    achieved = _uniform_interval_information(width, noise)
    assert achieved <= interval_capacity(width, noise) <= achieved + 0.75


@pytest.mark.parametrize(("radius", "noise"), [(2.0, 1.0), (50.0, 1.0), (15.0, 3.0)])
def test_uniform_disc_never_beats_the_displacement_bound(radius: float, noise: float) -> None:
    achieved = _uniform_disc_information(radius, noise)
    bound = displacement_capacity(radius, noise, innovation=False)
    assert achieved <= bound <= achieved + 0.75


def test_capacity_bounds_reach_the_high_snr_limits() -> None:
    # Flat over the range in noise units: ln(W / (sigma sqrt(2 pi e))), ln(R^2 / (2 e sigma^2)).
    one = math.log(1e4 / math.sqrt(2 * math.pi * math.e))
    assert one < interval_capacity(1e4, 1.0) < one + 0.01
    two = math.log(1e3**2 / (2 * math.e))
    assert two < displacement_capacity(1e3, 1.0, innovation=False) < two + 0.05
    assert displacement_capacity(0.0, 1.0) == 0.0
    assert interval_capacity(0.0, 1.0) == 0.0
    assert math.isinf(displacement_capacity(1.0, 0.0))
    # A relative (odometry) error only lowers what a picture carries.
    assert displacement_capacity(50.0, 1.0, radial=0.1) < displacement_capacity(50.0, 1.0)
    assert interval_capacity(50.0, 1.0, relative=0.1) < interval_capacity(50.0, 1.0)


def test_two_robots_without_noise_need_one_motion() -> None:
    config = _with_camera(scenario(2, 10), pixel_noise=0.0)
    limit = picture_limit(config)
    assert limit.information == 1.0
    assert limit.union == 1.0
    assert math.isinf(limit.nats_per_picture)
    lone = picture_limit(_with_camera(scenario(1, 10), pixel_noise=1.0))
    assert lone.information == 0.0
    assert lone.union == 0.0


def test_information_bound_by_hand() -> None:
    limit = picture_limit(scenario(100, 10))
    first, later = limit.nats_first, limit.nats_per_picture
    assert limit.nats_needed > first  # the length of one motion does not tell 100 robots apart
    assert limit.information == pytest.approx(1.0 + (limit.nats_needed - first) / later)
    # Free motion: the first picture shows a length in [0, 0.5 m * 100 px/m] against 1 px.
    assert first == pytest.approx(interval_capacity(50.0, 1.0))
    assert later == pytest.approx(displacement_capacity(50.0, 1.0))


def test_more_robots_need_more_pictures() -> None:
    limits = [picture_limit(scenario(n, 10)) for n in (10, 100, 1000)]
    assert limits[0].information <= limits[1].information < limits[2].information
    assert limits[0].union < limits[1].union < limits[2].union


def test_more_noise_needs_more_pictures() -> None:
    base = scenario(100, 10)
    calm, noisy = picture_limit(base), picture_limit(_with_camera(base, pixel_noise=3.0))
    assert noisy.information > calm.information
    assert noisy.union > calm.union
    shaky = dataclasses.replace(base, robot=dataclasses.replace(base.robot, odometry_noise=0.3))
    wobbly = picture_limit(shaky)
    assert wobbly.information > calm.information
    assert wobbly.union > calm.union
    missed = picture_limit(_with_camera(base, p_miss=0.2))
    assert missed.information > calm.information
    assert missed.union > calm.union
    cluttered = picture_limit(_with_camera(base, false_positives=5.0))
    assert cluttered.information == calm.information  # the genie removes clutter
    assert cluttered.union > calm.union


def test_headings_need_fewer_pictures() -> None:
    base = scenario(100, 10)
    blind, seeing = picture_limit(base), picture_limit(_with_camera(base, orientation=True))
    assert seeing.information < blind.information
    assert seeing.union < blind.union
    assert seeing.nats_first > blind.nats_first


def test_swarm_duty_needs_more_pictures_than_free_motion() -> None:
    config = scenario(100, 10)
    free, swarm = picture_limit(config, "free"), picture_limit(config, "swarm", budget=0.2)
    assert swarm.information > free.information
    assert swarm.union > free.union
    wider = picture_limit(config, "swarm", budget=0.5)
    assert wider.union < swarm.union
    frozen = picture_limit(config, "swarm", budget=0.0)
    assert math.isinf(frozen.information)
    assert math.isinf(frozen.union)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"condition": "herd"}, "condition must be one of"),
        ({"budget": 1.5}, r"budget must be a number in \[0, 1\]"),
        ({"budget": -0.1}, r"budget must be a number in \[0, 1\]"),
        ({"fraction": 1.0}, r"fraction must be in \(0, 1\)"),
        ({"threshold": 0.0}, r"threshold must be in \(0, 1\)"),
    ],
)
def test_bad_input_is_refused(kwargs: dict[str, object], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        picture_limit(scenario(10, 10), **kwargs)  # type: ignore[arg-type]  # wrong on purpose


def test_bad_config_and_count_are_refused() -> None:
    with pytest.raises(TypeError, match="config must be an EnvConfig"):
        picture_limit({"n_robots": 10})  # type: ignore[arg-type]  # wrong on purpose
    with pytest.raises(ValueError, match="n must be an integer >= 1"):
        nats_needed(0)


def test_excitations_never_beat_the_information_bound() -> None:
    """Seeded: 10 episodes of 20 robots (one per m^2) behind a 3 px camera, where the bound
    exceeds one motion, for the two best hand-written excitations."""
    import baselines
    from baselines.runner import run_episode
    from baselines.scoring import summarize

    config = _with_camera(scenario(20, 20), pixel_noise=3.0)
    limit = picture_limit(config)
    assert limit.information > 1.0  # one motion is not enough for the pictures to tell
    env = anonloc_env.AnonLocEnv(config, reward_fn=anonloc_env.EnergyCost())
    for name in ("distinct", "greedy"):
        results = [
            run_episode(env, baselines.make_team("bayes", env, excitation=name), s, max_pictures=20)
            for s in range(10)
        ]
        summary = summarize(results)
        assert summary.identified >= 8, (name, summary)
        assert summary.pictures_all.low >= limit.information, (name, summary, limit)
