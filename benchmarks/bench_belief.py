"""The belief env (``agents.vec.AnonLocVecEnv``, what ``anonloc train`` learns on) against an
older checkout of anonloc, alternated in one run.

Run from the repository root, with an older commit checked out elsewhere::

    git worktree add /work/old-main 9b13f2a
    python benchmarks/bench_belief.py --old /work/old-main             # about 10 minutes
    python benchmarks/bench_belief.py --old /work/old-main --robots 30 --copies 4 --rounds 5
    python benchmarks/bench_belief.py --old /work/old-main --train 2  # anonloc train, mixed
    python benchmarks/bench_belief.py --old /work/old-main --robots 10 30 100 300 1000 \
        --copies 1 --rounds 1 --growth                                # cost against N
    python benchmarks/bench_belief.py --profile --robots 30 --copies 4  # where the time goes
    python benchmarks/bench_belief.py --profile --train 2             # ... in anonloc train
    python benchmarks/bench_belief.py --one-env --robots 30 --copies 4 12  # what batching may win

Each measurement is a fresh interpreter (``PYTHONPATH`` set to one checkout or the other) that
builds the env (``--copies`` copies of the ``default`` scenario with N robots, the ``team``
reward; at N = 30 with clutter: 8 % misses and 2 false positives per picture), resets it with
seed 0, takes one untimed step, then steps it with uniform random candidate choices until
``--seconds`` have passed, and prints the decisions per second (slots x steps / s; with
``--clock cpu`` per second of the worker's own CPU time, which a loaded machine's other
processes do not add to, though they still share its caches). The two
checkouts run one after the other, in an order that alternates between rounds; the figures are
medians over the rounds and the ratio is the median of the per-round ratios, so that a slow spell
of the shared machine weighs on both sides.

``--train R`` measures ``anonloc train`` instead: the bundled run's configuration
(``benchmarks.train_bundled.BUNDLED``: the ``mixed`` condition, 12 env copies, the ``team``
reward, PPO with its hyperparameters and the candidate scorer, one torch thread), one untimed
rollout, then ``PPO.learn`` over R rollouts (collection and updates): decisions per second with
the network included.

``--one-env`` measures what batching the copies could win: in one process, the K copies of N
robots (with clutter: 8 % misses, 2 false positives per picture) against one env of K x N
robots in K times the area with K times the false positives (the same density, the same work
per robot), blocks of 20 decisions alternated, decisions per CPU second. A VecEnv whose copies
shared every numpy call would cost about what the one env costs.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

import numpy as np

WORKER = """
import sys, time
import numpy as np
from anonloc_env import make_config
from agents.vec import AnonLocVecEnv
n, copies, seconds = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[4])
clock = time.process_time if sys.argv[5] == "cpu" else time.perf_counter
clutter = sys.argv[3] == "1"
camera = {"p_miss": 0.08, "false_positives": 2.0} if clutter else {}
config = make_config(n_robots=n, camera=camera)
try:  # since issue 24 the team reward is part of the agent's spec
    from agents.spec import AgentSpec, Reward
    vec = AnonLocVecEnv(config, n_envs=copies, spec=AgentSpec(reward=Reward(identity="team")))
except ImportError:  # a checkout from before the spec
    vec = AnonLocVecEnv(config, n_envs=copies, reward="team")
vec.seed(0)
vec.reset()
rng = np.random.default_rng(0)
def step():
    vec.step_async(rng.integers(0, 8, vec.num_envs))
    vec.step_wait()
step()
steps, start = 0, clock()
while clock() - start < seconds or steps < 2:
    step()
    steps += 1
print(steps * vec.num_envs / (clock() - start))
"""


TRAIN = """
import sys, time
import torch
from agents.train import build_model, make_vec_env
from benchmarks.train_bundled import BUNDLED
torch.set_num_threads(1)
rollouts = int(sys.argv[1])
clock = time.process_time if sys.argv[2] == "cpu" else time.perf_counter
vec = make_vec_env(BUNDLED)
model = build_model(BUNDLED, vec)
per_rollout = model.n_steps * vec.num_envs
model.learn(total_timesteps=per_rollout)  # untimed: the first reset and rollout
start = clock()
model.learn(total_timesteps=rollouts * per_rollout, reset_num_timesteps=False)
print(rollouts * per_rollout / (clock() - start))
"""


PROFILE = """
import sys, time, collections, importlib
import numpy as np
clock = time.process_time
shares = collections.Counter()
def timed(owner, name, label):
    function = getattr(owner, name)
    def wrapper(*args, **kwargs):
        start = clock()
        try:
            return function(*args, **kwargs)
        finally:
            shares[label] += clock() - start
    setattr(owner, name, wrapper)
