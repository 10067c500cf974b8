"""``python -m anonloc_env``: the ``anonloc`` command line, or the one-frame demo without it.

With the ``cli`` extra installed, ``python -m anonloc_env COMMAND ...`` is ``anonloc COMMAND ...``
(``reproduce``, ``bench``, ``study``, ``render``, ``frame``); options given without a command go
to ``frame``, so ``python -m anonloc_env --out frame.png`` still writes one frame. Without the
extra, the demo runs: a short seeded rollout that writes one rendered frame.

Usage: ``python -m anonloc_env [--preset NAME] [--seed N] [--steps N] [--out FILE.png]``
"""

from __future__ import annotations

import sys

from anonloc_env.demo import demo

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


if __name__ == "__main__":
    raise SystemExit(main())
