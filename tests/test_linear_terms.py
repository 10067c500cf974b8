"""``agents.linear_terms``: the gates open where their documentation says (numpy only)."""

from __future__ import annotations

import numpy as np

from agents.candidate_features import CANDIDATE_COLUMN, CONTEXT_COLUMN
from agents.linear_terms import FAIR, FAIR_TERMS, KNOWN_TERMS, linear_terms


def test_the_fair_gate_opens_at_half_the_belief_and_multiplies_its_base() -> None:
    rng = np.random.default_rng(15)
    candidates = rng.normal(size=(4, 8, 7))
    context = np.zeros((4, 10))
    largest = CONTEXT_COLUMN["largest_belief"]
    context[:, largest] = [0.0, np.nextafter(FAIR, 0.0), FAIR, 0.999]
    terms = linear_terms(candidates, context, np.stack, FAIR_TERMS)
    entropy = FAIR_TERMS.index(KNOWN_TERMS["entropy_after*fair"])
    expected = candidates[..., CANDIDATE_COLUMN["entropy_after"]] * np.array([0, 0, 1, 1])[:, None]
    assert np.array_equal(terms[..., entropy], expected)
    assert all(t.name in KNOWN_TERMS for t in FAIR_TERMS)
