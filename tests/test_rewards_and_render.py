"""The default reward, pluggable rewards, and rendering."""

from __future__ import annotations

import numpy as np
import pytest

import anonloc_env
from anonloc_env.rewards import StepContext


def test_energy_cost_reward_is_the_documented_formula() -> None:
    env = anonloc_env.parallel_env(
        n_robots=2, dt=0.05, reward={"energy_weight": 2.0}, reward_fn=anonloc_env.EnergyCost()
    )
    env.reset(seed=0)
    _, rewards, *_ = env.step({"robot_0": [0.5, 0.0], "robot_1": [0.0, -1.0]})
    robot = env.config.robot
    turn_cost = robot.size / 2.0
    assert rewards["robot_0"] == pytest.approx(-2.0 * 0.05 * 0.5 * robot.v_max)
    assert rewards["robot_1"] == pytest.approx(-2.0 * 0.05 * turn_cost * robot.omega_max)


class PictureCounter:
    """A reward of 1 to every robot whenever a picture is taken."""

    def __init__(self) -> None:
        self.resets = 0

    def reset(self, config: anonloc_env.EnvConfig, rng: np.random.Generator, picture=None) -> None:
        self.resets += 1

    def __call__(self, context: StepContext) -> np.ndarray:
        return np.full(context.config.n_robots, float(context.picture is not None))


def test_pluggable_reward_sees_pictures() -> None:
    reward = PictureCounter()
    env = anonloc_env.parallel_env(n_robots=2, dt=0.1, picture_interval=0.2, reward_fn=reward)
    env.reset(seed=0)
    got = [env.step({"robot_0": [0, 0], "robot_1": [0, 0]})[1]["robot_0"] for _ in range(4)]
    assert got == [0.0, 1.0, 0.0, 1.0]
    assert reward.resets == 1


def test_reward_without_the_interface_is_refused() -> None:
    with pytest.raises(TypeError, match="reward_fn must have"):
        anonloc_env.parallel_env(reward_fn=lambda context: 0.0)


def test_rgb_array_frame_shows_the_arena_and_robots() -> None:
    pytest.importorskip("pygame")
    env = anonloc_env.parallel_env(n_robots=3, render_mode="rgb_array")
    env.reset(seed=0)
    env.guesses = {"robot_0": int(env.picture.true_index[0]), "robot_1": 0}
    frame = env.render()
    assert frame.dtype == np.uint8
    assert frame.ndim == 3
    assert frame.shape[2] == 3
    colours = {tuple(c) for c in frame.reshape(-1, 3)[::7]}
    assert len(colours) > 5  # background, walls, robots, detections, guesses
    env.close()


def test_bad_render_mode_is_refused() -> None:
    with pytest.raises(ValueError, match="render_mode must be one of"):
        anonloc_env.parallel_env(render_mode="video")


def test_missing_pygame_gives_an_install_hint(monkeypatch) -> None:
    import builtins

    real_import = builtins.__import__

    def no_pygame(name, *args, **kwargs):
        if name == "pygame":
            raise ImportError("no pygame")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_pygame)
    env = anonloc_env.parallel_env(n_robots=1, render_mode="rgb_array")
    env.reset(seed=0)
    with pytest.raises(ImportError, match=r"pip install 'anonloc\[render\]'"):
        env.render()


def test_reset_option_validation() -> None:
    env = anonloc_env.parallel_env(n_robots=2)
    with pytest.raises(ValueError, match=r"options\['poses'\] must have shape"):
        env.reset(seed=0, options={"poses": [[1.0, 1.0, 0.0]]})
    with pytest.raises(ValueError, match="outside the arena"):
        env.reset(seed=0, options={"poses": [[1.0, 1.0, 0.0], [9.0, 1.0, 0.0]]})
    with pytest.raises(ValueError, match=r"\[0\] and \[1\] overlap"):
        env.reset(seed=0, options={"poses": [[1.0, 1.0, 0.0], [1.1, 1.0, 0.0]]})
    with pytest.warns(UserWarning, match="valid options: \\['poses'\\]"):
        env.reset(seed=0, options={"pose": 1})
