"""Chance among the agent's candidates: :class:`UniformChoice`, the excitation ``uniform``.

``uniform`` is the learned agent with the network taken out: at every picture each robot draws
the agent's candidates in the agent's box (``candidates.GreedySettings``: 8 commands,
``v`` in [0.1, 0.5] m/s, ``w`` in [-1, 1] rad/s; on swarm duty, deviations with ``v`` in
[-0.5, 0.5] m/s) from its own generator, then flips a fair ``C``-sided coin among them with the
same generator, and holds the command until the next picture, reversing out of bumps (the
back-off of ``distinct`` and ``greedy``). A uniform pick among i.i.d. uniform candidates is one
command uniform in the box; the candidates are drawn anyway so that ``uniform`` consumes its
robots' random numbers exactly as the agent does: for a seed it is bit for bit the agent's
``CandidateChooser`` driven by zero logits (``agents.policy.draw``), the no-learning ablation a
learned agent must beat. Until a picture with a row has been taken in, a robot drives its first
candidate (as the agent does). No torch, no belief read beyond "is there a row".
"""

from __future__ import annotations

import numpy as np

from baselines.excitations.candidates import HeldCommand, candidate_commands, coin
from baselines.steps import BeliefView, Step


class UniformChoice(HeldCommand):
    """At every picture, one command drawn uniformly among the agent's candidates, held until the
    next picture, reversing out of bumps (see the module documentation).

    Args:
        settings: the candidates' number and box and the back-off (the agent's, by default:
            ``GreedySettings()``); only ``candidates``, ``speed``, ``turn`` and ``back`` are
            read.
    """

    def on_picture(self, step: Step, view: BeliefView) -> None:
        s = self.settings
        cand = candidate_commands(self.rngs, s.candidates, s.speed, s.turn, self.following)
        if np.asarray(view.belief).shape[1] == 0 or len(step.rows) == 0:
            pick = np.zeros(self.n, np.int64)
        else:
            pick = coin(self.rngs, s.candidates)
        robots = np.arange(self.n)
        self.v, self.w = cand[robots, pick, 0], cand[robots, pick, 1]
