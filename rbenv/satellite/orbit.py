"""The orbit and what it does to the attitude: a circular orbit, gravity gradient, Earth's field.

A scene opts in with an ``[orbit]`` table (``model = "circular"``); each effect is its own
switch, so a scene models only what it needs. Everything is closed form and evaluated on
components (floats for one satellite, (N,) arrays for N; ``xp`` the namespace):

* **Circular orbit** of radius ``r = R_eq + altitude``, inclination i, RAAN Ω and argument of
  latitude u₀ at the episode start; u(t) = u₀ + n t with the mean motion n = √(μ/r³).
  In ECI: ``r_N = r (cos u P̂ + sin u Q̂)`` with ``P̂ = [cos Ω, sin Ω, 0]`` and
  ``Q̂ = [−cos i sin Ω, cos i cos Ω, sin i]``.
* **Gravity gradient** ``τ_B = 3n² r̂_B × (I r̂_B)`` (r̂_B the unit position in body axes;
  Basilisk's GravityGradientEffector truth, Schaub & Junkins ch. 4).
* **Magnetic field**: a centred tilted dipole with IGRF-14's 2025.0 coefficients,
  ``B(r) = (R_ref/|r|)³ [3 (m·r̂) r̂ − m]``, ``m_E = [g₁¹, h₁¹, g₁⁰]``, in the Earth-fixed frame,
  which turns at ω_E about ECI z from the angle ``earth_rotation_deg`` at the episode start.
  About 23.7 µT at the equator and 47 µT at the poles at 500 km.

The world frame W of the envs is this ECI frame N. Sources: the actuators-and-orbit reference
note (§3, §5, §6): IGRF-14 (Alken et al. 2021 / Zenodo 14012303), μ and ω_E as Basilisk's
astroConstants.h.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

from rbenv.core import kernels as k
from rbenv.core import validation
from rbenv.core.errors import InvalidParameterError
from rbenv.satellite import disturbances as dist

__all__ = ["IGRF14_2025_NT", "MU_EARTH", "OMEGA_EARTH", "R_EQ", "R_REF", "Orbit", "OrbitTable"]

MU_EARTH = 3.986004418e14  # m³/s², Earth's gravitational parameter
R_EQ = 6378.137e3  # m, equatorial radius (altitude reference)
R_REF = 6371.2e3  # m, IGRF reference radius
OMEGA_EARTH = 2.0 * math.pi / (23.9345 * 3600.0)  # rad/s, sidereal rotation (7.2921e-5)
IGRF14_2025_NT = (-29350.0, -1410.3, 4545.5)  # g₁⁰, g₁¹, h₁¹ (nT), IGRF-14, epoch 2025.0


@dataclass(frozen=True)
class Orbit:
    """The scene's ``[orbit]`` table (angles in degrees, altitude in km).

    model: "none" or "circular". gravity_gradient, magnetic_field: each effect on or off.
    residual_dipole, drag, srp: the nested opt-in tables ``[orbit.residual_dipole]``,
    ``[orbit.drag]`` and ``[orbit.srp]`` (:mod:`rbenv.satellite.disturbances`), or None.
    """

    # Earth's constants, for the disturbances that take an orbit (rbenv.satellite.disturbances).
    EARTH_RADIUS: ClassVar[float] = R_EQ
    EARTH_RATE: ClassVar[float] = OMEGA_EARTH

    model: str = "none"
    altitude_km: float = 500.0
    inclination_deg: float = 97.4
    raan_deg: float = 0.0
    arg_latitude_deg: float = 0.0
    earth_rotation_deg: float = 0.0
    gravity_gradient: bool = False
    magnetic_field: bool = False
    # Nested opt-in tables (rbenv.satellite.disturbances): a dict from the scene, parsed to a frozen
    # dataclass here, or None.
    residual_dipole: object = None
    drag: object = None
    srp: object = None
    radius: float = field(init=False)  # m
    mean_motion: float = field(init=False)  # rad/s
    p_hat: tuple = field(init=False, repr=False)  # ECI unit vector to the ascending node
    q_hat: tuple = field(init=False, repr=False)  # ECI unit vector 90° ahead in the plane

    def __post_init__(self):
        validation.choice("orbit.model", self.model, ("none", "circular"))
        for name, low, high in (("altitude_km", 100.0, 1e5), ("inclination_deg", 0.0, 180.0),
                                ("raan_deg", -360.0, 360.0),
                                ("arg_latitude_deg", -360.0, 360.0),
                                ("earth_rotation_deg", -360.0, 360.0)):
            object.__setattr__(self, name, validation.number(f"orbit.{name}",
                                                             getattr(self, name), low=low,
                                                             high=high))
        for name in ("gravity_gradient", "magnetic_field"):
            flag = validation.flag(f"orbit.{name}", getattr(self, name))
            if flag and self.model == "none":
                raise InvalidParameterError(
                    f"orbit.{name} is true but orbit.model is 'none'; set model = 'circular'")

        for name, value in dist.parse_tables(self).items():
            object.__setattr__(self, name, value)
        r = R_EQ + 1e3 * self.altitude_km
        inc, raan = math.radians(self.inclination_deg), math.radians(self.raan_deg)
        object.__setattr__(self, "radius", r)
        object.__setattr__(self, "mean_motion", math.sqrt(MU_EARTH / r**3))
        object.__setattr__(self, "p_hat", (math.cos(raan), math.sin(raan), 0.0))
        object.__setattr__(self, "q_hat", (-math.cos(inc) * math.sin(raan),
                                           math.cos(inc) * math.cos(raan), math.sin(inc)))

    @property
    def enabled(self) -> bool:
        """Whether the scene models an orbit at all."""
        return self.model != "none"

    @property
    def torques(self) -> bool:
        """Whether the orbit applies a torque of its own (gravity gradient, residual dipole,
        drag, solar radiation pressure)."""
        return bool(self.gravity_gradient or self.residual_dipole or self.drag or self.srp)

    @property
    def period(self) -> float:
        """Orbital period, s."""
        return 2.0 * math.pi / self.mean_motion

    # ------------------------------------------------------------------- kinematics

    def direction_N(self, t, xp) -> tuple:
        """Unit position vector r̂_N (3 components) at time t (s, float or (N,) array)."""
        u = math.radians(self.arg_latitude_deg) + self.mean_motion * t
        c, s = xp.cos(u), xp.sin(u)
        p, q = self.p_hat, self.q_hat
        return (c * p[0] + s * q[0], c * p[1] + s * q[1], c * p[2] + s * q[2])

    def along_track_N(self, t, xp) -> tuple:
        """Unit velocity direction (3 components, ECI) at time t: d r̂_N / du."""
        u = math.radians(self.arg_latitude_deg) + self.mean_motion * t
        c, s = xp.cos(u), xp.sin(u)
        p, q = self.p_hat, self.q_hat
        return (-s * p[0] + c * q[0], -s * p[1] + c * q[1], -s * p[2] + c * q[2])

    # ------------------------------------------------------------------- torques, field

    def gravity_gradient_B(self, body, q_BN, t, xp) -> tuple:
        """Gravity-gradient torque at time t (:func:`gravity_gradient_torque_B`)."""
        return gravity_gradient_torque_B(body, q_BN, self.direction_N(t, xp), self.mean_motion)

    def field_N(self, t, xp) -> tuple:
        """Earth's field at the satellite, T, ECI axes (tilted dipole, IGRF-14 2025.0)."""
        r_hat = self.direction_N(t, xp)
        theta = math.radians(self.earth_rotation_deg) + OMEGA_EARTH * t
        c, s = xp.cos(theta), xp.sin(theta)
        g10, g11, h11 = (1e-9 * v for v in IGRF14_2025_NT)
        # The Earth-fixed dipole m_E = (g11, h11, g10), turned into ECI by θ about z.
        m = (c * g11 - s * h11, s * g11 + c * h11, g10 + 0.0 * c)
        scale = (R_REF / self.radius) ** 3
        d = 3.0 * k.dot(m, r_hat)
        return (scale * (d * r_hat[0] - m[0]), scale * (d * r_hat[1] - m[1]),
                scale * (d * r_hat[2] - m[2]))

    def field_B(self, q_BN, t, xp) -> tuple:
        """Earth's field in body axes, T."""
        return k.rotate_inverse(q_BN, self.field_N(t, xp))


