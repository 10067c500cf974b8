"""Same seed, same episode: hashes of seeded runs of the learning path and the raw env, for
one or more checkouts of anonloc (the guard that a speed change keeps every episode to the bit).

Run from the repository root, with older commits checked out elsewhere::

    git worktree add --detach /work/base f29f4a6
    python benchmarks/bench_hashes.py /work/base .           # every case, both checkouts
    python benchmarks/bench_hashes.py /work/base . --cases belief-30 train

Each checkout runs in a fresh interpreter (``PYTHONPATH`` set to it). A case's hash is the
SHA-256 of every array the run hands out (observations, rewards, ends and the infos of each
decision; the raw env's observations, rewards, terminations, truncations and infos of each
step), the bytes of each array with its dtype and each dict's keys in sorted order:

* ``belief-30``: the belief VecEnv (``agents.vec.AnonLocVecEnv``, the ``team`` reward), N = 30
  with 8 % misses and 2 false positives per picture, 4 copies, seed 3, 250 decisions of
  uniform random candidates (generator seed 0);
* ``belief-12``: the same without clutter, N = 12, 2 copies, 250 decisions;
* ``belief-100``: N = 100, 2 copies, 60 decisions;
* ``train``: ``anonloc train``'s VecEnv (``benchmarks.train_bundled.BUNDLED``: 12 copies of
  the ``mixed`` condition, 3 to 40 robots, redrawn at every episode's end), 70 decisions;
* ``raw``: the PettingZoo parallel env, N = 100, seed 5, 300 steps of uniform random actions;
* ``raw-energy``: the same with the energy reward (``EnergyCost``) at 4 robots per m² (the raw
  env of ``bench_physics.py``), float32 action rows as views of one array.

The table prints each case's hash per checkout and whether they all agree. A checkout that
lacks a case's code (an older one) prints the error's type instead.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

CASES = ("belief-30", "belief-12", "belief-100", "train", "raw", "raw-energy")

WORKER = """
import hashlib, sys
import numpy as np

def feed(h, x):
    if isinstance(x, dict):
        for k in sorted(x):
            h.update(str(k).encode())
            feed(h, x[k])
    elif isinstance(x, (list, tuple)):
        for y in x:
            feed(h, y)
    elif isinstance(x, np.ndarray):
        h.update(str(x.dtype).encode())
        h.update(np.ascontiguousarray(x).tobytes())
    else:
        h.update(repr(x).encode())

def vec_hash(vec, decisions):
    h, rng = hashlib.sha256(), np.random.default_rng(0)
    vec.seed(3)
    feed(h, vec.reset())
    for _ in range(decisions):
        vec.step_async(rng.integers(0, 8, vec.num_envs))
        feed(h, vec.step_wait())
    return h.hexdigest()[:16]

def belief(n, copies, decisions, clutter):
    from anonloc_env import make_config
    from agents.vec import AnonLocVecEnv
    camera = {"p_miss": 0.08, "false_positives": 2.0} if clutter else {}
    config = make_config(n_robots=n, camera=camera)
    try:  # since issue 24 the team reward is part of the agent's spec
        from agents.spec import AgentSpec, Reward
        vec = AnonLocVecEnv(config, n_envs=copies, spec=AgentSpec(reward=Reward(identity="team")))
    except ImportError:  # a checkout from before the spec
        vec = AnonLocVecEnv(config, n_envs=copies, reward="team")
    return vec_hash(vec, decisions)

def train():
    from agents.train import make_vec_env
    from benchmarks.train_bundled import BUNDLED
    return vec_hash(make_vec_env(BUNDLED), 70)

def raw():
    import anonloc_env
    env = anonloc_env.parallel_env(n_robots=100)
    h, rng = hashlib.sha256(), np.random.default_rng(1)
    feed(h, env.reset(seed=5))
    for _ in range(300):
        feed(h, env.step({a: rng.uniform(-1, 1, 2).astype(np.float32) for a in env.agents}))
    return h.hexdigest()[:16]

def raw_energy():
    import anonloc_env
    reward = anonloc_env.EnergyCost()
    env = anonloc_env.parallel_env(n_robots=100, arena_size=(5.0, 5.0), reward_fn=reward)
    h, rng = hashlib.sha256(), np.random.default_rng(2)
    feed(h, env.reset(seed=6))
    for _ in range(300):
        actions = rng.uniform(-1, 1, (100, 2)).astype(np.float32)
        feed(h, env.step(dict(zip(env.agents, actions))))
    return h.hexdigest()[:16]

RUN = {
    "belief-30": lambda: belief(30, 4, 250, True),
    "belief-12": lambda: belief(12, 2, 250, False),
    "belief-100": lambda: belief(100, 2, 60, False),
    "train": train,
    "raw": raw,
    "raw-energy": raw_energy,
}
for case in sys.argv[1:]:
    try:
        print(case, RUN[case](), flush=True)
    except Exception as error:  # an older checkout without this case's code
        print(case, type(error).__name__, flush=True)
"""


def hashes(checkout: Path, cases: list[str]) -> dict[str, str]:
    """Each case's hash on ``checkout`` (a fresh interpreter with ``PYTHONPATH`` set to it)."""
    env = {**os.environ, "PYTHONPATH": str(checkout)}
    out = subprocess.run(
        [sys.executable, "-c", WORKER, *cases],
        env=env,
        cwd=checkout,
        capture_output=True,
        text=True,
        check=True,
    )
    return dict(line.split(" ", 1) for line in out.stdout.strip().splitlines())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("checkouts", type=Path, nargs="+", help="checkouts to hash (e.g. old new)")
    parser.add_argument("--cases", nargs="+", choices=CASES, default=list(CASES))
    args = parser.parse_args()
    table = {str(c.resolve()): hashes(c.resolve(), args.cases) for c in args.checkouts}
    print("| case | " + " | ".join(table) + " | all equal |")
    print("|---|" + "---|" * len(table) + "---|")
    for case in args.cases:
        values = [table[c][case] for c in table]
        same = "yes" if len(set(values)) == 1 else "**no**"
        print(f"| {case} | " + " | ".join(values) + f" | {same} |")


if __name__ == "__main__":
    main()
