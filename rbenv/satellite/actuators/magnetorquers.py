"""Magnetorquers: coils whose dipole m turns the satellite against Earth's field, τ = m × B.

An actuator of the plant (:mod:`rbenv.satellite.actuators.base`), configured by the scene table
``[magnetorquers]``: rod axes (body frame) and the largest dipole of each rod (A·m²). The action
(every mode) is one entry per rod, the dipole as a fraction of its maximum in [-1, 1]; the body
dipole is ``m_B = G_t μ``, held over the control step as the envs hold every command, and the
torque ``m_B × R(q)ᵀ B_N(t)`` with the field of the scene's orbit (:mod:`rbenv.satellite.orbit`),
fixed in inertial axes: the plant evaluates it at every integrator stage
(:mod:`rbenv.satellite.disturbances`), since the body turns under the field. Only the part of a
torque perpendicular to B can be made.

Effort: electrical power ``Σ |μ_i|/μ_max,i · P_max,i`` over its maximum (``power_W`` per rod at
full dipole); ``mtq_energy_J`` accounts it. Observation part: the magnetometer, ``B_B`` over
``field_scale_T`` (50 µT), clipped to [-1, 1].
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from rbenv.core import kernels as k
from rbenv.core.backend import NUMPY
from rbenv.core.errors import InvalidParameterError
from rbenv.satellite.actuators import tables
from rbenv.satellite.actuators.base import (
    ActuatorDefaults,
    Contribution,
    action_components,
    one_row,
)

__all__ = ["Magnetorquers", "make_magnetorquers", "parse_magnetorquers"]

FIELD_SCALE_T = 5e-5  # T: one observation unit of the magnetometer
_new = tuple.__new__


@dataclass(frozen=True, eq=False)
class RodSet:
    """The scene's ``[magnetorquers]`` table, validated."""

    axes_B: np.ndarray  # (n, 3) unit rod axes, body frame
    max_dipole: np.ndarray  # (n,) A·m²
    power: np.ndarray  # (n,) W at full dipole

    @property
    def n(self) -> int:
        return len(self.max_dipole)

    def drawing(self) -> dict:
        """Keyword arguments of :class:`rbenv.envs.rendering.Renderer`: the dipole drawn at the
        arrow's full length, every rod at its maximum."""
        return {"full_dipole": float(np.linalg.norm(self.axes_B.T @ np.abs(self.max_dipole)))}


def parse_magnetorquers(table: dict, com_B=None) -> RodSet:
    """``axes`` (list of [x, y, z]), ``max_dipole`` (A·m², one or per rod), ``power_W``."""
    tables.keys("magnetorquers", table, {"axes", "max_dipole", "power_W"},
                ("axes", "max_dipole"))
    axes = tables.axes("magnetorquers", table["axes"])
    n = len(axes)
    return RodSet(axes_B=axes,
                  max_dipole=tables.per_element("magnetorquers", table, "max_dipole", n, 0.0,
                                                1e-9, 1e4),
                  power=tables.per_element("magnetorquers", table, "power_W", n, 0.0, 0.0,
                                           1e4))


