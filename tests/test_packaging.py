"""What a lab needs to cite and license the package, and the clash of its top-level names with
other distributions (``baselines``, ``agents``) named at import."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.helpers import ROOT

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]  # the cli extra installs it there


def project() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]


def test_license_file_is_the_mit_license_pyproject_declares() -> None:
    assert project()["license"] == "MIT"
    text = (ROOT / "LICENSE").read_text()
    assert text.startswith("MIT License")
    assert "Permission is hereby granted, free of charge" in text


def test_citation_file_matches_the_package_and_cites_both_papers() -> None:
    yaml = pytest.importorskip("yaml", reason="needs pyyaml (the cli extra)")
    citation = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    assert citation["cff-version"] == "1.2.0"
    assert citation["type"] == "software"
    assert citation["version"] == project()["version"]
    assert citation["license"] == project()["license"]
    assert citation["authors"], "CITATION.cff needs at least one author"
    dois = {reference["doi"] for reference in citation["references"]}
    assert dois == {"10.1109/ICCAR.2017.7942694", "10.3390/robotics13100148"}
    for reference in citation["references"]:
        assert reference["authors"][0]["family-names"] == "Poulet"


def test_every_extra_with_a_known_breaking_major_is_capped() -> None:
    extras = project()["optional-dependencies"]
    requirements = [r for extra in ("rl", "ray", "torchrl", "benchmarl") for r in extras[extra]]
    requirements += project()["dependencies"]
    for name in ("stable-baselines3", "torch", "ray[rllib]", "torchrl", "benchmarl", "pettingzoo"):
        specs = [r for r in requirements if r.split(">")[0].split("<")[0] == name]
        assert specs, f"{name} is not required"
        for spec in specs:
            assert "<" in spec, f"{spec}: no upper bound"


def run_python(code: str, cwd: Path, path: list[Path]) -> subprocess.CompletedProcess[str]:
    """``python -c code`` in a fresh interpreter, from ``cwd`` (first on ``sys.path``), with
    ``PYTHONPATH`` set to ``path``."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(str(p) for p in path)}
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=cwd, env=env
    )


def foreign(folder: Path, name: str, version: str, package: bool) -> None:
    """Install (by hand) a distribution ``name`` into ``folder``: its metadata, and a top-level
    package ``name`` if ``package``."""
    info = folder / f"{name}-{version}.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: {version}\n")
    (info / "top_level.txt").write_text(f"{name}\n")
    if package:
        (folder / name).mkdir()
        (folder / name / "__init__.py").write_text("FOREIGN = True\n")


@pytest.mark.parametrize("name", ["agents", "baselines"])
def test_a_foreign_distribution_installed_beside_ours_is_named(tmp_path: Path, name: str) -> None:
    foreign(tmp_path, name, "1.4.0", package=False)
    done = run_python(f"import {name}", cwd=ROOT, path=[ROOT, tmp_path])
    assert done.returncode == 0, done.stderr
    assert "ClashWarning" in done.stderr
    assert f"{name}-1.4.0.dist-info" in done.stderr
    assert f"pip uninstall {name}" in done.stderr


def test_a_foreign_baselines_first_on_the_path_stops_agents_with_a_clear_error(
    tmp_path: Path,
) -> None:
    foreign(tmp_path, "baselines", "0.1.6", package=True)
    done = run_python("import agents", cwd=tmp_path, path=[ROOT])
    assert done.returncode == 1
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("ImportError: the top-level package 'baselines' that Python imports")
    assert str(tmp_path / "baselines") in last
    assert "not anonloc's" in last


def test_the_check_names_a_foreign_agents_first_on_the_path(tmp_path: Path) -> None:
    foreign(tmp_path, "agents", "1.4.0", package=True)
    done = run_python(
        "from baselines._distribution import check; check('agents')", cwd=tmp_path, path=[ROOT]
    )
    assert done.returncode == 1
    assert f"({tmp_path / 'agents'}) is not anonloc's ({ROOT / 'agents'})" in done.stderr


def test_no_warning_when_nothing_clashes() -> None:
    done = run_python("import agents, baselines", cwd=ROOT, path=[ROOT])
    assert done.returncode == 0
    assert "ClashWarning" not in done.stderr
