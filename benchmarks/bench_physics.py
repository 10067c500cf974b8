"""How close the env's step comes to a bare pymunk loop, and where it stands against two peers.

Run from the repository root::

    python benchmarks/bench_physics.py              # about two minutes
    python benchmarks/bench_physics.py --rounds 3   # shorter, rougher

Everything runs in this one process (pinned to one core with ``--cpu``; torch gets one thread),
and every figure is a **ratio of speeds measured alternately**: a round times a block of env steps
and a block of the other side back to back (their order alternating between rounds), and the
reported ratio is the median over the rounds of the per-round ratios, so a slow spell of a shared
machine hits both sides of a ratio.

What is measured:

* ``env``: ``AnonLocEnv.step`` with the default robot and ``dt`` (two physics sub-steps per
  step), the energy reward (``EnergyCost``) and uniform random actions, for N in {100, 1000} at
  1 and 4 robots per m² (a square arena of side ``sqrt(N / density)``). The action dict is built
  before each step; only ``env.step`` is timed.
* ``bare``: :class:`BareLoop`, the bare pymunk loop of issue 18: the same square robots and
  walls in a plain pymunk space, the commanded velocities written with ``pymunk.batch``, one
  space step of ``dt``, the poses read with ``pymunk.batch``, a shuffled picture every 10 steps,
  and the per-agent observation dicts (the env's keys, views of shared arrays). At 4 robots/m²
  also with the env's sub-steps (two space steps of ``dt / 2`` at the default ``dt``, which keep
  a robot from crossing another within a step): the same physics work on both sides.
* ``mpe2``: ``simple_spread_v3`` (parallel API, discrete actions) with N = 100, against the env
  at N = 100, 4 robots per m².
* ``vmas``: ``navigation``, 1024 CPU environments of 4 agents with collisions, against the env
  at N = 1000, 4 robots per m² (agent-steps per second on both sides).

The peers are optional (install them in a separate environment: they are not dependencies of
anonloc); a peer that cannot be imported is skipped and named.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import pymunk
import pymunk.batch as pmb

import anonloc_env
from anonloc_env.config import RobotConfig

try:  # the longest episode the env accepts (since the hostile pass of issue 26)
    from anonloc_env.config import MAX_CYCLES
except ImportError:  # an older checkout, measured for a before/after
    MAX_CYCLES = 10**9

sys.path.insert(0, str(Path(__file__).resolve().parent))  # bench_env.py sits next to this file
import bench_env
from bench_env import Block, env_block, import_error, machine, mpe2_block, pin, vmas_block
from limit_loop import BareObservations

#: (N, robots per m²) of the env / bare loop rows.
SCENARIOS = ((100, 1.0), (100, 4.0), (1000, 1.0), (1000, 4.0))
STEPS_PER_PICTURE = 10
SEED = 0


class BareLoop:
    """The bare pymunk loop: batch velocities in, one space step, batch poses out, dicts.

    Args:
        n: robots (default squares of :class:`anonloc_env.RobotConfig`).
        side: side of the square arena (m).
        dt: the step (s).
        seed: seeds the start poses and the picture shuffles.
        substeps: space steps of ``dt / substeps`` per step (1: issue 18's loop; the env's
            count: the same physics work as the env, whose sub-steps keep a robot from
            crossing another in one step).
    """

    def __init__(self, n: int, side: float, dt: float, seed: int, substeps: int = 1) -> None:
        robot = RobotConfig()
        self.n, self.dt, self.substeps = n, dt, substeps
        self.rng = np.random.default_rng(seed)
        self.space = pymunk.Space(threaded=False)
        grid = math.ceil(math.sqrt(n))
        for k in range(n):
            body = pymunk.Body(1.0, math.inf)
            body.position = ((k % grid + 0.5) * side / grid, (k // grid + 0.5) * side / grid)
            body.angle = float(self.rng.uniform(-math.pi, math.pi))
            self.space.add(body, pymunk.Poly.create_box(body, (robot.size, robot.size)))
        r = robot.size / 2.0
        corners = [(-r, -r), (side + r, -r), (side + r, side + r), (-r, side + r)]
        for a, b in zip(corners, corners[1:] + corners[:1], strict=True):
            self.space.add(pymunk.Segment(self.space.static_body, a, b, r))
        self.velocity = np.zeros((n + 1, 3))  # (vx, vy, w) per body, the static body last
        self.set_buffer = pmb.Buffer()
        self.set_buffer.set_float_buf(self.velocity.reshape(-1))
        self.get_buffer = pmb.Buffer()
        self.poses = np.zeros((n, 3))
        self.observations = BareObservations(n, STEPS_PER_PICTURE, self.rng)

    def step(self, commands: np.ndarray) -> dict[str, dict[str, np.ndarray]]:
        """One step with ``commands`` ``(N, 2)`` = ``(v, w)`` (m/s, rad/s)."""
        n = self.n
        theta = self.poses[:, 2]
        self.velocity[:n, 0] = commands[:, 0] * np.cos(theta)
        self.velocity[:n, 1] = commands[:, 0] * np.sin(theta)
        self.velocity[:n, 2] = commands[:, 1]
        fields = pmb.BodyFields.VELOCITY | pmb.BodyFields.ANGULAR_VELOCITY
        pmb.set_space_bodies(self.space, fields, self.set_buffer)
        for _ in range(self.substeps):
            self.space.step(self.dt / self.substeps)
        self.get_buffer.clear()
        pmb.get_space_bodies(
            self.space, pmb.BodyFields.POSITION | pmb.BodyFields.ANGLE, self.get_buffer
        )
        self.poses = np.frombuffer(self.get_buffer.float_buf()).reshape(-1, 3)[:n].copy()
        return self.observations.build(self.poses)


def env_and_bare(n: int, density: float) -> tuple[dict[str, Block], int]:
    """Timed blocks of the env and the bare loop with ``n`` robots at ``density`` per m² (the
    bare loop with one space step per step, and with the env's sub-steps), and how many
    sub-steps the env takes per step."""
    side = math.sqrt(n / density)
    env = anonloc_env.parallel_env(
        n_robots=n,
        arena_size=(side, side),
        max_cycles=MAX_CYCLES,
        reward_fn=anonloc_env.EnergyCost(),
    )
    env.reset(seed=SEED)
    robot = env.config.robot
    scale = np.array([robot.v_max, robot.omega_max])
    assert env.world is not None
    rng = np.random.default_rng(SEED)

    def bare_block(bare: BareLoop) -> Block:
        def block(k: int) -> float:
            step, spent = bare.step, 0.0
            for _ in range(k):
                commands = rng.uniform(-1.0, 1.0, (n, 2)) * scale
                start = bench_env.clock()
                step(commands)
                spent += bench_env.clock() - start
            return spent

        return block

    matched = BareLoop(n, side, env.config.dt, SEED, env.world.substeps)
    return {
        "env": env_block(env, rng),
        "bare": bare_block(BareLoop(n, side, env.config.dt, SEED)),
        "bare, env's sub-steps": bare_block(matched),
    }, matched.substeps


def ratio(
    numerator: Block, denominator: Block, steps: tuple[int, int], rounds: int, per_step: float
) -> tuple[float, list[float]]:
    """Median over ``rounds`` of the speed ratio (agent-steps/s of ``numerator`` over those of
    ``denominator``, whose agents per step are ``per_step`` times the numerator's), alternating
    which goes first; also the per-round ratios."""
    numerator(max(1, steps[0] // 4))  # warm up
    denominator(max(1, steps[1] // 4))
    ratios = []
    for r in range(rounds):
        if r % 2 == 0:
            a = numerator(steps[0]) / steps[0]
            b = denominator(steps[1]) / steps[1]
        else:
            b = denominator(steps[1]) / steps[1]
            a = numerator(steps[0]) / steps[0]
        ratios.append(b / (a * per_step))
    return statistics.median(ratios), ratios


def show(label: str, value: float, ratios: list[float], target: float | None) -> None:
    spread = ", ".join(f"{r:.3g}" for r in ratios)
    verdict = "" if target is None else (" (met)" if value >= target else " (NOT met)")
    print(f"| {label} | {value:.3g}{verdict} | {spread} |", flush=True)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=7, help="alternated rounds per ratio")
    parser.add_argument("--cpu", type=int, default=None, help="core to pin to (default: none)")
    parser.add_argument("--no-peers", action="store_true", help="skip mpe2 and vmas")
    parser.add_argument(
        "--clock",
        choices=["wall", "cpu"],
        default="wall",
        help="time each step by the wall clock (default) or by this process's CPU time (what "
        "the other processes of a shared machine do not add to; about a microsecond per step "
        "more on both sides)",
    )
    args = parser.parse_args(argv)
    if args.clock == "cpu":
        bench_env.clock = time.process_time
    pinned = pin(args.cpu) if args.cpu is not None else "not pinned"
    print(f"machine: {machine()}; {pinned}", flush=True)
    print("| ratio | median | per round |\n|---|---:|---|")
    envs: dict[tuple[int, float], Block] = {}
    for n, density in SCENARIOS:
        blocks, substeps = env_and_bare(n, density)
        envs[(n, density)] = blocks["env"]
        steps = 200 if n == 100 else 40
        value, ratios = ratio(blocks["env"], blocks["bare"], (steps, steps), args.rounds, 1.0)
        target = 0.5 if density == 4.0 else None
        show(f"env / bare loop, N = {n}, {density:g} robots/m²", value, ratios, target)
        if density == 4.0:  # the same physics work on both sides: what the sub-steps cost
            matched = blocks["bare, env's sub-steps"]
            value, ratios = ratio(blocks["env"], matched, (steps, steps), args.rounds, 1.0)
            show(f"env / bare loop of {substeps} sub-steps, N = {n}, 4/m²", value, ratios, None)
    for name in ("mpe2", "vmas"):
        why = "--no-peers" if args.no_peers else import_error(name)
        if why is not None:
            print(f"| env / {name} | skipped: {why} | |")
            continue
        if name == "mpe2":
            value, ratios = ratio(envs[(100, 4.0)], mpe2_block(100), (200, 2), args.rounds, 1.0)
            show("env (N = 100, 4/m²) / mpe2 simple_spread N = 100", value, ratios, 500.0)
        else:
            per_step = 1024 * 4 / 1000  # VMAS agent-steps per step over the env's
            value, ratios = ratio(envs[(1000, 4.0)], vmas_block(), (40, 10), args.rounds, per_step)
            show("env (N = 1000, 4/m²) / VMAS navigation 1024 x 4", value, ratios, 2.0)


if __name__ == "__main__":
    main()
