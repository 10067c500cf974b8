"""The command line's entry points, help texts and start-up cost."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from tests.cli_helpers import ROOT, invoke, run_module
from tests.helpers import python_output

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
    """Only Typer and the registry's list of names (``baselines.catalog``, the standard library
    alone, and ``baselines._distribution``'s clash check, the same) are imported to answer
    ``--help``."""
    code = (
        "import sys; import anonloc_cli.app; "
        "heavy = ['anonloc_env', 'numpy', 'matplotlib', 'pyarrow', 'ray', 'imageio',"
        " 'pygame', 'torch', 'agents']; "
        "heavy += [m for m in sys.modules if m.startswith('baselines.')]; "
        "light = ('baselines.catalog', 'baselines._distribution'); "
        "print([m for m in heavy if m in sys.modules and m not in light])"
    )
    assert python_output(code) == "[]"


def test_no_library_module_imports_the_cli() -> None:
    offenders = [
        str(path.relative_to(ROOT))
        for package in ("anonloc_env", "baselines", "agents")
        for path in (ROOT / package).rglob("*.py")
        if path.name != "__main__.py" and "anonloc_cli" in path.read_text()
    ]
    assert offenders == []


def test_the_help_lists_the_registry_with_a_plugin_it_never_imports(tmp_path: Path) -> None:
    """``anonloc bench --help`` (the real console script) reads its policy and excitation names
    from the registry: a policy a package registers by entry point is listed at once, and its
    module is not imported to list it (here importing it would fail)."""
    import os
    import re

    from baselines.catalog import BUILT_IN_POLICIES, excitation_names, policy_names
    from tests.cli_helpers import SCRIPT, script_env

    info = tmp_path / "plugin_help-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: plugin-help\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text("[anonloc.policies]\nhelpdemo = plugin_help:team\n")
    (tmp_path / "plugin_help.py").write_text("raise RuntimeError('listing imported me')\n")
    env = script_env()
    env["PYTHONPATH"] = os.pathsep.join([env["PYTHONPATH"], str(tmp_path)])
    done = subprocess.run(
        [str(SCRIPT), "bench", "--help"], capture_output=True, text=True, env=env, timeout=60
    )
    assert done.returncode == 0, done.stderr
    text = " ".join(done.stdout.split())  # the help wraps at the terminal's width
    listed = re.search(r"A policy \(repeatable\): ([a-z0-9_, ]+)\.", text)
    assert listed is not None
    names = listed.group(1).split(", ")
    built_in = list(BUILT_IN_POLICIES)
    assert names[: len(built_in)] == built_in  # the built-in ones first, in their order
    # then every registered one (entry points come in the order the path lists them)
    assert sorted(names) == sorted({*policy_names(), "helpdemo"})
    assert f"the policy's own): {', '.join(excitation_names())}." in text
