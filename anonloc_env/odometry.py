"""Own-frame dead reckoning: what a robot knows of its own motion since the latest picture.

A robot integrates its wheel encoders in its own frame at the latest picture: after moving ``ds``
forward and turning ``dth`` (per physics sub-step),
``d += ds * (cos(phi), sin(phi))`` then ``phi += dth``, where ``phi`` is the heading change since
the picture. This is exactly how the physics integrates a unicycle over a sub-step, so without
noise the world displacement between two pictures equals ``R(theta_k) d`` to rounding error.
"""

from __future__ import annotations

import numpy as np

from anonloc_env.world import Motion


class Odometry:
    """Dead reckoning of N robots at once, reset at each picture.

    Args:
        n: number of robots.
        noise: standard deviation of the multiplicative error on each control step's distance and
            turn (``RobotConfig.odometry_noise``).
    """

    def __init__(self, n: int, noise: float) -> None:
        self.n = n
        self.noise = noise
        self.since_picture = np.zeros((n, 3))
        """``(N, 3)`` own-frame ``(dx, dy, dphi)`` since the latest picture (m, m, rad)."""

    def integrate(self, motion: Motion, rng: np.random.Generator) -> None:
        """Add one control step of wheel motion (with noise drawn from ``rng`` if any)."""
        noisy = self.noise > 0.0
        if noisy:
            distance_factor, turn_factor = 1.0 + self.noise * rng.standard_normal((2, self.n))
        odo = self.since_picture
        x, y, phi = odo[:, 0], odo[:, 1], odo[:, 2]  # column views, updated in place
        for ds, dth in zip(motion.forward, motion.turned, strict=True):
            if noisy:
                ds = ds * distance_factor
                dth = dth * turn_factor
            dx = np.cos(phi)
            dx *= ds
            dy = np.sin(phi)
            dy *= ds
            x += dx
            y += dy
            phi += dth

    def mark_picture(self) -> np.ndarray:
        """Start a new interval at a picture; return the ``(N, 3)`` motion of the one just ended."""
        ended = self.since_picture
        self.since_picture = np.zeros((self.n, 3))
        return ended
