"""One definition of the learned agent: :class:`AgentSpec`, built once and read by everything
that trains, runs or loads it.

An agent is defined by what it sees (its features, by name and meaning, and how many candidate
commands it chooses among), what it is rewarded for (:class:`Reward`, an object, not a string)
and where it acts (the condition, and the swarm budget), and when it rests (``rest``: a robot
sure of itself holds still, ``baselines.excitations.rest.RestWhenSure``).
:class:`agents.crew.Crew`, the SB3 ``VecEnv`` (:class:`agents.vec.AnonLocVecEnv`), the
PettingZoo env (:class:`agents.pettingzoo.BeliefParallelEnv`), RLlib
(:func:`agents.rllib.make_ppo_config`) and ``anonloc train`` (through
:meth:`agents.train.TrainConfig.spec`) take the spec, never its parts one by one.

The spec is saved inside the agent's zip (SB3's ``policy_kwargs``, plain JSON) and read back
before anything in the file is unpickled (:func:`saved_spec`): an agent whose features differ
from this anonloc's by name, meaning, number or order, or whose candidate count or layout differs,
is refused with a message that lists what differs (:func:`check_saved`). The condition and the
budget it recorded are the ones it runs in by default. A zip saved before specs existed (layout
2, without one) is read as this module's layout-2 spec with the candidate count of its action
space and the condition of its run folder.

>>> spec = AgentSpec(condition="swarm", budget=0.3, reward=Reward("team"))
>>> AgentSpec.from_json(spec.to_json()) == spec
True
"""

from __future__ import annotations

import dataclasses
import json
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from agents.candidate_features import (
    CANDIDATE_SPEC,
    CANDIDATES,
    CONTEXT_SPEC,
    LAYOUT,
    Feature,
    information,
)
from agents.crowd_features import CROWD_CANDIDATE_SPEC, CROWD_CONTEXT_SPEC
from agents.linear_terms import (
    CROWD_TERMS,
    DENSE_TERMS,
    KNOWN_TERMS,
    LINEAR_TERMS,
    MISSING_TERMS,
)
from anonloc_env._checks import check_choice, check_number
from baselines.excitations import Excitation, SwarmDuty
from baselines.excitations.rest import at_rest
from baselines.excitations.swarm import DUTY_BUDGET

#: Where the agent acts: ``free`` (the chosen candidate is the command), ``swarm`` (a bounded
#: deviation from a shared command stream) or ``mixed`` (training across drawn scenarios; a
#: ``mixed`` agent runs ``free`` unless told otherwise).
CONDITIONS = ("free", "swarm", "mixed")
#: The policy networks an agent can have (``agents.features``; named here, where torch is not
#: imported).
SCORERS = ("deep_sets", "linear")
#: The identity terms of :class:`Reward`.
IDENTITY_TERMS = ("log_belief", "information", "team")
#: The identity term of the ``log_belief`` and ``team`` rewards is floored here (nats: log 1e-3 =
#: -6.9), so that one robot's bad picture cannot dominate a batch.
LOG_BELIEF_FLOOR = 1e-3

#: Every feature this anonloc computes, by name: the layout's, then the crowd features
#: (``agents.crowd_features``), which a spec may append after the layout's.
KNOWN_CANDIDATE_FEATURES = {f.name: f for f in CANDIDATE_SPEC + CROWD_CANDIDATE_SPEC}
KNOWN_CONTEXT_FEATURES = {f.name: f for f in CONTEXT_SPEC + CROWD_CONTEXT_SPEC}


def check_features(candidate: tuple[Feature, ...], context: tuple[Feature, ...]) -> None:
    """Refuse features this anonloc cannot compute: each group must be the layout's features
    (:data:`agents.candidate_features.CANDIDATE_SPEC`, ``CONTEXT_SPEC``), in order, then any of
    the crowd features, each once.

    Raises:
        ValueError: naming the group and what is wrong.
    """
    groups = (
        ("candidate_features", candidate, CANDIDATE_SPEC, CROWD_CANDIDATE_SPEC),
        ("context_features", context, CONTEXT_SPEC, CROWD_CONTEXT_SPEC),
    )
    for name, found, base, extras in groups:
        rest = found[len(base) :]
        if found[: len(base)] != base or len(set(rest)) != len(rest) or set(rest) - set(extras):
            raise ValueError(
                f"{name} must be the layout's {[f.name for f in base]} followed by any of "
                f"{[f.name for f in extras]}, got {[f.name for f in found]}"
            )


