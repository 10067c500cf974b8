"""How fast anonloc steps, next to the limit of its design and two peer simulators.

Run from the repository root::

    python benchmarks/bench_env.py            # about a minute
    python benchmarks/bench_env.py --quick    # about 15 s, rougher numbers

Everything runs in this one process, pinned to one CPU core (``--cpu``, default 0; torch gets one
thread). The script prints a Markdown table of environment steps per second and agent-steps per
second (steps/s times the number of agents), then checks the speed targets.

What is measured:

* ``anonloc``: ``AnonLocEnv.step`` for N in {2, 10, 100, 1000} robots, with ``dt = 0.02`` s (one
  physics sub-step per control step with the default robot; checked), an arena of side
  ``max(4, 0.8 * sqrt(N))`` m, a picture every 0.5 s (every 25 steps) and the default camera.
  Before every step a fresh action dict ``dict(zip(env.agents, actions))`` is built from an
  ``(N, 2)`` float32 array of uniform random actions. **Building it is not timed**: the clock
  runs around ``env.step`` only (freeing the previous step's outputs included).
* ``limit``: :class:`limit_loop.LimitLoop`: the same pymunk bodies, arena, ``dt``, picture
  interval and commands (the same kind of random actions times ``(v_max, omega_max)``), doing only
  what no implementation of this design can skip (see ``limit_loop.py``). Only ``limit.step`` is
  timed.
* ``mpe2``: ``simple_spread_v3`` (parallel API, discrete actions) with N in {3, 10, 100}; a random
  action dict is built before each step, only ``step`` is timed.
* ``vmas``: ``navigation`` on the CPU: 1024 batched environments of 4 agents with collisions,
  continuous actions, one torch thread; 4096 agent-steps per step.

Timing: short blocks of steps, the env and its limit loop back to back with their order
alternating, repeated many times; every figure is the median over the repetitions, and
``anonloc / limit`` is the median of the per-repetition ratios (so a slow spell of a noisy
machine hits both sides of a ratio). Peers that cannot be imported are skipped and named.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

import anonloc_env

try:  # the longest episode the env accepts (since the hostile pass of issue 26)
    from anonloc_env.config import MAX_CYCLES
except ImportError:  # an older checkout, measured for a before/after
    MAX_CYCLES = 10**9

sys.path.insert(0, str(Path(__file__).resolve().parent))  # limit_loop.py sits next to this file
from limit_loop import LimitLoop

ANONLOC_SIZES = (2, 10, 100, 1000)
MPE2_SIZES = (3, 10, 100)
VMAS_ENVS, VMAS_AGENTS = 1024, 4
DT = 0.02
STEPS_PER_PICTURE = 25
SEED = 0

#: A timed block: run ``k`` steps and return the seconds spent inside the step calls.
Block = Callable[[int], float]
clock = time.perf_counter


@dataclass
class Row:
    """One line of the result table."""

    simulator: str
    agents: str  # as printed: "100", "1024 x 4"
    agents_per_step: int
    seconds_per_step: float | None  # None: skipped
    note: str = ""

    @property
    def agent_steps_per_s(self) -> float:
        assert self.seconds_per_step is not None
        return self.agents_per_step / self.seconds_per_step


# -- timing ---------------------------------------------------------------------------------------


def block_steps(block: Block, target_s: float, multiple: int = 1, cap: int = 100_000) -> int:
    """Steps per block (a multiple of ``multiple``) for blocks of about ``target_s`` seconds."""
    block(multiple)  # warm up
    k = multiple
    while True:
        elapsed = block(k)
        if elapsed >= target_s / 4 or k >= cap:
            break
        k *= 4
    per_step = elapsed / k
    return max(multiple, min(cap, round(target_s / per_step / multiple) * multiple))


def repeat_blocks(blocks: dict[str, Block], steps: int, reps: int) -> dict[str, list[float]]:
    """Seconds per step of each block, ``reps`` times, in alternating order."""
    names = list(blocks)
    samples: dict[str, list[float]] = {name: [] for name in names}
    for rep in range(reps):
        for name in names if rep % 2 == 0 else names[::-1]:
            samples[name].append(blocks[name](steps) / steps)
    return samples


# -- anonloc and its limit ------------------------------------------------------------------------


def arena_side(n: int) -> float:
    """Side (m) of the square arena used for ``n`` robots."""
    return max(4.0, 0.8 * math.sqrt(n))


def env_block(env: anonloc_env.AnonLocEnv, rng: np.random.Generator) -> Block:
    """Timed block of ``env.step`` on uniform random actions from ``rng``; building each step's
    action dict is not timed."""

    def block(k: int) -> float:
        step, agents, spent = env.step, env.agents, 0.0
        for _ in range(k):
            actions_array = rng.uniform(-1.0, 1.0, (len(agents), 2)).astype(np.float32)
            actions = dict(zip(agents, actions_array, strict=True))
            start = clock()
            step(actions)
            spent += clock() - start
        return spent

    return block


def anonloc_blocks(n: int) -> dict[str, Block]:
    """Timed blocks for the env and its limit loop with ``n`` robots, on the same commands."""
    side = arena_side(n)
    env = anonloc_env.parallel_env(
        n_robots=n,
        arena_size=(side, side),
        dt=DT,
        picture_interval=DT * STEPS_PER_PICTURE,
        max_cycles=MAX_CYCLES,
        # The energy reward: the default information-gain reward runs the Bayesian identifier
        # at every picture, timed on its own in bench_identify.py.
        reward_fn=anonloc_env.EnergyCost(),
    )
    env.reset(seed=SEED)
    assert env.world is not None
    assert env.world.substeps == 1, "the scenario must have one physics sub-step per step"
    robot = env.config.robot
    scale = np.array([robot.v_max, robot.omega_max])
    limit = LimitLoop(n, side, DT, STEPS_PER_PICTURE, SEED)
    rng = np.random.default_rng(SEED)

    def limit_block(k: int) -> float:
        step, spent = limit.step, 0.0
        for _ in range(k):
            commands = rng.uniform(-1.0, 1.0, (n, 2)).astype(np.float32) * scale
            start = clock()
            step(commands)
            spent += clock() - start
        return spent

    return {"anonloc": env_block(env, rng), "limit": limit_block}


REWARD_SIZES = (100, 1000)
REWARD_STEPS = 300


def reward_run(n: int, reward_fn: Any, seed: int = SEED) -> tuple[float, float]:
    """Seconds of ``env.step`` over :data:`REWARD_STEPS` steps from reset (the first interval
    included), and the worst single step, under ``reward_fn``, on seeded random commands."""
    side = arena_side(n)
    env = anonloc_env.parallel_env(
        n_robots=n, arena_size=(side, side), max_cycles=MAX_CYCLES, reward_fn=reward_fn
    )
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    agents, total, worst = env.agents, 0.0, 0.0
    for _ in range(REWARD_STEPS):
        actions = dict(zip(agents, rng.uniform(-1.0, 1.0, (n, 2)).astype(np.float32), strict=True))
        start = clock()
        env.step(actions)
        spent = clock() - start
        total += spent
        worst = max(worst, spent)
    return total, worst


def reward_table(reps: int) -> str:
    """The default reward (information gain) against ``EnergyCost`` on the same runs."""
    lines = [
        "| N | reward | agent-steps/s | worst step (ms) | default / EnergyCost speed |",
        "|---:|---|---:|---:|---:|",
    ]
    for n in REWARD_SIZES:
        runs: dict[str, list[tuple[float, float]]] = {"default": [], "EnergyCost": []}
        for _ in range(reps):  # alternated, so a busy neighbour slows both alike
            runs["default"].append(reward_run(n, None))
            runs["EnergyCost"].append(reward_run(n, anonloc_env.EnergyCost()))
        ratio = statistics.median(
            e[0] / d[0] for d, e in zip(runs["default"], runs["EnergyCost"], strict=True)
        )
        for name, samples in runs.items():
            rate = n * REWARD_STEPS / statistics.median(t for t, _ in samples)
            worst = 1e3 * max(w for _, w in samples)
            shown = f"{ratio:.2f}" if name == "default" else ""
            lines.append(f"| {n} | {name} | {fmt(rate)} | {worst:.1f} | {shown} |")
        print(f"  rewards N = {n} done", flush=True)
    return "\n".join(lines)


# -- peers ----------------------------------------------------------------------------------------


def mpe2_block(n: int) -> Block:
    """Timed block for mpe2's ``simple_spread`` (parallel API) with ``n`` agents."""
    from mpe2 import simple_spread_v3

    env = simple_spread_v3.parallel_env(N=n, max_cycles=10**9)
    env.reset(seed=SEED)
    rng = np.random.default_rng(SEED)

    def block(k: int) -> float:
        spent = 0.0
        for _ in range(k):
            actions = dict(zip(env.agents, rng.integers(0, 5, n).tolist(), strict=True))
            start = clock()
            env.step(actions)
            spent += clock() - start
        return spent

    return block


