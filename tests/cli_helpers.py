"""Helpers of the command-line tests: run ``anonloc`` in-process or as a subprocess."""

from __future__ import annotations

import csv
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

from typer.testing import CliRunner

from anonloc_cli.app import app
from tests.helpers import ROOT


def invoke(*args: str) -> Any:
    """Run ``anonloc ARGS`` in this process (Typer's CliRunner); returns the click Result."""
    return CliRunner().invoke(app, [str(a) for a in args], catch_exceptions=False)


def run_module(
    *args: str, module: str = "anonloc_cli", sdl_dummy: bool = True, **kwargs: Any
) -> subprocess.CompletedProcess[str]:
    """Run ``python -m MODULE ARGS`` in a subprocess with this checkout first on the path
    (and SDL's dummy video driver unless ``sdl_dummy`` is false: a user's machine has none)."""
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
    }
    if sdl_dummy:
        env.setdefault("SDL_VIDEODRIVER", "dummy")
    return subprocess.run(
        [sys.executable, "-m", module, *map(str, args)],
        capture_output=True,
        text=True,
        env=env,
        cwd=kwargs.pop("cwd", ROOT),
        timeout=kwargs.pop("timeout", 120),
        **kwargs,
    )


def read_csv(path: Path) -> list[dict[str, str]]:
    """A CSV file's rows as dicts of strings."""
    with open(path, newline="") as file:
        return list(csv.DictReader(file))


#: The ``anonloc`` console script installed beside this interpreter (what users run).
SCRIPT = Path(sys.executable).with_name("anonloc")


def script_env() -> dict[str, str]:
    """The environment of a console-script run: this checkout first on the path."""
    return {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
        "SDL_VIDEODRIVER": "dummy",
    }


def run_script(*args: Any, timeout: float = 180, **kwargs: Any) -> subprocess.CompletedProcess[str]:
    """Run the real ``anonloc ARGS`` console script in a subprocess (as a user does)."""
    return subprocess.run(
        [str(SCRIPT), *map(str, args)],
        capture_output=True,
        text=True,
        env=script_env(),
        cwd=kwargs.pop("cwd", ROOT),
        timeout=timeout,
        **kwargs,
    )


def start_script(*args: Any, **kwargs: Any) -> subprocess.Popen[str]:
    """Start ``anonloc ARGS`` in the background (for signal tests); the caller waits for it."""
    return subprocess.Popen(
        [str(SCRIPT), *map(str, args)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=script_env(),
        cwd=kwargs.pop("cwd", ROOT),
        **kwargs,
    )


def run_in_terminal(
    *args: Any, columns: int = 80, timeout: float = 180, env: dict[str, str] | None = None
) -> tuple[int, str]:
    """Run ``anonloc ARGS`` with stdout and stderr on a pseudo-terminal ``columns`` wide (as in
    a user's terminal window); returns the exit status and everything it wrote (``\\r\\n``
    line ends, as a terminal receives them)."""
    import fcntl
    import pty
    import struct
    import termios
    import threading

    leader, follower = pty.openpty()
    fcntl.ioctl(follower, termios.TIOCSWINSZ, struct.pack("HHHH", 50, columns, 0, 0))
    environment = {**script_env(), "COLUMNS": str(columns), **(env or {})}
    chunks: list[bytes] = []

    def drain() -> None:
        while True:
            try:
                data = os.read(leader, 65536)
            except OSError:  # the terminal closed
                return
            if not data:
                return
            chunks.append(data)

    reader = threading.Thread(target=drain, daemon=True)
    reader.start()
    process = subprocess.Popen(
        [str(SCRIPT), *map(str, args)],
        stdin=subprocess.DEVNULL, stdout=follower, stderr=follower, env=environment, cwd=ROOT,
    )  # fmt: skip
    os.close(follower)
    try:
        code = process.wait(timeout=timeout)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
        reader.join(timeout=10)
        os.close(leader)
    return code, b"".join(chunks).decode("utf-8", errors="replace")