def on_duty(condition: str, own: Excitation, budget: float, common_seed: int = 0) -> Excitation:
    """The excitation of a condition: ``own`` itself (``free``, ``mixed``), or ``own`` as the
    bounded deviation from a shared command stream seeded by ``common_seed`` (``swarm``, see
    ``baselines.excitations.SwarmDuty``). The one place the free/swarm switch is written."""
    check_choice("condition", condition, CONDITIONS)
    if condition == "swarm":
        return SwarmDuty(own, budget=budget, common_seed=common_seed)
    return own


@dataclass(frozen=True)
class Reward:
    """What a robot is rewarded for, at each picture, besides the env's energy term.

    Attributes:
        identity: ``log_belief``: the log of the belief the robot gives its true row (floored at
            :data:`LOG_BELIEF_FLOOR`), so that every picture spent unsure costs what is still
            unknown; ``information``: the nats gained since the previous picture (it telescopes,
            so only the discount rewards being quick); ``team``: the mean over the env's robots
            of their ``log_belief`` terms, the same for every robot (a robot's motion also
            decides how well the others are told apart).
        information_weight: weight of the identity term (per nat), >= 0.
        energy_weight: reward lost per metre of wheel travel (the env's ``EnergyCost``); None
            keeps the scenario's ``reward.energy_weight``.
    """

    identity: str = "log_belief"
    information_weight: float = 1.0
    energy_weight: float | None = None

    def __post_init__(self) -> None:
        check_choice("identity", self.identity, IDENTITY_TERMS)
        check_number("information_weight", self.information_weight, 0.0)
        if self.energy_weight is not None:
            check_number("energy_weight", self.energy_weight, 0.0)

    def term(self, before: np.ndarray, after: np.ndarray) -> np.ndarray:
        """``(R,)`` the weighted identity term at a picture, from the belief each robot gave its
        true row at the previous picture (``before``) and now (``after``)."""
        if self.identity == "information":
            return self.information_weight * information(before, after)
        own = np.log(np.maximum(after, LOG_BELIEF_FLOOR))
        if self.identity == "team":
            own = np.full(len(own), own.mean())
        return self.information_weight * own


