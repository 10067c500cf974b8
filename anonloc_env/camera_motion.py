"""A camera on a hovering drone: its pose at each picture, drawn from the env's generator.

The camera's set point is the fixed camera of :class:`anonloc_env.config.CameraConfig` (above
the arena centre, turned by ``tilt_deg`` about the world x axis). A hovering drone never holds it
exactly; each picture is taken from the set point moved by (``camera.*`` fields):

* a horizontal **drift** ``(dx, dy)``: two Ornstein-Uhlenbeck processes of standard deviation
  ``drift`` (m) and correlation time ``drift_time`` (s), what a position hold leaves;
* a **height** wobble ``dz`` and a **yaw** wobble, Ornstein-Uhlenbeck processes of standard
  deviations ``height_wobble`` (m) and ``yaw_wobble_deg`` and correlation time ``wobble_time``;
* the drone's **roll and pitch**, Ornstein-Uhlenbeck processes of standard deviation
  ``tilt_wobble_deg`` and correlation time ``wobble_time``, of which the gimbal removes what is
  slower than its bandwidth: the gimbal angle ``g`` follows the drone's angle ``a`` through a
  first-order lag ``dg/dt = (a - g) / tau_g``, ``tau_g = 1 / (2 pi gimbal_bandwidth)``, and the
  camera is left tilted by ``a - g`` (its standard deviation is
  ``tilt_wobble * sqrt(tau_g / (wobble_time + tau_g))``). Without a gimbal (bandwidth 0) the
  camera tilts by ``a``.

Every process is a linear Gauss-Markov process, advanced exactly from one picture's time to the
next (no discretisation error, whatever the interval), and started from its stationary law at
reset. A fixed camera draws nothing, so its episodes are those of a camera without this module.

The pose is ``(x, y, z, yaw, pitch, roll)``: the camera's optical centre (m, world frame) and its
orientation ``Rz(yaw) Ry(pitch) Rx(roll)`` applied to a camera looking straight down (image
``u`` along world x, ``v`` along world y); the set point is
``(xc, yc - H sin(tilt), H cos(tilt), 0, 0, tilt)``. :func:`pose_homography` turns a pose into
the ground-to-image homography, the same as :class:`anonloc_env.camera.Camera`'s at the set point.
"""

from __future__ import annotations

import math

import numpy as np

from anonloc_env.config import EnvConfig

#: Names of the pose's components, in order (m, m, m, rad, rad, rad).
POSE_FIELDS = ("x", "y", "z", "yaw", "pitch", "roll")


def set_point(config: EnvConfig) -> np.ndarray:
    """``(6,)`` the fixed camera's pose ``(x, y, z, yaw, pitch, roll)`` (m, rad)."""
    cam = config.camera
    width, height = config.arena_size
    tilt = math.radians(cam.tilt_deg)
    return np.array(
        [
            width / 2.0,
            height / 2.0 - cam.height * math.sin(tilt),
            cam.height * math.cos(tilt),
            0.0,
            0.0,
            tilt,
        ]
    )


def left_tilt(config: EnvConfig) -> float:
    """Standard deviation (rad) of the camera's pitch and roll about the set point, each: the
    drone's ``tilt_wobble_deg`` less what the gimbal corrects,
    ``tilt_wobble * sqrt(tau_g / (wobble_time + tau_g))`` (all of it without a gimbal)."""
    cam = config.camera
    tilt = math.radians(cam.tilt_wobble_deg)
    if cam.gimbal_bandwidth > 0.0:
        tau_g = 1.0 / (2.0 * math.pi * cam.gimbal_bandwidth)
        tilt *= math.sqrt(tau_g / (cam.wobble_time + tau_g))
    return tilt


def pose_sigma(config: EnvConfig) -> np.ndarray:
    """``(6,)`` the standard deviations of the pose ``(x, y, z, yaw, pitch, roll)`` about the
    set point under the hover's stationary law (m, rad): what is known of a picture's pose
    before it is seen (all 0 for a fixed camera)."""
    cam = config.camera
    yaw = math.radians(cam.yaw_wobble_deg)
    tilt = left_tilt(config)
    return np.array([cam.drift, cam.drift, cam.height_wobble, yaw, tilt, tilt])


