"""Decisions from the identifier's beliefs: decide at ``threshold``; optionally hold a decision
through a dip down to ``keep`` (and let go of robots that stood still since they decided), and
take no new decision while jammed.

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
* **release** (metres, with a hold): a robot that has rolled less than ``release`` since it
  decided (its wheels' path, summed over the intervals since) is not held: it stood still, so
  its own pictures cannot have confirmed its track against a still neighbour's, and a dip is
  the one sign that it decided wrong (issue 23, tenth round: ``random``'s robots turn in place
  after a bump and kept wrong decisions through the dips that would have undone them).
* **pressed keep** (with a hold): a decided robot pressed now (pushed in the newest interval and
  the one before: what the contact model calls pressed) is held down to ``pressed_keep`` rather
  than ``keep``, its top row still continuing its decided track (issue 23, eleventh round: of the
  43 right robots ``greedy`` lost between two pictures at 6 per m^2, N = 30, on 12 tuning seeds,
  38 were pressed with their top belief dipped below 0.9 (down to 0.58), 37 of them along their
  own track, continued at their true row: the contact model's wide pushes spread a pressed
  robot's belief without the pictures pointing elsewhere).

* **touched** (an int, with a hold): only a robot a contact pushed in one of the newest
  ``touched`` intervals is held; the others decide at the threshold (issue 23, thirteenth round:
  in open space, where robots seldom touch, the dips that undid right decisions came with a
  contact: of the 67 right robots ``random`` lost between two pictures at one robot per m^2,
  N = 30, on 12 seeds, 56 were pushed in the newest interval, all with their own row on top).

* **pinned** (with ``(window, pushes, path, threshold)``): a robot pushed in most of the newest
  intervals that hardly rolled in them (pressed against a wall or its neighbours) takes a new
  decision only at a higher ``threshold`` (issue 23, fourteenth round: at 4 robots per m^2,
  N = 30, ``random``'s robots pressed against the arena's wall took the row of a far robot that
  hardly moved either, at beliefs 0.990 to 0.9989, and kept it for up to 16 pictures; on 96
  tuning episodes of ``random`` at 4 per m^2 every confident wrong top belief (13
  robot-pictures) was below 0.999, 11 of them of a robot pushed in at least 4 of its newest 5
  intervals. Only ``random`` hardly rolls while pressed; ``greedy``, ``distinct`` and ``gaps``
  decided as before on the tuning episodes. A pinned robot's
  pictures say where it is, not which of the still robots it is: the motion that tells robots
  apart is what the wall and the neighbours take away.)

``Decisions.crowd`` is ``bayes``'s default: the hold with the release, the pressed keep and the
pinned robots' guard for every robot in a crowd (see ``in_crowd``: above one robot per m^2, clean
pictures, a fixed camera, where it was measured); in a crowd with misses or false positives
(``in_cluttered_crowd``) the pinned robots' guard without the hold, and exclusive rows: robots
that would decide the same row at a picture are all undecided there (issue 23, fifteenth round:
on 24 tuning episodes at 4 per m^2, N = 50, 8 % misses and 2 false positives, pinned robots' top
beliefs in 0.99 to 0.999 were right only 93.9 % of the time, and 92 of the 120 wrong decisions
left after the guard shared their row with another decided robot: with misses or false
positives each robot's belief is computed alone, and several pinned robots take the row of one
still robot at once); in open space where the identifier models
contacts (clean pictures, a fixed camera: ``in_contact``) the same hold for robots touched in the
newest ``CONTACT_WINDOW`` intervals only; elsewhere (misses or false positives at one robot per
m^2 or less, a moving camera) the plain threshold, bit for bit (``docs/crowds.md``).
"""

from __future__ import annotations

import numpy as np

from anonloc_env.identify import Identifier, SensorModel
from anonloc_env.identify.lineage import continuations, decided_tracks
from anonloc_env.identify.model import FILTER_DENSITY
from anonloc_env.identify.tracks import Tracks