@dataclass(frozen=True)
class AgentSpec:
    """The learned agent's definition (see the module documentation).

    Attributes:
        candidates: candidate commands per robot and picture (the policy's choices), >= 1.
        candidate_features: the features of each candidate, in column order.
        context_features: the features of the robot's context, in column order.
        layout: the observation layout (:data:`agents.candidate_features.LAYOUT`).
        reward: the reward (:class:`Reward`).
        condition: ``free``, ``swarm`` or ``mixed`` (:data:`CONDITIONS`).
        budget: on swarm duty, the largest deviation as a fraction of ``v_max`` and
            ``omega_max``, in [0, 1].
        scorer: the policy's network: ``deep_sets`` (``agents.features.CandidateScorer``) or
            ``linear`` (``agents.features.LinearScorer``, one weight per term).
        terms: the linear scorer's terms by name and meaning
            (:data:`agents.linear_terms.LINEAR_TERMS`); empty for ``deep_sets``.
        rest: the belief at which a robot holds still until the next picture (on swarm duty: no
            deviation), in (0.5, 1] (``baselines.excitations.rest.RestWhenSure``); None:
            the policy chooses at every picture. Saved with the agent, so that it rests where
            it runs as it did where it was trained and searched.
    """

    candidates: int = CANDIDATES
    candidate_features: tuple[Feature, ...] = CANDIDATE_SPEC
    context_features: tuple[Feature, ...] = CONTEXT_SPEC
    layout: int = LAYOUT
    reward: Reward = field(default_factory=Reward)
    condition: str = "free"
    budget: float = DUTY_BUDGET
    scorer: str = "deep_sets"
    terms: tuple[Feature, ...] = ()
    rest: float | None = None

    def __post_init__(self) -> None:
        check_number("candidates", self.candidates, 1, 1024, integer=True)
        check_choice("condition", self.condition, CONDITIONS)
        check_number("budget", self.budget, 0.0, 1.0)
        check_choice("scorer", self.scorer, SCORERS)
        if self.rest is not None:
            check_number("rest", self.rest, 0.5, 1.0, low_open=True)
        if (self.scorer == "linear") != bool(self.terms):
            raise ValueError("terms must be given for the linear scorer, and only for it")
        for name in ("candidate_features", "context_features", "terms"):
            names = [f.name for f in getattr(self, name)]
            if len(set(names)) != len(names):
                raise ValueError(f"{name} must have distinct names, got {names}")

    def with_crowd_features(self) -> AgentSpec:
        """This spec seeing the crowd features too (``agents.crowd_features``: each candidate's
        ``contact_risk``, the context's ``free_space``, ``crowding`` and ``density``), and, for
        the linear scorer, their terms (:data:`agents.linear_terms.CROWD_TERMS`)."""
        return dataclasses.replace(
            self,
            candidate_features=CANDIDATE_SPEC + CROWD_CANDIDATE_SPEC,
            context_features=CONTEXT_SPEC + CROWD_CONTEXT_SPEC,
            terms=CROWD_TERMS if self.scorer == "linear" else (),
        )

    def with_density(self) -> AgentSpec:
        """This linear spec seeing the arena's ``density`` too (the one crowd feature of
        ``agents.crowd_features`` it adds), with the terms behind the ``dense`` and ``missing``
        gates after its own (:data:`agents.linear_terms.DENSE_TERMS`,
        :data:`agents.linear_terms.MISSING_TERMS`): the bundled agent's spec since the ninth
        round, from the seventh round's."""
        density = next(f for f in CROWD_CONTEXT_SPEC if f.name == "density")
        return dataclasses.replace(
            self,
            context_features=(*self.context_features, density),
            terms=self.terms + DENSE_TERMS + MISSING_TERMS,
        )

    @property
    def features(self) -> tuple[tuple[Feature, ...], tuple[Feature, ...]]:
        """``(candidate_features, context_features)``."""
        return self.candidate_features, self.context_features

    def columns(self) -> tuple[dict[str, int], dict[str, int]]:
        """The column of each feature by name: ``(candidate columns, context columns)``."""
        return (
            {f.name: i for i, f in enumerate(self.candidate_features)},
            {f.name: i for i, f in enumerate(self.context_features)},
        )

    def excitation(self, own: Excitation, common_seed: int = 0) -> Excitation:
        """``own`` at rest once sure (when :attr:`rest` is set) in this spec's condition
        (:func:`on_duty`)."""
        return on_duty(self.condition, at_rest(own, self.rest), self.budget, common_seed)

    def in_scenario(self, condition: str, budget: float) -> AgentSpec:
        """This spec in one drawn scenario's condition and budget (training across them)."""
        return dataclasses.replace(self, condition=condition, budget=budget)

    def observation_space(self) -> spaces.Dict:
        """One robot's observation space: ``candidates`` ``(C, F)``, ``context`` ``(X,)``."""
        shape = (self.candidates, len(self.candidate_features))
        return spaces.Dict(
            {
                "candidates": spaces.Box(-np.inf, np.inf, shape, np.float32),
                "context": spaces.Box(-np.inf, np.inf, (len(self.context_features),), np.float32),
            }
        )

    def action_space(self) -> spaces.Discrete:
        """One robot's action space: which candidate it drives."""
        return spaces.Discrete(self.candidates)

    def to_json(self) -> dict[str, Any]:
        """The spec as JSON values (saved with the agent; tuples become lists)."""
        data: dict[str, Any] = json.loads(json.dumps(dataclasses.asdict(self)))
        return data

    @classmethod
    def from_json(cls, data: Any) -> AgentSpec:
        """The spec :meth:`to_json` wrote.

        Raises:
            ValueError: ``data`` is not such a spec (the message says what is wrong).
        """
        try:
            values = dict(data)
            for key in ("candidate_features", "context_features", "terms"):
                if key in values:
                    values[key] = tuple(Feature(**f) for f in values[key])
            if "reward" in values:
                values["reward"] = Reward(**values["reward"])
            return cls(**values)
        except (TypeError, ValueError) as error:
            raise ValueError(f"not an agent spec ({error}): {json.dumps(data)[:200]}") from None

    def differences(self, other: AgentSpec) -> list[str]:
        """What an agent of spec ``other`` would see differently from one of this spec (layout,
        candidate count, and each feature by position, name and meaning); empty when a policy
        trained on one reads the other's observations as it learned them."""
        out = []
        if self.layout != other.layout:
            out.append(f"observation layout {other.layout}, this anonloc's is {self.layout}")
        if self.candidates != other.candidates:
            out.append(f"{other.candidates} candidates, this spec has {self.candidates}")
        if self.scorer != other.scorer:
            out.append(f"scorer {other.scorer!r}, this spec has {self.scorer!r}")
        for group in ("candidate_features", "context_features", "terms"):
            mine, theirs = getattr(self, group), getattr(other, group)
            for i in range(max(len(mine), len(theirs))):
                a = mine[i] if i < len(mine) else None
                b = theirs[i] if i < len(theirs) else None
                if a == b:
                    continue
                if a is None or b is None:
                    extra = a or b
                    assert extra is not None
                    side = "the saved agent" if a is None else "this anonloc"
                    out.append(f"{group}[{i}] {extra.name!r} is only in {side}")
                elif a.name != b.name:
                    out.append(f"{group}[{i}] is {b.name!r} in the saved agent, {a.name!r} here")
                else:
                    out.append(
                        f"{group}[{i}] {a.name!r} means {b.meaning!r} in the saved agent, "
                        f"{a.meaning!r} here"
                    )
        return out


