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


def test_rgb_array_frame_draws_robots_where_they_are_and_marks_guesses() -> None:
    pytest.importorskip("pygame")
    from anonloc_env import render

    env = anonloc_env.parallel_env(n_robots=2, camera={"pixel_noise": 0.0}, render_mode="rgb_array")
    poses = [[1.0, 1.0, 0.0], [3.0, 2.5, np.pi / 2]]  # metres, metres, radians
    env.reset(seed=0, options={"poses": poses})
    blank = env.render()
    truth = env.picture.true_index
    # robot_0 guesses right, robot_1 wrong (robot_0's row)
    env.guesses = {"robot_0": int(truth[0]), "robot_1": int(truth[0])}
    frame = env.render()
    env.close()
    renderer = env._renderer or render.Renderer(env.config, env.camera, "rgb_array")
    assert frame.dtype == np.uint8
    assert frame.shape == (renderer.size[1], renderer.size[0], 3)
    ring = renderer._ring_radius()

    def pixel(xy: list[float], dx: float = 0.0, dy: float = 0.0) -> tuple[int, ...]:
        x, y = renderer._to_screen(np.array(xy, dtype=float))
        return tuple(int(c) for c in frame[round(y + dy), round(x + dx)])

    assert renderer.pixels_per_metre * env.config.robot.size / 2 > 7  # bodies wider than 7 px
    for (x, y, _), colour in zip(poses, renderer.colors, strict=True):
        # 6 px below the centre: off the heading line (+x, then up) and the cross's diagonals
        assert pixel([x, y], dy=6) == colour
        assert pixel([x, y], dx=60) == (250, 250, 250)  # background beside it
    assert pixel(poses[0][:2], dx=-ring + 1) == render._RIGHT  # green ring: right
    x0, y0 = renderer._to_screen(np.array(poses[0][:2]))
    assert tuple(blank[round(y0), round(x0 - ring + 1)]) == (250, 250, 250)  # no guess: no ring
    # robot_1's wrong guess: a red ring, wider, on robot_0's detection (noise-free: on robot_0)
    assert pixel(poses[0][:2], dx=ring + 3) == render._WRONG
    assert pixel(poses[1][:2], dx=ring - 1) == (250, 250, 250)  # no ring on a wrong robot


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
