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
from typing import Any

import numpy as np

from agents.candidate_features import (
    CANDIDATE_SPEC,
    CANDIDATES,
    CONTEXT_SPEC,
    Feature,
    belief_context,
    candidate_columns,
    empty_observation,
    stack_columns,
)
from agents.crowd_features import crowd_columns
from agents.spec import check_features
from anonloc_env.camera import survey
from anonloc_env.config import EnvConfig
from baselines.active import (
    CandidateSet,
    GreedyIdentification,
    GreedySettings,
    Hypotheses,
    ScoringJob,
)
from baselines.steps import BeliefView, Step


class CandidateChooser(GreedyIdentification):
    """Scored candidates, chosen by ``decide`` (see the module doc).

    Args:
        candidates: candidates per robot and picture (the policy's choices), >= 1.
        settings: the candidates' box and the prediction's model (``GreedySettings``; its
            ``candidates`` is replaced by ``candidates``).
    """

    def __init__(
        self,
        candidates: int = CANDIDATES,
        settings: GreedySettings | None = None,
        features: tuple[tuple[Feature, ...], tuple[Feature, ...]] | None = None,
    ) -> None:
        base = settings or GreedySettings()
        super().__init__(
            GreedySettings(**{**base.__dict__, "candidates": candidates})  # validated again
        )
        self.candidates = candidates
        found = features or (CANDIDATE_SPEC, CONTEXT_SPEC)
        check_features(*found)
        self.names = (tuple(f.name for f in found[0]), tuple(f.name for f in found[1]))
        self.crowd = frozenset(self.names[0][len(CANDIDATE_SPEC) :]) | frozenset(
            self.names[1][len(CONTEXT_SPEC) :]
        )  # the crowd features named (agents.crowd_features)
        self.cset: CandidateSet | None = None
        self.observation = empty_observation(0, candidates, (len(found[0]), len(found[1])))
        self.decided = False
        self.defer = False
        """When True, ``on_picture`` prepares the scoring job and leaves its expected entropy to
        the caller, who hands it to ``scored`` (the VecEnv scores all its copies together)."""
        self._waiting: tuple[Step, BeliefView, Any, ScoringJob | None] | None = None
        self._view: tuple[EnvConfig, tuple[float, float, float, float]] | None = None

    def reset(self, rngs: Sequence[np.random.Generator]) -> None:
        super().reset(rngs)
        self.cset = None
        self.observation = empty_observation(
            self.n, self.candidates, (len(self.names[0]), len(self.names[1]))
        )
        self.decided = False
        self._waiting = None

    def on_picture(self, step: Step, view: BeliefView) -> None:
        super().on_picture(step, view)
        pending = self._pending
        job = self.prepare()
        self._waiting = (step, view, pending, job)
        if not self.defer:
            self.scored(None if job is None else job.entropy())

    @property
    def job(self) -> ScoringJob | None:
        """The scoring job of the picture taken in last, while its expected entropies are
        awaited (``defer``); None when nothing is awaited or nothing was scored."""
        return None if self._waiting is None else self._waiting[3]

    @property
    def waiting(self) -> bool:
        """Whether a picture waits for ``scored`` (only while ``defer`` is set)."""
        return self._waiting is not None

    def scored(self, entropy: np.ndarray | None) -> None:
        """Finish the picture taken in last with its job's expected ``entropy`` ``(R, C)``
        (None when its job is None): the candidate set, the observation and ``on_scored``."""
        assert self._waiting is not None, "no picture waits for its scores"
        step, view, pending, job = self._waiting
        self._waiting = None
        cset = None if job is None or entropy is None else job.finish(entropy)
        model = view.model
        config = view.config
        belief = np.asarray(view.belief, np.float64)
        now, largest, absent = belief_context(belief, None if cset is None else cset.now).T
        robot = config.robot
        context = {
            "entropy_now": now,
            "largest_belief": largest,
            "absent": absent,
            "rows": np.full(self.n, math.log(len(step.rows) + 1.0) / math.log(1001.0)),
            "bumper": np.asarray(step.bumper, np.float64),
            "headings": np.full(self.n, float(model.orientation)),
            "on_duty": np.full(self.n, float(self.following)),
            "budget": np.full(self.n, self.budget if self.following else 0.0),
            "p_detect": np.full(self.n, model.p_detect),
        }
        columns = None
        if cset is not None:
            columns = candidate_columns(
                cset,
                (robot.v_max, robot.omega_max),
                config.schedule.picture_interval,
                model.pixel_noise,
            )
        if self.crowd:
            crowd, more = self._crowd_columns(view, step.rows, belief, cset, pending)
            context.update(more)
            if columns is not None:
                columns.update(crowd)
        self.cset = cset
        self.observation = stack_columns(columns, context, self.names, self.n, self.candidates)
        self.decided = False
        self.on_scored()

    def _crowd_columns(
        self,
        view: BeliefView,
        rows: np.ndarray,
        belief: np.ndarray,
        cset: CandidateSet | None,
        pending: tuple[Hypotheses, Any, Any] | None,
    ) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
        """The crowd features (:func:`agents.crowd_features.crowd_columns`): the believed heading
        is the top hypothesis's (from the previous picture when headings are not detected)."""
        model, config = view.model, view.config
        low, high = model.scale_bounds
        scale = math.sqrt(low * high)
        heading = np.full(self.n, np.nan)
        if pending is not None:
            hyp = pending[0]
            heading = np.where(hyp.known[:, 0], hyp.theta[:, 0], np.nan)
        commands = None
        if cset is not None:
            commands = np.stack(
                [
                    self.base[0][:, None] + self.budget * cset.commands[..., 0],
                    self.base[1][:, None] + self.budget * cset.commands[..., 1],
                ],
                axis=-1,
            )
        # The field of view, again when the config changes (a training copy redraws its scenario).
        if self._view is None or self._view[0] is not config:
            self._view = (config, survey(config).field_of_view)
        return crowd_columns(
            belief,
            rows,
            heading,
            commands,
            config.schedule.picture_interval,
            scale,
            config.robot.size * scale,
            self._view[1],
            self.crowd,
        )

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