import agents.candidates, agents.crew, agents.vec, baselines.active, baselines.localizers
import baselines.policies, anonloc_env.world
env = importlib.import_module("anonloc_env.env")
timed(agents.vec.AnonLocVecEnv, "step_wait", "the VecEnv's step")
timed(agents.vec.AnonLocVecEnv, "_next_episode", "the next episode of a copy (redraw, reset)")
if hasattr(agents.vec.AnonLocVecEnv, "_started"):  # since the copies' first pictures are batched
    timed(agents.vec.AnonLocVecEnv, "_started", "the first pictures' scores (all new episodes)")
timed(env.AnonLocEnv, "step_arrays", "the env's control steps (step_arrays)")
timed(anonloc_env.world.World, "step", "  of which the physics (World.step)")
timed(baselines.localizers.BayesLocalizer, "on_picture", "the identifier's update")
timed(agents.candidates.CandidateChooser, "on_picture", "the chooser's hypotheses, draws")
timed(agents.candidates.CandidateChooser, "scored", "the chooser's features, observation")
timed(agents.vec, "entropies_together", "the expected entropy (all copies)")
timed(baselines.active.GreedyIdentification, "commands", "the excitation's commands")
timed(baselines.policies.Team, "command", "the team's commands and motion log")
rounds = int(sys.argv[1])
if sys.argv[2] == "train":
    import torch
    import stable_baselines3.ppo.ppo
    from agents.train import build_model, make_vec_env
    from benchmarks.train_bundled import BUNDLED
    timed(stable_baselines3.ppo.ppo.PPO, "train", "PPO's update")
    torch.set_num_threads(1)
    vec = make_vec_env(BUNDLED)
    model = build_model(BUNDLED, vec)
    per_rollout = model.n_steps * vec.num_envs
    model.learn(total_timesteps=per_rollout)
    shares.clear()
    start = clock()
    model.learn(total_timesteps=rounds * per_rollout, reset_num_timesteps=False)
else:
    from anonloc_env import make_config
    from agents.spec import AgentSpec, Reward
    camera = {"p_miss": 0.08, "false_positives": 2.0}
    config = make_config(n_robots=int(sys.argv[2]), camera=camera if sys.argv[2] == "30" else {})
    vec = agents.vec.AnonLocVecEnv(
        config, n_envs=int(sys.argv[3]), spec=AgentSpec(reward=Reward(identity="team"))
    )
    vec.seed(0)
    vec.reset()
    rng = np.random.default_rng(0)
    for k in range(5 + rounds):
        if k == 5:
            shares.clear()
            start = clock()
        vec.step_async(rng.integers(0, 8, vec.num_envs))
        vec.step_wait()
total = clock() - start
print("| part | share of the CPU time |")
print("|---|---:|")
for label, seconds in sorted(shares.items(), key=lambda item: -item[1]):
    print(f"| {label} | {100 * seconds / total:.0f} % |")
"""


ONE_ENV = """
import sys, time
import numpy as np
from anonloc_env import make_config
from agents.vec import AnonLocVecEnv
from agents.spec import AgentSpec, Reward
n, k, rounds = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
spec = AgentSpec(reward=Reward(identity="team"))
def build(robots, copies, fp):
    camera = {"p_miss": 0.08, "false_positives": fp}
    vec = AnonLocVecEnv(make_config(n_robots=robots, camera=camera), n_envs=copies, spec=spec)
    vec.seed(0)
    vec.reset()
    return vec
sides = {"copies": build(n, k, 2.0), "one": build(n * k, 1, 2.0 * k)}
rng = np.random.default_rng(0)
def block(vec, steps):
    start = time.process_time()
    for _ in range(steps):
        vec.step_async(rng.integers(0, 8, vec.num_envs))
        vec.step_wait()
    return steps * vec.num_envs / (time.process_time() - start)
for vec in sides.values():
    block(vec, 5)
rates = {side: [] for side in sides}
for r in range(rounds):
    for side in ("copies", "one") if r % 2 == 0 else ("one", "copies"):
        rates[side].append(block(sides[side], 20))
