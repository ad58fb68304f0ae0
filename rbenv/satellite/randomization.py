"""Domain randomization: the true physics of each episode, drawn from the env's own seed.

A scene's ``[randomization]`` table (or ``gym.make(..., randomize={...})``) perturbs, per
episode, what a model-based controller believes it knows:

* the inertia: each principal second moment of the mass distribution scaled by
  ``1 ± inertia_scale`` and the distribution turned by up to ``inertia_rotation_deg`` (this
  creates products of inertia). Working on the second-moment matrix ``J = ½tr(I)E − I`` keeps
  every draw physically valid: ``S J S`` and ``R J Rᵀ`` stay positive semi-definite, so
  ``I = tr(J)E − J`` is symmetric positive definite and obeys the triangle inequality;
* the centre of mass: offset uniformly inside a ball of radius ``com_offset`` (m), which changes
  every thruster's lever arm;
* each thruster's force, scaled by ``1 ± force_scale``, and its direction, tilted by up to
  ``misalignment_deg`` about a random perpendicular axis;
* a one-step control delay (the throttles commanded at step t fire at step t + 1), switched on
  for an episode with probability ``delay_probability``.

The policy does not observe any of these values, and the scripted baselines keep using the
nominal model: this is where a learned, robust policy can beat a model-based one. All draws come
from the episode's counter-based stream ("randomization", :mod:`rbenv.satellite.draws`), so the
single env and sub-env ``i`` of the vector env draw the same physics for the same (seed, episode).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import ClassVar

import numpy as np

from rbenv.core import quaternion, validation
from rbenv.core.body import RigidBody
from rbenv.core.errors import InvalidParameterError
from rbenv.core.vec import cross

__all__ = ["BatchBody", "EpisodeModel", "Randomization", "draw_episode_model"]


@dataclass(frozen=True)
class Randomization:
    """Sizes of the per-episode perturbations; all zero (the default) means off.

    inertia_scale: fraction, [0, 0.9]. inertia_rotation_deg: [0, 90]. com_offset: m, ≥ 0.
    force_scale: fraction, [0, 0.9]. misalignment_deg: [0, 45]. delay_probability: [0, 1].
    """

    inertia_scale: float = 0.0
    inertia_rotation_deg: float = 0.0
    com_offset: float = 0.0
    force_scale: float = 0.0
    misalignment_deg: float = 0.0
    delay_probability: float = 0.0

    _LIMITS: ClassVar[dict] = {"inertia_scale": 0.9, "inertia_rotation_deg": 90.0,
                               "com_offset": 10.0, "force_scale": 0.9,
                               "misalignment_deg": 45.0, "delay_probability": 1.0}

    def __post_init__(self):
        for f in fields(self):
            value = validation.number(f"randomization.{f.name}", getattr(self, f.name),
                                      low=0.0, high=self._LIMITS[f.name])
            object.__setattr__(self, f.name, value)

    @property
    def enabled(self) -> bool:
        """True when any perturbation is non-zero."""
        return any(getattr(self, f.name) for f in fields(self))

    @classmethod
    def from_mapping(cls, mapping) -> Randomization:
        """From a dict (unknown names are errors), a Randomization, or None/False (off)."""
        if mapping is None or mapping is False:
            return cls()
        if isinstance(mapping, Randomization):
            return mapping
        if not isinstance(mapping, dict):
            raise InvalidParameterError(
                f"randomization must be a table/dict of perturbation sizes, got {mapping!r}")
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(mapping) - names)
        if unknown:
            raise InvalidParameterError(
                f"randomization has unknown field(s) {unknown}; allowed: {sorted(names)}")
        return cls(**mapping)


class BatchBody:
    """N rigid bodies with per-body inertia, with the kernel interface of :class:`RigidBody`.

    inertia: (N, 3, 3) kg·m², each a valid inertia (checked by the caller). The integrator
    kernels only call ``inertia_times``, ``inverse_times`` and ``inverse_columns`` and read
    ``is_isotropic`` and ``mass``; here every coefficient is an (N,) array.
    """

    kind = "full"
    is_isotropic = False

    def __init__(self, mass: float, inertia: np.ndarray):
        inv = np.linalg.inv(inertia)
        inv = 0.5 * (inv + np.swapaxes(inv, -1, -2))
        self.mass = mass
        self.inertia, self.inertia_inv = inertia, inv
        self._rows = tuple(tuple(inertia[:, i, j] for j in range(3)) for i in range(3))
        self._inv_rows = tuple(tuple(inv[:, i, j] for j in range(3)) for i in range(3))
        self.inverse_columns = tuple(tuple(inv[:, i, j] for i in range(3)) for j in range(3))

    @staticmethod
    def _times(rows, v):
        (a, b, c), (d, e, f), (g, h, i) = rows
        x, y, z = v
        return (a * x + b * y + c * z, d * x + e * y + f * z, g * x + h * y + i * z)

    def inertia_times(self, v: tuple) -> tuple:
        """``I v`` on (N,) components."""
        return self._times(self._rows, v)

    def inverse_times(self, v: tuple) -> tuple:
        """``I⁻¹ v`` on (N,) components."""
        return self._times(self._inv_rows, v)


class EpisodeModel:
    """The true physics of N episodes (N = 1 for the single env): body, actuation, delay.

    inertia: (N, 3, 3) kg·m². com_offset_B: (N, 3) m. action_matrix: (N, n, k) throttles →
    ``[τ_B, Σu_iF_i, F_B]`` as :func:`rbenv.satellite.actuators.thrusters.action_matrix`.
    delayed: (N,) bool. body: a :class:`RigidBody` (single) or :class:`BatchBody`. ``single()``
    gives the one-env view.
    """

    __slots__ = ("action_matrix", "body", "com_offset_B", "delayed", "inertia", "mass")

    def __init__(self, mass, inertia, com_offset_B, action_matrix, delayed):
        self.mass, self.inertia, self.com_offset_B = mass, inertia, com_offset_B
        self.action_matrix, self.delayed = action_matrix, delayed
        self.body = BatchBody(mass, inertia)

    def single(self) -> EpisodeModel:
        """The same model for one env: a validated RigidBody, (n, k) matrix, bool delay."""
        model = object.__new__(EpisodeModel)
        model.mass, model.inertia = self.mass, self.inertia[0]
        model.com_offset_B = self.com_offset_B[0]
        model.action_matrix = np.ascontiguousarray(self.action_matrix[0])
        model.delayed = bool(self.delayed[0])
        model.body = RigidBody(mass=self.mass, inertia=self.inertia[0])
        return model

    def assign(self, idx: np.ndarray, new: EpisodeModel) -> None:
        """Replace rows ``idx`` by ``new`` (a model of len(idx) episodes); rebuild the body."""
        self.inertia[idx] = new.inertia
        self.com_offset_B[idx] = new.com_offset_B
        self.action_matrix[idx] = new.action_matrix
        self.delayed[idx] = new.delayed
        self.body = BatchBody(self.mass, self.inertia)


def _perturbed_inertia(inertia: np.ndarray, scale: np.ndarray, rotvec: np.ndarray) -> np.ndarray:
    """(N, 3, 3) inertias: second moments scaled by ``scale`` (N, 3) and turned by ``rotvec``.

    Works on ``J = ½tr(I)E − I`` (positive semi-definite for a valid inertia), so the result
    ``tr(J')E − J'`` is valid for any positive scale and rotation.
    """
    J = 0.5 * np.trace(inertia) * np.eye(3) - inertia
    R = quaternion.to_matrix(quaternion.from_rotation_vector(rotvec))
    J_new = _similar(R, scale[:, :, None] * J * scale[:, None, :])
    J_new = 0.5 * (J_new + np.swapaxes(J_new, -1, -2))  # as RigidBody stores it (one episode)
    trace = J_new[:, 0, 0] + J_new[:, 1, 1] + J_new[:, 2, 2]
    return trace[:, None, None] * np.eye(3) - J_new


def _similar(R: np.ndarray, S: np.ndarray) -> np.ndarray:
    """``R S Rᵀ`` for (N, 3, 3) stacks, each sum written out in one order.

    A stacked ``@`` takes another BLAS path for one matrix than for several, so an episode's
    inertia would depend on how many sub-envs restart with it.
    """
    RS = [[R[:, i, 0] * S[:, 0, j] + R[:, i, 1] * S[:, 1, j] + R[:, i, 2] * S[:, 2, j]
           for j in range(3)] for i in range(3)]
    out = np.empty_like(S)
    for i in range(3):
        for j in range(3):
            out[:, i, j] = RS[i][0] * R[:, j, 0] + RS[i][1] * R[:, j, 1] + RS[i][2] * R[:, j, 2]
    return out


def _tilted(directions: np.ndarray, normals: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Unit directions (n, 3) tilted by ``angle`` (N, n) rad about random perpendicular axes.

    normals: (N, n, 3) standard normals giving the tilt direction.
    """
    d = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    perp = normals - np.sum(normals * d, axis=-1, keepdims=True) * d
    perp /= np.maximum(np.linalg.norm(perp, axis=-1, keepdims=True), 1e-300)
    return np.cos(angle)[..., None] * d + np.sin(angle)[..., None] * perp


def draw_episode_model(plant, draws) -> EpisodeModel:
    """The randomized physics of ``draws.n`` episodes (stream "randomization").

    Slot layout (normals take two slots each and start on even slots): uniforms 0–2 inertia
    scale, normals from 4 (rotation) and 10 (CoM direction), uniform 16 (CoM radius), uniforms
    17… (n force scales), then from the next even slot t: 3n normals (tilt axes), n uniforms
    (tilt angles) and 1 uniform (delay).
    """
    rnd, sc = plant.randomization, plant.scene
    thr, N = sc.thrusters, draws.n
    n = 0 if thr is None else thr.n
    u = draws.uniform_array
    scale = 1.0 + rnd.inertia_scale * (2.0 * u("randomization", 3) - 1.0)
    rot = math.radians(rnd.inertia_rotation_deg) * draws.normal_array("randomization", 3, 4)
    inertia = _perturbed_inertia(sc.body.inertia, scale.T, rot.T)
    direction = draws.normal_array("randomization", 3, 10).T
    direction /= np.maximum(np.linalg.norm(direction, axis=1, keepdims=True), 1e-300)
    radius = rnd.com_offset * np.cbrt(u("randomization", 1, 16)[0])
    com_offset = direction * radius[:, None]
    force = thr.max_force * (1.0 + rnd.force_scale * (2.0 * u("randomization", n, 17).T - 1.0))
    t = 18 + n - n % 2  # the first even slot after the force scales
    tilt_normals = draws.normal_array("randomization", 3 * n, t).T.reshape(N, n, 3)
    tilt = math.radians(rnd.misalignment_deg) * np.sqrt(u("randomization", n, t + 6 * n).T)
    dirs = _tilted(thr.directions_B, tilt_normals, tilt)
    delayed = u("randomization", 1, t + 7 * n)[0] < rnd.delay_probability
    force_B = dirs * force[..., None]  # (N, n, 3) N at full throttle
    arms = thr.positions_B - thr.com_B - com_offset[:, None, :]  # (N, n, 3) m
    torque_B = cross(arms, force_B)
    cols = [torque_B, force[..., None]] + ([force_B] if sc.physics.translation else [])
    matrix = np.concatenate(cols, axis=-1)
    return EpisodeModel(sc.body.mass, inertia, com_offset, matrix, delayed)
