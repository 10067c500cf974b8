"""A centralized reference: robots that know who they are, each driving its own codeword
(:class:`CentralizedCode`).

It is not an excitation robots without identities can run: it reads robot ``i``'s index, which
is exactly what they are trying to find out. It is a practical floor for what coordination could
do, beside the information bound and the union estimate of :mod:`baselines.limit`: a designer
who knew every identity would give each robot a different command sequence, as far apart as the
robots' limits allow.

The code (a Reed-Solomon code over a max-min-distance alphabet):

* **Alphabet.** ``q`` commands (``q`` prime) in the agent's candidate box
  (:class:`~baselines.excitations.candidates.GreedySettings`: ``v`` in [0.1, 0.5] m/s, ``w`` in
  [-1, 1] rad/s; on swarm duty, deviations with ``v`` in [-0.5, 0.5] m/s), chosen by farthest-point
  sampling over a 21 x 21 grid of the box so that their displacements over one picture interval
  (in the robot's frame) are as far apart as possible; the first symbol is the longest
  displacement.
* **Codewords.** Robot ``i`` writes ``i`` in base ``q`` as the coefficients of a polynomial
  ``P_i`` of degree below ``m = ceil(log_q R)``; at the ``t``-th picture it drives symbol
  ``P_i(t mod q) mod q``. Two robots' symbols agree at no more than ``m - 1`` of any ``q``
  consecutive pictures (a polynomial of degree below ``m`` has fewer than ``m`` roots): with
  ``q = 11``, ten robots differ at every picture, a thousand at all but two of eleven.

Each command is held until the next picture, with the back-off of ``distinct`` after a bump.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from baselines.excitations.candidates import GreedySettings, HeldCommand
from baselines.steps import BeliefView, Step

#: Alphabet size of the code (a prime).
SYMBOLS = 11


def alphabet(
    symbols: int, speed: tuple[float, float], turn: float, deviation: bool, duration: float
) -> np.ndarray:
    """``(q, 2)`` commands ``(v, w)`` whose displacements over ``duration`` s are spread by
    farthest-point sampling over a 21 x 21 grid of the box (see the module documentation)."""
    from baselines.active import unicycle  # baselines.active imports the excitations package

    low = -speed[1] if deviation else speed[0]
    v, w = np.meshgrid(np.linspace(low, speed[1], 21), np.linspace(-turn, turn, 21))
    grid = np.stack([v.ravel(), w.ravel()], axis=1)
    moved = unicycle(grid[:, 0], grid[:, 1], duration)
    chosen = [int(np.argmax(np.hypot(moved[:, 0], moved[:, 1])))]
    gap = np.linalg.norm(moved - moved[chosen[0]], axis=1)
    while len(chosen) < symbols:
        chosen.append(int(np.argmax(gap)))
        gap = np.minimum(gap, np.linalg.norm(moved - moved[chosen[-1]], axis=1))
    return grid[chosen]


def codewords(robots: int, symbols: int, pictures: int) -> np.ndarray:
    """``(pictures, robots)`` the symbol each robot drives at each picture: robot ``i``'s base-``q``
    digits are the coefficients of a polynomial evaluated at ``t mod q`` (Reed-Solomon)."""
    digits = max(1, math.ceil(math.log(max(robots, 2)) / math.log(symbols) - 1e-12))
    index = np.arange(robots)
    coefficients = np.stack([(index // symbols**j) % symbols for j in range(digits)])  # (m, R)
    x = np.arange(pictures) % symbols
    powers = np.stack([x**j % symbols for j in range(digits)], axis=1)  # (T, m)
    return np.asarray((powers @ coefficients) % symbols, np.int64)


class CentralizedCode(HeldCommand):
    """Robot ``i`` drives codeword ``i`` of a designed code (see the module documentation): a
    reference that knows every identity, not an excitation anonymous robots can run.

    Args:
        symbols: alphabet size ``q``, a prime >= 2.
        settings: the box the alphabet is drawn in and the back-off (the agent's by default).
    """

    def __init__(self, symbols: int = SYMBOLS, settings: GreedySettings | None = None) -> None:
        if not (
            isinstance(symbols, int)
            and symbols >= 2
            and all(symbols % k for k in range(2, symbols))
        ):
            raise ValueError(f"symbols must be a prime >= 2, got {symbols!r}")
        super().__init__(settings)
        self.symbols = symbols

    def reset(self, rngs: Sequence[np.random.Generator]) -> None:
        super().reset(rngs)
        self.picture = 0
        self.code = codewords(self.n, self.symbols, self.symbols)

    def on_picture(self, step: Step, view: BeliefView) -> None:
        s = self.settings
        duration = view.config.schedule.picture_interval
        letters = alphabet(self.symbols, s.speed, s.turn, self.following, duration)
        chosen = letters[self.code[self.picture % self.symbols]]
        self.v, self.w = chosen[:, 0].copy(), chosen[:, 1].copy()
        self.picture += 1
