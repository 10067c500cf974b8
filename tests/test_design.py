"""docs/design.md's arrows, read from the code: which package may import which, and no cycles.

Every import counts, at module level or inside a function (a lazy import is still an arrow), and
under ``TYPE_CHECKING`` too.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("anonloc_env", "baselines", "agents", "anonloc_cli")
#: package -> the packages it must not import.
FORBIDDEN = {
    "anonloc_env": {"baselines", "agents", "anonloc_cli"},
    "baselines": {"agents", "anonloc_cli"},
    "agents": {"anonloc_cli"},
}
#: Inside ``anonloc_env``: module prefix -> the modules it must not import. The identifier is pure
#: maths on pictures (it never renders, measures a detector or runs an env); the image path is a
#: detection source and its calibration tools (they never run an env or read beliefs).
INNER = {
    "anonloc_env.identify": (
        "anonloc_env.images",
        "anonloc_env.detection",
        "anonloc_env.env",
        "anonloc_env.rewards",
    ),
    "anonloc_env.images": ("anonloc_env.env", "anonloc_env.rewards", "anonloc_env.identify"),
}
#: ``python -m anonloc_env`` is the command line, as the ``anonloc`` console script is.
ALLOWED = {("anonloc_env.__main__", "anonloc_cli.app")}


def _modules(root: Path) -> dict[str, Path]:
    out = {}
    for package in PACKAGES:
        for file in sorted((root / package).rglob("*.py")):
            parts = list(file.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            out[".".join(parts)] = file
    return out


def import_graph(root: Path = ROOT) -> dict[str, set[str]]:
    """module -> the project modules it imports (``from p import m`` counts as ``p.m`` when
    ``m`` is a module, else as ``p``)."""
    modules = _modules(root)

    def resolve(name: str) -> str | None:
        while name and name not in modules:
            name = name.rpartition(".")[0]
        return name or None

    graph: dict[str, set[str]] = {}
    for name, file in modules.items():
        package = name if file.name == "__init__.py" else name.rpartition(".")[0]
        targets: set[str | None] = set()
        for node in ast.walk(ast.parse(file.read_text(), str(file))):
            if isinstance(node, ast.Import):
                targets.update(resolve(alias.name) for alias in node.names)
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    parts = package.split(".")[: len(package.split(".")) - node.level + 1]
                    base = ".".join([*parts, *([node.module] if node.module else [])])
                for alias in node.names:
                    full = f"{base}.{alias.name}"
                    targets.add(full if full in modules else resolve(base))
        graph[name] = {t for t in targets if t is not None and t != name}
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The groups of modules that import each other round a circle (strongly connected
    components of more than one module; Tarjan's algorithm, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                group = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    group.append(member)
                    if member == node:
                        break
                if len(group) > 1:
                    found.append(sorted(group))
    return found


GRAPH = import_graph()


@pytest.mark.parametrize("package", sorted(FORBIDDEN))
def test_a_package_imports_nothing_above_it(package: str) -> None:
    upward = sorted(
        (module, target)
        for module, targets in GRAPH.items()
        if module.split(".")[0] == package
        for target in targets
        if target.split(".")[0] in FORBIDDEN[package] and (module, target) not in ALLOWED
    )
    assert upward == []


@pytest.mark.parametrize("inner", sorted(INNER))
def test_inner_layers_of_the_env(inner: str) -> None:
    crossing = sorted(
        (module, target)
        for module, targets in GRAPH.items()
        if module == inner or module.startswith(inner + ".")
        for target in targets
        if any(target == f or target.startswith(f + ".") for f in INNER[inner])
    )
    assert crossing == []


def test_nothing_but_the_command_line_imports_it() -> None:
    importers = sorted(
        module
        for module, targets in GRAPH.items()
        if not module.startswith("anonloc_cli")
        and any(t.startswith("anonloc_cli") for t in targets)
        and not any((module, t) in ALLOWED for t in targets)
    )
    assert importers == []


def test_no_import_cycles() -> None:
    assert cycles(GRAPH) == []


def test_the_checker_sees_lazy_imports_and_cycles(tmp_path: Path) -> None:
    """The reader is not blind: a lazy upward import and a two-module circle are found."""
    for package in PACKAGES:
        (tmp_path / package).mkdir()
        (tmp_path / package / "__init__.py").write_text("")
    (tmp_path / "baselines" / "a.py").write_text(
        "from baselines import b\n\ndef f():\n    import agents.x\n"
    )
    (tmp_path / "baselines" / "b.py").write_text("from . import a\n")
    (tmp_path / "agents" / "x.py").write_text("")
    graph = import_graph(tmp_path)
    assert graph["baselines.a"] == {"baselines.b", "agents.x"}
    assert graph["baselines.b"] == {"baselines.a"}
    assert cycles(graph) == [["baselines.a", "baselines.b"]]
