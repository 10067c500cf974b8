"""A saved agent as an excitation, so it runs through the same teams, runner and tables as every
baseline: ``baselines.make("agent", env)`` (the bundled agent) or ``path=`` a saved one. The name
``agent`` is registered with ``baselines`` through the entry point ``anonloc.policies`` (see
:func:`team`), so ``baselines`` never imports this package.

The policy as trained is the policy users get: at every picture each robot's candidates are
scored by the network and one is drawn from the resulting categorical distribution with the
robot's own generator (:class:`LearnedExcitation`). There is no "mean action" variant: the draw
is how identical robots running one policy choose different motions, in training and in use, and
the team's seeds make it reproducible bit for bit.

Loading an agent unpickles parts of the file inside SB3 (``PPO.load``): load only files you trust
(the bundled agent ships with the package). Only the path the user names is ever loaded.
"""

from __future__ import annotations

import base64
import json
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from agents.candidate_features import LAYOUT
from agents.candidates import CandidateChooser
from agents.saved_agent import check_members, load_failure, run_settings
from agents.spec import AgentSpec, check_saved, on_duty, saved_spec
from anonloc_env.config import EnvConfig
from baselines.excitations import Excitation
from baselines.excitations.rest import at_rest
from baselines.excitations.swarm import DUTY_BUDGET
from baselines.localizers import BayesLocalizer
from baselines.policies import Team

#: The agent shipped with the package (``docs/agents.md`` names the command that trained it).
BUNDLED = Path(__file__).parent / "data" / "agent.zip"
#: The name that stands for :data:`BUNDLED` (``anonloc eval --agent bundled``).
BUNDLED_NAME = "bundled"


def draw(logits: np.ndarray, rngs: list[np.random.Generator]) -> np.ndarray:
    """``(R,)`` one candidate per robot, drawn from ``softmax(logits)`` ``(R, C)`` with robot
    ``i``'s own generator (one uniform number each)."""
    z = logits - logits.max(axis=1, keepdims=True)
    p = np.exp(z)
    cdf = np.cumsum(p, axis=1)
    u = np.fromiter((rng.random() for rng in rngs), np.float64, len(rngs)) * cdf[:, -1]
    return np.minimum((cdf <= u[:, None]).sum(axis=1), logits.shape[1] - 1)


class LearnedExcitation(CandidateChooser):
    """The robots' commands from a trained policy: at every picture each robot's candidates are
    scored (:mod:`agents.candidate_features`) and one is drawn with the robot's own generator; it is
    held until the next picture, with the back-off after a bump (as in training).

    It must be the excitation of a team whose localizer is a ``BayesLocalizer`` (the scores are
    that localizer's predictions).

    Args:
        model: a trained SB3 model whose policy is :class:`agents.features.CandidatePolicy`.
        threads: torch threads while scoring (set for the call, then restored): one is fastest
            for this small network, several slow it down when other processes share the cores.
    """

    def __init__(self, model: Any, threads: int = 1) -> None:
        spec = model_spec(model)
        features = spec.features if spec is not None else None
        super().__init__(int(model.action_space.n), features=features)
        if not isinstance(threads, int) or threads < 1:
            raise ValueError(f"threads must be an integer >= 1, got {threads!r}")
        self.model = model
        self.threads = threads

    def on_scored(self) -> None:
        if self.cset is None:
            return
        import torch

        policy = self.model.policy
        before = torch.get_num_threads()
        torch.set_num_threads(self.threads)
        try:
            with torch.no_grad():
                tensors, _ = policy.obs_to_tensor(self.observation)
                logits = policy.logits(tensors).cpu().numpy().astype(np.float64)
        finally:
            torch.set_num_threads(before)
        self.decide(draw(logits, self.rngs))


def agent_file(path: str | Path) -> Path:
    """The ``agent.zip`` that ``path`` names (the file, its run folder, or ``"bundled"``)."""
    if str(path) == BUNDLED_NAME:
        path = BUNDLED
    path = Path(path)
    if path.is_dir():
        path = path / "agent.zip"
    if not path.is_file():
        raise FileNotFoundError(f"no saved agent at {path}")
    return path


