"""The command line's entry points, help texts and start-up cost."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from tests.cli_helpers import ROOT, invoke, run_module

COMMANDS = ["reproduce", "bench", "study", "render", "frame"]


@pytest.mark.parametrize("command", COMMANDS)
def test_every_command_has_help_quiet_and_verbose(command: str) -> None:
    result = invoke(command, "--help")
    assert result.exit_code == 0
    for option in ("--help", "--quiet", "--verbose"):
        assert option in result.output


def test_root_help_lists_the_commands() -> None:
    result = invoke("--help")
    assert result.exit_code == 0
    for command in COMMANDS:
        assert command in result.output


def test_version() -> None:
    import anonloc_env

    result = invoke("--version")
    assert result.exit_code == 0
    assert anonloc_env.__version__ in result.output


def test_python_m_anonloc_cli_and_anonloc_env_run_the_cli() -> None:
    for module in ("anonloc_cli", "anonloc_env"):
        done = run_module("--help", module=module)
        assert done.returncode == 0, done.stderr
        assert "reproduce" in done.stdout
        assert "bench" in done.stdout


def test_python_m_anonloc_env_frame_writes_a_png_quietly(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("pygame", reason="the frame needs pygame-ce")
    for name in ("SDL_VIDEODRIVER", "SDL_AUDIODRIVER", "XDG_RUNTIME_DIR", "DISPLAY"):
        monkeypatch.delenv(name, raising=False)  # a headless machine, as a user has it
    out = tmp_path / "f.png"
    args = ("frame", "--out", out, "--steps", "5", "--quiet")
    done = run_module(*args, module="anonloc_env", sdl_dummy=False)
    assert done.returncode == 0, done.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert str(out.resolve()) in done.stdout  # it says where it wrote
    assert done.stderr == ""  # no SDL message (XDG_RUNTIME_DIR) on a headless machine


def test_help_imports_nothing_heavy() -> None:
    code = (
        "import sys; import anonloc_cli.app; "
        "heavy = ['anonloc_env', 'baselines', 'numpy', 'matplotlib', 'pyarrow', 'ray', 'imageio',"
        " 'pygame', 'torch']; print([m for m in heavy if m in sys.modules])"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True
    )
    assert done.stdout.strip() == "[]"


def test_no_library_module_imports_the_cli() -> None:
    offenders = [
        str(path.relative_to(ROOT))
        for package in ("anonloc_env", "baselines", "agents")
        for path in (ROOT / package).rglob("*.py")
        if path.name != "__main__.py" and "anonloc_cli" in path.read_text()
    ]
    assert offenders == []


def test_the_help_names_every_registered_policy_and_excitation() -> None:
    """The help text is written out (importing the registry would cost ``anonloc --help`` about
    half a second), so this keeps it equal to the registry: a name registered and not listed,
    or listed and gone, fails here."""
    import re

    from baselines.registry import excitation_names, policy_names

    source = (ROOT / "anonloc_cli" / "app.py").read_text()
    text = re.sub(r'"\s*\n\s*"', "", source)  # join implicitly concatenated strings
    policies = re.search(r"A policy: ([a-z0-9, ]+)", text)
    excitations = re.search(r"the policy's own\): ([a-z0-9, ]+)\.", text)
    assert policies is not None
    assert excitations is not None
    assert [n.strip() for n in policies.group(1).split(",")] == policy_names()
    assert [n.strip() for n in excitations.group(1).split(",")] == excitation_names()
