"""Scenarios as the commands take them: a preset name or a TOML/YAML file, plus ``--set`` overrides.

A scenario file is a mapping with an optional ``preset`` (default ``"default"``) and any overrides
of :func:`anonloc_env.make_config`::

    preset = "paper-motion"
    n_robots = 10
    [camera]
    pixel_noise = 1.0

Every scenario is resolved to its :class:`~anonloc_env.config.EnvConfig` before any work starts,
so that a typo stops the command at once with the config's own message (which lists the valid
names or the accepted range).
"""

from __future__ import annotations

import ast
import json
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from anonloc_env._checks import did_you_mean
from anonloc_env.config import EnvConfig

SCENARIO_SUFFIXES = (".toml", ".yaml", ".yml")


class InputError(ValueError):
    """Bad user input, found before any work; the message says what and what is valid."""


@dataclass(frozen=True)
class Scenario:
    """A resolved scenario.

    Attributes:
        name: how tables and files call it (the preset name or the file's stem).
        spec: the arguments of :func:`anonloc_env.parallel_env`: ``{"preset": ..., **overrides}``,
            as plain JSON values (part of every work unit's key).
        config: the config it resolves to.
    """

    name: str
    spec: dict[str, Any]
    config: EnvConfig


def resolve(text: str, sets: Sequence[str] = ()) -> Scenario:
    """The scenario named ``text`` (a preset or a file) with the ``key=value`` overrides ``sets``.

    Raises:
        InputError: an unknown preset, a missing or malformed file, a bad ``--set``, or a config
            the env refuses (unknown key, value out of range).
    """
    from anonloc_env.presets import preset_names

    presets = preset_names()
    if text in presets:
        name, spec = text, {"preset": text}
    elif Path(text).suffix.lower() in SCENARIO_SUFFIXES:
        name, spec = Path(text).stem, read_file(Path(text))
    else:
        raise InputError(
            f"unknown scenario {text!r}{did_you_mean(text, presets)}; valid: a preset {presets} "
            f"or a scenario file ending in {', '.join(SCENARIO_SUFFIXES)}"
        )
    before = spec.get("preset", "default")
    spec = apply_sets(spec, sets)
    after = spec.get("preset", "default")
    if after != before:  # --set preset=...: the rows say which preset ran
        name = after if text in presets else f"{name}+{after}"
    return build(name, spec)


def distinct(scenarios: Sequence[Scenario], texts: Sequence[str]) -> list[Scenario]:
    """``scenarios`` (resolved from ``texts``) renamed where two different ones share a name
    (``a/ten.toml`` and ``b/ten.toml``): each is then called by its path, so that no summary
    row pools them and each keeps its own config in the metadata."""
    specs: dict[str, list[str]] = {}
    for scenario in scenarios:
        key = json.dumps(scenario.spec, sort_keys=True)
        if key not in specs.setdefault(scenario.name, []):
            specs[scenario.name].append(key)
    out = []
    for scenario, text in zip(scenarios, texts, strict=True):
        if len(specs[scenario.name]) > 1:
            path = Path(text)
            label = str(path.with_suffix("")) if path.suffix else text
            scenario = Scenario(label, scenario.spec, scenario.config)
        out.append(scenario)
    return out


def apply_sets(spec: dict[str, Any], sets: Sequence[str]) -> dict[str, Any]:
    """``spec`` with the ``key=value`` overrides ``sets`` merged in (in place; returned)."""
    for item in sets:
        key, value = parse_set(item)
        _merge(spec, key.split("."), value)
    return spec


def build(name: str, spec: Mapping[str, Any]) -> Scenario:
    """Resolve ``spec`` (``{"preset": ..., **overrides}``) to a :class:`Scenario`."""
    from anonloc_env.presets import make_config

    try:
        plain = json.loads(json.dumps(spec))  # lists for tuples; refuses what JSON cannot hold
    except (TypeError, ValueError) as error:
        raise InputError(f"scenario {name!r}: {error}") from error
    except RecursionError:
        raise InputError(f"scenario {name!r}: a value is nested too deeply") from None
    try:
        config = make_config(**plain)
    except (TypeError, ValueError) as error:
        raise InputError(f"scenario {name!r}: {error}") from error
    return Scenario(name, plain, config)


