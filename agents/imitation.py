"""Imitation of the ``greedy`` excitation: the starting point of PPO.

The learned excitation chooses among the same candidates that ``greedy`` scores
(:mod:`agents.candidate_features`), so ``greedy``'s choice is a label for every observation:
:func:`collect_demonstrations` drives the robots of a vectorized env with it and records the
observations, the labels and the discounted returns; :func:`imitate` fits the policy's logits to
the labels (cross-entropy) and its value to the returns (squared error). PPO then starts from a
policy that is already as good as ``greedy`` instead of from random choices.

>>> demos = collect_demonstrations(vec_env, decisions=20_000, seed=0)  # doctest: +SKIP
>>> imitate(model.policy, demos, epochs=10, seed=0)  # doctest: +SKIP
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from agents.candidate_features import CONTEXT_COLUMN
from agents.vec import AnonLocVecEnv


@dataclass(frozen=True)
class Demonstrations:
    """Observations of the robots driven by ``greedy``, with its choices and the returns.

    Attributes:
        candidates: ``(M, C, F)`` the candidate features of each recorded decision.
        context: ``(M, X)`` the context.
        labels: ``(M,)`` the candidate ``greedy`` drove.
        returns: ``(M,)`` the discounted return from that decision on (to the end of the data,
            bootstrapped with 0 where an episode was cut by its time limit).
    """

    candidates: np.ndarray
    context: np.ndarray
    labels: np.ndarray
    returns: np.ndarray

    @property
    def scored(self) -> np.ndarray:
        """``(M,)`` whether the decision's candidates were scored (the others carry no label)."""
        return self.context[:, CONTEXT_COLUMN["scored"]] > 0.5


def collect_demonstrations(
    vec_env: AnonLocVecEnv, decisions: int, seed: int, gamma: float = 0.95
) -> Demonstrations:
    """Drive ``vec_env``'s robots with ``greedy``'s choices for at least ``decisions`` robot
    decisions (whole rounds of every slot) and record them.

    Raises:
        ValueError: ``decisions`` < 1 or ``gamma`` outside [0, 1].
    """
    if decisions < 1:
        raise ValueError(f"decisions must be >= 1, got {decisions}")
    if not 0.0 <= gamma <= 1.0:
        raise ValueError(f"gamma must be in [0, 1], got {gamma}")
    vec_env.seed(seed)
    observation = vec_env.reset()
    assert isinstance(observation, dict)
    rounds = -(-decisions // vec_env.num_envs)
    cands, contexts, labels, rewards, dones = [], [], [], [], []
    for _ in range(rounds):
        label = np.concatenate([crew.chooser.teacher() for crew in vec_env.crews])
        cands.append(observation["candidates"])
        contexts.append(observation["context"])
        labels.append(label)
        stepped, reward, done, _ = vec_env.step(label)
        assert isinstance(stepped, dict)
        observation = stepped
        rewards.append(reward)
        dones.append(done)
    returns = np.zeros((rounds, vec_env.num_envs))
    running = np.zeros(vec_env.num_envs)
    for t in range(rounds - 1, -1, -1):
        running = rewards[t] + gamma * running * ~dones[t]
        returns[t] = running
    return Demonstrations(
        np.concatenate(cands),
        np.concatenate(contexts),
        np.concatenate(labels).astype(np.int64),
        returns.reshape(-1).astype(np.float32),
    )


def imitate(
    policy: Any,
    demos: Demonstrations,
    epochs: int = 10,
    learning_rate: float = 1e-3,
    batch_size: int = 512,
    value_weight: float = 0.5,
    seed: int = 0,
) -> list[float]:
    """Fit ``policy`` (an :class:`agents.features.CandidatePolicy`) to the demonstrations: the
    cross-entropy of its logits against the labels on scored decisions, plus ``value_weight``
    times the squared error of its value against the returns. Returns the share of scored
    decisions on which the policy's most likely candidate is the label, after each epoch.
    """
    import torch

    generator = torch.Generator().manual_seed(seed)
    cand = torch.as_tensor(demos.candidates)
    ctx = torch.as_tensor(demos.context)
    labels = torch.as_tensor(demos.labels)
    returns = torch.as_tensor(demos.returns)
    scored = torch.as_tensor(demos.scored)
    optimizer = torch.optim.Adam(policy.scorer.parameters(), lr=learning_rate)
    agreement = []
    for _ in range(epochs):
        order = torch.randperm(len(labels), generator=generator)
        for start in range(0, len(order), batch_size):
            take = order[start : start + batch_size]
            logits, value = policy.scorer(cand[take], ctx[take])
            mask = scored[take].float()
            ce = torch.nn.functional.cross_entropy(logits, labels[take], reduction="none")
            loss = (ce * mask).sum() / mask.sum().clamp(min=1.0)
            loss = loss + value_weight * ((value - returns[take]) ** 2).mean()
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
        with torch.no_grad():
            logits, _ = policy.scorer(cand, ctx)
            hit = (logits.argmax(dim=1) == labels)[scored].float().mean()
        agreement.append(float(hit))
    return agreement