def _rotation(yaw: float, pitch: float, roll: float) -> np.ndarray:
    """``Rz(yaw) @ Ry(pitch) @ Rx(roll)``."""
    cz, sz = math.cos(yaw), math.sin(yaw)
    cy, sy = math.cos(pitch), math.sin(pitch)
    cx, sx = math.cos(roll), math.sin(roll)
    rz = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]])
    ry = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
    return rz @ ry @ rx


#: A camera looking straight down: its x, y (image ``u``, ``v``) and viewing axes, as columns.
_DOWN = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]])


def pose_homography(config: EnvConfig, pose: np.ndarray) -> np.ndarray:
    """``(3, 3)`` ground-to-image homography of the camera at ``pose`` ``(6,)``.

    The lens is the fixed camera's: focal length ``scale * height`` image units and principal
    point ``camera.principal_point`` (or its default). Scaled so that the arena centre has
    ``w = 1``, as the fixed camera's is.
    """
    cam = config.camera
    width, height = config.arena_size
    xc, yc = width / 2.0, height / 2.0
    s = cam.scale
    cu, cv = cam.principal_point if cam.principal_point is not None else (s * xc, s * yc)
    focal = s * cam.height
    axes = _rotation(float(pose[3]), float(pose[4]), float(pose[5])) @ _DOWN
    to_camera = np.array([[1.0, 0.0, -pose[0]], [0.0, 1.0, -pose[1]], [0.0, 0.0, -pose[2]]])
    lens = np.array([[focal, 0.0, cu], [0.0, focal, cv], [0.0, 0.0, 1.0]])
    g = lens @ axes.T @ to_camera
    depth = float(g[2] @ np.array([xc, yc, 1.0]))
    return g / depth


def _expm2(m: np.ndarray) -> np.ndarray:
    """``exp(m)`` of a real ``(2, 2)`` matrix with real eigenvalues (closed form)."""
    half_trace = 0.5 * (m[0, 0] + m[1, 1])
    shifted = m - half_trace * np.eye(2)
    q2 = -np.linalg.det(shifted)  # q^2: the eigenvalues are half_trace +- q
    q = math.sqrt(max(q2, 0.0))
    sinhc = math.sinh(q) / q if q > 1e-12 else 1.0
    return math.exp(half_trace) * (math.cosh(q) * np.eye(2) + sinhc * shifted)


class _Gimballed:
    """One tilt axis: the drone's angle ``a`` (OU) and the gimbal's ``g`` lagging it.

    State ``(a, g)``, drift matrix ``A = [[-1/tau, 0], [1/tau_g, -1/tau_g]]``; the transition over
    ``delta`` is ``expm(A delta)`` and its noise covariance ``P - Phi P Phi^T`` with ``P`` the
    stationary covariance (a 2-D Lyapunov equation, solved once).
    """

    def __init__(self, sigma: float, tau: float, bandwidth: float) -> None:
        tau_g = 1.0 / (2.0 * math.pi * bandwidth)
        if abs(tau_g - tau) < 1e-9 * tau:  # equal eigenvalues: the closed form still holds
            tau_g *= 1.0 + 1e-6
        self.drift = np.array([[-1.0 / tau, 0.0], [1.0 / tau_g, -1.0 / tau_g]])
        noise = np.zeros((2, 2))
        noise[0, 0] = 2.0 * sigma**2 / tau
        eye = np.eye(2)
        lyapunov = np.kron(eye, self.drift) + np.kron(self.drift, eye)
        self.stationary = np.linalg.solve(lyapunov, -noise.reshape(-1)).reshape(2, 2)
        self.stationary = 0.5 * (self.stationary + self.stationary.T)

    def start(self, rng: np.random.Generator) -> np.ndarray:
        """A state drawn from the stationary law."""
        return _gaussian(np.zeros(2), self.stationary, rng)

    def advance(self, state: np.ndarray, delta: float, rng: np.random.Generator) -> np.ndarray:
        """The state ``delta`` seconds later."""
        phi = _expm2(self.drift * delta)
        cov = self.stationary - phi @ self.stationary @ phi.T
        return _gaussian(phi @ state, 0.5 * (cov + cov.T), rng)


