"""The learned excitation's network: a scorer over a robot's candidate commands.

:class:`CandidateScorer` (plain torch, shared by the SB3 policy and the RLlib module) reads one
robot's observation (:mod:`agents.candidate_features`): ``C`` candidates and the robot's
context. Each candidate is encoded with the context by one shared network ``phi``; the encodings
are averaged (Deep Sets, Zaheer et al., 2017); each candidate's logit is ``score(phi_c, mean)``
and the value is ``value(context, mean)``. So the logits are equivariant and the value invariant
to the order of the candidates, and no weight depends on N, the camera or the clutter: one set
of weights runs everywhere.

:class:`CandidatePolicy` is that scorer as an SB3 ``ActorCriticPolicy`` over the discrete choice
of a candidate::

    from stable_baselines3 import PPO
    from agents.features import CandidatePolicy

    model = PPO(CandidatePolicy, vec_env)
"""

from __future__ import annotations

import itertools
from typing import Any

import torch
from gymnasium import spaces
from stable_baselines3.common.distributions import Distribution
from stable_baselines3.common.policies import ActorCriticPolicy
from torch import nn

from agents.candidate_features import CANDIDATE_FEATURES, CONTEXT_FEATURES, Feature
from agents.linear_terms import LINEAR_TERMS, linear_terms
from agents.spec import SCORERS, AgentSpec


def _mlp(sizes: list[int], last_activation: bool = True) -> nn.Sequential:
    layers: list[nn.Module] = []
    for a, b in itertools.pairwise(sizes):
        layers += [nn.Linear(a, b), nn.Tanh()]
    if not last_activation:
        layers.pop()
    return nn.Sequential(*layers)