ratio = np.median(np.array(rates["one"]) / np.array(rates["copies"]))
copies, one = np.median(rates["copies"]), np.median(rates["one"])
print(f"| {n} | {k} | {copies:,.0f} | {n * k} | {one:,.0f} | {ratio:.2f}x |")
"""


def rate(checkout: Path, code: str, args: list[str]) -> float:
    """Decisions per second that ``code`` prints, run in a fresh interpreter on ``checkout``."""
    env = {**os.environ, "PYTHONPATH": str(checkout)}
    out = subprocess.run(
        [sys.executable, "-c", code, *args],
        env=env,
        cwd=checkout,
        capture_output=True,
        text=True,
        check=True,
    )
    return float(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--old", type=Path, help="the older checkout (required but with --profile)")
    parser.add_argument("--new", type=Path, default=Path.cwd(), help="this checkout (default)")
    parser.add_argument("--robots", type=int, nargs="+", default=[10, 30, 100, 300])
    parser.add_argument("--copies", type=int, nargs="+", default=[4, 12])
    parser.add_argument("--rounds", type=int, default=3, help="alternations (medians)")
    parser.add_argument("--seconds", type=float, default=4.0, help="timed stepping per run")
    parser.add_argument(
        "--train",
        type=int,
        default=0,
        metavar="ROLLOUTS",
        help="instead: PPO.learn of the bundled run (mixed condition, 12 copies, network "
        "included, one torch thread) over this many rollouts after an untimed one",
    )
    parser.add_argument(
        "--growth", action="store_true", help="also fit how a decision's cost grows with N"
    )
    parser.add_argument(
        "--clock",
        choices=["wall", "cpu"],
        default="wall",
        help="time by the wall clock (default) or by the worker's own CPU time (what the other "
        "processes on a shared machine do not add to)",
    )
    parser.add_argument(
        "--profile",
        action="store_true",
        help="instead: where the new checkout's time goes (timers around each part, CPU time; "
        "the first --robots and --copies, 200 decisions; with --train, its rollouts)",
    )
    parser.add_argument(
        "--one-env",
        action="store_true",
        help="instead: the copies against one env of all their robots (what batching the "
        "copies could win; --robots with clutter, --copies, --rounds; the new checkout)",
    )
    args = parser.parse_args()
    if args.one_env:
        print("| N | copies | copies' decisions/s | one env of | its decisions/s | one / copies |")
        print("|---:|---:|---:|---:|---:|---:|")
        env = {**os.environ, "PYTHONPATH": str(args.new.resolve())}
        for n in args.robots:
            for copies in args.copies:
                work = [str(n), str(copies), str(args.rounds)]
                subprocess.run(
                    [sys.executable, "-c", ONE_ENV, *work], env=env, cwd=args.new, check=True
                )
        return
    if args.profile:
        first = [str(args.robots[0]), str(args.copies[0])]
        work = [str(args.train), "train"] if args.train else ["200", *first]
        env = {**os.environ, "PYTHONPATH": str(args.new.resolve())}
        subprocess.run([sys.executable, "-c", PROFILE, *work], env=env, cwd=args.new, check=True)
        return
    if args.old is None:
        parser.error("--old is required (the older checkout to compare with)")
    sides = {"old": args.old.resolve(), "new": args.new.resolve()}
    if args.train:
        work = [str(args.train), args.clock]
        alternate(sides, args.rounds, TRAIN, work, "anonloc train (mixed)")
        return
    print("| N | copies | clutter | old decisions/s | new decisions/s | new / old |")
    print("|---:|---:|---|---:|---:|---:|")
    medians: dict[str, list[float]] = {"old": [], "new": []}
    for n in args.robots:
        for copies in args.copies:
            clutter = n == 30
            label = f"{n} | {copies} | {'8 % misses, 2 FP' if clutter else 'none'}"
            work = [str(n), str(copies), "1" if clutter else "0", str(args.seconds), args.clock]
            for side, value in alternate(sides, args.rounds, WORKER, work, label).items():
                medians[side].append(value)
    if args.growth:
        robots = np.repeat(args.robots, len(args.copies))
        for side, values in medians.items():
            # decisions/s ~ N^-b: the cost of one decision grows as N^b.
            slope = np.polyfit(np.log(robots), np.log(values), 1)[0]
            print(f"\n{side}: one decision costs ~ N^{-slope:.2f} (least squares, log-log)")


def alternate(
    sides: dict[str, Path], rounds: int, code: str, args: list[str], label: str
) -> dict[str, float]:
    """Run ``code`` on the old and new checkouts ``rounds`` times each, alternating which goes
    first, and print a table row: the medians and the median of the per-round ratios. Returns
    the medians."""
    rates: dict[str, list[float]] = {"old": [], "new": []}
    for r in range(rounds):
        for side in ("old", "new") if r % 2 == 0 else ("new", "old"):
            rates[side].append(rate(sides[side], code, args))
    ratio = statistics.median(b / a for a, b in zip(rates["old"], rates["new"], strict=True))
    old, new = (statistics.median(rates[side]) for side in ("old", "new"))
    print(f"| {label} | {old:,.0f} | {new:,.0f} | {ratio:.2f}x |", flush=True)
    return {"old": old, "new": new}


if __name__ == "__main__":
    main()
