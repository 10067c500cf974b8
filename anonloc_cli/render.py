"""``anonloc render``: a scenario played by a team, as a GIF or MP4 (or live in a window).

At every picture each robot's current estimate is handed to the env (``env.guesses``), so the
frames show, for every robot, a line to the detection it believes is itself: green when right, red
when wrong. Frames are taken every ``1 / fps`` seconds of simulated time and played back in real
time.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from anonloc_cli import store
from anonloc_cli.console import echo, progress
from anonloc_cli.scenarios import InputError, Scenario

SUFFIXES = (".gif", ".mp4")


def check_output(out: Path | None, human: bool) -> None:
    """Refuse an output the writers cannot produce, before any work."""
    if human:
        return
    if out is None:
        raise InputError("--out is required (a .gif or .mp4 file) unless --human is given")
    suffix = out.suffix.lower()
    if suffix not in SUFFIXES:
        raise InputError(f"--out must end in one of {list(SUFFIXES)}, got {str(out)!r}")
    if suffix == ".mp4" and not _ffmpeg_available():
        raise InputError(
            "writing .mp4 needs an ffmpeg plugin for imageio (pip install imageio-ffmpeg, or "
            "pip install av); none is installed. Write a .gif instead (--out FILE.gif)"
        )


def _ffmpeg_available() -> bool:
    import importlib.util

    return any(importlib.util.find_spec(name) for name in ("imageio_ffmpeg", "av"))


def main(
    scenario: Scenario,
    policy: str,
    *,
    out: Path | None,
    seed: int,
    steps: int,
    human: bool,
    fps: float,
    quiet: bool,
) -> int:
    """Play ``steps`` control steps and write the frames to ``out`` (or show them)."""
    import numpy as np

    import anonloc_env
    from anonloc_cli.policies import build_team

    env = anonloc_env.parallel_env(**scenario.spec, render_mode="human" if human else "rgb_array")
    team = build_team(policy, env.config, seed=seed)
    agents = env.possible_agents
    observations, _ = env.reset(seed=seed)
    team.reset(np.random.SeedSequence(seed).spawn(len(agents)))  # as run_episode does
    stride = max(1, round(1.0 / (fps * env.config.dt)))
    frames: list[Any] = []
    with progress(steps, "render", quiet=quiet, unit="step") as bar:
        for step in range(steps + 1):
            actions = team.act([observations[a] for a in agents])
            if observations[agents[0]]["new_picture"][0] > 0.5:
                env.guesses = {
                    a: (int(e) if e >= 0 else None)
                    for a, e in zip(agents, team.estimates(), strict=True)
                }
            if not human and step % stride == 0:
                frames.append(env.render())
            if step == steps or not env.agents:
                break
            observations, *_ = env.step(dict(zip(agents, actions, strict=True)))
            bar.update()
    env.close()
    if human:
        return 0
    assert out is not None
    _write(out, frames, fps=1.0 / (stride * env.config.dt))
    seconds = len(frames) * stride * env.config.dt
    echo(f"wrote {out}: {len(frames)} frames, {seconds:.1f} s of {scenario.name} with {policy}")
    return 0


def _write(out: Path, frames: list[Any], fps: float) -> None:
    import imageio.v3 as iio

    with store.atomic_path(out) as tmp:
        if out.suffix.lower() == ".gif":
            # Pillow's GIF writer takes the frame duration in ms (multiples of 10).
            duration = max(20, 10 * math.ceil(100.0 / fps))
            iio.imwrite(tmp, frames, extension=".gif", duration=duration, loop=0)
        else:
            iio.imwrite(tmp, frames, extension=".mp4", fps=fps)
