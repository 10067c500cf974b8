"""Training throughput: anonloc's SB3 adapter against SuperSuit + SB3 on the same env.

Run from the repository root::

    python benchmarks/bench_train.py                 # N = 10, about 2 minutes
    python benchmarks/bench_train.py --robots 10 100 # N = 100 too, a few minutes more
    python benchmarks/bench_train.py --quick         # rougher, about 40 s

Both sides train PPO (``stable_baselines3.PPO.learn``) with the same hyperparameters
(``--n-steps`` per slot, ``--batch-size``, ``--n-epochs``; the rest SB3's defaults), on
``--copies`` copies of the ``default`` scenario with N robots, every robot a slot of the
``VecEnv``, one torch thread:

* ``anonloc``: :class:`agents.vec.AnonLocVecEnv` (what ``anonloc train`` trains on): the
  candidate observation ``candidates (8, 7)``, ``context (10,)`` (every robot's own identifier
  scores its candidate commands) and the crew's reward, with
  :class:`agents.features.CandidatePolicy` (the candidate scorer, 64 wide). The policy decides
  once per picture and its choice is held until the next one, so one decision covers
  ``picture_interval / dt`` control steps (20 in the ``default`` scenario).
* ``supersuit``: ``concat_vec_envs_v1(pettingzoo_env_to_vec_env_v1(env), copies,
  base_class="stable_baselines3")`` around the raw ``AnonLocEnv`` (its default
  ``InformationGain`` reward, its raw observation of 8 keys: ``detections (D, 3)``, ``mask``,
  ``new_picture``, ``since_picture``, ``odometry``, ``bumper``, ``odometry_between``,
  ``interval``), with the same ``MultiInputPolicy``. ``PPO(seed=...)`` fails on SuperSuit's
  ``ConcatVecEnv`` (it has no ``seed`` method), so that side runs with ``seed=None``.

The observations differ (that is the point of the adapter), so the networks' inputs differ:
``66`` numbers for ``anonloc``, ``4 D + 10`` for ``supersuit``; the script prints each policy's
parameter count.

Two rates are printed: **decisions/s** (samples PPO trains on per second: slots x policy calls)
and **robot-steps/s** (robot control steps of experience simulated per second). For SuperSuit,
which asks the policy at every control step, the two are equal; for ``anonloc`` one decision is
a picture interval. Both ratios are printed: per decision the two sides do the same network work,
so that ratio shows the adapter's overhead; per robot-step it shows how much more experience
``anonloc train`` simulates in the same time.

Timing: each repetition builds every model (not timed), then times ``learn`` over
``--rollouts`` rollouts (collection and PPO updates), the sides in an order that alternates
between repetitions; figures are medians over repetitions, ratios the median of the
per-repetition ratios. The same is done for the environment alone (``step_async`` /
``step_wait`` with random actions, no network), which is where the two sides differ.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time
import warnings
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

import anonloc_env
from anonloc_env import make_config

SEED = 0


def _threads() -> None:
    import torch

    torch.set_num_threads(1)


def build_anonloc(n_robots: int, copies: int, ppo: dict[str, Any]) -> Any:
    from stable_baselines3 import PPO

    from agents.features import CandidatePolicy
    from agents.vec import AnonLocVecEnv

    env = AnonLocVecEnv(make_config(n_robots=n_robots), n_envs=copies)
    return PPO(CandidatePolicy, env, seed=SEED, verbose=0, **ppo)


def supersuit_env(n_robots: int, copies: int) -> Any:
    import supersuit as ss

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env = ss.pettingzoo_env_to_vec_env_v1(anonloc_env.parallel_env(n_robots=n_robots))
        return ss.concat_vec_envs_v1(env, copies, num_cpus=0, base_class="stable_baselines3")


def build_supersuit(n_robots: int, copies: int, ppo: dict[str, Any]) -> Any:
    from stable_baselines3 import PPO

    # ConcatVecEnv has no seed(): PPO(seed=0) raises AttributeError, hence seed=None.
    return PPO("MultiInputPolicy", supersuit_env(n_robots, copies), seed=None, verbose=0, **ppo)


def learn_rate(model: Any, rollouts: int) -> tuple[float, float]:
    """Decisions and robot control steps per second of ``model.learn`` over ``rollouts``
    rollouts."""
    steps = rollouts * model.n_steps * model.env.num_envs
    vec = model.env
    before = getattr(vec, "control_steps", None)
    start = time.perf_counter()
    model.learn(total_timesteps=steps)
    seconds = time.perf_counter() - start
    if before is None:  # one decision per control step
        return steps / seconds, steps / seconds
    robots = vec.num_envs // len(vec.crews)
    return steps / seconds, (vec.control_steps - before) * robots / seconds


def env_rate(vec: Any, steps: int) -> float:
    """Robot control steps per second of stepping ``vec`` with uniform random actions."""
    rng = np.random.default_rng(SEED)
    space = vec.action_space
    if isinstance(space, gym.spaces.Discrete):  # anonloc's: which candidate
        actions = rng.integers(0, int(space.n), (steps, vec.num_envs))
    else:
        actions = rng.uniform(-1.0, 1.0, (steps, vec.num_envs, 2)).astype(np.float32)
    vec.reset()
    before = getattr(vec, "control_steps", None)
    start = time.perf_counter()
    for a in actions:
        vec.step_async(a)
        vec.step_wait()
    seconds = time.perf_counter() - start
    if before is None:
        return steps * vec.num_envs / seconds
    return (vec.control_steps - before) * (vec.num_envs // len(vec.crews)) / seconds


def parameters(model: Any) -> int:
    return sum(p.numel() for p in model.policy.parameters())


def measure(
    n_robots: int, copies: int, ppo: dict[str, Any], rollouts: int, repeats: int, env_steps: int
) -> None:
    from agents.vec import AnonLocVecEnv

    builders: dict[str, Callable[[], Any]] = {
        "anonloc": lambda: build_anonloc(n_robots, copies, ppo),
        "supersuit": lambda: build_supersuit(n_robots, copies, ppo),
    }
    names = list(builders)
    learn: dict[str, list[float]] = {name: [] for name in names}
    experience: dict[str, list[float]] = {name: [] for name in names}
    env: dict[str, list[float]] = {"anonloc": [], "supersuit": []}
    sizes: dict[str, int] = {}
    for repeat in range(repeats):
        order = names if repeat % 2 == 0 else names[::-1]
        for name in order:
            model = builders[name]()
            sizes[name] = parameters(model)
            decisions, robot_steps = learn_rate(model, rollouts)
            learn[name].append(decisions)
            experience[name].append(robot_steps)
            model.env.close()
        env_order = ["anonloc", "supersuit"][:: 1 if repeat % 2 == 0 else -1]
        for name in env_order:
            vec = (
                AnonLocVecEnv(make_config(n_robots=n_robots), n_envs=copies)
                if name == "anonloc"
                else supersuit_env(n_robots, copies)
            )
            env[name].append(env_rate(vec, env_steps))
            vec.close()
    print(f"\n### N = {n_robots} robots, {copies} copies ({n_robots * copies} slots)\n")
    print(
        "| path | policy parameters | PPO.learn decisions/s | vs supersuit "
        "| robot-steps/s | vs supersuit |"
    )
    print("|---|---:|---:|---:|---:|---:|")
    for name in names:
        ratios = [
            statistics.median(a / b for a, b in zip(rates[name], rates["supersuit"], strict=True))
            for rates in (learn, experience)
        ]
        print(
            f"| {name} | {sizes[name]:,} | {statistics.median(learn[name]):,.0f} "
            f"| {ratios[0]:.2f}x | {statistics.median(experience[name]):,.0f} | {ratios[1]:.2f}x |"
        )
    ratio = statistics.median(a / b for a, b in zip(env["anonloc"], env["supersuit"], strict=True))
    print(
        f"\nEnvironment alone (random actions, no network): anonloc "
        f"{statistics.median(env['anonloc']):,.0f} robot-steps/s, supersuit "
        f"{statistics.median(env['supersuit']):,.0f} robot-steps/s: {ratio:.2f}x"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, nargs="+", default=[10], help="N values")
    parser.add_argument("--copies", type=int, default=2, help="env copies per VecEnv")
    parser.add_argument("--n-steps", type=int, default=128, help="PPO n_steps per slot")
    parser.add_argument("--batch-size", type=int, default=256, help="PPO minibatch size")
    parser.add_argument("--n-epochs", type=int, default=4, help="PPO epochs per rollout")
    parser.add_argument("--rollouts", type=int, default=3, help="rollouts per timed learn")
    parser.add_argument("--repeats", type=int, default=3, help="repetitions (medians)")
    parser.add_argument("--env-steps", type=int, default=300, help="steps of the env-only runs")
    parser.add_argument("--quick", action="store_true", help="1 rollout, 2 repeats")
    args = parser.parse_args()
    if args.quick:
        args.rollouts, args.repeats, args.env_steps = 1, 2, 100
    _threads()
    ppo = {"n_steps": args.n_steps, "batch_size": args.batch_size, "n_epochs": args.n_epochs}
    print(
        f"PPO {ppo}, {args.rollouts} rollouts per learn, {args.repeats} repetitions, "
        f"1 torch thread; {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs"
    )
    for n in args.robots:
        measure(n, args.copies, ppo, args.rollouts, args.repeats, args.env_steps)


if __name__ == "__main__":
    main()