def _gaussian(mean: np.ndarray, cov: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """One draw of ``N(mean, cov)`` for a ``(2, 2)`` covariance (possibly singular)."""
    values, vectors = np.linalg.eigh(cov)
    return mean + vectors @ (np.sqrt(np.clip(values, 0.0, None)) * rng.standard_normal(2))


class CameraMotion:
    """The camera's pose over an episode: a set point plus the hover's random processes.

    Args:
        config: the task; its ``camera`` section's drift, wobble and gimbal fields.

    Attributes:
        pose: ``(6,)`` the pose at the newest picture (``set_point`` before any), read-only.
        moves: whether the camera moves at all (else nothing is ever drawn).
    """

    def __init__(self, config: EnvConfig) -> None:
        cam = config.camera
        self.config = config
        self.moves = cam.moves
        self.home = set_point(config)
        self.home.flags.writeable = False
        # Standard deviations and correlation times of (dx, dy, dz, yaw), each an OU process.
        self._sigma = np.array(
            [cam.drift, cam.drift, cam.height_wobble, math.radians(cam.yaw_wobble_deg)]
        )
        self._tau = np.array([cam.drift_time, cam.drift_time, cam.wobble_time, cam.wobble_time])
        tilt = math.radians(cam.tilt_wobble_deg)
        self._gimbal = (
            _Gimballed(tilt, cam.wobble_time, cam.gimbal_bandwidth)
            if cam.gimbal_bandwidth > 0.0 and tilt > 0.0
            else None
        )
        self._tilt_sigma = tilt
        self.pose = self.home
        self._time = 0.0
        self._ou = np.zeros(4)
        self._tilts = np.zeros((2, 2))  # (pitch, roll) x (drone angle a, gimbal angle g)

    def reset(self, rng: np.random.Generator) -> None:
        """Start an episode at time 0, every process drawn from its stationary law."""
        self._time = 0.0
        self.pose = self.home
        if not self.moves:
            return
        self._ou = self._sigma * rng.standard_normal(4)
        if self._gimbal is not None:
            self._tilts = np.stack([self._gimbal.start(rng), self._gimbal.start(rng)])
        else:
            self._tilts = np.zeros((2, 2))
            self._tilts[:, 0] = self._tilt_sigma * rng.standard_normal(2)
        self._set_pose()

    def advance(self, time: float, rng: np.random.Generator) -> np.ndarray:
        """Move the processes on to ``time`` (s since reset, not before the last call) and return
        the pose then (``(6,)``, read-only)."""
        if not self.moves:
            return self.pose
        delta = max(time - self._time, 0.0)
        self._time = max(time, self._time)
        rho = np.exp(-delta / self._tau)
        self._ou = rho * self._ou + self._sigma * np.sqrt(1.0 - rho**2) * rng.standard_normal(4)
        if self._gimbal is not None:
            self._tilts = np.stack(
                [self._gimbal.advance(self._tilts[i], delta, rng) for i in range(2)]
            )
        else:
            r = math.exp(-delta / self.config.camera.wobble_time)
            noise = self._tilt_sigma * math.sqrt(1.0 - r * r) * rng.standard_normal(2)
            self._tilts[:, 0] = r * self._tilts[:, 0] + noise
        self._set_pose()
        return self.pose

    def _set_pose(self) -> None:
        tilt = self._tilts[:, 0] - self._tilts[:, 1]  # what the gimbal left: (pitch, roll)
        pose = self.home + np.array(
            [self._ou[0], self._ou[1], self._ou[2], self._ou[3], tilt[0], tilt[1]]
        )
        pose.flags.writeable = False
        self.pose = pose
