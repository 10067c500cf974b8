"""Work units for the job-runner tests (``kind="tests.cli_units"``): ones whose worker dies."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from anonloc_cli.jobs import Unit


def run_unit(unit: Unit) -> dict[str, Any]:
    """``params["die"]``: ``"once"`` kills the worker on the first try (a marker file remembers
    it), ``"always"`` on every try; anything else returns at once."""
    die = unit.params.get("die")
    marker = Path(unit.params.get("marker", "")) / f"{unit.key}.tried"
    if die == "always" or (die == "once" and not marker.exists()):
        marker.touch()
        os._exit(1)  # a worker killed from within: no exception, no cleanup
    return {"seed": unit.seed}