def vmas_block() -> Block:
    """Timed block for VMAS ``navigation``: 1024 CPU envs of 4 agents, collisions on."""
    import torch
    import vmas

    torch.set_num_threads(1)
    env = vmas.make_env(
        "navigation",
        num_envs=VMAS_ENVS,
        device="cpu",
        continuous_actions=True,
        seed=SEED,
        n_agents=VMAS_AGENTS,
        collisions=True,
    )
    env.reset()
    generator = torch.Generator().manual_seed(SEED)

    def block(k: int) -> float:
        spent = 0.0
        with torch.no_grad():
            for _ in range(k):
                actions = torch.rand((VMAS_AGENTS, VMAS_ENVS, 2), generator=generator) * 2 - 1
                start = clock()
                env.step(list(actions))
                spent += clock() - start
        return spent

    return block


def import_error(module: str) -> str | None:
    """None if ``module`` imports, else why it does not."""
    try:
        __import__(module)
    except Exception as error:  # a missing or broken install: the peer is skipped
        return f"{type(error).__name__}: {error}"
    return None


# -- report ---------------------------------------------------------------------------------------


def fmt(rate: float) -> str:
    """A rate with thousands separators, three significant digits below 100."""
    return f"{rate:,.0f}" if rate >= 100 else f"{rate:.3g}"


