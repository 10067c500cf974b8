"""``python -m anonloc_env``: the ``anonloc`` command line, or the one-frame demo without it.

With the ``cli`` extra installed, ``python -m anonloc_env COMMAND ...`` is ``anonloc COMMAND ...``
(``reproduce``, ``bench``, ``study``, ``render``, ``frame``); options given without a command go
to ``frame``, so ``python -m anonloc_env --out frame.png`` still writes one frame. Without the
extra, the demo runs: a short seeded rollout that writes one rendered frame.

Usage: ``python -m anonloc_env [--preset NAME] [--seed N] [--steps N] [--out FILE.png]``
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import anonloc_env

#: Options of the command line that are not the demo's.
_CLI_FLAGS = ("--help", "-h", "--version")


def main(argv: list[str] | None = None) -> int:
    """Run the command line if it is installed, else :func:`demo`."""
    args = sys.argv[1:] if argv is None else list(argv)
    try:
        from anonloc_cli.app import main as cli
    except ModuleNotFoundError as error:  # the cli extra (Typer) is not installed
        if (error.name or "").split(".")[0] not in ("anonloc_cli", "typer", "click"):
            raise
        return demo(args)
    if args and args[0].startswith("-") and args[0] not in _CLI_FLAGS:
        args = ["frame", *args]  # the demo's options without a command: the demo, as before
    cli(args, prog_name="python -m anonloc_env")
    return 0  # pragma: no cover - the command line always exits


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


if __name__ == "__main__":
    raise SystemExit(main())
