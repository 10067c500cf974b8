"""The learned excitation's network as an RLlib RLModule (new API stack, torch).

:class:`CandidateRLModule` holds one :class:`agents.features.CandidateScorer`, the network of
the SB3 policy :class:`agents.features.CandidatePolicy`: same class, same parameter names, so a
module trained by RLlib becomes an SB3 agent by copying ``module.scorer.state_dict()``
(:func:`agents.rllib.export_agent` does it and saves the zip). It reads the flat observation of
:class:`agents.pettingzoo.BeliefParallelEnv` (``observation="flat"``), splits it back into
``candidates (B, C, 7)`` and ``context (B, 10)`` with :func:`agents.pettingzoo.unflatten`, and
returns the candidates' logits, the inputs of RLlib's categorical distribution over
``Discrete(C)``. The logits are equivariant and the value invariant to the order of the
candidates, and no weight depends on N, the camera or the clutter (see :mod:`agents.features`).

One pass of the scorer gives both heads. The training forward pass keeps the value under
``Columns.EMBEDDINGS``, and ``CandidateRLModule.compute_values`` returns it as it is when PPO
hands those embeddings back (RLlib's shared-encoder convention), so the learner runs the
network once per batch.

Example (``agents.rllib.make_ppo_config`` builds this spec)::

    from ray.rllib.core.rl_module.rl_module import RLModuleSpec
    from agents.rllib_module import CandidateRLModule

    spec = RLModuleSpec(module_class=CandidateRLModule, model_config={"hidden": 64})

Needs the ``ray`` and ``rl`` extras (``ray[rllib]`` and torch).
"""

from __future__ import annotations

from typing import Any

import torch
from gymnasium import spaces
from ray.rllib.core.columns import Columns
from ray.rllib.core.rl_module.apis.value_function_api import ValueFunctionAPI
from ray.rllib.core.rl_module.torch import TorchRLModule

from agents.features import CandidateScorer
from agents.pettingzoo import flat_size, unflatten

#: Width of the scorer's encodings when ``model_config`` names none (CandidatePolicy's default).
DEFAULT_HIDDEN = 64


class CandidateRLModule(TorchRLModule, ValueFunctionAPI):
    """:class:`agents.features.CandidateScorer` over the flat candidate observation, for PPO.

    ## Observation Space
    ``Box((7 C + 10,), float32)``: :func:`agents.pettingzoo.flatten` of one robot's
    observation (``C`` candidates of 7 features, row-major, then 10 of context).

    ## Action Space
    ``Discrete(C)``: which candidate the robot drives; ``C`` is read from this space.

    ## Arguments
    ``model_config``: ``{"hidden": int}``, the width of the scorer's encodings (default
    :data:`DEFAULT_HIDDEN`); the other arguments are RLlib's.

    Attributes:
        scorer: the network (the same class as ``CandidatePolicy.scorer``).
        candidates: ``C``.
        hidden: the width of the scorer's encodings.
    """

    def setup(self) -> None:
        """Build the scorer after checking the spaces (called by RLlib's constructor)."""
        action_space = self.action_space
        if not isinstance(action_space, spaces.Discrete):
            raise ValueError(
                f"action_space must be Discrete(C) (which candidate), got {action_space!r}"
            )
        self.candidates = int(action_space.n)
        shape = (flat_size(self.candidates),)
        if getattr(self.observation_space, "shape", None) != shape:
            raise ValueError(
                f"observation_space must be a flat Box of shape {shape} for {self.candidates} "
                "candidates (BeliefParallelEnv(observation='flat')), "
                f"got {self.observation_space!r}"
            )
        # RLlib hands the spec's dict merged with its own defaults (keys this module ignores).
        config = self.model_config if isinstance(self.model_config, dict) else {}
        hidden = config.get("hidden", DEFAULT_HIDDEN)
        if not isinstance(hidden, int) or isinstance(hidden, bool) or hidden < 1:
            raise ValueError(f"model_config['hidden'] must be an integer >= 1, got {hidden!r}")
        self.hidden = hidden
        self.scorer = CandidateScorer(hidden)

    def scores(self, observations: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``(logits (B, C), value (B,))`` for flat observations ``(B, 7 C + 10)``."""
        # unflatten only slices and reshapes, so it takes tensors as it takes arrays.
        parts = unflatten(observations.float(), self.candidates)  # type: ignore[arg-type]
        logits: torch.Tensor
        value: torch.Tensor
        logits, value = self.scorer(parts["candidates"], parts["context"])
        return logits, value

    def _forward(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, Any]:
        """Inference and exploration: the candidates' logits."""
        logits, _ = self.scores(batch[Columns.OBS])
        return {Columns.ACTION_DIST_INPUTS: logits}

    def _forward_train(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, Any]:
        """Training: the logits, and the value of the same pass as the embeddings."""
        logits, value = self.scores(batch[Columns.OBS])
        return {Columns.ACTION_DIST_INPUTS: logits, Columns.EMBEDDINGS: value}

    def compute_values(self, batch: dict[str, Any], embeddings: Any = None) -> torch.Tensor:
        """``(B,)`` the value of each observation (``embeddings``: the value already computed
        by :meth:`_forward_train` on this batch, returned as it is)."""
        if embeddings is not None:
            return embeddings  # the value tensor of this batch
        return self.scores(batch[Columns.OBS])[1]
