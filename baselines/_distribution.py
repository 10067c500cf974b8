"""The anonloc distribution's top-level packages, and a check that no other distribution claims one.

anonloc installs four top-level packages: ``anonloc_env``, ``baselines``, ``agents`` and the
command line's. Two of those names are taken on the package index by unrelated distributions
(OpenAI's ``baselines``, and ``agents``). Installed into one environment, two distributions with
one top-level name write into the same folder, and whichever was installed last overwrites the
other's files; on ``sys.path``, a package found first hides the other whole. ``baselines`` and
``agents`` call :func:`check` when imported, so the clash is named where it happens instead of
surfacing as a missing attribute (``docs/design.md``, "Packaging"). A foreign package found
before anonloc's never runs anonloc's code: ``agents`` names that case for ``baselines``; for
``agents`` itself, and for ``baselines`` imported alone, Python's own error is all there is.

Standard library only, and cheap (``import baselines`` stays light): a ``find_spec`` (nothing
imported) and one folder listing per ``sys.path`` entry.
"""

from __future__ import annotations

import importlib.util
import sys
import warnings
from pathlib import Path

#: Top-level names anonloc shares with other distributions on the package index.
SHARED_NAMES = ("baselines", "agents")
#: Where anonloc's top-level packages are: the folder that holds ``baselines`` (and the others).
HOME = Path(__file__).resolve().parent.parent


class ClashWarning(UserWarning):
    """Another installed distribution also provides one of anonloc's top-level packages."""


def foreign_distributions(name: str, path: list[str] | None = None) -> list[Path]:
    """The metadata folders (``*.dist-info``, ``*.egg-info``) on ``path`` (default
    ``sys.path``) of distributions called ``name``: a distribution other than anonloc whose
    top-level package is ``name``."""
    found: list[Path] = []
    for entry in sys.path if path is None else path:
        folder = Path(entry or ".")
        if not folder.is_dir():
            continue
        for suffix in ("dist-info", "egg-info"):
            found.extend(sorted(folder.glob(f"{name}-*.{suffix}")))
    return found


def location(name: str) -> Path | None:
    """The folder (or file) that ``import name`` would load, found without importing it;
    None when there is none."""
    spec = importlib.util.find_spec(name)
    if spec is None:
        return None
    if spec.submodule_search_locations:
        return Path(next(iter(spec.submodule_search_locations))).resolve()
    return Path(spec.origin).resolve() if spec.origin else None


def check(name: str) -> None:
    """Make sure the top-level package ``name`` that Python imports is anonloc's.

    Raises:
        ImportError: the package that ``import name`` finds is another one, elsewhere (it comes
            first on ``sys.path``), so anonloc's cannot be imported in this environment.

    Warns:
        ClashWarning: another distribution called ``name`` is installed beside anonloc; its
            files and anonloc's may have overwritten each other.
    """
    ours = HOME / name
    where = location(name)
    if where is not None and where != ours:
        raise ImportError(
            f"the top-level package {name!r} that Python imports ({where}) is not anonloc's "
            f"({ours}): another distribution with that name comes first on sys.path. Install "
            f"anonloc in a virtual environment without it (pip uninstall {name}); see "
            "docs/design.md, 'Packaging'",
            name=name,
        )
    clashing = foreign_distributions(name)
    if clashing:
        warnings.warn(
            f"another distribution provides a top-level package {name!r} too "
            f"({', '.join(str(p) for p in clashing)}): installed in one environment, it and "
            f"anonloc overwrite each other's {name}/ files. Uninstall it (pip uninstall {name}) "
            "or give anonloc its own virtual environment; see docs/design.md, 'Packaging'",
            ClashWarning,
            stacklevel=3,
        )
