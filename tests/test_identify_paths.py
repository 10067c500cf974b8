"""The identifier's fast kernels against the general path they stand for (``fast=False``).

The fast kernels (:mod:`anonloc_env.identify.kernels`) compute what the general path computes,
reordered: the anchored tracks' heading-only Kalman step is the same arithmetic, so with no
detected heading the two paths give bit-identical beliefs; the first leg with a detected heading
works in the robot's frame (the pair turned once), so its beliefs differ by rounding alone. The
tolerance :data:`ROUNDING` is far below any belief that matters and far above what was measured
(2.2e-14 at most on the recorded episodes of N = 30 to 1000 robots).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import replace
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_identify_reference import _model, simulate

import anonloc_env
from anonloc_env.config import EnvConfig
from anonloc_env.identify import Identifier, Interval, SensorModel, fused_calls, kernels
from anonloc_env.rewards import StepContext

#: Largest difference allowed between the fast and the general path's beliefs where they are not
#: bit-identical (the first leg with a detected heading: rounding of a rotation).
ROUNDING = 1e-12

Episode = list[tuple[np.ndarray, Interval | None]]


class _Recorder:
    """A reward function that keeps every picture's rows and interval (and rewards nothing)."""

    def reset(self, config: EnvConfig, rng: np.random.Generator, picture: Any = None) -> None:
        self.log: Episode = [] if picture is None else [(picture.detections, None)]

    def __call__(self, context: StepContext) -> np.ndarray:
        if context.picture is not None:
            self.log.append((context.picture.detections, context.interval))
        return np.zeros(context.config.n_robots)


def _record(seed: int, pictures: int, **overrides: Any) -> tuple[EnvConfig, Episode]:
    """``pictures`` pictures of an env episode under seeded random commands."""
    recorder = _Recorder()
    env = anonloc_env.parallel_env(reward_fn=recorder, max_cycles=10**6, **overrides)
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    while len(recorder.log) < pictures:
        env.step({a: rng.uniform(-1, 1, 2).astype(np.float32) for a in env.agents})
    return env.config, recorder.log[:pictures]


def _beliefs(model: SensorModel, n: int, episode: Episode, fast: bool) -> list[np.ndarray]:
    """``[belief | missing]`` after every picture of ``episode``."""
    ident = Identifier(model, n, fast=fast)
    out = []
    for rows, interval in episode:
        ident.update(rows, interval)
        out.append(np.column_stack([ident.belief(), ident.missing()]))
    return out


@contextmanager
def _calls(name: str, module: Any = kernels) -> Iterator[list[int]]:
    """Count the candidates kernel ``name`` (of ``module``) scores while the block runs."""
    seen: list[int] = []
    kernel: Callable[..., Any] = getattr(module, name)

    def spy(*args: Any, **kwargs: Any) -> Any:
        out = kernel(*args, **kwargs)
        seen.append(len(out))
        return out

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(module, name, spy)
        yield seen


def _agree(fast: list[np.ndarray], general: list[np.ndarray], exact: bool) -> None:
    assert len(fast) == len(general)
    for k, (a, b) in enumerate(zip(fast, general, strict=True)):
        if exact:
            np.testing.assert_array_equal(a, b, err_msg=f"picture {k}")
        else:
            np.testing.assert_allclose(a, b, rtol=0.0, atol=ROUNDING, err_msg=f"picture {k}")


CAMERA = {"p_miss": 0.1, "false_positives": 2.0, "pixel_noise": 1.0}
RECORDED = {
    # name: (env overrides, scale known, whether the first leg runs)
    "headings": ({"n_robots": 60, "camera": CAMERA}, True, True),
    "headings-dense": ({"n_robots": 30, "arena_size": (3.0, 3.0), "camera": CAMERA}, True, True),
    "no-headings": ({"n_robots": 60, "camera": {**CAMERA, "orientation": False}}, True, False),
    "scale-unknown": ({"n_robots": 60, "camera": CAMERA}, False, False),
}


@pytest.mark.parametrize("name", list(RECORDED))
def test_fast_and_general_paths_agree_on_recorded_episodes(name: str) -> None:
    """Env episodes with misses, false positives and contacts: bit-identical beliefs where the
    first leg does not run, within :data:`ROUNDING` where it does; each kernel scored
    candidates (the comparison is not empty)."""
    overrides, scale_known, first_leg = RECORDED[name]
    config, episode = _record(3, 15, **overrides)
    model = SensorModel.from_config(config, scale_known=scale_known)
    with (
        _calls("first_leg") as first,
        _calls("known_children") as known,
        _calls("known_compiled", fused_calls) as known_compiled,  # test_identify_fused: same bits
    ):
        fast = _beliefs(model, config.n_robots, episode, fast=True)
    with _calls("first_leg") as first_general, _calls("known_children") as known_general:
        general = _beliefs(model, config.n_robots, episode, fast=False)
    assert first_general == []
    assert known_general == []
    assert sum(known) + sum(known_compiled) > 0
    assert (sum(first) > 0) == first_leg
    _agree(fast, general, exact=not first_leg)


def drawn(
    robots: int,
    orientation: bool,
    p_detect: float,
    false_positives: float,
    others: bool,
    pushed: bool,
    seed: int,
) -> tuple[SensorModel, int, Episode]:
    """A model, its number of robots and a 5-picture episode drawn from it (unseen pushes on
    half the robots where ``pushed``)."""
    model = _model(
        orientation=orientation,
        orientation_noise=0.05 if orientation else 0.0,
        p_detect=p_detect,
        n_robots=robots if others else None,
        false_positives=false_positives,
        others_sigma=0.4 if others else None,
        odometry_noise=0.05,
    )
    rows, intervals, _ = simulate(model, robots, 5, false_positives, seed)
    rng = np.random.default_rng(seed)
    if pushed:
        intervals = [
            replace(
                i,
                push=np.where(rng.random(robots) < 0.5, rng.uniform(0.0, 0.1, robots), 0.0),
                push_sum=np.zeros((robots, 2)),
            )
            for i in intervals
        ]
    episode: Episode = [(rows[0], None), *zip(rows[1:], intervals, strict=True)]
    return model, robots, episode


#: Episodes drawn from the model by :func:`drawn`: ``(model, robots, episode)``.
DRAWN = st.builds(
    drawn,
    robots=st.integers(1, 6),
    orientation=st.booleans(),
    p_detect=st.sampled_from([0.8, 1.0]),
    false_positives=st.sampled_from([0.0, 1.5]),
    others=st.booleans(),
    pushed=st.booleans(),
    seed=st.integers(0, 2**16),
)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(case=DRAWN)
def test_fast_and_general_paths_agree_on_fuzzed_episodes(
    case: tuple[SensorModel, int, Episode],
) -> None:
    """Episodes drawn from the model (headings detected or not, misses, clutter, the others
    persisting or not, unseen pushes): the same agreement as on the recorded ones."""
    model, robots, episode = case
    orientation = model.orientation
    fast = _beliefs(model, robots, episode, fast=True)
    general = _beliefs(model, robots, episode, fast=False)
    _agree(fast, general, exact=not orientation)
