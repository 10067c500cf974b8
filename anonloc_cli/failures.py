"""How an ``anonloc`` command ends when something expected goes wrong: a message, not a trace.

Every command runs inside :func:`failures_reported`, which sets up logging and turns bad input, a
busy store, a failed work unit, Ctrl-C and a full disk into a one-line message on stderr and an
exit status (2: bad input or a backend that cannot run; 1: a busy store, a failed unit or a
full disk; 130: interrupted). Only Typer is imported at the top.

Ctrl-C works in every command, even one started in the background from a script (``anonloc train
... &``): such a job inherits SIGINT as *ignored*, and Python then installs no handler, so
:func:`failures_reported` then installs Python's own (``KeyboardInterrupt``) explicitly.
"""

from __future__ import annotations

import contextlib
import errno
import signal
import threading
from collections.abc import Iterator

import typer

#: Errors of a disk that cannot take more (full, over quota, read-only): a message, not a trace.
_DISK_ERRORS = (errno.ENOSPC, errno.EDQUOT, errno.EROFS)


@contextlib.contextmanager
def failures_reported(verbose: int) -> Iterator[None]:
    """Set up logging; turn the expected failures into a message and an exit status."""
    from anonloc_cli.console import setup_logging

    setup_logging(verbose)
    main = threading.current_thread() is threading.main_thread()
    if main and signal.getsignal(signal.SIGINT) is signal.SIG_IGN:  # a background job's
        signal.signal(signal.SIGINT, signal.default_int_handler)
    from anonloc_cli.jobs import BackendError, UnitError
    from anonloc_cli.scenarios import InputError
    from anonloc_cli.store import StoreBusyError

    try:
        yield
    except (InputError, BackendError) as error:
        typer.echo(f"Error: {error}", err=True)
        raise typer.Exit(2) from None
    except (StoreBusyError, UnitError) as error:
        typer.echo(f"Error: {error}", err=True)
        raise typer.Exit(1) from None
    except KeyboardInterrupt:
        typer.echo(
            "\nInterrupted. Every finished unit is saved; run the same command again to resume.",
            err=True,
        )
        raise typer.Exit(130) from None
    except OSError as error:
        if error.errno not in _DISK_ERRORS:
            raise
        where = f" {error.filename}" if error.filename else ""
        typer.echo(
            f"Error: cannot write{where}: {error.strerror}. What was finished before is kept "
            "(stored units, checkpoints); make room and run the same command again (train: "
            "--resume).",
            err=True,
        )
        raise typer.Exit(1) from None
