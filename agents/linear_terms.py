"""The terms of the linear candidate scorer, defined once for numpy and torch.

A linear scorer gives candidate ``c`` of a robot the logit ``sum_k weight_k * term_k(c)``, where
each term is a named candidate feature (:data:`agents.candidate_features.CANDIDATE_SPEC`) times
a named gate read from the robot's context. Softmax ignores anything a robot adds to all its
candidates alike, so every term must vary across candidates; the gates let the preference
depend on the robot's state: whether it has decided its row, and whether it is on swarm duty.
An agent that sees the crowd features (``agents.spec.AgentSpec.with_crowd_features``) has
:data:`CROWD_TERMS`: a gate ``crowding`` and a base ``contact_risk`` more; one searched with
``size`` has :data:`SIZE_TERMS` more: every base times ``rows_free``, the number of robots in
the picture on a log scale, in free motion; an agent with the crowd features may have
:data:`CROWDED_TERMS`, every base times ``crowded``, 1 only where ``crowding`` reaches
:data:`CROWDED`; an agent that sees the arena's ``density`` may have :data:`DENSE_TERMS`,
every base times ``dense``, 1 only where the picture holds at least :data:`DENSE` rows per
square metre; any agent may have :data:`MISSING_TERMS`, every base times ``missing``, the share
of robots a picture misses (0 on a clean camera). Terms are named
``base*gate`` and computed by name from the columns the spec gives each feature.

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

from collections.abc import Callable, Mapping
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
#: The base and the gate an agent with the crowd features
#: (``agents.crowd_features``) adds: its terms are every base times ``crowding`` and
#: ``contact_risk`` times every gate.
CROWD_BASE = Feature("contact_risk", "the candidate's contact risk (agents.crowd_features)")
CROWD_GATE = Feature("crowding", "the crowding around the believed self (agents.crowd_features)")
#: The gate of the size terms (``agents.search.SearchConfig.size``): the context's ``rows``,
#: ``log(rows + 1) / log(1001)``, in free motion, 0 on swarm duty, so that a preference can
#: grow or fade with the number of robots in the picture (0.35 at 10 rows, 0.67 at 100, 1 at
#: 1000) without changing what the robots do on duty (whose terms are gated by ``on_duty``).
SIZE_GATE = Feature(
    "rows_free", "log(rows + 1) / log(1001), rows in the picture, in free motion (0 on duty)"
)
#: The ``crowding`` (``agents.crowd_features``) at which the ``crowded`` gate opens: about the
#: median robot's at 4 robots per m², one robot in twelve at one per m² (``docs/agents.md``,
#: *More episodes where the verdicts were close*).
CROWDED = 2.0
#: A gate that is 1 only in a crowd (``crowding`` at least :data:`CROWDED`), where the product
#: with ``crowding`` of :data:`CROWD_TERMS` also acts in open space.
CROWDED_GATE = Feature("crowded", f"1 where the crowding around the believed self is >= {CROWDED}")
#: The ``density`` (rows per m² of the field of view, ``agents.crowd_features``) at which the
#: ``dense`` gate opens: between 2 per m², where ``greedy``'s trade cost the bundled agent
#: pictures on selection seeds (N = 30: 4.92 against 4.46), and 3 per m², where it saved them
#: (6.79 against 7.42); far above the evaluation's open space (1 per m², with clutter at most
#: 1.05), below its crowds (4 per m²) (``docs/agents.md``, *The arena's density*).
DENSE = 2.5
#: A gate that is 1 in a dense arena (``density`` at least :data:`DENSE`) for every robot, also
#: where none is near: what the ``crowded`` gate, read around each robot, missed (ninth round).
DENSE_GATE = Feature("dense", f"1 where the picture holds >= {DENSE} rows per m² of its view")


def _terms(bases: tuple[Feature, ...], gates: tuple[Feature, ...]) -> tuple[Feature, ...]:
    return tuple(
        Feature(f"{b.name}*{g.name}", f"({b.meaning}) times ({g.meaning})")
        for b in bases
        for g in gates
    )


#: Every term of the default features, named ``base*gate``, in the order of
#: :func:`linear_terms`' last axis.
LINEAR_TERMS = _terms(TERM_BASES, TERM_GATES)
#: The terms of an agent with the crowd features: :data:`LINEAR_TERMS`, then each base times
#: ``crowding``, then ``contact_risk`` times each gate.
CROWD_TERMS = (
    LINEAR_TERMS
    + _terms(TERM_BASES, (CROWD_GATE,))
    + _terms((CROWD_BASE,), (*TERM_GATES, CROWD_GATE))
)
#: The terms a search with ``size`` adds: every base times the ``rows_free`` gate.
SIZE_TERMS = _terms(TERM_BASES, (SIZE_GATE,))
#: The terms an agent with the crowd features may have to act only in a crowd: every base times
#: the ``crowded`` gate.
CROWDED_TERMS = _terms(TERM_BASES, (CROWDED_GATE,))
#: The terms an agent that sees the arena's ``density`` may have to act only in a dense arena:
#: every base times the ``dense`` gate.
DENSE_TERMS = _terms(TERM_BASES, (DENSE_GATE,))
#: A gate that grows with the share of robots a picture misses (``1 - p_detect``), 0 on a clean
#: camera, so that terms behind it leave every clean condition bit for bit (ninth round).
MISSING_GATE = Feature("missing", "1 - p_detect, the share of robots a picture misses")
#: The terms any agent may have to act on a camera that misses robots: every base times the
#: ``missing`` gate.
MISSING_TERMS = _terms(TERM_BASES, (MISSING_GATE,))
#: The belief at which the ``fair`` gate opens: a robot that gives one row at least half its
#: belief has few rivals left, so what a candidate is predicted to tell it (``entropy_after``)
#: is about those few rows, not about a crowd of look-alikes (fifteenth round).
FAIR = 0.5
#: A gate that is 1 once the robot's largest belief is at least :data:`FAIR`.
FAIR_GATE = Feature("fair", f"1 once the robot's largest belief is at least {FAIR}")
#: The terms an agent may have to act once fairly sure: every base times the ``fair`` gate.
FAIR_TERMS = _terms(TERM_BASES, (FAIR_GATE,))

#: Every term this anonloc can compute, by name.
KNOWN_TERMS = {
    t.name: t
    for t in CROWD_TERMS + SIZE_TERMS + CROWDED_TERMS + DENSE_TERMS + MISSING_TERMS + FAIR_TERMS
}


def _base(name: str, candidates: Any, column: Mapping[str, int]) -> Any:
    if name == "speed_sq":
        speed = candidates[..., column["speed"]]
        return speed * speed
    if name == "abs_turn":
        return abs(candidates[..., column["turn"]])
    return candidates[..., column[name]]


#: The gates that open where a context feature reaches a threshold: gate -> (feature, threshold).
THRESHOLD_GATES = {
    "fair": ("largest_belief", FAIR),
    "decided": ("largest_belief", DECIDED),
    "crowded": ("crowding", CROWDED),
    "dense": ("density", DENSE),
}


def _gate(name: str, context: Any, column: Mapping[str, int]) -> Any:
    if name in THRESHOLD_GATES:
        feature, threshold = THRESHOLD_GATES[name]
        return (context[:, None, column[feature]] >= threshold) * 1.0
    if name == "always":
        return context[:, None, column["scored"]] * 0.0 + 1.0
    if name == "rows_free":
        rows = context[:, None, column["rows"]]
        return rows * (1.0 - context[:, None, column["on_duty"]])
    if name == "missing":
        return 1.0 - context[:, None, column["p_detect"]]
    return context[:, None, column[name]]


def linear_terms(
    candidates: Any,
    context: Any,
    stack: Callable[..., Any],
    terms: tuple[Feature, ...] = LINEAR_TERMS,
    columns: tuple[Mapping[str, int], Mapping[str, int]] = (CANDIDATE_COLUMN, CONTEXT_COLUMN),
) -> Any:
    """``(B, C, T)`` the ``terms`` of every candidate, from ``candidates (B, C, F)`` and
    ``context (B, X)`` (numpy arrays with ``stack=np.stack``, or torch tensors with
    ``stack=torch.stack``), whose features sit in ``columns`` (candidate, context: the column of
    each feature by name; :func:`agents.spec.AgentSpec.columns`)."""
    bases: dict[str, Any] = {}
    gates: dict[str, Any] = {}
    out = []
    for term in terms:
        base, gate = term.name.split("*")
        if base not in bases:
            bases[base] = _base(base, candidates, columns[0])
        if gate not in gates:
            gates[gate] = _gate(gate, context, columns[1])
        out.append(bases[base] * gates[gate])
    return stack(out, -1)


def check_weights(weights: Any, count: int = len(LINEAR_TERMS)) -> np.ndarray:
    """``weights`` as a float64 array of ``count`` finite weights (one per term, default: of
    :data:`LINEAR_TERMS`).

    Raises:
        ValueError: another length, or a weight that is not finite.
    """
    out = np.asarray(weights, np.float64)
    if out.shape != (count,) or not np.all(np.isfinite(out)):
        raise ValueError(f"weights must be {count} finite numbers, got {out.tolist()}")
    return out
