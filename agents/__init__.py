"""agents: robots that learn to move so that they are recognised.

Every robot runs the same policy on its own observation: a few candidate commands drawn from its
own generator, each scored by its own Bayesian identifier (:mod:`agents.candidate_features`); the
policy picks one (:mod:`agents.features`). K copies of the env become one SB3 ``VecEnv`` with a
slot per robot (:mod:`agents.vec`). A general agent ships with the package
(:data:`agents.policy.BUNDLED`).

Needs the ``rl`` extra (stable-baselines3 and torch; install ``torch==2.13.0`` first, see the
README). Submodules that need torch import it themselves: ``import agents`` alone is cheap.
"""

from __future__ import annotations

try:
    from baselines._distribution import check as _check_distribution
except ModuleNotFoundError as missing:  # the `baselines` found first is not anonloc's
    import baselines

    raise ImportError(
        f"the top-level package 'baselines' that Python imports ({baselines.__path__}) is not "
        "anonloc's: another distribution with that name comes first on sys.path. Install "
        "anonloc in a virtual environment without it (pip uninstall baselines); see "
        "docs/design.md, 'Packaging'",
        name="baselines",
    ) from missing

# A foreign `baselines` first on sys.path can still lend anonloc's `baselines._distribution`
# (an editable install's finder maps submodules by name), so check what `baselines` is too.
_check_distribution("baselines")
# `agents` 1.4.0 on the package index has this top-level name too (docs/design.md).
_check_distribution("agents")
