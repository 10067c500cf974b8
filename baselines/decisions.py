"""Decisions from the identifier's beliefs: decide at ``threshold``; optionally hold a decision
through a dip down to ``keep``, and take no new decision while jammed.

By default (``keep = threshold``, no ``settle``) a robot is decided exactly while its top belief
is at least ``threshold`` (0.99): ``bayes``'s rule. Two options change it (issue 23, sixth round;
``docs/crowds.md`` measures each alone and both together on the crowded grid, and says why
neither is the default):

* **hold** (``keep < threshold``): in a crowd the belief of a decided robot pressed against
  others dips below the threshold and comes back, its own row still on top (the contact model's
  wide pushes and track breaks, ``anonloc_env.identify.contact``). A robot decided at the previous
  picture keeps its decision while its top belief is at least ``keep`` and its top row is the
  row that continues the track it decided on best (``anonloc_env.identify.lineage``): the belief
  dipped along the same lineage rather than moving to a neighbour's track or a broken track's
  fresh start. Fewer decisions flicker; more wrong ones last.
* **settle** (an int): a robot pushed in more than ``settle`` intervals in a row takes no new
  decision (one decided before keeps it while the rule above allows): what a jammed robot's
  pictures add cannot tell it from the robots jammed like it. Fewer wrong decisions; jammed
  robots are identified later.
"""

from __future__ import annotations

import numpy as np

from anonloc_env.identify import Identifier
from anonloc_env.identify.lineage import continuations, decided_tracks
from anonloc_env.identify.tracks import Tracks


class Decisions:
    """One team's decisions, picture after picture (see the module).

    Args:
        threshold: belief at which a robot decides, in (0.5, 1).
        keep: belief down to which a decided robot keeps its decision, in (0.5, threshold];
            ``threshold`` (the default): no hold.
        settle: intervals pushed in a row (>= 2) past which a robot takes no new decision;
            None (the default): no such limit.
    """

    def __init__(
        self, threshold: float = 0.99, keep: float | None = None, settle: int | None = None
    ) -> None:
        if not 0.5 < threshold < 1.0:
            raise ValueError(f"threshold must be in (0.5, 1), got {threshold}")
        keep = threshold if keep is None else keep
        if not 0.5 < keep <= threshold:
            raise ValueError(f"keep must be in (0.5, threshold = {threshold}], got {keep}")
        if settle is not None and settle < 2:
            raise ValueError(f"settle must be >= 2 intervals (or None), got {settle}")
        self.threshold = threshold
        self.keep = keep
        self.settle = settle
        self.reset()

    @property
    def plain(self) -> bool:
        """Whether these are ``bayes``'s plain decisions (no hold, no settle)."""
        return self.keep >= self.threshold and self.settle is None

    def reset(self) -> None:
        """Forget every decision (a new episode)."""
        self._tracks: Tracks | None = None  # each decided robot's track at its decided row
        self._estimate: np.ndarray | None = None
        self.held = 0  # decisions held below the threshold so far (a count for the benchmarks)

    def decide(self, identifier: Identifier, belief: np.ndarray) -> np.ndarray:
        """``(R,)`` each robot's decision at the identifier's newest picture: its top row of
        ``belief`` (``identifier.belief()``), or -1 while undecided."""
        n = belief.shape[0]
        if belief.shape[1] == 0:
            self._tracks, self._estimate = None, None
            return np.full(n, -1, dtype=np.int64)
        best = belief.argmax(axis=1)
        top = belief[np.arange(n), best]
        decided = top >= self.threshold
        if self.plain:
            return np.where(decided, best, -1)
        before = self._estimate
        if self.settle is not None and before is not None:
            decided &= (identifier.pushed_run <= self.settle) | (before >= 0)
        if self.keep < self.threshold:
            decided |= self._held(identifier, best, top, decided)
            robots = np.flatnonzero(decided)
            self._tracks = decided_tracks(identifier.tracks, robots, best[robots])
        self._estimate = np.where(decided, best, -1)
        return self._estimate

    def _held(
        self, identifier: Identifier, best: np.ndarray, top: np.ndarray, sure: np.ndarray
    ) -> np.ndarray:
        """The robots decided at the previous picture that keep their decision (see the
        module)."""
        hold = np.zeros(len(best), bool)
        before, interval, rows = self._tracks, identifier.interval, identifier.rows
        if before is None or not len(before) or interval is None or rows is None:
            return hold
        asked = np.flatnonzero(~sure[before.slot] & (top[before.slot] >= self.keep))
        if not len(asked):
            return hold
        scoring = identifier.scoring
        robots, row = continuations(before.take(asked), rows, interval, identifier.pix_var, scoring)
        hold[robots] = row == best[robots]
        self.held += int(hold.sum())
        return hold
