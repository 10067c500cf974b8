"""The terms of the linear candidate scorer, defined once for numpy and torch.

A linear scorer gives candidate ``c`` of a robot the logit ``sum_k weight_k * term_k(c)``, where
each term is a named candidate feature (:data:`agents.candidate_features.CANDIDATE_SPEC`) times
a named gate read from the robot's context. Softmax ignores anything a robot adds to all its
candidates alike, so every term must vary across candidates; the gates let the preference
depend on the robot's state: whether it has decided its row, and whether it is on swarm duty.

With all weights zero the scorer is ``uniform`` exactly (a fair draw among the candidates), so a
search that starts there measures what it learns against chance from its first step
(:mod:`agents.search`).

:func:`linear_terms` only indexes, multiplies and stacks, so the same function computes the
terms of a batch of numpy observations (the search) and of torch tensors (the SB3 policy,
:class:`agents.features.LinearScorer`); a test checks that both agree.

>>> import numpy as np
>>> linear_terms(np.zeros((2, 8, 7)), np.zeros((2, 10)), np.stack).shape
(2, 8, 18)
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from agents.candidate_features import CANDIDATE_COLUMN, CONTEXT_COLUMN, Feature

#: The belief at which the ``decided`` gate opens: ``bayes``'s decision threshold.
DECIDED = 0.99
#: The candidate features a term is built from (``speed_sq`` is ``speed`` squared, so that a
#: preference can favour the middle or the ends of the speed range; ``abs_turn`` is ``|turn|``).
TERM_BASES = (
    Feature("speed", "forward speed over v_max (on swarm duty the deviation)"),
    Feature("speed_sq", "the square of speed"),
    Feature("abs_turn", "|turn rate| over omega_max (on swarm duty the deviation)"),
    Feature("entropy_after", "expected entropy of the belief after the next picture (nats)"),
    Feature("energy", "energy over the interval over v_max times the interval"),
    Feature("reach", "log1p of the displacement's length over the pixel noise"),
)
#: The gates each base is multiplied by.
TERM_GATES = (
    Feature("always", "1"),
    Feature("decided", f"1 once the robot's largest belief is at least {DECIDED}"),
    Feature("on_duty", "1 on swarm duty"),
)
#: Every term, named ``base*gate``, in the order of :func:`linear_terms`' last axis.
LINEAR_TERMS = tuple(
    Feature(f"{b.name}*{g.name}", f"({b.meaning}) times ({g.meaning})")
    for b in TERM_BASES
    for g in TERM_GATES
)


def _bases(candidates: Any) -> list[Any]:
    speed = candidates[..., CANDIDATE_COLUMN["speed"]]
    turn = candidates[..., CANDIDATE_COLUMN["turn"]]
    return [
        speed,
        speed * speed,
        abs(turn),
        candidates[..., CANDIDATE_COLUMN["entropy_after"]],
        candidates[..., CANDIDATE_COLUMN["energy"]],
        candidates[..., CANDIDATE_COLUMN["reach"]],
    ]


def _gates(context: Any) -> list[Any]:
    one = context[:, None, CONTEXT_COLUMN["scored"]] * 0.0 + 1.0
    decided = (context[:, None, CONTEXT_COLUMN["largest_belief"]] >= DECIDED) * 1.0
    return [one, decided, context[:, None, CONTEXT_COLUMN["on_duty"]]]


def linear_terms(candidates: Any, context: Any, stack: Callable[..., Any]) -> Any:
    """``(B, C, T)`` the terms of every candidate, from ``candidates (B, C, F)`` and
    ``context (B, X)`` (numpy arrays with ``stack=np.stack``, or torch tensors with
    ``stack=torch.stack``), in :data:`LINEAR_TERMS`' order."""
    gates = _gates(context)
    return stack([base * gate for base in _bases(candidates) for gate in gates], -1)


def check_weights(weights: Any) -> np.ndarray:
    """``weights`` as a float64 array of one finite weight per term of :data:`LINEAR_TERMS`.

    Raises:
        ValueError: another length, or a weight that is not finite.
    """
    out = np.asarray(weights, np.float64)
    if out.shape != (len(LINEAR_TERMS),) or not np.all(np.isfinite(out)):
        raise ValueError(f"weights must be {len(LINEAR_TERMS)} finite numbers, got {out.tolist()}")
    return out
