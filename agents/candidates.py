"""An excitation that scores its candidate commands and lets someone else choose among them.

:class:`CandidateChooser` is ``baselines.active.GreedyIdentification`` with the choice taken
out: at every picture each robot draws its candidates from its own generator and its identifier
predicts what each would tell (``baselines.active.GreedyIdentification.score``); the result
is the robots' observation (:mod:`agents.candidate_features`). The choice comes from ``decide``:
the trainer's (:class:`agents.crew.Crew`, the action of each slot) or a policy's
(:class:`agents.policy.LearnedExcitation` overrides ``on_scored``). The chosen candidate is
held until the next picture, with the back-off after a bump. Until a picture with a row has been
taken in, a robot drives its first candidate.

Everything happens in ``on_picture``, so the observation a policy acts on is the same in
training and in use. On swarm duty the deviation's base is the shared command
``baselines.excitations.SwarmDuty`` last told it (at the reset, or the step before the
picture).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from agents.candidate_features import (
    CANDIDATES,
    CONTEXT_COLUMN,
    CONTEXT_FEATURES,
    belief_context,
    candidate_observation,
    empty_observation,
)
from baselines.active import CandidateSet, GreedyIdentification, GreedySettings
from baselines.steps import BeliefView, Step


class CandidateChooser(GreedyIdentification):
    """Scored candidates, chosen by ``decide`` (see the module doc).

    Args:
        candidates: candidates per robot and picture (the policy's choices), >= 1.
        settings: the candidates' box and the prediction's model (``GreedySettings``; its
            ``candidates`` is replaced by ``candidates``).
    """

    def __init__(
        self, candidates: int = CANDIDATES, settings: GreedySettings | None = None
    ) -> None:
        base = settings or GreedySettings()
        super().__init__(
            GreedySettings(**{**base.__dict__, "candidates": candidates})  # validated again
        )
        self.candidates = candidates
        self.cset: CandidateSet | None = None
        self.observation = empty_observation(0, candidates)
        self.decided = False

    def reset(self, rngs: Sequence[np.random.Generator]) -> None:
        super().reset(rngs)
        self.cset = None
        self.observation = empty_observation(self.n, self.candidates)
        self.decided = False

    def on_picture(self, step: Step, view: BeliefView) -> None:
        super().on_picture(step, view)
        model = view.model
        config = view.config
        cset = self.score()
        belief = np.asarray(view.belief, np.float64)
        col = CONTEXT_COLUMN
        context = np.zeros((self.n, CONTEXT_FEATURES - 1))
        context[:, : col["rows"]] = belief_context(belief, None if cset is None else cset.now)
        context[:, col["rows"]] = math.log(len(step.rows) + 1.0) / math.log(1001.0)
        context[:, col["bumper"]] = step.bumper
        context[:, col["headings"]] = float(model.orientation)
        context[:, col["on_duty"]] = float(self.following)
        context[:, col["budget"]] = self.budget if self.following else 0.0
        context[:, col["p_detect"]] = model.p_detect
        robot = config.robot
        self.cset = cset
        self.observation = candidate_observation(
            cset,
            context,
            (robot.v_max, robot.omega_max),
            config.schedule.picture_interval,
            model.pixel_noise,
            self.candidates,
        )
        self.decided = False
        self.on_scored()

    def on_scored(self) -> None:
        """Called when the candidates of a new picture are scored (``self.observation``); a
        policy calls ``decide`` here. The default waits for the trainer's decision."""

    def decide(self, pick: np.ndarray) -> None:
        """Drive candidate ``pick[i]`` of robot ``i`` (``(R,)`` integers in ``[0, C)``) until the
        next picture. Ignored when nothing was scored at this picture.

        Raises:
            ValueError: ``pick`` has the wrong shape or a choice outside ``[0, C)``.
        """
        pick = np.asarray(pick).reshape(-1)
        if pick.shape != (self.n,) or not np.issubdtype(pick.dtype, np.integer):
            raise ValueError(f"pick must be {self.n} integers, got {pick!r}")
        if pick.size and (pick.min() < 0 or pick.max() >= self.candidates):
            raise ValueError(f"pick must be in [0, {self.candidates}), got {pick.tolist()}")
        if self.cset is not None:
            self.drive(self.cset, pick)
        self.decided = True

    def teacher(self) -> np.ndarray:
        """``(R,)`` the candidate ``greedy`` would drive (smallest expected entropy plus
        ``energy_weight`` times the energy): the target of imitation."""
        if self.cset is None:
            return np.zeros(self.n, np.int64)
        cost = self.cset.entropy + self.settings.energy_weight * self.cset.spent
        return cost.argmin(axis=1)

    def choose(self) -> None:
        """The choice was made at the picture (``decide``): nothing to do here."""
