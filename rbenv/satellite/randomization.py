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
  for an episode with probability ``delay_probability``;
* each reaction wheel's spin axis, tilted by up to ``wheel_misalignment_deg`` about a random
  perpendicular axis; its motor torque, scaled by ``1 ± wheel_torque_scale`` (the torque the
  motor realizes of what the firmware commands); and its speed sensor, whose reading is scaled by
  ``1 ± wheel_speed_scale`` (the observation only: the physics keeps the true speed);
* each magnetorquer's dipole, scaled by ``1 ± rod_dipole_scale`` (its power is unchanged).

With reaction wheels the inertia drawn is the bus's, ``I_bus = I − Σ J ĝĝᵀ`` (what the plant
integrates): the rotors keep their spin inertia J about their (possibly tilted) axes ĝ', and
the whole spacecraft's inertia, ``I_bus' + Σ J ĝ'ĝ'ᵀ``, is what the gravity gradient acts on.
The wheels' firmware (the speed-limit headroom, the acceleration modes' ``J_eff``) keeps the
nominal model, as the flight software does: it limits the torque it commands, so a motor
stronger than nominal can pass Ω_max by up to ``wheel_torque_scale`` of the last step's headroom.

A field that perturbs an actuator the scene lacks (``force_scale`` on a scene without
``[thrusters]``, say) would change nothing and is refused by name (:func:`check_applies`).

The policy does not observe any of these values, and the scripted baselines keep using the
nominal model: this is where a learned, robust policy can beat a model-based one. All draws come
from the episode's counter-based streams (:mod:`rbenv.satellite.draws`): "randomization" for the
body and thrusters, "randomization.wheels" and "randomization.magnetorquers" for the wheels and
rods (streams of their own: adding them shifted no earlier draw), so the single env and sub-env
``i`` of the vector env draw the same physics for the same (seed, episode).
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

__all__ = ["ACTUATOR_FIELDS", "BatchBody", "EpisodeModel", "Randomization", "check_applies",
           "draw_episode_model"]

ROD_STREAM = "randomization.magnetorquers"
WHEEL_STREAM = "randomization.wheels"


@dataclass(frozen=True)
class Randomization:
    """Sizes of the per-episode perturbations; all zero (the default) means off.

    inertia_scale: fraction, [0, 0.9]. inertia_rotation_deg: [0, 90]. com_offset: m, [0, 10].
    force_scale: fraction, [0, 0.9]. misalignment_deg: [0, 45]. delay_probability: [0, 1].
    wheel_misalignment_deg: [0, 45]. wheel_torque_scale, wheel_speed_scale, rod_dipole_scale:
    fractions, [0, 0.9].
    """

    inertia_scale: float = 0.0
    inertia_rotation_deg: float = 0.0
    com_offset: float = 0.0
    force_scale: float = 0.0
    misalignment_deg: float = 0.0
    delay_probability: float = 0.0
    wheel_misalignment_deg: float = 0.0
    wheel_torque_scale: float = 0.0
    wheel_speed_scale: float = 0.0
    rod_dipole_scale: float = 0.0

    _LIMITS: ClassVar[dict] = {"inertia_scale": 0.9, "inertia_rotation_deg": 90.0,
                               "com_offset": 10.0, "force_scale": 0.9,
                               "misalignment_deg": 45.0, "delay_probability": 1.0,
                               "wheel_misalignment_deg": 45.0, "wheel_torque_scale": 0.9,
                               "wheel_speed_scale": 0.9, "rod_dipole_scale": 0.9}

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


# Each field that perturbs one actuator: its scene table, and what it perturbs (for the error).
ACTUATOR_FIELDS = {
    "com_offset": ("thrusters", "the thrusters' lever arms"),
    "force_scale": ("thrusters", "each thruster's force"),
    "misalignment_deg": ("thrusters", "each thruster's direction"),
    "delay_probability": ("thrusters", "the throttles (a one-step delay)"),
    "wheel_misalignment_deg": ("wheels", "each reaction wheel's spin axis"),
    "wheel_torque_scale": ("wheels", "each reaction wheel's motor torque"),
    "wheel_speed_scale": ("wheels", "each reaction wheel's speed sensor"),
    "rod_dipole_scale": ("magnetorquers", "each magnetorquer's dipole"),
}


