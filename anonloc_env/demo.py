"""The one-frame demo: a short seeded random rollout that writes one rendered frame.

``python -m anonloc_env`` runs it when the ``cli`` extra is not installed, and ``anonloc frame``
runs it otherwise. It needs the ``render`` extra (pygame-ce).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import anonloc_env


def demo(argv: list[str] | None = None) -> int:
    """Play ``--steps`` random steps of ``--preset`` and save the last frame to ``--out``."""
    parser = argparse.ArgumentParser(prog="python -m anonloc_env", description=__doc__)
    parser.add_argument("--preset", default="default", choices=anonloc_env.preset_names())
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--out", type=Path, default=Path("frame.png"))
    args = parser.parse_args(argv)
    env = anonloc_env.parallel_env(args.preset, render_mode="rgb_array")
    env.reset(seed=args.seed)
    rng = np.random.default_rng(args.seed)
    rewards = 0.0
    for _ in range(args.steps):
        if not env.agents:
            break
        actions = {a: rng.uniform(-1, 1, 2).astype(np.float32) for a in env.agents}
        _, reward, *_ = env.step(actions)
        rewards += sum(reward.values())
    if env.picture is not None:  # draw each robot's true row as its "guess"
        truth = env.picture.true_index
        env.guesses = {a: int(truth[i]) for i, a in enumerate(env.possible_agents)}
    frame = env.render()
    assert frame is not None  # rgb_array mode always returns a frame
    import pygame  # the render extra is installed if render() worked

    surface = pygame.surfarray.make_surface(np.transpose(frame, (1, 0, 2)))
    pygame.image.save(surface, str(args.out))
    print(
        f"{args.preset}: {env.steps} steps, {env.pictures_taken} pictures, "
        f"total reward {rewards:.4f}; frame written to {args.out}"
    )
    env.close()
    return 0
