"""``python -m anonloc_cli``: the ``anonloc`` command line."""

from __future__ import annotations

from anonloc_cli.app import main

if __name__ == "__main__":
    main(prog_name="python -m anonloc_cli")
