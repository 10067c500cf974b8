"""``python -m anonloc_env``: the ``anonloc`` command line (the ``cli`` extra).

``python -m anonloc_env COMMAND ...`` is ``anonloc COMMAND ...``. Without the extra it says which
``pip install`` gives it, and exits with status 1.
"""

from __future__ import annotations

import sys


def main(argv: list[str] | None = None) -> int:
    """Run the command line if it is installed, else say how to install it."""
    args = sys.argv[1:] if argv is None else list(argv)
    try:
        from anonloc_cli.app import main as cli
    except ModuleNotFoundError as error:  # the cli extra (Typer) is not installed
        if (error.name or "").split(".")[0] not in ("anonloc_cli", "typer", "click"):
            raise
        sys.stderr.write("python -m anonloc_env is the command line: pip install 'anonloc[cli]'\n")
        return 1
    cli(args, prog_name="python -m anonloc_env")
    return 0  # pragma: no cover - the command line always exits


if __name__ == "__main__":
    raise SystemExit(main())