def check_layout(path: Path) -> None:
    """Refuse, before unpickling anything, an agent saved for another observation layout (or
    with members past :mod:`agents.saved_agent`'s size limits, checked before any is read).

    Raises:
        ValueError: the file is not an SB3 save, holds a member too large, or its observations
            are not :data:`agents.candidate_features.LAYOUT`'s.
    """
    check_members(path)
    try:
        with zipfile.ZipFile(path) as archive:
            data = json.loads(archive.read("data"))
        space = base64.b64decode(data["observation_space"][":serialized:"])
    except (zipfile.BadZipFile, KeyError, TypeError, ValueError) as error:
        raise ValueError(f"{path} is not a saved agent (an SB3 zip): {error}") from error
    if b"candidates" not in space or b"context" not in space:
        raise ValueError(
            f"{path} was trained on an older observation layout (the picture's rows); this "
            f"anonloc reads layout {LAYOUT} (scored candidate commands, see "
            "agents.candidate_features). "
            "Retrain it with `anonloc train`, or use the bundled agent."
        )
    spec = saved_spec(path)
    if spec is not None:
        check_saved(path, spec)


def load_model(path: str | Path) -> Any:
    """The SB3 model saved at ``path`` (unpickled by SB3: load only files you trust).

    Raises:
        FileNotFoundError: nothing there.
        ValueError: an agent of another observation layout, or a file SB3 cannot load (the
            message names the member at fault).
    """
    from stable_baselines3 import PPO

    file = agent_file(path)
    check_layout(file)
    try:
        model = PPO.load(file, device="cpu")
    except Exception as error:  # torch and pickle raise many kinds; all are one
        raise load_failure(file, error) from None
    space = model.observation_space
    assert isinstance(space, spaces.Dict)  # check_layout saw its two keys
    shapes = (tuple(space["candidates"].shape or ())[1:], space["context"].shape)
    spec = model_spec(model) or AgentSpec()
    expected = ((len(spec.candidate_features),), (len(spec.context_features),))
    if shapes != expected:
        raise ValueError(
            f"{file} has {shapes[0]} features per candidate and {shapes[1]} of context; its "
            f"spec says {expected[0]} and {expected[1]}: retrain it"
        )
    return model


def model_spec(model: Any) -> AgentSpec | None:
    """The spec in ``model``'s ``policy_kwargs`` (None for a model saved before specs)."""
    data = (getattr(model, "policy_kwargs", None) or {}).get("spec")
    return AgentSpec.from_json(data) if data is not None else None


def load_agent(
    path: str | Path, condition: str | None = None, budget: float = DUTY_BUDGET
) -> Excitation:
    """The excitation of the agent saved at ``path`` (an ``agent.zip``, its run folder, or
    ``"bundled"``), at rest once sure when its spec says so (``AgentSpec.rest``), in
    ``condition`` (default: the one its spec records, for an older file its
    run's, else ``free``; ``mixed`` runs ``free``; on ``swarm`` duty the agent is the deviation
    of ``baselines.excitations.SwarmDuty``, with the spec's or the run's budget, else
    ``budget``)."""
    file = agent_file(path)
    train = run_settings(file)  # a bad config.json is named before the model is loaded
    model = load_model(file)
    spec = saved_spec(file)
    if spec is not None:  # the agent's own record, before its run folder's
        train = {"condition": spec.condition, "budget": spec.budget}
    condition = condition or str(train.get("condition", "free"))
    return on_duty(condition, as_saved(model), float(train.get("budget", budget)))


def as_saved(model: Any) -> Excitation:
    """The policy of ``model`` (an SB3 model, loaded or in training) as its spec runs it: at
    rest once sure when the spec in its ``policy_kwargs`` sets ``rest``
    (``baselines.excitations.rest.RestWhenSure``), before any swarm duty. Every evaluation of
    a model goes through here, so none forgets the rest it was trained with."""
    spec = model_spec(model)
    return at_rest(LearnedExcitation(model), spec.rest if spec is not None else None)


def team(
    config: EnvConfig,
    n: int,
    mode: str,
    excitation: Any,
    path: str | None = None,
    condition: str | None = None,
    **kwargs: Any,
) -> Team:
    """The policy ``agent`` (registered under the entry-point group ``anonloc.policies``): ``n``
    robots with the ``bayes`` localizer (``mode``, ``kwargs``: ``threshold``, ``scale_known``)
    driven by the agent saved at ``path`` (None: the bundled agent); ``condition``: ``free`` or
    ``swarm`` (None: the run's own).

    Raises:
        ValueError: an ``excitation`` is given (the agent moves as it learned).
    """
    if excitation is not None:
        raise ValueError("policy 'agent' moves as it learned: it takes no excitation")
    localizer = BayesLocalizer(config, n, mode, **kwargs)
    return Team(config, localizer, load_agent(path or BUNDLED_NAME, condition))