#: ``bayes``'s hold in a crowd: the belief down to which a decided robot keeps its decision.
CROWD_KEEP = 0.9
#: ``bayes``'s release in a crowd: the path (m) a robot must have rolled since it decided to be
#: held.
CROWD_RELEASE = 0.05
#: ``bayes``'s hold in a crowd for a decided robot pressed now: the belief down to which it keeps
#: its decision.
CROWD_PRESSED_KEEP = 0.8
#: ``bayes``'s hold in open space: only robots pushed in one of this many newest intervals (the
#: newest and the one before, the contact model's window for a pressed robot) are held.
CONTACT_WINDOW = 2
#: ``bayes``'s guard in a crowd on new decisions of pinned robots: ``(window, pushes, path,
#: threshold)``, a robot pushed in at least 4 of the newest 5 intervals that rolled less than
#: 0.15 m over them decides at 0.999 rather than the threshold (issue 23, fourteenth round).
CROWD_PINNED = (5, 4, 0.15, 0.999)


def check_pinned(pinned: object) -> None:
    """Refuse a ``pinned`` setting that is not ``(window, pushes, path, threshold)``: ints with
    ``1 <= pushes <= window`` (intervals), a path > 0 m and a threshold in (0.5, 1]."""
    ok = isinstance(pinned, tuple) and len(pinned) == 4
    if ok:
        assert isinstance(pinned, tuple)
        window, pushes, path, threshold = (pinned[0], pinned[1], pinned[2], pinned[3])
        ok = (
            isinstance(window, int)
            and isinstance(pushes, int)
            and 1 <= pushes <= window
            and isinstance(path, int | float)
            and path > 0.0
            and isinstance(threshold, int | float)
            and 0.5 < threshold <= 1.0
        )
    if not ok:
        raise ValueError(
            "pinned must be (window, pushes, path, threshold): ints with 1 <= pushes <= window "
            f"(intervals), a path > 0 m and a threshold in (0.5, 1], got {pinned!r}"
        )


def in_crowd(model: SensorModel) -> bool:
    """Whether ``Decisions.crowd`` holds every robot's decision under ``model``: where the
    identifier models a crowd (``filter_position``: above one robot per m^2, clean pictures) with
    a fixed camera (no ``registration``), the conditions of ``crowd_noise`` and of the
    measurements."""
    return model.filter_position and model.registration is None


def in_cluttered_crowd(model: SensorModel) -> bool:
    """Whether ``Decisions.crowd`` guards pinned robots where it holds no one: above
    ``FILTER_DENSITY`` robots per m^2 (``model.density``) with misses or false positives, a fixed
    camera, where the identifier has no crowd model (issue 23, fourteenth round)."""
    clutter = model.p_detect < 1.0 or model.false_positives > 0.0
    crowded = model.density > FILTER_DENSITY * (1.0 + 1e-9)
    return crowded and clutter and model.registration is None and model.view is None


def in_contact(model: SensorModel) -> bool:
    """Whether ``Decisions.crowd`` holds the decisions of touched robots under ``model``: where
    the identifier models contacts (``crowd_push_share``: clean pictures) with a fixed camera,
    a crowd or not."""
    return model.crowd_push_share is not None and model.registration is None


