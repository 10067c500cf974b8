"""Griffe extension: render Sphinx roles in docstrings as links on the docs site.

The package's docstrings cite other objects with Sphinx roles (``:class:`EnvConfig```,
``:func:`anonloc_env.parallel_env```, ``:mod:`anonloc_env.camera```). mkdocstrings renders
docstrings as Markdown, where a role would show up as the literal text ``:class:``. This extension
rewrites each role, before the docstring is parsed, into an optional cross-reference: a link when
the target is documented on the site, plain code otherwise.

A role whose target does not resolve in the docstring's scope is logged as a warning, so a typo
fails ``mkdocs build --strict``. Configured in ``mkdocs.yml`` (python handler, ``extensions``).
"""

from __future__ import annotations

import html
import re
from typing import Any

import griffe

_ROLE = re.compile(r":(?:py:)?(?:class|func|meth|mod|data|attr|obj|exc|const):`(?P<target>[^`]+)`")
_logger = griffe.get_logger(__name__)


class SphinxRoles(griffe.Extension):
    """Replace ``:role:`target``` in every docstring of the loaded package."""

    def on_object(self, *, obj: griffe.Object, loader: griffe.GriffeLoader, **kwargs: Any) -> None:
        """Rewrite the roles of ``obj``'s docstring (the object tree is complete here)."""
        docstring = obj.docstring
        if docstring is None or ":`" not in docstring.value:
            return

        def replace(match: re.Match[str]) -> str:
            target = match["target"].strip()
            shown = target
            if target.startswith("~"):
                target = target[1:]
                shown = target.rsplit(".", 1)[-1]
            path = _resolve(obj, target, loader)
            code = f"<code>{html.escape(shown)}</code>"
            if path is None:
                _logger.warning(
                    "%s: cannot resolve %r in a docstring of %s",
                    obj.relative_filepath,
                    match[0],
                    obj.path,
                )
                return code
            return f'<autoref identifier="{html.escape(path)}" optional>{code}</autoref>'

        docstring.value = _ROLE.sub(replace, docstring.value)


def _resolve(obj: griffe.Object, target: str, loader: griffe.GriffeLoader) -> str | None:
    """Full path of ``target`` seen from ``obj`` (its own scope first, then absolute paths)."""
    scope = obj if obj.is_module or obj.is_class else obj.parent
    if scope is not None and "." not in target:
        try:
            return scope.resolve(target)
        except griffe.NameResolutionError:
            pass
    try:
        found = loader.modules_collection[target]
    except (KeyError, ValueError, griffe.AliasResolutionError):
        return None
    if found.is_alias:
        try:
            return found.final_target.path
        except (griffe.AliasResolutionError, griffe.CyclicAliasError):
            return found.target_path
    return found.path