def read_file(path: Path) -> dict[str, Any]:
    """A scenario file's mapping (TOML or YAML)."""
    if not path.is_file():
        raise InputError(f"scenario file {str(path)!r} not found")
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as error:
        raise InputError(
            f"scenario file {str(path)!r} is not UTF-8 text (byte {error.start}: "
            f"{error.reason}); save it as UTF-8"
        ) from None
    try:
        if path.suffix.lower() == ".toml":
            data: Any = _toml().loads(text)
        else:
            data = _yaml_load(text)
    except RecursionError:
        raise InputError(f"scenario file {str(path)!r} is nested too deeply") from None
    except Exception as error:
        raise InputError(f"scenario file {str(path)!r} is not valid: {error}") from error
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise InputError(
            f"scenario file {str(path)!r} must hold a mapping (preset and overrides), "
            f"got {type(data).__name__}"
        )
    return dict(data)


def _yaml_load(text: str) -> Any:
    """YAML as plain data, stricter than ``yaml.safe_load``: no aliases (a few hundred bytes of
    nested aliases expand to gigabytes) and no duplicate keys (TOML refuses them too)."""
    import yaml

    class Loader(yaml.SafeLoader):
        def compose_node(self, parent: Any, index: Any) -> Any:
            if self.check_event(yaml.AliasEvent):
                mark = self.peek_event().start_mark
                raise yaml.YAMLError(
                    f"aliases (*name) are not accepted in scenario files ({mark}); write the "
                    "value out"
                )
            return super().compose_node(parent, index)

        def construct_mapping(self, node: Any, deep: bool = False) -> Any:
            seen: set[Any] = set()
            for key_node, _ in node.value:
                key = self.construct_object(key_node, deep=True)
                if isinstance(key, list | dict):
                    continue  # unhashable: construct_mapping itself refuses it
                if key in seen:
                    raise yaml.YAMLError(f"duplicate key {key!r} ({key_node.start_mark})")
                seen.add(key)
            return super().construct_mapping(node, deep=deep)

    return yaml.load(text, Loader=Loader)  # a SafeLoader subclass: plain data only


def _toml() -> Any:
    if sys.version_info >= (3, 11):
        import tomllib

        return tomllib
    try:  # pragma: no cover - Python 3.10
        import tomli
    except ImportError as error:  # pragma: no cover
        raise InputError(
            "reading TOML on Python 3.10 needs tomli: pip install 'anonloc[cli]'"
        ) from error
    return tomli  # pragma: no cover


def parse_set(item: str) -> tuple[str, Any]:
    """``"camera.pixel_noise=1.5"`` -> ``("camera.pixel_noise", 1.5)``.

    The value is read as JSON, else as a Python literal (``(6, 6)``, ``True``), else kept as a
    string.
    """
    key, sep, raw = item.partition("=")
    key = key.strip()
    if not sep or not key or any(not part for part in key.split(".")):
        raise InputError(f"--set takes key=value (e.g. camera.pixel_noise=1.5), got {item!r}")
    raw = raw.strip()
    for parse in (json.loads, ast.literal_eval):
        try:
            return key, parse(raw)
        except (ValueError, SyntaxError):
            continue
        except (RecursionError, MemoryError):
            raise InputError(f"--set {key}: the value is nested too deeply") from None
    return key, raw


def _merge(spec: dict[str, Any], path: list[str], value: Any) -> None:
    target = spec
    for part in path[:-1]:
        current = target.setdefault(part, {})
        if not isinstance(current, dict):
            raise InputError(f"--set {'.'.join(path)}: {part!r} is not a section")
        target = current
    target[path[-1]] = value
