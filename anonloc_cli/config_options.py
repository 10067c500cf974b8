"""Command-line options generated from a config dataclass, as CleanRL builds its command line
from its ``Args``: one option per field, named after it, with the field's default and the first
sentence of its docstring as help; the config validates the values (its ``__post_init__`` names
the field and the accepted range).

The fields are read from the class's *source* (``ast``), not by importing it, so that
``anonloc --help`` stays instant: ``agents.train`` pulls in numpy, gymnasium and the baselines.
A field whose default is not a literal (a ``default_factory``) or whose type is not one of
:data:`TYPES` gets no option; the command names those it handles itself in ``skip``.

>>> fields = config_fields("agents", "train.py", "TrainConfig")
>>> fields["gamma"].default
0.99
"""

from __future__ import annotations

import ast
import functools
import importlib.util
import inspect
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import typer

#: The field types that become options (annotation as written -> type Typer parses).
TYPES: dict[str, Any] = {
    "int": int,
    "float": float,
    "str": str,
    "bool": bool,
    "int | None": int | None,
    "float | None": float | None,
    "str | None": str | None,
}


@dataclass(frozen=True)
class ConfigField:
    """One field of a config class as its source declares it.

    Attributes:
        name: the field's name (the option is ``--name`` with ``_`` as ``-``).
        kind: the type Typer parses (a value of :data:`TYPES`).
        default: the field's literal default.
        doc: the field's docstring (the string right below it).
    """

    name: str
    kind: Any
    default: Any
    doc: str


def config_fields(package: str, module_file: str, class_name: str) -> dict[str, ConfigField]:
    """The fields of ``class_name`` declared in ``module_file`` of ``package`` that can become
    options, in declaration order (the package is located, not imported)."""
    spec = importlib.util.find_spec(package)
    if spec is None or not spec.submodule_search_locations:
        raise ImportError(f"package {package!r} is not installed")
    source = Path(next(iter(spec.submodule_search_locations))) / module_file
    tree = ast.parse(source.read_text(encoding="utf-8"))
    body = next(
        node.body
        for node in ast.walk(tree)
        if isinstance(node, ast.ClassDef) and node.name == class_name
    )
    out = {}
    for node, after in zip(body, [*body[1:], None], strict=True):
        if not (isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name)):
            continue
        kind = TYPES.get(ast.unparse(node.annotation))
        try:
            default = ast.literal_eval(node.value) if node.value is not None else None
        except ValueError:  # a default_factory: not an option
            continue
        if kind is None or node.value is None:
            continue
        doc = ""
        if isinstance(after, ast.Expr) and isinstance(after.value, ast.Constant):
            doc = inspect.cleandoc(str(after.value.value))
        out[node.target.id] = ConfigField(node.target.id, kind, default, doc)
    return out


def _help(doc: str) -> str:
    """The first sentence of a docstring, on one line, without reST markup."""
    text = re.sub(r":\w+:`([^`]*)`", r"\1", " ".join(doc.split())).replace("``", "")
    end = text.find(". ")
    return text if end < 0 else text[: end + 1]


def with_config_options(
    fields: dict[str, ConfigField], skip: set[str]
) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """Decorate a Typer command that takes ``config: dict[str, Any]`` (the generated options'
    values by field name): its signature gains one option per field of ``fields`` not in
    ``skip``, after its own parameters."""
    chosen = [f for name, f in fields.items() if name not in skip]

    def decorate(command: Callable[..., Any]) -> Callable[..., Any]:
        own = [
            p
            for p in inspect.signature(command, eval_str=True).parameters.values()
            if p.name != "config"
        ]
        taken = {p.name for p in own}
        clash = taken & {f.name for f in chosen}
        if clash:
            raise ValueError(f"options {sorted(clash)} are both generated and the command's own")
        generated = [
            inspect.Parameter(
                f.name,
                inspect.Parameter.KEYWORD_ONLY,
                default=f.default,
                annotation=Annotated[f.kind, typer.Option(help=_help(f.doc))],
            )
            for f in chosen
        ]

        @functools.wraps(command)
        def wrapper(**kwargs: Any) -> Any:
            config = {f.name: kwargs.pop(f.name) for f in chosen}
            return command(**kwargs, config=config)

        parameters = [p.replace(kind=inspect.Parameter.KEYWORD_ONLY) for p in own] + generated
        wrapper.__signature__ = inspect.Signature(parameters)  # type: ignore[attr-defined]  # read by Typer
        wrapper.__annotations__ = {p.name: p.annotation for p in parameters}
        return wrapper

    return decorate
