"""The linear scorer's weights as a saved agent (``agent.zip``), loadable like any other.

A search (:mod:`agents.search`) finds weights; :func:`save_linear_agent` writes them as an SB3
PPO agent whose policy is :class:`agents.features.CandidatePolicy` with the ``linear`` scorer,
and whose spec (:class:`agents.spec.AgentSpec`, ``scorer="linear"`` with the term names) is
saved beside them and checked when it is loaded. So ``baselines.make("agent", env, path=...)``,
``anonloc eval --agent`` and ``anonloc train --resume``-style fine-tuning read it as they read a
PPO agent. Its logits are computed in float32 by torch; the search's numpy chooser
(:class:`agents.search.LinearChooser`) computes the same terms in float64 (a test checks they
agree within 1e-5).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from agents.linear_terms import LINEAR_TERMS, check_weights
from agents.spec import AgentSpec
from baselines.excitations.swarm import DUTY_BUDGET


def linear_spec(condition: str = "mixed", budget: float = DUTY_BUDGET) -> AgentSpec:
    """The spec of a linear agent (the default features and candidates)."""
    return AgentSpec(condition=condition, budget=budget, scorer="linear", terms=LINEAR_TERMS)


#: The spec of a linear agent with the defaults (what a search without crowd features saves).
LINEAR_SPEC = linear_spec()


def save_linear_agent(weights: np.ndarray, path: Path, spec: AgentSpec | None = None) -> Path:
    """Write ``weights`` (one per term of ``spec.terms``) as an agent at ``path``
    (atomically); ``spec`` defaults to :func:`linear_spec`.

    Raises:
        ValueError: ``weights`` has the wrong length or a non-finite value, or ``spec`` is not a
            linear one.
    """
    import torch
    from stable_baselines3 import PPO

    import anonloc_env
    from agents.checkpoints import save_atomic
    from agents.features import CandidatePolicy, LinearScorer
    from agents.vec import AnonLocVecEnv

    spec = spec or linear_spec()
    if spec.scorer != "linear":
        raise ValueError(f"spec must be a linear agent's, got scorer {spec.scorer!r}")
    weights = check_weights(weights, len(spec.terms))
    free = dataclasses.replace(spec, condition="free")  # the spaces only; the spec saved is `spec`
    venv = AnonLocVecEnv(anonloc_env.make_config(n_robots=2), n_envs=1, spec=free)
    kwargs = {"spec": spec.to_json(), "scorer": "linear"}
    model = PPO(CandidatePolicy, venv, policy_kwargs=kwargs, device="cpu", seed=0)
    scorer = model.policy.scorer
    assert isinstance(scorer, LinearScorer)  # the policy_kwargs above
    with torch.no_grad():
        scorer.weights.copy_(torch.as_tensor(weights, dtype=torch.float32))
    venv.close()
    return save_atomic(model, Path(path))


def linear_weights(path: str | Path) -> dict[str, float]:
    """The weights of the linear agent at ``path`` (an ``agent.zip``, its run folder, or
    ``"bundled"``) by term name: how a search starts from a saved agent
    (``agents.search.SearchConfig.start``).

    Raises:
        FileNotFoundError: nothing there.
        ValueError: the agent there is not a linear one (or cannot be loaded).
    """
    from agents.features import LinearScorer
    from agents.policy import load_model, model_spec

    model = load_model(path)
    scorer = model.policy.scorer
    spec = model_spec(model)
    if not isinstance(scorer, LinearScorer) or spec is None:
        raise ValueError(f"{path} is not a linear agent (its scorer has no named terms)")
    values = scorer.weights.detach().double().numpy()
    return {t.name: float(w) for t, w in zip(spec.terms, values, strict=True)}
