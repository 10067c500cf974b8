"""The linear scorer as a numpy excitation: what a search plays (:mod:`agents.search`).

:class:`LinearChooser` draws each robot's candidate from ``softmax(terms @ weights)`` with the
robot's own generator, in float64; the saved agent (:mod:`agents.linear_agent`) computes the
same logits in float32 with torch (a test checks they agree within 1e-5). All weights zero is
``uniform`` bit for bit.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from agents.candidates import CandidateChooser
from agents.linear_agent import LINEAR_SPEC
from agents.linear_terms import check_weights, linear_terms
from agents.policy import draw
from agents.spec import AgentSpec
from baselines.excitations import Excitation
from baselines.excitations.rest import at_rest


class LinearChooser(CandidateChooser):
    """Candidates drawn from ``softmax(terms @ weights)`` with each robot's own generator.

    Args:
        weights: ``(T,)`` one weight per term of ``spec.terms``; all zeros is ``uniform`` bit
            for bit.
        spec: the features and terms (default: :func:`agents.linear_agent.linear_spec`'s, the
            layout's features and :data:`agents.linear_terms.LINEAR_TERMS`).
    """

    def __init__(self, weights: np.ndarray, spec: AgentSpec = LINEAR_SPEC) -> None:
        super().__init__(spec.candidates, features=spec.features)
        self.weights = check_weights(weights, len(spec.terms))
        self.terms = spec.terms
        self.columns = spec.columns()

    def on_scored(self) -> None:
        if self.cset is None:
            return
        obs = self.observation
        terms = linear_terms(
            obs["candidates"].astype(np.float64),
            obs["context"].astype(np.float64),
            np.stack,
            self.terms,
            self.columns,
        )
        self.decide(draw(terms @ self.weights, self.rngs))


def chooser(
    weights: np.ndarray, rest: float | None = None, spec: AgentSpec = LINEAR_SPEC
) -> Callable[[], Excitation]:
    """A maker of the linear scorer of ``spec`` with ``weights`` (zeros: ``uniform``), at rest
    once its belief reaches ``rest`` (None: never; zeros then: ``uniform-rest``)."""
    return lambda: at_rest(LinearChooser(weights, spec), rest)