def saved_spec(path: Path) -> AgentSpec | None:
    """The spec saved in the agent zip at ``path``, read from its JSON before anything is
    unpickled; None for a zip saved before specs existed (or not an SB3 zip: the loader says
    why).

    Raises:
        ValueError: the zip holds a spec that is not one.
    """
    try:
        with zipfile.ZipFile(path) as archive:
            data = json.loads(archive.read("data"))
    except (zipfile.BadZipFile, KeyError, ValueError, OSError):
        return None
    kwargs = data.get("policy_kwargs") if isinstance(data, dict) else None
    if not isinstance(kwargs, dict) or "spec" not in kwargs:
        return None
    return AgentSpec.from_json(kwargs["spec"])


def check_saved(path: Path, saved: AgentSpec) -> None:
    """Refuse the agent at ``path`` (of spec ``saved``) when it would see this anonloc's
    observations differently (:meth:`agents.spec.AgentSpec.differences`).

    Raises:
        ValueError: naming what differs.
    """
    here = AgentSpec(
        candidates=saved.candidates,
        candidate_features=_known(
            saved.candidate_features, CANDIDATE_SPEC, KNOWN_CANDIDATE_FEATURES
        ),
        context_features=_known(saved.context_features, CONTEXT_SPEC, KNOWN_CONTEXT_FEATURES),
        scorer=saved.scorer,
        terms=tuple(KNOWN_TERMS[t.name] for t in saved.terms if t.name in KNOWN_TERMS)
        or (LINEAR_TERMS if saved.scorer == "linear" else ()),
    )
    found = here.differences(saved)
    if found:
        raise ValueError(
            f"{path} was trained on other observations than this anonloc computes: "
            + "; ".join(found)
            + ". Retrain it with `anonloc train`, or use the bundled agent."
        )


def _known(
    saved: tuple[Feature, ...], base: tuple[Feature, ...], known: dict[str, Feature]
) -> tuple[Feature, ...]:
    """This anonloc's definitions of the features ``saved`` names: the layout's, then the known
    ones it appends (an unknown name is left out, so that it shows as a difference)."""
    extra = tuple(known[f.name] for f in saved[len(base) :] if f.name in known)
    return base + tuple(f for f in extra if f not in base)
