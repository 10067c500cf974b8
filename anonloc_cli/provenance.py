"""What every output records about how it was made: versions, the command and the configs."""

from __future__ import annotations

import platform
import shlex
import sys
from importlib import metadata
from typing import Any


def versions() -> dict[str, str]:
    """Versions of anonloc, Python and the libraries that decide the numbers."""
    import anonloc_env

    out = {"anonloc": anonloc_env.__version__, "python": platform.python_version()}
    for package in ("numpy", "pymunk", "scipy"):
        try:
            out[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            out[package] = "not installed"
    return out


def command_line() -> str:
    """The command as the user typed it (``anonloc ...``), quoted for a shell."""
    args = [shlex.quote(a) for a in sys.argv[1:]]
    return " ".join(["anonloc", *args])


def provenance(configs: dict[str, Any], **more: Any) -> dict[str, Any]:
    """The record written next to (or inside) every output file.

    Args:
        configs: the full resolved config of each scenario used, by scenario name (as given by
            :func:`anonloc_env.presets.config_to_dict`).
        **more: anything else worth recording (e.g. policies, seeds).
    """
    return {"command": command_line(), "versions": versions(), **more, "configs": configs}


def markdown(record: dict[str, Any]) -> str:
    """The provenance record as a Markdown section (versions inline, configs as JSON)."""
    import json

    lines = ["## How this was made", "", f"Command: `{record['command']}`", ""]
    lines.append(
        "Versions: " + ", ".join(f"{name} {value}" for name, value in record["versions"].items())
    )
    lines.append("")
    for key, value in record.items():
        if key not in ("command", "versions", "configs"):
            lines.append(f"- {key}: `{json.dumps(value)}`")
    lines.append("")
    lines.append("Resolved configs:")
    lines.append("")
    for name, config in record["configs"].items():
        lines += [f"`{name}`:", "", "```json", json.dumps(config, indent=1), "```", ""]
    return "\n".join(lines)