def table(rows: list[Row], ratios: dict[int, float]) -> str:
    """The Markdown result table; ``ratios`` maps N to anonloc's fraction of the limit."""
    anonloc = {int(r.agents): r.agent_steps_per_s for r in rows if r.simulator == "anonloc"}
    lines = [
        "| simulator | agents | env steps/s | agent-steps/s | ratio |",
        "|---|---:|---:|---:|---|",
    ]
    for r in rows:
        if r.seconds_per_step is None:
            lines.append(f"| {r.simulator} | {r.agents} | skipped | skipped | {r.note} |")
            continue
        n = int(r.agents) if r.agents.isdigit() else None
        if r.simulator == "anonloc" and n in ratios:
            ratio = f"anonloc / limit = {ratios[n]:.2f}"
        elif r.simulator == "mpe2" and n in anonloc:
            ratio = f"anonloc / mpe2 = {anonloc[n] / r.agent_steps_per_s:,.0f}"
        elif r.simulator == "vmas" and 1000 in anonloc:
            ratio = f"anonloc (N = 1000) / vmas = {anonloc[1000] / r.agent_steps_per_s:.2f}"
        else:
            ratio = ""
        lines.append(
            f"| {r.simulator} | {r.agents} | {fmt(1.0 / r.seconds_per_step)} "
            f"| {fmt(r.agent_steps_per_s)} | {ratio} |"
        )
    return "\n".join(lines)


def targets(rows: list[Row], ratios: dict[int, float]) -> list[str]:
    """Each speed target with its measured value and whether it is met."""
    anonloc = {int(r.agents): r.agent_steps_per_s for r in rows if r.simulator == "anonloc"}
    peers = {(r.simulator, r.agents): r for r in rows if r.seconds_per_step is not None}
    out = [
        _target(f"anonloc >= 0.6 of the limit at N = {n}", f"{ratios[n]:.2f}", ratios[n] >= 0.6)
        for n in (100, 1000)
        if n in ratios
    ]
    mpe2 = peers.get(("mpe2", "100"))
    if mpe2 is not None and 100 in anonloc:
        ratio = anonloc[100] / mpe2.agent_steps_per_s
        out.append(_target("anonloc >= 100 x mpe2 at N = 100", f"{ratio:,.0f} x", ratio >= 100))
    vmas = peers.get(("vmas", f"{VMAS_ENVS} x {VMAS_AGENTS}"))
    if vmas is not None and 1000 in anonloc:
        ratio = anonloc[1000] / vmas.agent_steps_per_s
        out.append(_target("anonloc at N = 1000 >= vmas", f"{ratio:.2f} x", ratio >= 1.0))
    if 1000 in anonloc:
        rate = anonloc[1000]
        out.append(_target("anonloc at N = 1000 >= 400,000", f"{rate:,.0f}", rate >= 400_000))
    return out


