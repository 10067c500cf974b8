"""The names of the policies and the excitations, and where each one is defined.

Everything that lists names reads this module (:func:`policy_names`, :func:`excitation_names`,
the command line's help texts): it imports nothing but the standard library, so listing costs
no numpy, no physics and no plug-in. :mod:`baselines.registry` loads the classes named here when
it builds them.

Other packages add policies without ``baselines`` importing them: under the entry-point group
:data:`ENTRY_POINTS` (``name = "module:factory"`` in the package's ``pyproject.toml``; ``agents``
registers ``agent`` so), or at run time with :func:`register_policy`. A factory is called as
``factory(config, n, mode, excitation, **kwargs)`` and returns a
:class:`~baselines.policies.Team`; it is imported only when its name is built.

Which one wins when a name is claimed twice (:func:`plugin_notes` says it, and the command line
prints it): a built-in name always means the built-in policy (an entry point with that name is
ignored); :func:`register_policy` comes before an entry point; of two entry points with one name,
anonloc's own (``agent``) wins, else the one whose package's name sorts first
(case-insensitively). A plug-in that fails to
import, whatever it raises, is a :class:`PluginError` naming the plug-in, its entry point and the
error.
"""

from __future__ import annotations

from collections.abc import Callable, Collection
from dataclasses import dataclass
from importlib import import_module, metadata
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from baselines.policies import Team


@dataclass(frozen=True)
class Entry:
    """A built-in name.

    Attributes:
        target: ``"module:attribute"``, where the class is defined.
        excitation: for a policy, the name of the excitation its method prescribes (empty for an
            excitation).
    """

    target: str
    excitation: str = ""

    def load(self) -> Any:
        """The class ``target`` names (its module is imported now)."""
        module, _, attribute = self.target.partition(":")
        return getattr(import_module(module), attribute)


#: The built-in policies: a localizer and the excitation its method prescribes.
BUILT_IN_POLICIES: dict[str, Entry] = {
    "angular": Entry("baselines.localizers:AngularLocalizer", "angular"),
    "linear": Entry("baselines.localizers:LinearLocalizer", "linear"),
    "motion": Entry("baselines.localizers:MotionLocalizer", "random"),
    "motion3": Entry("baselines.localizers:Motion3Localizer", "random"),
    "bayes": Entry("baselines.localizers:BayesLocalizer", "random"),
    "mlp": Entry("baselines.mlp:MLPLocalizer", "random"),
}

BUILT_IN_EXCITATIONS: dict[str, Entry] = {
    "still": Entry("baselines.excitations:Still"),
    "angular": Entry("baselines.excitations:Angular"),
    "linear": Entry("baselines.excitations:Linear"),
    "random": Entry("baselines.excitations:RandomMotion"),
    "swarm": Entry("baselines.excitations:SwarmMotion"),
    "distinct": Entry("baselines.excitations:DistinctMotion"),
    "greedy": Entry("baselines.active:GreedyIdentification"),
    "gaps": Entry("baselines.excitations:GapSeeking"),
    "uniform": Entry("baselines.excitations.uniform:UniformChoice"),
    "uniform-rest": Entry("baselines.excitations.rest:uniform_rest"),
}
"""The excitations by name. ``random`` is the paper's random motion (the excitation of the
``motion`` localizer); ``swarm`` is ``SwarmMotion`` with its defaults (jitter ``SWARM_JITTER``,
common seed 0); ``distinct`` is ``DistinctMotion``; ``greedy`` is
``baselines.active.GreedyIdentification``; ``uniform`` is
``baselines.excitations.uniform.UniformChoice`` (chance among the learned agent's candidates,
its no-learning ablation); ``uniform-rest`` is ``uniform`` with the robots that are sure of
themselves (largest belief at least 0.999) at rest (``baselines.excitations.rest``); ``gaps`` is
``GapSeeking``, the crowd-aware one (``docs/crowds.md``)."""

RENAMED = {"motion": "random"}
"""Old excitation names, still accepted with a ``DeprecationWarning``: old name -> new name.
``motion`` named both a localizer and this excitation; the excitation is now only ``random``."""

