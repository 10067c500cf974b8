"""What a learning robot sees: the picture's rows as its own identifier believes them.

A :class:`BeliefObserver` follows the R robots of one env: it runs the ``bayes`` localizer of every
robot (robot i's belief depends only on the pictures and robot i's own motion, so one vectorised
identifier is R independent ones), and turns each step into the policy's observation, a dict of
fixed-shape float32 arrays with a leading robot axis (D = the env's rows per picture):

| key | shape | meaning |
|---|---|---|
| `rows` | `(R, D, 6)` | per row of the newest picture (see below) |
| `mask` | `(R, D)` | 1 where the row holds a detection, else 0 |
| `own` | `(R, 12)` | the robot's own state (see below) |

The 6 row features: `(du, dv)`, the row's position relative to the row the robot believes most
is itself, in metres (image units over the camera scale), turned into that row's detected
heading frame when headings are detected; `(cos, sin)` of the row's detected heading relative to
that row's (0, 0 without headings); the robot's belief that the row is itself; 1 on the
believed row.

The 12 own features: own odometry since the picture `(dx, dy, dphi)` (m, m, rad); time since the
picture over the picture interval; bumper; largest belief; belief "not in the picture";
normalised entropy of the belief; the last command the policy asked `(v / v_max, w / omega_max)`;
and two dice, uniform in [-1, 1], thrown by the robot's own generator at every picture.

The dice are how identical robots running one policy can choose different motions: a policy that
sees nothing but the same picture would otherwise move every robot alike, the one thing that keeps
them anonymous. They come from each robot's own generator (seeded like every excitation's), so an
episode is reproducible and robots share no random state.

The row features change only at a new picture and are computed then; the ``own`` features every
step. Everything is computed from the robots' observations and their own commands: no ground
truth. :func:`information` reads the belief of each robot's true row (from ``infos``) for the
reward, outside the observation.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from gymnasium import spaces

from baselines.localizers import BayesLocalizer
from baselines.observations import Step

ROW_FEATURES = 6
OWN_FEATURES = 12
#: Beliefs are floored here before taking logs (the reward's information term).
BELIEF_FLOOR = 1e-12


def policy_observation_space(capacity: int) -> spaces.Dict:
    """The observation space of one robot (one slot of the vectorized env)."""
    return spaces.Dict(
        {
            "rows": spaces.Box(-np.inf, np.inf, (capacity, ROW_FEATURES), np.float32),
            "mask": spaces.Box(0.0, 1.0, (capacity,), np.float32),
            "own": spaces.Box(-np.inf, np.inf, (OWN_FEATURES,), np.float32),
        }
    )


class BeliefObserver:
    """The policy observations of the R robots of one env, from their own identifiers.

    Args:
        localizer: the robots' ``bayes`` localizer (a team's; it is updated by its team, this
            only reads it).
        capacity: rows per picture ``D`` (the env's ``observation_space(agent)["mask"]`` size).
    """

    def __init__(self, localizer: BayesLocalizer, capacity: int) -> None:
        config = localizer.config
        self.config = config
        self.capacity = capacity
        self.n = localizer.n
        self.localizer = localizer
        self._dt = config.dt
        self.since_picture = 0.0
        self._scale = float(self.localizer.model.scale_bounds[1])
        self._orientation = config.camera.orientation
        self.rows = np.zeros((self.n, capacity, ROW_FEATURES), np.float32)
        self.mask = np.zeros((self.n, capacity), np.float32)
        self.summary = np.zeros((self.n, 3), np.float32)  # largest belief, missing, entropy
        self.last_command = np.zeros((self.n, 2), np.float32)
        self.dice = np.zeros((self.n, 2), np.float32)
        self.rngs: list[np.random.Generator] = []

    def reset(self, rngs: Sequence[np.random.Generator]) -> None:
        """Start an episode; ``rngs`` are the robots' own generators (they throw the dice)."""
        if len(rngs) != self.n:
            raise ValueError(f"rngs must have one generator per robot ({self.n}), got {len(rngs)}")
        self.rngs = list(rngs)
        self.dice[:] = 0.0
        self.since_picture = 0.0
        self.rows[:] = 0.0
        self.mask[:] = 0.0
        self.summary[:] = 0.0
        self.last_command[:] = 0.0

    def on_picture(self, step: Step) -> None:
        """Recompute the row features after the localizer took in ``step``'s picture, and throw
        the dice."""
        self.dice[:] = [rng.uniform(-1.0, 1.0, 2) for rng in self.rngs]
        belief = self.localizer.belief
        rows = step.rows
        count = min(len(rows), self.capacity, belief.shape[1])
        self.rows[:] = 0.0
        self.mask[:] = 0.0
        self.summary[:] = 0.0
        if count == 0:
            self.summary[:, 1] = 1.0
            return
        belief = belief[:, :count]
        rows = rows[:count]
        best = belief.argmax(axis=1)
        delta = (rows[None, :, :2] - rows[best][:, None, :2]) / self._scale  # (R, D, 2)
        features = self.rows[:, :count]
        if self._orientation:
            heading = rows[best, 2][:, None]  # (R, 1): the believed row's detected heading
            c, s = np.cos(heading), np.sin(heading)
            features[..., 0] = c * delta[..., 0] + s * delta[..., 1]
            features[..., 1] = -s * delta[..., 0] + c * delta[..., 1]
            relative = rows[None, :, 2] - heading
            features[..., 2] = np.cos(relative)
            features[..., 3] = np.sin(relative)
        else:
            features[..., :2] = delta
        features[..., 4] = belief
        features[np.arange(self.n), best, 5] = 1.0
        self.mask[:, :count] = 1.0
        total = belief.sum(axis=1)
        missing = np.clip(1.0 - total, 0.0, 1.0)
        entropy = -(belief * np.log(np.maximum(belief, BELIEF_FLOOR))).sum(axis=1)
        entropy -= missing * np.log(np.maximum(missing, BELIEF_FLOOR))
        self.summary[:, 0] = belief.max(axis=1)
        self.summary[:, 1] = missing
        self.summary[:, 2] = entropy / np.log(count + 1.0)

    def observe(self, step: Step, first: bool = False) -> dict[str, np.ndarray]:
        """The robots' observation at ``step`` (after :meth:`on_picture` at a new picture).

        Args:
            step: the robots' step (see ``baselines.observations.read_step``).
            first: the step is the episode's first (the reset), whatever it holds.
        """
        if first or step.new_picture:
            self.since_picture = 0.0
        else:
            self.since_picture += self._dt
        own = np.empty((self.n, OWN_FEATURES), np.float32)
        own[:, :3] = step.odometry
        own[:, 3] = self.since_picture / self.config.picture_interval
        own[:, 4] = step.bumper
        own[:, 5:8] = self.summary
        own[:, 8:10] = self.last_command
        own[:, 10:12] = self.dice
        return {"rows": self.rows.copy(), "mask": self.mask.copy(), "own": own}

    def true_belief(self, true_rows: np.ndarray) -> np.ndarray:
        """``(R,)`` belief each robot gives its true row (``-1``: the belief it is in none)."""
        belief = self.localizer.belief
        out = np.empty(self.n)
        inside = true_rows >= 0
        if belief.shape[1]:
            rows = np.clip(true_rows, 0, belief.shape[1] - 1)
            out[:] = belief[np.arange(self.n), rows]
        else:
            out[:] = 0.0
        missing = np.clip(1.0 - belief.sum(axis=1), 0.0, 1.0)
        return np.where(inside, out, missing)


def information(before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """Nats gained about each robot's identity: ``log after - log before`` (floored)."""
    return np.log(np.maximum(after, BELIEF_FLOOR)) - np.log(np.maximum(before, BELIEF_FLOOR))


def true_rows(infos: Mapping[str, Mapping[str, Any]], agents: Sequence[str]) -> np.ndarray:
    """``(R,)`` each robot's true row in the newest picture (ground truth, for scoring only)."""
    return np.fromiter((infos[a]["true_index"] for a in agents), np.int64, len(agents))
