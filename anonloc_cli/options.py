"""The options several ``anonloc`` commands share: one declaration each, and their checks.

Each shared option is an ``Annotated`` alias that a command names as a parameter's type
(``quiet: Quiet = False``), so its flags and help text are written once. :func:`run_options` and
:func:`check_out` check the shared options before any work is done. Like :mod:`anonloc_cli.app`,
this module imports only Typer at the top: ``anonloc --help`` reads it.
"""

from __future__ import annotations

from enum import Enum
from pathlib import Path
from typing import Annotated

import typer

from anonloc_cli.jobs import RunOptions  # a dataclass; jobs imports nothing heavy at the top


class Backend(str, Enum):
    """Where the work units run."""

    process = "process"
    ray = "ray"


Quiet = Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")]
Verbose = Annotated[
    int,
    typer.Option(
        "--verbose", "-v", count=True, help="Log to stderr as JSON lines (-v info, -vv debug)."
    ),
]
BackendOption = Annotated[
    Backend,
    typer.Option(
        help="process: a local process pool; ray: Ray tasks (pip install 'anonloc[ray]')."
    ),
]
Address = Annotated[
    str | None,
    typer.Option(
        help="With --backend ray: the cluster to join (e.g. ray://host:10001 or auto); "
        "default: start a local Ray instance."
    ),
]
Workers = Annotated[
    int | None,
    typer.Option(min=1, help="Parallel workers (default: one per core)."),
]
Pictures = Annotated[
    int | None,
    typer.Option(min=1, help="Stop each episode after K pictures (default: run it to its end)."),
]
Sets = Annotated[
    list[str] | None,
    typer.Option(
        "--set",
        help="Override a config value in every scenario: key=value, e.g. n_robots=10 or "
        "camera.pixel_noise=1.5 (repeatable).",
    ),
]
OutFolder = Annotated[Path, typer.Option(help="Output folder.")]
OutTable = Annotated[Path, typer.Option(help="Output file: .csv or .parquet.")]

#: The table formats ``--out`` writes (``bench``, ``eval``, ``detect``): any other suffix is
#: refused before any work, never written as CSV under a misleading name.
TABLE_SUFFIXES = (".csv", ".parquet")

#: What ``render`` and ``frame`` show without --scenario: the default preset with enough robots
#: that the first pictures leave some of them wrong (with its 4, every guess is right from the
#: second picture on, and a newcomer never sees the problem).
SHOW_SETS = ("n_robots=12",)
ShownScenario = Annotated[
    str | None,
    typer.Option(
        help="A preset or a TOML/YAML scenario file (default: the default preset with 12 robots, "
        "so that the first pictures show wrong guesses)."
    ),
]
ShownPolicy = Annotated[str, typer.Option(help="The policy every robot runs.")]
EpisodeSeed = Annotated[int, typer.Option(help="Episode seed.")]


def run_options(
    backend: Backend, address: str | None, workers: int | None, quiet: bool
) -> RunOptions:
    """The shared run options, checked before any work: a wrong backend must not leave an empty
    store behind."""
    import importlib.util

    from anonloc_cli.scenarios import InputError

    if address is not None and backend is not Backend.ray:
        raise InputError("--address only applies to --backend ray")
    if backend is Backend.ray and importlib.util.find_spec("ray") is None:
        raise InputError("--backend ray needs Ray: pip install 'anonloc[ray]'")
    return RunOptions(backend=backend.value, address=address, workers=workers, quiet=quiet)


def check_table_suffix(out: Path) -> None:
    """Refuse a table output whose suffix is not one of :data:`TABLE_SUFFIXES`."""
    from anonloc_cli.scenarios import InputError

    if out.suffix.lower() not in TABLE_SUFFIXES:
        given = f"a {out.suffix} file" if out.suffix else "no suffix"
        raise InputError(
            f"--out {out}: tables are written as .csv (CSV) or .parquet (Parquet), and this is "
            f"{given}; give FILE.csv (a spreadsheet opens it) or FILE.parquet"
        )


def check_out(out: Path, *, folder: bool) -> None:
    """Refuse an --out that cannot be written before any work is done."""
    import tempfile

    from anonloc_cli.scenarios import InputError

    if folder:
        if out.exists() and not out.is_dir():
            raise InputError(f"--out {out} is a file; give a folder")
        parent = out
        while not parent.exists():  # the folder is made later: check its first existing parent
            parent = parent.parent
    else:
        suffix = out.suffix.lower()
        if suffix in (".md", ".json", ".jsonl"):
            raise InputError(
                f"--out {out}: {suffix} files are written beside the output (summary, metadata, "
                "store); give a .csv or .parquet file"
            )
        if out.is_dir():
            raise InputError(f"--out {out} is a folder; give a file such as {out / 'bench.csv'}")
        check_table_suffix(out)
        parent = out.parent
    if not parent.is_dir():
        raise InputError(f"--out {out}: {parent} is not a folder")
    try:
        with tempfile.TemporaryFile(dir=parent):
            pass
    except OSError as error:
        raise InputError(f"--out {out}: cannot write in {parent} ({error.strerror})") from None
