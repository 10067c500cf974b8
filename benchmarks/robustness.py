"""How solid the robots and the walls are, and what building an env costs in memory.

Run from the repository root::

    python benchmarks/robustness.py soak --steps 100000   # N = 100, default settings
    python benchmarks/robustness.py corner                 # 100 robots driven into a corner
    python benchmarks/robustness.py wall                   # one robot at full speed into a wall
    python benchmarks/robustness.py column                 # 80 robots at 5 m/s in a corridor
    python benchmarks/robustness.py memory                 # construction memory at N = 1000, 4000

Overlaps are measured from the poses after every step with :mod:`anonloc_env.overlap` (separating
axes for squares), as a percentage of the robot size; "outside" counts robots whose centre left
the arena. The soak uses the energy reward (the physics does not depend on the reward, and the
default reward's identifier would dominate the time) and persistent random actions: each robot
keeps its action and redraws it with probability 0.05 per step, so robots drive into walls and
into each other for seconds at a time.
"""

from __future__ import annotations

import argparse
import math
import tracemalloc

import numpy as np

import anonloc_env
from anonloc_env.overlap import robot_overlaps, wall_overlaps


class Tracker:
    """Largest overlaps seen so far, in % of the robot size."""

    def __init__(self, env: anonloc_env.AnonLocEnv) -> None:
        self.env = env
        self.robot_max = self.wall_max = 0.0
        self.outside = 0
        self.steps = 0
        self.steps_over_10 = 0

    def update(self) -> None:
        env = self.env
        assert env.world is not None
        poses = env.world.poses
        robot, (width, height) = env.config.robot, env.config.arena_size
        _, _, depth = robot_overlaps(robot, poses)
        pair = 100.0 * float(depth.max(initial=0.0)) / robot.size
        wall = 100.0 * float(wall_overlaps(robot, env.config.arena_size, poses).max()) / robot.size
        x, y = poses[:, 0], poses[:, 1]
        self.outside += int(np.sum((x < 0) | (x > width) | (y < 0) | (y > height)))
        self.robot_max = max(self.robot_max, pair)
        self.wall_max = max(self.wall_max, wall)
        self.steps_over_10 += max(pair, wall) > 10.0
        self.steps += 1

    def report(self, label: str) -> None:
        print(
            f"{label}: {self.steps} steps, max robot-robot overlap {self.robot_max:.1f} % of the "
            f"size, max robot-wall overlap {self.wall_max:.1f} %, steps with an overlap > 10 %: "
            f"{100.0 * self.steps_over_10 / max(self.steps, 1):.2f} %, robots outside the arena "
            f"(robot-steps): {self.outside}"
        )


def soak(steps: int, n: int, seed: int) -> None:
    # The 4 m arena of the default preset, as in the issue (n_robots alone would grow it).
    env = anonloc_env.parallel_env(
        n_robots=n, arena_size=(4.0, 4.0), reward_fn=anonloc_env.EnergyCost()
    )
    rng = np.random.default_rng(seed)
    tracker = Tracker(env)
    episodes = 0
    actions = rng.uniform(-1.0, 1.0, (n, 2)).astype(np.float32)
    while tracker.steps < steps:
        env.reset(seed=seed + episodes)
        episodes += 1
        while env.agents and tracker.steps < steps:
            redraw = rng.random(n) < 0.05
            actions[redraw] = rng.uniform(-1.0, 1.0, (int(redraw.sum()), 2))
            env.step(dict(zip(env.agents, actions, strict=True)))
            tracker.update()
    tracker.report(f"soak N={n}, {episodes} episodes, arena {env.config.arena_size}")


def corner(n: int, seconds: float) -> None:
    # The 4 m arena of the default preset, as in the issue (n_robots alone would grow it).
    env = anonloc_env.parallel_env(
        n_robots=n, arena_size=(4.0, 4.0), reward_fn=anonloc_env.EnergyCost()
    )
    env.reset(seed=0)
    tracker = Tracker(env)
    for _ in range(round(seconds / env.config.dt)):
        assert env.world is not None
        x, y, theta = env.world.poses.T
        error = np.arctan2(-y, -x) - theta
        error = (error + np.pi) % (2 * np.pi) - np.pi
        actions = np.column_stack([np.ones(n), np.clip(3.0 * error, -1.0, 1.0)])
        env.step(dict(zip(env.agents, actions.astype(np.float32), strict=True)))
        tracker.update()
    tracker.report(f"corner N={n}, {seconds:g} s towards (0, 0)")


def wall(shape: str) -> None:
    env = anonloc_env.parallel_env(n_robots=1, robot={"shape": shape})
    env.reset(seed=0, options={"poses": [[2.0, 2.0, 0.0]]})
    tracker = Tracker(env)
    for _ in range(200):
        env.step({"robot_0": np.array([1.0, 0.0], np.float32)})
        tracker.update()
    tracker.report(f"one {shape} robot at v_max into a wall")


def column(n: int, v_max: float, steps: int) -> None:
    width = 0.3 * n + 0.5
    env = anonloc_env.parallel_env(
        n_robots=n, arena_size=(width, 0.3), robot={"v_max": v_max}, max_cycles=10**6
    )
    env.reset(seed=0, options={"poses": [[0.25 + 0.3 * i, 0.15, 0.0] for i in range(n)]})
    tracker = Tracker(env)
    first_swap = None
    for step in range(steps):
        env.step({a: np.array([1.0, 0.0], np.float32) for a in env.agents})
        tracker.update()
        assert env.world is not None
        if first_swap is None and np.any(np.diff(env.world.poses[:, 0]) <= 0.0):
            first_swap = step + 1
    assert env.world is not None
    print(f"first order swap at step: {first_swap}; largest x {env.world.poses[:, 0].max():.3f} m")
    tracker.report(f"column of {n} at v_max={v_max} into the wall at x={width:g} m")


def memory(sizes: list[int]) -> None:
    for n in sizes:
        side = 0.4 * math.sqrt(n)
        tracemalloc.start()
        env = anonloc_env.parallel_env(n_robots=n, arena_size=(side, side))
        _, peak = tracemalloc.get_traced_memory()
        current, _ = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        print(
            f"construction N={n}: {current / 1e6:.1f} MB held, {peak / 1e6:.1f} MB peak "
            f"(tracemalloc), {len(env.possible_agents)} agents"
        )
        del env


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("what", choices=["soak", "corner", "wall", "column", "memory"])
    parser.add_argument("--steps", type=int, default=100_000)
    parser.add_argument("--n", type=int, default=None)
    parser.add_argument("--v-max", type=float, default=5.0)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    if args.what == "soak":
        soak(args.steps, args.n or 100, args.seed)
    elif args.what == "corner":
        corner(args.n or 100, 30.0)
    elif args.what == "wall":
        for shape in ("square", "circle"):
            wall(shape)
    elif args.what == "column":
        column(args.n or 80, args.v_max, min(args.steps, 600))
    else:
        memory([args.n] if args.n else [1000, 4000])


if __name__ == "__main__":
    main()