class CandidateScorer(nn.Module):
    """Logits over a robot's candidates and the value of its state (see the module doc).

    Args:
        hidden: width of the encodings.
        candidate_features: features per candidate.
        context_features: features of the context.
    """

    def __init__(
        self,
        hidden: int = 64,
        candidate_features: int = CANDIDATE_FEATURES,
        context_features: int = CONTEXT_FEATURES,
    ) -> None:
        super().__init__()
        self.phi = _mlp([candidate_features + context_features, hidden, hidden])
        self.score = _mlp([2 * hidden, hidden, 1], last_activation=False)
        self.value = _mlp([context_features + hidden, hidden, 1], last_activation=False)

    def forward(
        self, candidates: torch.Tensor, context: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """``(logits (B, C), value (B,))`` from ``candidates (B, C, F)`` and ``context (B, X)``."""
        count = candidates.shape[1]
        joined = torch.cat([candidates, context.unsqueeze(1).expand(-1, count, -1)], dim=-1)
        encoded = self.phi(joined)  # (B, C, H)
        pooled = encoded.mean(dim=1)  # (B, H)
        paired = torch.cat([encoded, pooled.unsqueeze(1).expand(-1, count, -1)], dim=-1)
        logits = self.score(paired).squeeze(-1)
        value = self.value(torch.cat([context, pooled], dim=-1)).squeeze(-1)
        return logits, value


class LinearScorer(nn.Module):
    """Logits linear in the named terms of :mod:`agents.linear_terms` (one weight each, zero at
    the start: ``uniform``), and the value of the robot's state from its context.

    Args:
        hidden: width of the value network.
        context_features: features of the context.
        terms: the terms, by name (:mod:`agents.linear_terms`).
        columns: the column of each feature by name (``agents.spec.AgentSpec.columns``).
    """

    def __init__(
        self,
        hidden: int = 64,
        context_features: int = CONTEXT_FEATURES,
        terms: tuple[Feature, ...] = LINEAR_TERMS,
        columns: tuple[dict[str, int], dict[str, int]] | None = None,
    ) -> None:
        super().__init__()
        self.terms = terms
        self.columns = columns or AgentSpec().columns()
        self.weights = nn.Parameter(torch.zeros(len(terms)))
        self.value = _mlp([context_features, hidden, 1], last_activation=False)

    def forward(
        self, candidates: torch.Tensor, context: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """``(logits (B, C), value (B,))`` from ``candidates (B, C, F)`` and ``context (B, X)``."""
        terms = linear_terms(candidates, context, torch.stack, self.terms, self.columns)
        logits = terms @ self.weights
        return logits, self.value(context).squeeze(-1)


class CandidatePolicy(ActorCriticPolicy):
    """:class:`CandidateScorer` as an SB3 actor-critic over ``Discrete(C)`` (which candidate).

    Args:
        observation_space: ``agents.spec.AgentSpec.observation_space()``.
        action_space: ``agents.spec.AgentSpec.action_space()``.
        lr_schedule: SB3's learning-rate schedule.
        hidden: width of the scorer's encodings.
        scorer: ``deep_sets`` (:class:`CandidateScorer`) or ``linear`` (:class:`LinearScorer`).
        spec: the agent's spec as JSON (``agents.spec.AgentSpec.to_json``), kept in
            ``policy_kwargs`` so that it is saved with the model and checked when it is loaded
            (``agents.spec.check_saved``); None for a policy without one.
        **kwargs: passed to ``ActorCriticPolicy`` (``net_arch`` is not used).
    """

    def __init__(
        self,
        observation_space: spaces.Space,
        action_space: spaces.Space,
        lr_schedule: Any,
        hidden: int = 64,
        spec: dict[str, Any] | None = None,
        scorer: str = "deep_sets",
        **kwargs: Any,
    ) -> None:
        if scorer not in SCORERS:
            raise ValueError(f"scorer must be one of {SCORERS}, got {scorer!r}")
        self.hidden = hidden
        self.scorer_kind = scorer
        self.spec = spec
        kwargs.pop("net_arch", None)
        super().__init__(observation_space, action_space, lr_schedule, net_arch=[], **kwargs)

    def _build(self, lr_schedule: Any) -> None:
        spec = AgentSpec.from_json(self.spec) if self.spec is not None else None
        if spec is None:  # a policy without a spec: the layout's features
            terms = LINEAR_TERMS if self.scorer_kind == "linear" else ()
            spec = AgentSpec(scorer=self.scorer_kind, terms=terms)
        sizes = (len(spec.candidate_features), len(spec.context_features))
        self.scorer: CandidateScorer | LinearScorer
        if self.scorer_kind == "linear":
            self.scorer = LinearScorer(self.hidden, sizes[1], spec.terms, spec.columns())
        else:
            self.scorer = CandidateScorer(self.hidden, *sizes)
        self.optimizer = self.optimizer_class(  # type: ignore[call-arg]  # SB3 types it loosely
            self.parameters(), lr=lr_schedule(1), **self.optimizer_kwargs
        )

    def _get_constructor_parameters(self) -> dict[str, Any]:
        data = super()._get_constructor_parameters()
        data["hidden"] = self.hidden
        data["spec"] = self.spec
        data["scorer"] = self.scorer_kind
        return data

    def _evaluate(self, obs: Any) -> tuple[Distribution, torch.Tensor]:
        logits, value = self.scorer(obs["candidates"].float(), obs["context"].float())
        return self.action_dist.proba_distribution(action_logits=logits), value

    def forward(
        self, obs: Any, deterministic: bool = False
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        distribution, value = self._evaluate(obs)
        actions = distribution.get_actions(deterministic=deterministic)
        return actions, value.unsqueeze(-1), distribution.log_prob(actions)

    def evaluate_actions(
        self, obs: Any, actions: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor | None]:
        distribution, value = self._evaluate(obs)
        return value.unsqueeze(-1), distribution.log_prob(actions), distribution.entropy()

    def get_distribution(self, obs: Any) -> Distribution:
        return self._evaluate(obs)[0]

    def predict_values(self, obs: Any) -> torch.Tensor:
        return self._evaluate(obs)[1].unsqueeze(-1)

    def logits(self, obs: Any) -> torch.Tensor:
        """``(B, C)`` the candidates' logits for a batch of observations (tensors)."""
        return self.scorer(obs["candidates"].float(), obs["context"].float())[0]
