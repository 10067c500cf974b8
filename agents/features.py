"""Features extractors over the picture's rows, for SB3 policies (``policy_kwargs``).

The rows of a picture are a set: shuffled, padded to a fixed count, with a mask. A policy that
depends on their order would have to learn every permutation. Two extractors are invariant by
construction and ignore padded rows exactly:

* :class:`DeepSetsExtractor`: ``rho(own, mean_j phi(row_j, own), max_j phi(row_j, own))`` over
  the unmasked rows (Zaheer et al., 2017).
* :class:`AttentionExtractor`: multi-head attention with the robot's own state as the query and
  the rows as keys and values, masked rows excluded from the softmax (Lee et al., 2019, pooling by
  attention).

:class:`FlatExtractor` is the comparison: the rows flattened in their given order (masked rows
zeroed), concatenated with the own state, through an MLP of a similar parameter count.

Usage::

    from stable_baselines3 import PPO
    from agents.features import DeepSetsExtractor

    model = PPO("MultiInputPolicy", vec_env,
                policy_kwargs={"features_extractor_class": DeepSetsExtractor})
"""

from __future__ import annotations

import itertools

import gymnasium as gym
import torch
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
from torch import nn

#: Extractors by name (``anonloc train --extractor``).
EXTRACTORS: dict[str, type[BaseFeaturesExtractor]] = {}


def _sizes(observation_space: gym.spaces.Dict) -> tuple[int, int, int]:
    rows = observation_space["rows"].shape
    own = observation_space["own"].shape
    assert rows is not None
    assert own is not None
    return rows[0], rows[1], own[0]


def _mlp(sizes: list[int]) -> nn.Sequential:
    layers: list[nn.Module] = []
    for a, b in itertools.pairwise(sizes):
        layers += [nn.Linear(a, b), nn.ReLU()]
    return nn.Sequential(*layers)


class DeepSetsExtractor(BaseFeaturesExtractor):
    """Masked Deep Sets over the rows, conditioned on the robot's own state.

    Args:
        observation_space: the policy observation space (:mod:`agents.observation`).
        hidden: width of the per-row network ``phi``.
        features_dim: size of the output.
    """

    def __init__(
        self, observation_space: gym.spaces.Dict, hidden: int = 64, features_dim: int = 64
    ) -> None:
        super().__init__(observation_space, features_dim)
        _, row_size, own_size = _sizes(observation_space)
        self.phi = _mlp([row_size + own_size, hidden, hidden])
        self.rho = _mlp([own_size + 2 * hidden, features_dim])

    def forward(self, observations: dict[str, torch.Tensor]) -> torch.Tensor:
        rows, mask, own = observations["rows"], observations["mask"], observations["own"]
        count = rows.shape[1]
        joined = torch.cat([rows, own.unsqueeze(1).expand(-1, count, -1)], dim=-1)
        encoded = self.phi(joined)  # (B, D, H)
        weights = mask.unsqueeze(-1)
        total = weights.sum(dim=1).clamp(min=1.0)
        mean = (encoded * weights).sum(dim=1) / total
        # ReLU outputs are >= 0, so masked rows set to 0 never exceed a present row's maximum;
        # with no row at all the maximum is 0.
        peak = (encoded * weights).amax(dim=1)
        return self.rho(torch.cat([own, mean, peak], dim=-1))


class AttentionExtractor(BaseFeaturesExtractor):
    """Masked multi-head attention: the robot's own state asks, the rows answer.

    Args:
        observation_space: the policy observation space (:mod:`agents.observation`).
        hidden: width of the embeddings.
        heads: attention heads (``hidden`` must be a multiple).
        features_dim: size of the output.
    """

    def __init__(
        self,
        observation_space: gym.spaces.Dict,
        hidden: int = 64,
        heads: int = 4,
        features_dim: int = 64,
    ) -> None:
        super().__init__(observation_space, features_dim)
        _, row_size, own_size = _sizes(observation_space)
        self.embed_rows = _mlp([row_size + own_size, hidden])
        self.embed_own = _mlp([own_size, hidden])
        self.attention = nn.MultiheadAttention(hidden, heads, batch_first=True)
        self.out = _mlp([own_size + hidden, features_dim])

    def forward(self, observations: dict[str, torch.Tensor]) -> torch.Tensor:
        rows, mask, own = observations["rows"], observations["mask"], observations["own"]
        count = rows.shape[1]
        keys = self.embed_rows(torch.cat([rows, own.unsqueeze(1).expand(-1, count, -1)], dim=-1))
        query = self.embed_own(own).unsqueeze(1)
        absent = mask < 0.5
        empty = absent.all(dim=1)
        # A picture with no row at all: attend to the first (padded) row, then zero the result
        # (a softmax over nothing would be NaN).
        absent[:, 0] &= ~empty
        pooled, _ = self.attention(query, keys, keys, key_padding_mask=absent, need_weights=False)
        pooled = pooled.squeeze(1) * (~empty).unsqueeze(1).to(pooled.dtype)
        return self.out(torch.cat([own, pooled], dim=-1))


class FlatExtractor(BaseFeaturesExtractor):
    """The rows flattened in their order (masked rows zeroed) and the own state, through an MLP
    (the order-dependent comparison).

    Args:
        observation_space: the policy observation space (:mod:`agents.observation`).
        hidden: width of the hidden layer.
        features_dim: size of the output.
    """

    def __init__(
        self, observation_space: gym.spaces.Dict, hidden: int = 64, features_dim: int = 64
    ) -> None:
        super().__init__(observation_space, features_dim)
        count, row_size, own_size = _sizes(observation_space)
        self.net = _mlp([count * row_size + count + own_size, hidden, features_dim])

    def forward(self, observations: dict[str, torch.Tensor]) -> torch.Tensor:
        rows, mask, own = observations["rows"], observations["mask"], observations["own"]
        flat = (rows * mask.unsqueeze(-1)).flatten(1)
        return self.net(torch.cat([flat, mask, own], dim=-1))


EXTRACTORS.update(
    {"deepsets": DeepSetsExtractor, "attention": AttentionExtractor, "flat": FlatExtractor}
)