@dataclass(frozen=True, eq=False)
class Magnetorquers(ActuatorDefaults):
    """The scene's magnetorquers, precomputed for the per-step path."""

    scene_table: ClassVar[str] = "magnetorquers"
    info_keys: ClassVar[tuple] = ("mtq_energy_J",)
    gives_dipole: ClassVar[bool] = True
    start_stream: ClassVar[str] = "magnetorquers"
    observation_structure: ClassVar[dict] = {"field_B": 3}

    rods: RodSet
    control_dt: float  # s
    noise_T: float = 0.0  # the magnetometer's noise, T (1σ per axis)
    n: int = field(init=False)
    action_shape: tuple = field(init=False)
    action_bounds: tuple = field(init=False, repr=False)
    dipole_matrix: np.ndarray = field(init=False, repr=False)  # (n, 3): fraction → m_B
    max_power: float = field(init=False)  # W
    inv_max_power: float = field(init=False)  # 1/W (0 when the rods draw no power)
    dipoles: tuple = field(init=False, repr=False)  # n rows μ_max,i ĝ_i, 3-tuples of floats
    powers: tuple = field(init=False, repr=False)  # n floats, W at full dipole
    state_fields: dict = field(init=False, repr=False)
    sensor_normals: int = field(init=False)  # the magnetometer's: 3 when noisy, else 0

    def __post_init__(self):
        rods = self.rods
        low, high = -np.ones(rods.n), np.ones(rods.n)
        for arr in (low, high):
            arr.setflags(write=False)
        matrix = rods.axes_B * rods.max_dipole[:, None]
        matrix.setflags(write=False)
        total = float(rods.power.sum())
        values = {"n": rods.n, "action_shape": (rods.n,), "action_bounds": (low, high),
                  "dipole_matrix": matrix, "max_power": total,
                  "inv_max_power": 1.0 / total if total else 0.0,
                  "dipoles": tuple(tuple(float(c) for c in row) for row in matrix),
                  "powers": tuple(float(p) for p in rods.power),
                  # mtq_dipole_B: the body dipole of the last step, A·m² (3 components).
                  # mtq_energy_J: cumulative. (The field is the plant's field_B_T.)
                  "state_fields": {"mtq_dipole_B": "c3", "mtq_energy_J": "f"},
                  "sensor_normals": 3 if self.noise_T else 0}
        for name, value in values.items():
            object.__setattr__(self, name, value)

    def command(self, a, in_place: bool = False, xp=NUMPY) -> tuple:
        """Dipole fractions per rod (components), clipped to [-1, 1]; NaN raises."""
        clip = xp.clip
        return tuple([clip(c, -1.0, 1.0) for c in action_components(a, xp)])

    def actuate(self, st, fraction, noise, xp) -> Contribution:
        """The body dipole ``m_B`` (the contribution's ``dipole_B``), held over the step; the
        plant evaluates ``m_B × R(q)ᵀ B_N(t)`` at every integrator stage. Sets the mtq_*
        fields."""
        f = fraction  # one component per rod
        model = st.model  # domain randomization: this episode's dipole scales, or None
        g = f if model is None or model.rod_dipole_c is None else tuple(
            [fi * si for fi, si in zip(f, model.rod_dipole_c, strict=True)])
        m_B = k.scale(self.dipoles[0], g[0])  # Σ μ_i ĝ_i, A·m², body axes
        power = abs(f[0]) * self.powers[0]  # the coil's power follows its command
        for i in range(1, self.n):
            m_B = k.add(m_B, self.dipoles[i], g[i])
            power = power + abs(f[i]) * self.powers[i]
        st.mtq_dipole_B = m_B
        st.mtq_energy_J = st.mtq_energy_J + power * self.control_dt
        zero = k.scale(m_B, 0.0)  # the torque m_B × B is the plant's, at every stage
        return _new(Contribution, (zero, None, None, None, power * self.inv_max_power, m_B))

    def sample_start(self, draws) -> dict:
        m = draws.n
        zero = draws.xp.zeros(m)
        return {"mtq_dipole_B": (zero, zero, zero), "mtq_energy_J": zero}

    def observe(self, st, xp, sensed=None) -> tuple:
        """The magnetometer: B_B / 50 µT, clipped to [-1, 1] (the field now), with noise
        ``σ·sensed`` (σ the scene's ``sensor_noise.magnetometer``, T) when ``sensed`` is given."""
        s, clip = 1.0 / FIELD_SCALE_T, xp.clip
        b = st.field_B_T if sensed is None else k.add(st.field_B_T, sensed, self.noise_T)
        return (clip(b[0] * s, -1.0, 1.0), clip(b[1] * s, -1.0, 1.0), clip(b[2] * s, -1.0, 1.0))

    def render_values(self, st, index: int | None) -> dict:
        """The body dipole of the last step, A·m² (an arrow)."""
        return {"dipole_B": one_row(st.mtq_dipole_B, index)}

    def info(self, st, xp, out: dict) -> None:
        """mtq_energy_J (cumulative)."""
        out["mtq_energy_J"] = st.mtq_energy_J


def make_magnetorquers(scene, action_mode: str = "throttle",
                       allocator: str = "pinv") -> Magnetorquers:
    """The scene's magnetorquers (its ``[magnetorquers]`` table); they need a field."""
    if not scene.orbit.magnetic_field:
        raise InvalidParameterError(
            "magnetorquers need Earth's field: set orbit.model = 'circular' and "
            "orbit.magnetic_field = true in the scene")
    sensor = scene.sensor_noise
    return Magnetorquers(rods=scene.actuators["magnetorquers"],
                         control_dt=scene.physics.control_dt,
                         noise_T=sensor.magnetometer if sensor.model == "gaussian" else 0.0)
