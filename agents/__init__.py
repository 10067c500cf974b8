"""agents: robots that learn to move so that they are recognised.

Every robot runs the same policy on its own observation, annotated with what its own Bayesian
identifier believes (:mod:`agents.observation`); K copies of the env become one SB3 ``VecEnv``
with a slot per robot (:mod:`agents.vec`); permutation-invariant features extractors read the
rows of a picture as a set (:mod:`agents.features`).

Needs the ``rl`` extra (stable-baselines3 and torch; install ``torch==2.13.0`` first, see the
README). Submodules that need torch import it themselves: ``import agents`` alone is cheap.
"""

from __future__ import annotations