class Decisions:
    """One team's decisions, picture after picture (see the module).

    Args:
        threshold: belief at which a robot decides, in (0.5, 1).
        keep: belief down to which a decided robot keeps its decision, in (0.5, threshold];
            ``threshold`` (the default): no hold.
        settle: intervals pushed in a row (>= 2) past which a robot takes no new decision;
            None (the default): no such limit.
        release: path (m, > 0) a decided robot must have rolled since it decided to be held;
            None (the default): every decided robot may be held. Needs a hold.
        only_in_crowd: apply the hold, release and settle only where ``in_crowd`` (the
            identifier's model); elsewhere decide at ``threshold`` (but see ``open_touched``).
        pressed_keep: belief down to which a decided robot that is pressed (pushed in the
            newest interval and the one before, the contact model's test) keeps its decision, in
            (0.5, keep]; None (the default): ``keep``. Needs a hold.
        touched: hold only robots pushed in one of the newest ``touched`` intervals (>= 1);
            None (the default): any robot. Needs a hold.
        open_touched: with ``only_in_crowd``, where not ``in_crowd`` but ``in_contact``, hold
            the robots pushed in one of the newest ``open_touched`` intervals (>= 1) as
            ``touched`` would; None (the default): the plain threshold there.
        pinned: ``(window, pushes, path, threshold)``: a robot undecided at the previous picture
            that was pushed in at least ``pushes`` of the newest ``window`` intervals and rolled
            less than ``path`` (m) over them decides only at ``threshold`` (in (0.5, 1]; 1: not
            at all while so); None (the default): no such guard. With ``only_in_crowd``, in a
            crowd only.
        cluttered_pinned: with ``only_in_crowd`` and ``pinned``, guard pinned robots also where
            ``in_cluttered_crowd`` (misses or false positives above one robot per m^2), deciding
            at ``threshold`` otherwise there; False (the default): the plain threshold there.
        exclusive: with ``cluttered_pinned``, where ``in_cluttered_crowd``, robots that would
            decide the same row at a picture are all undecided there (at most one of them can
            be right); False (the default): each robot decides alone.
    """

    def __init__(
        self,
        threshold: float = 0.99,
        keep: float | None = None,
        settle: int | None = None,
        release: float | None = None,
        only_in_crowd: bool = False,
        pressed_keep: float | None = None,
        touched: int | None = None,
        open_touched: int | None = None,
        pinned: tuple[int, int, float, float] | None = None,
        cluttered_pinned: bool = False,
        exclusive: bool = False,
    ) -> None:
        if not 0.5 < threshold < 1.0:
            raise ValueError(f"threshold must be in (0.5, 1), got {threshold}")
        keep = threshold if keep is None else keep
        if not 0.5 < keep <= threshold:
            raise ValueError(f"keep must be in (0.5, threshold = {threshold}], got {keep}")
        if settle is not None and settle < 2:
            raise ValueError(f"settle must be >= 2 intervals (or None), got {settle}")
        if release is not None and not (release > 0.0 and keep < threshold):
            raise ValueError(f"release must be > 0 m and come with keep < threshold, got {release}")
        pressed_keep = keep if pressed_keep is None else pressed_keep
        if not (0.5 < pressed_keep <= keep and (pressed_keep == keep or keep < threshold)):
            raise ValueError(
                f"pressed_keep must be in (0.5, keep = {keep}] and come with keep < threshold, "
                f"got {pressed_keep}"
            )
        for name, window in (("touched", touched), ("open_touched", open_touched)):
            if window is not None and not (
                isinstance(window, int) and window >= 1 and keep < threshold
            ):
                raise ValueError(
                    f"{name} must be an int >= 1 (intervals) and come with keep < threshold, "
                    f"got {window!r}"
                )
        if pinned is not None:
            check_pinned(pinned)
        if cluttered_pinned and not (only_in_crowd and pinned is not None):
            raise ValueError("cluttered_pinned needs only_in_crowd and pinned (it extends them)")
        if exclusive and not cluttered_pinned:
            raise ValueError("exclusive needs cluttered_pinned (it applies where that does)")
        if open_touched is not None and not only_in_crowd:
            raise ValueError("open_touched needs only_in_crowd (it says how to hold outside one)")
        self.threshold = threshold
        self.keep = keep
        self.settle = settle
        self.release = release
        self.only_in_crowd = only_in_crowd
        self.pressed_keep = pressed_keep
        self.touched = touched
        self.open_touched = open_touched
        self.pinned = pinned
        self.cluttered_pinned = cluttered_pinned
        self.exclusive = exclusive
        self.reset()

    @classmethod
    def crowd(
        cls,
        threshold: float = 0.99,
        pinned: tuple[int, int, float, float] | None = CROWD_PINNED,
        cluttered: bool = True,
    ) -> Decisions:
        """``bayes``'s default: the hold (``CROWD_KEEP``, ``CROWD_PRESSED_KEEP`` for pressed
        robots) with the release (``CROWD_RELEASE``) and the pinned robots' guard
        (``pinned``, ``CROWD_PINNED``; None: the thirteenth round's decisions) in a crowd, the
        same hold for robots touched in the newest ``CONTACT_WINDOW`` intervals in open space
        with the contact model, the pinned robots' guard and exclusive rows in a crowd with
        misses or false positives (``cluttered``), the plain threshold elsewhere (see the
        module)."""
        return cls(
            threshold,
            CROWD_KEEP,
            None,
            CROWD_RELEASE,
            True,
            pressed_keep=CROWD_PRESSED_KEEP,
            open_touched=CONTACT_WINDOW,
            pinned=pinned,
            cluttered_pinned=cluttered and pinned is not None,
            exclusive=cluttered and pinned is not None,
        )

    @property
    def plain(self) -> bool:
        """Whether these are ``bayes``'s plain decisions (no hold, no settle, no pinned
        guard)."""
        return self.keep >= self.threshold and self.settle is None and self.pinned is None

    def reset(self) -> None:
        """Forget every decision (a new episode)."""
        # The identifier's tracks at the previous picture, the robots decided there and their
        # rows: each one's decided track is taken from them only when it is asked (``_held``).
        self._decided: tuple[Tracks, np.ndarray, np.ndarray] | None = None
        self._estimate: np.ndarray | None = None
        self._rolled: np.ndarray | None = None  # path (m) each decided robot rolled since deciding
        self._untouched: np.ndarray | None = None  # intervals since each robot was last pushed
        # The newest intervals' (pushed, path) per robot, newest last (for ``pinned``).
        self._recent: tuple[np.ndarray, np.ndarray] | None = None
        self.held = 0  # decisions held below the threshold so far (a count for the benchmarks)

    def decide(self, identifier: Identifier, belief: np.ndarray) -> np.ndarray:
        """``(R,)`` each robot's decision at the identifier's newest picture: its top row of
        ``belief`` (``identifier.belief()``), or -1 while undecided."""
        n = belief.shape[0]
        untouched = self._untouched_now(identifier, n)
        crowd = not self.only_in_crowd or in_crowd(identifier.model)
        guard = self.cluttered_pinned and in_cluttered_crowd(identifier.model)
        pinned = self._pinned_now(identifier, n) if crowd or guard else None
        if belief.shape[1] == 0:
            self._decided, self._estimate = None, None
            return np.full(n, -1, dtype=np.int64)
        best = belief.argmax(axis=1)
        top = belief[np.arange(n), best]
        decided = top >= self.threshold
        touched = self.touched
        if not crowd and guard:
            return self._guarded(decided, best, top, pinned)
        if not crowd:
            touched = self.open_touched if in_contact(identifier.model) else None
            if touched is None:
                return np.where(decided, best, -1)
        if self.plain:
            return np.where(decided, best, -1)
        before = self._estimate
        rolled = self._rolled_now(identifier, n)
        if self.settle is not None and before is not None:
            decided &= (identifier.pushed_run <= self.settle) | (before >= 0)
        if pinned is not None and self.pinned is not None and before is not None:
            decided &= ~pinned | (before >= 0) | (top >= self.pinned[3])
        if self.keep < self.threshold:
            moved = rolled >= self.release if self.release is not None else np.ones(n, bool)
            pressed = identifier.pushed_run >= 2  # the contact model's pressed
            keep = np.where(pressed, self.pressed_keep, self.keep)
            high = top >= keep
            if touched is not None:
                high &= untouched < touched
            decided |= self._held(identifier, best, high, decided | ~moved)
            robots = np.flatnonzero(decided)
            self._decided = (identifier.tracks, robots, best[robots])
        self._estimate = np.where(decided, best, -1)
        self._rolled = np.where(decided, rolled, 0.0)
        return self._estimate

    def _guarded(
        self, decided: np.ndarray, best: np.ndarray, top: np.ndarray, pinned: np.ndarray | None
    ) -> np.ndarray:
        """The threshold's decisions but for the pinned robots' guard (no hold) and, with
        ``exclusive``, no row decided twice: where ``in_cluttered_crowd``."""
        before = self._estimate
        if pinned is not None and self.pinned is not None and before is not None:
            decided &= ~pinned | (before >= 0) | (top >= self.pinned[3])
        if self.exclusive and decided.any():
            rows, counts = np.unique(best[decided], return_counts=True)
            decided &= ~np.isin(best, rows[counts > 1])
        self._estimate = np.where(decided, best, -1)
        return self._estimate

    def _untouched_now(self, identifier: Identifier, n: int) -> np.ndarray:
        """``(R,)`` the intervals since each robot was last pushed: 0 if pushed in the newest,
        1 if in the one before and not since, ...; large where never (kept for ``touched``)."""
        run = identifier.pushed_run
        before = self._untouched
        if identifier.interval is None or before is None or len(before) != n:
            before = np.full(n, np.iinfo(np.int64).max // 2, np.int64)
            if identifier.interval is None:
                self._untouched = before
                return before
        self._untouched = np.where(run >= 1, 0, before + 1)
        return self._untouched

    def _pinned_now(self, identifier: Identifier, n: int) -> np.ndarray | None:
        """``(R,)`` the robots pinned now (``pinned``: pushed in at least ``pushes`` of the newest
        ``window`` intervals and rolled less than ``path`` over them), or None without
        ``pinned``; the newest intervals kept for the next picture."""
        if self.pinned is None:
            return None
        window, pushes, path, _ = self.pinned
        interval = identifier.interval
        recent = self._recent
        if interval is None or recent is None or recent[0].shape[1] != n:
            recent = (np.zeros((0, n), bool), np.zeros((0, n)))
        if interval is not None:
            kept = max(0, len(recent[0]) - (window - 1))  # the window's older intervals
            pushed = identifier.pushed_run >= 1
            recent = (
                np.vstack([recent[0][kept:], pushed[None]]),
                np.vstack([recent[1][kept:], interval.path[None]]),
            )
        self._recent = recent
        if len(recent[0]) < window:
            return np.zeros(n, bool)
        return (recent[0].sum(axis=0) >= pushes) & (recent[1].sum(axis=0) < path)

    def _rolled_now(self, identifier: Identifier, n: int) -> np.ndarray:
        """``(R,)`` the path each robot decided at the previous picture has rolled since it
        decided, the newest interval included (0 for the others)."""
        interval = identifier.interval
        if self._estimate is None or self._rolled is None or len(self._rolled) != n:
            return np.zeros(n)
        path = np.zeros(n) if interval is None else interval.path
        return np.where(self._estimate >= 0, self._rolled + path, 0.0)

    def _held(
        self, identifier: Identifier, best: np.ndarray, high: np.ndarray, sure: np.ndarray
    ) -> np.ndarray:
        """The robots decided at the previous picture that keep their decision (see the
        module): of those not ``sure``, the ones whose top belief is ``high`` enough (at least
        their keep) and whose top row continues their decided track."""
        hold = np.zeros(len(best), bool)
        decided, interval, rows = self._decided, identifier.interval, identifier.rows
        if decided is None or interval is None or rows is None:
            return hold
        tracks, robots, at = decided
        wanted = ~sure[robots] & high[robots]
        if not wanted.any():
            return hold
        # The decided tracks of the robots asked only (the identifier replaces its tracks at
        # every update and never writes into them, so those of the previous picture still
        # hold; the same tracks, in the same order, as taking them all and then the asked).
        asked = decided_tracks(tracks, robots[wanted], at[wanted])
        if not len(asked):
            return hold
        scoring = identifier.scoring
        robots, row = continuations(asked, rows, interval, identifier.pix_var, scoring)
        hold[robots] = row == best[robots]
        self.held += int(hold.sum())
        return hold