#: The entry-point group other packages register policies under.
ENTRY_POINTS = "anonloc.policies"

#: ``factory(config, n, mode, excitation, **kwargs) -> Team``.
PolicyFactory = Callable[..., "Team"]

_registered: dict[str, PolicyFactory] = {}


def register_policy(name: str, factory: PolicyFactory) -> None:
    """Make ``name`` a policy built by ``factory`` (see the module documentation).

    Raises:
        ValueError: ``name`` is a built-in policy's.
    """
    if name in BUILT_IN_POLICIES:
        raise ValueError(f"{name!r} is a built-in policy; valid new names are any others")
    _registered[name] = factory


class PluginError(ImportError):
    """A registered policy's module could not be imported (or raised while importing)."""


def _origin(entry: metadata.EntryPoint) -> str:
    dist = getattr(entry, "dist", None)
    return f"{entry.name} = {entry.value!r} (from {dist.name if dist else 'an unknown package'})"


def _precedence(entry: metadata.EntryPoint) -> tuple[bool, str, str]:
    """Sort key of the claims on one name: anonloc's own first, then by package name."""
    dist = str(getattr(getattr(entry, "dist", None), "name", "")).lower()
    return (dist != "anonloc", dist, entry.value)


def _claims() -> dict[str, list[metadata.EntryPoint]]:
    """Every entry point of :data:`ENTRY_POINTS` by name, the winner first (see the module doc)."""
    claims: dict[str, list[metadata.EntryPoint]] = {}
    for entry in metadata.entry_points(group=ENTRY_POINTS):
        claims.setdefault(entry.name, []).append(entry)
    for entries in claims.values():
        entries.sort(key=_precedence)
    return claims


def _entry_points() -> dict[str, metadata.EntryPoint]:
    return {name: entries[0] for name, entries in _claims().items()}


def plugin_notes(names: Collection[str] | None = None) -> list[str]:
    """One line per policy name that is claimed twice (of ``names``, default all): which claim
    wins and which are ignored (see the module doc)."""
    notes = []
    for name, entries in _claims().items():
        if names is not None and name not in names:
            continue
        ignored = ", ".join(_origin(e) for e in entries)
        if name in BUILT_IN_POLICIES:
            notes.append(f"policy {name!r} is built in; the plug-in {ignored} is ignored")
        elif name in _registered:
            notes.append(
                f"policy {name!r} was registered at run time; the plug-in {ignored} is ignored"
            )
        elif len(entries) > 1:
            others = ", ".join(_origin(e) for e in entries[1:])
            notes.append(
                f"policy {name!r} is claimed by {len(entries)} plug-ins: {_origin(entries[0])} "
                f"is used (anonloc's own, else the package whose name sorts first); ignored: "
                f"{others}"
            )
    return notes


def policy_names() -> list[str]:
    """The valid policy names: the built-in ones, then those registered (entry points and
    :func:`register_policy`). Nothing is imported to list them."""
    names = [*BUILT_IN_POLICIES]
    for name in [*_entry_points(), *_registered]:
        if name not in names:
            names.append(name)
    return names


def excitation_names() -> list[str]:
    """The valid excitation names (:data:`BUILT_IN_EXCITATIONS`)."""
    return list(BUILT_IN_EXCITATIONS)


def registered_factory(name: str) -> PolicyFactory:
    """The factory registered for ``name`` (an entry point's module is imported now).

    Raises:
        KeyError: ``name`` is not registered.
        PluginError: the entry point's module could not be imported, or raised while being
            imported (the message names the plug-in, its entry point and the error).
    """
    if name in _registered:
        return _registered[name]
    entry = _entry_points()[name]
    try:
        factory: PolicyFactory = entry.load()
    except Exception as error:  # a plug-in may raise anything at import
        hint = "; for 'agent': pip install 'anonloc[rl]'" if isinstance(error, ImportError) else ""
        raise PluginError(
            f"policy plug-in {_origin(entry)} failed to import: {type(error).__name__}: "
            f"{error}{hint}"
        ) from error
    return factory