def check_applies(rnd: Randomization, scene) -> None:
    """Refuse (named error) a non-zero field that perturbs an actuator ``scene`` lacks: it
    would change nothing, and a user who set it expects it to."""
    for name, (table, what) in ACTUATOR_FIELDS.items():
        value = getattr(rnd, name)
        if value and table not in scene.actuators:
            raise InvalidParameterError(
                f"randomization.{name} = {value!r} perturbs {what}, but scene {scene.name!r} "
                f"has no [{table}] table, so it would change nothing; it must be 0 on this "
                f"scene (the scene's actuators: {sorted(scene.actuators)})")


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

    inertia: (N, 3, 3) kg·m², the integrated body's (the bus's, with reaction wheels).
    com_offset_B: (N, 3) m. action_matrix: (N, n, k) throttles → ``[τ_B, Σu_iF_i, F_B]`` as
    :func:`rbenv.satellite.actuators.thrusters.action_matrix`, or None without thrusters.
    delayed: (N,) bool. body: a :class:`RigidBody` (single) or :class:`BatchBody`. Optional,
    None when not drawn: total_inertia (N, 3, 3) kg·m², the whole spacecraft's (bus plus the
    rotors' spin inertia; ``whole_body`` is its body, else ``body``); wheel_axes (N, n, 3) unit
    spin axes; wheel_torque_scale and wheel_speed_scale (N, n); rod_dipole_scale (N, n). Their
    ``*_c`` views are components for the actuators (floats for one env, (N,) views for N:
    rows written by :meth:`assign` show in them). ``single()`` gives the one-env view.
    """

    __slots__ = ("action_matrix", "body", "com_offset_B", "delayed", "inertia", "mass",
                 "rod_dipole_c", "rod_dipole_scale", "total_inertia", "wheel_axes",
                 "wheel_axes_c", "wheel_speed_c", "wheel_speed_scale", "wheel_torque_c",
                 "wheel_torque_scale", "whole_body")
    _EXTRA = ("total_inertia", "wheel_axes", "wheel_torque_scale", "wheel_speed_scale",
              "rod_dipole_scale")

    def __init__(self, mass, inertia, com_offset_B, action_matrix, delayed, **extra):
        self.mass, self.inertia, self.com_offset_B = mass, inertia, com_offset_B
        self.action_matrix, self.delayed = action_matrix, delayed
        for name in self._EXTRA:
            setattr(self, name, extra.pop(name, None))
        if extra:
            raise TypeError(f"EpisodeModel got unknown fields {sorted(extra)}")
        self.body = BatchBody(mass, inertia)
        self.whole_body = self.body if self.total_inertia is None \
            else BatchBody(mass, self.total_inertia)
        self.wheel_axes_c = None if self.wheel_axes is None else tuple(
            tuple(self.wheel_axes[:, i, c] for c in range(3))
            for i in range(self.wheel_axes.shape[1]))
        self.wheel_torque_c, self.wheel_speed_c, self.rod_dipole_c = (
            None if a is None else tuple(a.T)
            for a in (self.wheel_torque_scale, self.wheel_speed_scale, self.rod_dipole_scale))

    def single(self) -> EpisodeModel:
        """The same model for one env: a validated RigidBody, (n, k) matrix, bool delay,
        component views of Python floats."""
        model = object.__new__(EpisodeModel)
        model.mass, model.inertia = self.mass, self.inertia[0]
        model.com_offset_B = self.com_offset_B[0]
        model.action_matrix = None if self.action_matrix is None \
            else np.ascontiguousarray(self.action_matrix[0])
        model.delayed = bool(self.delayed[0])
        model.body = RigidBody(mass=self.mass, inertia=self.inertia[0])
        for name in self._EXTRA:
            value = getattr(self, name)
            setattr(model, name, None if value is None else value[0])
        model.whole_body = model.body if self.total_inertia is None \
            else RigidBody(mass=self.mass, inertia=self.total_inertia[0])
        model.wheel_axes_c = None if self.wheel_axes is None else tuple(
            tuple(row) for row in self.wheel_axes[0].tolist())
        model.wheel_torque_c, model.wheel_speed_c, model.rod_dipole_c = (
            None if a is None else tuple(a[0].tolist())
            for a in (self.wheel_torque_scale, self.wheel_speed_scale, self.rod_dipole_scale))
        return model

    def assign(self, idx: np.ndarray, new: EpisodeModel) -> None:
        """Replace rows ``idx`` by ``new`` (a model of len(idx) episodes); rebuild the body."""
        self.inertia[idx] = new.inertia
        self.com_offset_B[idx] = new.com_offset_B
        if self.action_matrix is not None:
            self.action_matrix[idx] = new.action_matrix
        self.delayed[idx] = new.delayed
        for name in self._EXTRA:
            arr = getattr(self, name)
            if arr is not None:  # in place: the component views see the new rows
                arr[idx] = getattr(new, name)
        self.body = BatchBody(self.mass, self.inertia)
        self.whole_body = self.body if self.total_inertia is None \
            else BatchBody(self.mass, self.total_inertia)


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
    """The randomized physics of ``draws.n`` episodes.

    Stream "randomization" (normals take two slots each and start on even slots): uniforms 0–2
    inertia scale, normals from 4 (rotation) and 10 (CoM direction), uniform 16 (CoM radius),
    uniforms 17… (n force scales), then from the next even slot t: 3n normals (tilt axes), n
    uniforms (tilt angles) and 1 uniform (delay); n = 0 without thrusters. Streams
    "randomization.wheels" and "randomization.magnetorquers": see :func:`_wheel_draws` and
    :func:`_rod_draws`. The inertia perturbed is the integrated body's (``plant.body``: the
    scene's, or the bus without the wheels' spin inertia).
    """
    rnd, sc = plant.randomization, plant.scene
    thr, N = sc.thrusters, draws.n
    n = 0 if thr is None else thr.n
    u = draws.uniform_array
    scale = 1.0 + rnd.inertia_scale * (2.0 * u("randomization", 3) - 1.0)
    rot = math.radians(rnd.inertia_rotation_deg) * draws.normal_array("randomization", 3, 4)
    inertia = _perturbed_inertia(plant.body.inertia, scale.T, rot.T)
    direction = draws.normal_array("randomization", 3, 10).T
    direction /= np.maximum(np.linalg.norm(direction, axis=1, keepdims=True), 1e-300)
    radius = rnd.com_offset * np.cbrt(u("randomization", 1, 16)[0])
    com_offset = direction * radius[:, None]
    t = 18 + n - n % 2  # the first even slot after the force scales
    delayed = u("randomization", 1, t + 7 * n)[0] < rnd.delay_probability
    matrix = None
    if thr is not None:
        force = thr.max_force * (1.0 + rnd.force_scale
                                 * (2.0 * u("randomization", n, 17).T - 1.0))
        tilt_normals = draws.normal_array("randomization", 3 * n, t).T.reshape(N, n, 3)
        tilt = math.radians(rnd.misalignment_deg) * np.sqrt(u("randomization", n, t + 6 * n).T)
        dirs = _tilted(thr.directions_B, tilt_normals, tilt)
        force_B = dirs * force[..., None]  # (N, n, 3) N at full throttle
        arms = thr.positions_B - thr.com_B - com_offset[:, None, :]  # (N, n, 3) m
        torque_B = cross(arms, force_B)
        cols = [torque_B, force[..., None]] + ([force_B] if sc.physics.translation else [])
        matrix = np.concatenate(cols, axis=-1)
    extra = {}
    wheels = plant.actuator("wheels")
    if wheels is not None:
        extra.update(_wheel_draws(rnd, wheels.wheels, draws, inertia))
    rods = plant.actuator("magnetorquers")
    if rods is not None and rnd.rod_dipole_scale:
        extra.update(_rod_draws(rnd, rods.rods.n, draws))
    return EpisodeModel(sc.body.mass, inertia, com_offset, matrix, delayed, **extra)


def _scales(size: float, u: np.ndarray) -> np.ndarray:
    """(N, n) factors ``1 ± size`` from (n, N) uniforms."""
    return 1.0 + size * (2.0 * u.T - 1.0)


def _wheel_draws(rnd: Randomization, ws, draws, bus: np.ndarray) -> dict:
    """The wheels' part (stream "randomization.wheels", n wheels): normals from slot 0 (3n,
    the tilt axes), uniforms 6n… (n tilt angles), 7n… (n torque scales), 8n… (n speed-sensor
    scales); each block drawn only when its field is on, at fixed slots. ``bus``: the drawn
    (N, 3, 3) bus inertia; the whole spacecraft's adds each rotor's ``J ĝ'ĝ'ᵀ``."""
    n, N, out = ws.n, draws.n, {}
    axes = np.broadcast_to(ws.axes_B, (N, n, 3))
    if rnd.wheel_misalignment_deg:
        normals = draws.normal_array(WHEEL_STREAM, 3 * n, 0).T.reshape(N, n, 3)
        tilt = math.radians(rnd.wheel_misalignment_deg) * np.sqrt(
            draws.uniform_array(WHEEL_STREAM, n, 6 * n).T)
        axes = out["wheel_axes"] = _tilted(ws.axes_B, normals, tilt)
    total = bus.copy()
    for i in range(n):  # element by element: the same sums for one env as for a batch
        g, J = axes[:, i, :], float(ws.inertia[i])
        total += J * (g[:, :, None] * g[:, None, :])
    out["total_inertia"] = total
    if rnd.wheel_torque_scale:
        out["wheel_torque_scale"] = _scales(rnd.wheel_torque_scale,
                                            draws.uniform_array(WHEEL_STREAM, n, 7 * n))
    if rnd.wheel_speed_scale:
        out["wheel_speed_scale"] = _scales(rnd.wheel_speed_scale,
                                           draws.uniform_array(WHEEL_STREAM, n, 8 * n))
    return out


def _rod_draws(rnd: Randomization, n: int, draws) -> dict:
    """The magnetorquers' part (stream "randomization.magnetorquers", n rods): uniforms 0…
    (n dipole scales)."""
    return {"rod_dipole_scale": _scales(rnd.rod_dipole_scale,
                                        draws.uniform_array(ROD_STREAM, n, 0))}