def _target(name: str, value: str, met: bool) -> str:
    return f"- {name}: {value} ({'met' if met else 'NOT met'})"


def machine() -> str:
    """The CPU, its core count, and the versions that matter."""
    import pymunk

    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return (
        f"{cpu}, {os.cpu_count()} cores; Python {platform.python_version()}, "
        f"numpy {np.__version__}, pymunk {pymunk.version}"
    )


def pin(cpu: int) -> str:
    """Pin this process to core ``cpu`` where the OS allows it; say what was done."""
    if not hasattr(os, "sched_setaffinity"):
        return "not pinned (no sched_setaffinity here)"
    os.sched_setaffinity(0, {cpu})
    return f"pinned to core {cpu}"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="shorter blocks, fewer repetitions")
    parser.add_argument("--cpu", type=int, default=0, help="core to pin to (default 0)")
    parser.add_argument("--no-peers", action="store_true", help="skip mpe2 and vmas")
    parser.add_argument(
        "--rewards-only",
        action="store_true",
        help="only the default reward against EnergyCost (300 steps from reset)",
    )
    args = parser.parse_args(argv)
    if args.rewards_only:
        print(f"machine: {machine()}; {pin(args.cpu)}", flush=True)
        print(reward_table(1 if args.quick else 3))
        return
    block_s, reps, peer_reps = (0.02, 10, 3) if args.quick else (0.05, 40, 7)
    print(f"machine: {machine()}; {pin(args.cpu)}", flush=True)

    rows: list[Row] = []
    ratios: dict[int, float] = {}
    for n in ANONLOC_SIZES:
        blocks = anonloc_blocks(n)
        steps = block_steps(blocks["anonloc"], block_s, multiple=STEPS_PER_PICTURE)
        samples = repeat_blocks(blocks, steps, reps)
        for name in ("anonloc", "limit"):
            rows.append(Row(name, str(n), n, statistics.median(samples[name])))
        ratios[n] = statistics.median(
            lim / env for env, lim in zip(samples["anonloc"], samples["limit"], strict=True)
        )
        print(f"  N = {n}: anonloc / limit = {ratios[n]:.2f}", flush=True)

    why_not = {
        name: "--no-peers" if args.no_peers else import_error(name) for name in ("mpe2", "vmas")
    }
    if why_not["mpe2"] is None:
        for n in MPE2_SIZES:
            block = mpe2_block(n)
            samples = repeat_blocks({"mpe2": block}, block_steps(block, block_s, cap=50), peer_reps)
            rows.append(Row("mpe2", str(n), n, statistics.median(samples["mpe2"])))
            print(f"  mpe2 N = {n} done", flush=True)
    else:
        rows.extend(Row("mpe2", str(n), n, None, "not run") for n in MPE2_SIZES)
    label, per_step = f"{VMAS_ENVS} x {VMAS_AGENTS}", VMAS_ENVS * VMAS_AGENTS
    if why_not["vmas"] is None:
        block = vmas_block()
        samples = repeat_blocks({"vmas": block}, block_steps(block, block_s), peer_reps)
        rows.append(Row("vmas", label, per_step, statistics.median(samples["vmas"])))
        print("  vmas done", flush=True)
    else:
        rows.append(Row("vmas", label, per_step, None, "not run"))

    print()
    print(table(rows, ratios))
    print()
    print(reward_table(1 if args.quick else 3))
    print()
    print("Targets:")
    print("\n".join(targets(rows, ratios)))
    skipped = [f"{name} ({reason})" for name, reason in why_not.items() if reason is not None]
    if skipped:
        print(f"Skipped peers: {', '.join(skipped)}")


if __name__ == "__main__":
    main()