def gravity_gradient_torque_B(body, q_BN, r_hat_N: tuple, mean_motion: float) -> tuple:
    """``3n² r̂_B × (I r̂_B)``, N·m, body axes: r̂_N the unit position (ECI components), n the
    mean motion (rad/s); ``body`` a RigidBody (or BatchBody)."""
    r_B = k.rotate_inverse(q_BN, r_hat_N)
    return k.scale(k.cross(r_B, body.inertia_times(r_B)), 3.0 * mean_motion ** 2)


class OrbitTable:
    """The orbit's inertial vectors at every half integrator step of an episode, computed once.

    Entry ``i`` holds time ``i·h/2``: a substep ``j`` starts at entry ``2j``, and the stages of
    the integrators (at 0, h/2 and h into the substep) look up ``2j``, ``2j + 1`` and
    ``2j + 2`` instead of evaluating sines and cosines per satellite; ``index`` is an int for
    one satellite, an (N,) int array for N. Vectors: ``direction`` (r̂_N), ``field`` (T, with
    the magnetic field), ``drag`` and ``srp`` (forces, N, with those tables) and ``lit`` (1 in
    sunlight, with SRP). Past the table (a step after the episode's end) the values are computed
    directly for one satellite and held at the last entry for a batch (those sub-envs are being
    reset).
    """

    def __init__(self, orbit: Orbit, h: float, substeps_per_episode: int):
        import numpy as np

        from rbenv.core.backend import NUMPY

        self.orbit, self.h = orbit, h
        self.gravity_gradient = orbit.gravity_gradient
        size = 2 * (substeps_per_episode + 2 * max(1, substeps_per_episode // 1000) + 64)
        t = np.arange(size) * (0.5 * h)
        self.last = size - 1
        self.direct = {"direction": orbit.direction_N}
        if orbit.magnetic_field:
            self.direct["field"] = orbit.field_N
        if orbit.drag is not None:
            self.direct["drag"] = lambda t, xp: dist.drag_force_N(orbit, t, xp)
        if orbit.srp is not None:
            self.direct["srp"] = lambda t, xp: dist.srp_force_N(orbit, t, xp)
            self.direct["lit"] = lambda t, xp: (dist.sun_and_shadow(orbit, t, xp)[1],)
        self.arrays = {name: tuple(np.ascontiguousarray(np.broadcast_to(c, t.shape))
                                   for c in fn(t, NUMPY))
                       for name, fn in self.direct.items()}
        self.floats = {}  # name → list of 3-tuples of floats, made at one satellite's first use
        self.direction = self.arrays["direction"]
        self.field = self.arrays.get("field")

    def lookup(self, name: str, index, xp) -> tuple:
        """Vector ``name`` at half-step ``index`` (components)."""
        if type(index) is int:
            if index <= self.last:
                rows = self.floats.get(name)
                if rows is None:
                    rows = self.floats[name] = list(zip(*(c.tolist() for c in
                                                          self.arrays[name]), strict=True))
                return rows[index]
            return tuple(float(c) for c in self.direct[name](index * 0.5 * self.h, xp))
        index = xp.minimum(index, self.last)
        const = xp.const
        return tuple(const(c)[index] for c in self.arrays[name])

    def direction_N(self, index, xp) -> tuple:
        """r̂_N at half-step ``index``."""
        return self.lookup("direction", index, xp)

    def field_N(self, index, xp) -> tuple:
        """Earth's field (T, ECI) at half-step ``index``."""
        return self.lookup("field", index, xp)

    def field_B(self, q_BN, index, xp) -> tuple:
        """Earth's field in body axes at half-step ``index``, T."""
        return k.rotate_inverse(q_BN, self.field_N(index, xp))

    def lit(self, index, xp):
        """1.0 in sunlight, 0.0 in the Earth's shadow, at half-step ``index`` (with SRP)."""
        return self.lookup("lit", index, xp)[0]
