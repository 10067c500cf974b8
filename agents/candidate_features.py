"""What a learning robot sees: a few candidate commands, each with what it is predicted to tell.

At every picture each robot draws ``C`` candidate commands from its own random generator (the
box of ``baselines.active.GreedySettings``, or deviations on swarm duty) and its own
identifier predicts, for each, the entropy its belief would have after the next picture
(``baselines.active.expected_entropy``, what the ``greedy`` excitation computes). The policy
scores the candidates and picks one; the robot holds it until the next picture.

The observation of one robot (observation layout :data:`LAYOUT`) is a dict of two float32 arrays:

| key | shape | meaning |
|---|---|---|
| `candidates` | `(C, 7)` | one row per candidate (below), in the order they were drawn |
| `context` | `(10,)` | the robot's state (below) |

The 7 candidate features: the command ``(v / v_max, w / omega_max)`` (on swarm duty the
deviation, before the budget scales it); the expected entropy after the next picture (nats); the
expected information, entropy now minus that (nats); that entropy minus the smallest of the
robot's candidates (nats, 0 for the best); the energy over the interval over ``v_max`` times
the interval; ``log1p`` of the displacement's length over the pixel noise (how far above the
noise the motion shows).

The 10 context features: the belief's entropy over the robot's hypotheses (nats); the largest
belief; the belief that the robot is in no row; ``log(rows + 1) / log(1001)``; the bumper;
1 when detections carry headings; 1 on swarm duty; the swarm budget (0 in free motion); the
probability of being detected; 1 when the candidates were scored (0 before the first picture
with a row, when the choice is ignored).

Why this layout (decided, see ``docs/agents.md``): every size in it is fixed by ``C`` alone,
so one set of weights runs at any N, camera, clutter or duty; the rows of the picture reach the
policy only through the identifier's predictions, which already weigh the robot's own motion
model, the noise, misses and false positives; and the randomness that breaks the symmetry
between identical robots is the robot's own: its candidates, and the categorical draw over them
(:class:`agents.policy.LearnedExcitation`). Nothing in it is ground truth.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from baselines.active import CandidateSet


@dataclass(frozen=True)
class Feature:
    """One column of the observation: its ``name`` (how code reads it) and its ``meaning`` (what
    the number is, with its unit). A saved agent records both (:class:`agents.spec.AgentSpec`);
    an agent whose features differ by either is refused when loaded."""

    name: str
    meaning: str


#: The features of each candidate, in column order.
CANDIDATE_SPEC = (
    Feature("speed", "forward speed over v_max (on swarm duty the deviation, before the budget)"),
    Feature("turn", "turn rate over omega_max (on swarm duty the deviation, before the budget)"),
    Feature("entropy_after", "expected entropy of the belief after the next picture (nats)"),
    Feature("information", "entropy over the hypotheses now minus entropy_after (nats)"),
    Feature("gap_to_best", "entropy_after minus the smallest of the robot's candidates (nats)"),
    Feature("energy", "energy over the interval (m of wheel travel) over v_max times the interval"),
    Feature("reach", "log1p of the displacement's length over the pixel noise"),
)
#: The features of the robot's context, in column order.
CONTEXT_SPEC = (
    Feature("entropy_now", "entropy of the belief over the robot's hypotheses (nats)"),
    Feature("largest_belief", "the largest belief of a row"),
    Feature("absent", "the belief that the robot is in no row"),
    Feature("rows", "log(rows + 1) / log(1001), rows in the picture"),
    Feature("bumper", "1 after a contact in the last control step"),
    Feature("headings", "1 when detections carry headings"),
    Feature("on_duty", "1 on swarm duty"),
    Feature("budget", "the swarm deviation budget (0 in free motion)"),
    Feature("p_detect", "the probability that a robot is in a picture"),
    Feature("scored", "1 when the candidates were scored (0 before the first picture with a row)"),
)
#: Column of each feature by name.
CANDIDATE_COLUMN = {f.name: i for i, f in enumerate(CANDIDATE_SPEC)}
CONTEXT_COLUMN = {f.name: i for i, f in enumerate(CONTEXT_SPEC)}

#: The observation layout of this module. A saved agent records the layout it was trained on and
#: its features (:mod:`agents.spec`); agents of another layout are refused when loaded.
LAYOUT = 2
#: Candidate commands per robot and picture (the policy's discrete choices).
CANDIDATES = 8
CANDIDATE_FEATURES = len(CANDIDATE_SPEC)
CONTEXT_FEATURES = len(CONTEXT_SPEC)
#: Beliefs are floored here before taking logs.
BELIEF_FLOOR = 1e-12


def empty_observation(
    n: int, candidates: int = CANDIDATES, shape: tuple[int, int] | None = None
) -> dict[str, np.ndarray]:
    """``n`` robots' observations before anything was scored (all zeros); ``shape``: the
    features per candidate and of the context (default: this layout's)."""
    per_candidate, context = shape or (CANDIDATE_FEATURES, CONTEXT_FEATURES)
    return {
        "candidates": np.zeros((n, candidates, per_candidate), np.float32),
        "context": np.zeros((n, context), np.float32),
    }


def candidate_columns(
    cset: CandidateSet, scale: tuple[float, float], duration: float, pixel_noise: float
) -> dict[str, np.ndarray]:
    """The candidate features of :data:`CANDIDATE_SPEC`, by name, each ``(R, C)`` float64.

    Args:
        cset: the candidates and their predictions (``GreedyIdentification.score``).
        scale: ``(v_max, omega_max)`` of the robot.
        duration: the picture interval (s).
        pixel_noise: standard deviation of a detection (image units).
    """
    return {
        "speed": cset.commands[..., 0] / scale[0],
        "turn": cset.commands[..., 1] / scale[1],
        "entropy_after": cset.entropy,
        "information": cset.now[:, None] - cset.entropy,
        "gap_to_best": cset.entropy - cset.entropy.min(axis=1, keepdims=True),
        "energy": cset.spent / (scale[0] * duration),
        "reach": np.log1p(cset.reach / max(pixel_noise, 1e-3)),
    }


def stack_columns(
    candidates: dict[str, np.ndarray] | None,
    context: dict[str, np.ndarray],
    names: tuple[tuple[str, ...], tuple[str, ...]],
    n: int,
    count: int,
) -> dict[str, np.ndarray]:
    """The robots' observations (leading robot axis, float32) from their features by name, in
    the order of ``names`` (candidate features, context features); ``candidates`` None: nothing
    was scored, so the candidate features are zeros and the context's ``scored`` is 0."""
    out = empty_observation(n, count, (len(names[0]), len(names[1])))
    for i, name in enumerate(names[1]):
        out["context"][:, i] = 0.0 if name == "scored" else context[name]
    if candidates is not None:
        for i, name in enumerate(names[0]):
            out["candidates"][..., i] = candidates[name]
        out["context"][:, names[1].index("scored")] = 1.0
    return out


def belief_context(belief: np.ndarray, now: np.ndarray | None) -> np.ndarray:
    """``(R, 3)``: entropy over the hypotheses (``now``; the whole belief's if None), the
    largest belief, and the belief in no row."""
    out = np.zeros((belief.shape[0], 3))
    if belief.shape[1] == 0:
        out[:, 2] = 1.0
        return out
    if now is None:
        now = -(belief * np.log(np.maximum(belief, BELIEF_FLOOR))).sum(axis=1)
    out[:, 0] = now
    out[:, 1] = belief.max(axis=1)
    out[:, 2] = np.clip(1.0 - belief.sum(axis=1), 0.0, 1.0)
    return out


def true_belief(belief: np.ndarray, true_rows: np.ndarray) -> np.ndarray:
    """``(R,)`` belief each robot gives its true row (where ``true_rows`` is ``-1``: the belief it
    is in none)."""
    out = np.zeros(belief.shape[0])
    inside = true_rows >= 0
    if belief.shape[1]:
        rows = np.clip(true_rows, 0, belief.shape[1] - 1)
        out[:] = belief[np.arange(belief.shape[0]), rows]
    missing = np.clip(1.0 - belief.sum(axis=1), 0.0, 1.0)
    return np.where(inside, out, missing)


def information(before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """Nats gained about each robot's identity: ``log after - log before`` (floored)."""
    return np.log(np.maximum(after, BELIEF_FLOOR)) - np.log(np.maximum(before, BELIEF_FLOOR))


def true_rows(infos: Mapping[str, Mapping[str, Any]], agents: Sequence[str]) -> np.ndarray:
    """``(R,)`` each robot's true row in the newest picture (ground truth, for scoring only)."""
    return np.fromiter((infos[a]["true_index"] for a in agents), np.int64, len(agents))
