"""``anonloc render`` and ``anonloc frame``: a scenario played by a team, drawn.

At every picture each robot's current estimate is handed to the env (``env.guesses``), so the
frames show every robot's guess: a green ring around the robot when it is right, a red ring on the
detection it chose (joined to it by a red line) when it is wrong, an amber ring while it is
undecided; a legend says so. ``render`` takes a frame every ``1 / fps`` seconds of simulated time
and streams it to a GIF or MP4 played back in real time (or shows a window); ``frame`` writes the
last frame as a PNG. Both refuse more ``--steps`` than the scenario's ``max_cycles``.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from anonloc_cli import store
from anonloc_cli.console import echo, progress
from anonloc_cli.scenarios import InputError, Scenario

SUFFIXES = (".gif", ".mp4")


def check_output(out: Path | None, human: bool) -> None:
    """Refuse an output the writers cannot produce, before any work."""
    check_pygame()
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


def check_png(out: Path) -> None:
    """Refuse a ``frame`` output that is not a PNG in an existing folder, before any work."""
    check_pygame()
    if out.suffix.lower() != ".png":
        raise InputError(f"--out must end in .png, got {str(out)!r}")
    if not out.parent.is_dir():
        raise InputError(f"--out {out}: {out.parent} is not a folder")


def check_steps(steps: int, scenario: Scenario) -> None:
    """Refuse more ``--steps`` than the scenario's episode lasts (``max_cycles``), before any
    work: the episode would end there, and fewer steps be shown than asked for."""
    cycles = scenario.config.max_cycles
    if steps > cycles:
        raise InputError(
            f"--steps {steps} is more than scenario {scenario.name!r} lasts: its episodes end "
            f"after max_cycles = {cycles} steps. Pass --steps {cycles} or less, or lengthen the "
            f"episode: --set max_cycles={steps}"
        )


def check_pygame() -> None:
    """One line, not a traceback, where the drawing library is missing."""
    import importlib.util

    if importlib.util.find_spec("pygame") is None:
        raise InputError(
            "drawing needs pygame-ce, which is not installed: pip install 'anonloc[cli]' "
            "(or pip install pygame-ce)"
        )


def _ffmpeg_available() -> bool:
    import importlib.util

    return any(importlib.util.find_spec(name) for name in ("imageio_ffmpeg", "av"))


def play(
    scenario: Scenario,
    policy: str,
    *,
    seed: int,
    steps: int,
    human: bool,
    stride: int,
    on_frame: Callable[[Any], None],
    quiet: bool,
) -> Any:
    """Play ``steps`` control steps of ``scenario`` with ``policy`` on every robot.

    Unless ``human``, a frame is drawn every ``stride`` control steps (from step 0) and at the
    last step, each handed to ``on_frame``. Returns the closed env.

    Raises:
        InputError: ``human`` on a machine without a display.
    """
    import numpy as np

    import anonloc_env
    from anonloc_cli.teams import build_team

    env = anonloc_env.parallel_env(**scenario.spec, render_mode="human" if human else "rgb_array")
    team = build_team(policy, env, seed=seed)  # bayes reads the identifier of the env's reward
    agents = env.possible_agents
    try:
        observations, _ = env.reset(seed=seed)
    except RuntimeError:  # the human window found no display
        raise InputError(
            "--human needs a display, and none was found; write a file instead (--out FILE.gif)"
        ) from None
    team.reset(np.random.SeedSequence(seed).spawn(len(agents)))  # as run_episode does
    with progress(steps, "render", quiet=quiet, unit="step") as bar:
        for step in range(steps + 1):
            actions = team.act([observations[a] for a in agents])
            if observations[agents[0]]["new_picture"][0] > 0.5:
                env.guesses = {
                    a: (int(e) if e >= 0 else None)
                    for a, e in zip(agents, team.estimates(), strict=True)
                }
            last = step == steps or not env.agents
            if not human and (step % stride == 0 or last):
                on_frame(env.render())
            if last:
                break
            observations, *_ = env.step(dict(zip(agents, actions, strict=True)))
            bar.update()
    env.close()
    return env


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
    """Play ``steps`` control steps and write the frames to ``out`` as they are drawn (or show
    them): memory holds one frame, however long the episode (:mod:`anonloc_cli.video`)."""
    from anonloc_cli.video import open_video

    dt = scenario.config.dt
    stride = max(1, round(1.0 / (fps * dt)))
    if human:
        play(scenario, policy, seed=seed, steps=steps, human=True, stride=stride,
             on_frame=lambda _: None, quiet=quiet)  # fmt: skip
        return 0
    assert out is not None
    with store.atomic_path(out) as tmp:
        video = open_video(tmp, fps=1.0 / (stride * dt))
        try:
            play(scenario, policy, seed=seed, steps=steps, human=False, stride=stride,
                 on_frame=video.add, quiet=quiet)  # fmt: skip
        finally:
            video.close()
    seconds = video.frames * stride * dt
    echo(f"wrote {out}: {video.frames} frames, {seconds:.1f} s of {scenario.name} with {policy}")
    return 0


def frame(scenario: Scenario, policy: str, *, out: Path, seed: int, steps: int, quiet: bool) -> int:
    """Play ``steps`` control steps and write the last frame to ``out`` (a PNG)."""
    import imageio.v3 as iio

    frames: list[Any] = []
    env = play(
        scenario,
        policy,
        seed=seed,
        steps=steps,
        human=False,
        stride=steps + 1,  # only the first and the last; the last one is kept
        on_frame=frames.append,
        quiet=quiet,
    )
    with store.atomic_path(out) as tmp:
        iio.imwrite(tmp, frames[-1], extension=".png")
    taken = "" if env.picture is None else f", the newest taken at t = {env.picture.time:.2f} s"
    echo(
        f"wrote {out.resolve()}: {scenario.name} with {policy} after {env.steps} steps "
        f"(t = {env.steps * scenario.config.dt:.2f} s), {env.pictures_taken} pictures{taken}"
    )
    return 0
