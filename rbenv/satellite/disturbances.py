"""The torques a low orbit applies, evaluated where they act: at every integrator stage.

The plant hands the integrators one function of the stage (``torque_fn(s, q, ω)``, see
:mod:`rbenv.core.integrators`) that sums the orbit's torques at the stage's attitude and time,
for the whole batch at once (components: floats, NumPy or torch arrays). Each torque is opt-in:

* **gravity gradient** ``3n² r̂_B × (I r̂_B)`` (``orbit.gravity_gradient``);
* **magnetic** ``m_B × R(q)ᵀ B_N(t)``: the magnetorquers' dipole command, held over the control
  step, plus the spacecraft's residual dipole (``[orbit.residual_dipole]``); the field is fixed
  in inertial axes and the body turns under it;
* **aerodynamic** ``r_cp × F_B`` with ``F = −½ ρ C_D A |v| v`` (``[orbit.drag]``): ρ from the
  exponential atmosphere of Vallado (Fundamentals of Astrodynamics and Applications, 4th ed.,
  table 8-4) at the orbit's altitude, v the velocity of the circular orbit relative to an
  atmosphere that co-rotates with the Earth (ω_E about ECI z), A a constant reference area and
  r_cp the centre of pressure's offset from the centre of mass (body axes);
* **solar radiation pressure** ``r_cp × F_B`` with ``F = −P C_R A ŝ`` in sunlight and 0 in the
  Earth's cylindrical shadow (``[orbit.srp]``): P = 1361 W/m² / c (total solar irradiance,
  Kopp & Lean 2011), C_R = 1 + reflectivity, ŝ the Sun direction of the Astronomical Almanac's
  low-precision formula (about 0.01°) from the table's epoch (UTC).

Everything but the attitude is a function of time on a circular orbit, so the inertial vectors
(position, field, drag and SRP forces) are tabulated once per episode at every half integrator
step (:class:`rbenv.satellite.orbit.OrbitTable`): a stage looks them up and rotates them into body
axes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import datetime, timezone

from rbenv.core import kernels as k
from rbenv.core import validation
from rbenv.core.errors import InvalidParameterError

__all__ = ["ATMOSPHERE_VALLADO", "P_SUN", "Drag", "OrbitTorque", "ResidualDipole",
           "SolarPressure", "density", "parse_tables", "sun_direction_N"]

# Vallado, Fundamentals of Astrodynamics and Applications (4th ed.), table 8-4: base altitude
# h0 (km), density at h0 (kg/m³), scale height H (km); ρ = ρ0 exp(−(h − h0)/H) in [h0, next h0).
ATMOSPHERE_VALLADO = (
    (100.0, 5.297e-7, 5.877), (110.0, 9.661e-8, 7.263), (120.0, 2.438e-8, 9.473),
    (130.0, 8.484e-9, 12.636), (140.0, 3.845e-9, 16.149), (150.0, 2.070e-9, 22.523),
    (180.0, 5.464e-10, 29.740), (200.0, 2.789e-10, 37.105), (250.0, 7.248e-11, 45.546),
    (300.0, 2.418e-11, 53.628), (350.0, 9.518e-12, 53.298), (400.0, 3.725e-12, 58.515),
    (450.0, 1.585e-12, 60.828), (500.0, 6.967e-13, 63.822), (600.0, 1.454e-13, 71.835),
    (700.0, 3.614e-14, 88.667), (800.0, 1.170e-14, 124.64), (900.0, 5.245e-15, 181.05),
    (1000.0, 3.019e-15, 268.00),
)
C_LIGHT = 299_792_458.0  # m/s
P_SUN = 1361.0 / C_LIGHT  # N/m², solar radiation pressure at 1 AU (TSI 1361 W/m²)
J2000_UTC = datetime(2000, 1, 1, 12, 0, 0, tzinfo=timezone.utc)  # J2000.0 (UTC ≈ TT here)


def density(altitude_km: float) -> float:
    """Atmospheric density, kg/m³, at ``altitude_km`` (Vallado table 8-4; above 1000 km the
    last band continues)."""
    band = ATMOSPHERE_VALLADO[0]
    for row in ATMOSPHERE_VALLADO:
        if altitude_km >= row[0]:
            band = row
    h0, rho0, scale = band
    return rho0 * math.exp(-(altitude_km - h0) / scale)


def sun_direction_N(days_since_j2000, xp) -> tuple:
    """Unit vector from the Earth to the Sun, ECI (mean equator and equinox of date),
    Astronomical Almanac low-precision formula; ``days_since_j2000``: float or array."""
    deg = math.pi / 180.0
    n = days_since_j2000
    mean_lon = (280.460 + 0.9856474 * n) * deg
    g = (357.528 + 0.9856003 * n) * deg
    lam = mean_lon + (1.915 * deg) * xp.sin(g) + (0.020 * deg) * xp.sin(2.0 * g)
    eps = (23.439 - 0.0000004 * n) * deg
    c, s = xp.cos(lam), xp.sin(lam)
    return (c, xp.cos(eps) * s, xp.sin(eps) * s)


# --------------------------------------------------------------------------- scene tables


def _vector(path: str, value, bound: float) -> tuple:
    """3 finite numbers with |component| <= bound."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 3:
        raise InvalidParameterError(
            f"{path} must be 3 numbers (a body-axes vector), got {value!r}")
    return tuple(validation.number(f"{path}[{i}]", v, low=-bound, high=bound)
                 for i, v in enumerate(value))


def _table(path: str, table, allowed: dict) -> dict:
    """The table's keys checked against ``allowed`` (key → default, None: required)."""
    if not isinstance(table, dict):
        raise InvalidParameterError(f"[{path}] must be a table, got {table!r}")
    unknown = sorted(set(table) - set(allowed))
    if unknown:
        raise InvalidParameterError(
            f"[{path}] has unknown field(s) {unknown}; allowed: {sorted(allowed)}")
    missing = sorted(key for key, default in allowed.items()
                     if default is None and key not in table)
    if missing:
        raise InvalidParameterError(f"[{path}] needs the field(s) {missing}")
    return {**{key: v for key, v in allowed.items() if v is not None}, **table}


@dataclass(frozen=True)
class ResidualDipole:
    """``[orbit.residual_dipole]``: the spacecraft's own magnetic dipole, A·m², body axes
    (careful CubeSat designs 1e-3 to 1e-2 A·m², up to about 0.1)."""

    moment_B_Am2: tuple

    @classmethod
    def parse(cls, table) -> ResidualDipole:
        if isinstance(table, cls):
            return table
        t = _table("orbit.residual_dipole", table, {"moment_B_Am2": None})
        return cls(_vector("orbit.residual_dipole.moment_B_Am2", t["moment_B_Am2"], 10.0))


@dataclass(frozen=True)
class Drag:
    """``[orbit.drag]``: reference area (m²), drag coefficient (≈ 2.2 in free molecular flow),
    centre-of-pressure offset from the centre of mass (m, body axes), and a factor on the
    table's density (solar activity moves ρ by an order of magnitude)."""

    area_m2: float
    cd: float = 2.2
    cp_offset_B_m: tuple = (0.0, 0.0, 0.0)
    density_scale: float = 1.0

    @classmethod
    def parse(cls, table) -> Drag:
        if isinstance(table, cls):
            return table
        path = "orbit.drag"
        t = _table(path, table, {"area_m2": None, "cd": 2.2, "cp_offset_B_m": (0.0, 0.0, 0.0),
                                 "density_scale": 1.0})
        return cls(area_m2=validation.number(f"{path}.area_m2", t["area_m2"], low=0.0,
                                             high=1e4, low_open=True),
                   cd=validation.number(f"{path}.cd", t["cd"], low=0.0, high=10.0,
                                        low_open=True),
                   cp_offset_B_m=_vector(f"{path}.cp_offset_B_m", t["cp_offset_B_m"], 100.0),
                   density_scale=validation.number(f"{path}.density_scale",
                                                   t["density_scale"], low=0.0, high=1e3,
                                                   low_open=True))


def parse_epoch(path: str, value) -> float:
    """Days from J2000.0 of an ISO 8601 UTC date-time (no zone, or Z / +00:00)."""
    if not isinstance(value, str):
        raise InvalidParameterError(
            f"{path} must be an ISO 8601 UTC date-time string such as "
            f"'2025-03-20T12:00:00', got {value!r}")
    try:
        when = datetime.fromisoformat(value.replace("Z", "+00:00"))
    except ValueError:
        raise InvalidParameterError(
            f"{path} = {value!r} does not parse as an ISO 8601 date-time "
            "(e.g. '2025-03-20T12:00:00')") from None
    if when.tzinfo is None:
        when = when.replace(tzinfo=timezone.utc)
    if when.utcoffset().total_seconds() != 0.0:
        raise InvalidParameterError(f"{path} = {value!r} must be in UTC (offset +00:00 or Z)")
    days = (when - J2000_UTC).total_seconds() / 86400.0
    if not -36525.0 <= days <= 36525.0:
        raise InvalidParameterError(
            f"{path} = {value!r} must lie within a century of J2000.0 (the Sun formula's range)")
    return days


@dataclass(frozen=True)
class SolarPressure:
    """``[orbit.srp]``: area facing the Sun (m²), reflectivity in [0, 1] (C_R = 1 +
    reflectivity), centre-of-pressure offset (m, body axes), epoch of the episode start
    (ISO 8601 UTC)."""

    area_m2: float
    reflectivity: float = 0.0
    cp_offset_B_m: tuple = (0.0, 0.0, 0.0)
    epoch: str = "2025-03-20T12:00:00"
    epoch_days: float = field(init=False, default=0.0)  # days from J2000.0, from epoch

    def __post_init__(self):
        object.__setattr__(self, "epoch_days", parse_epoch("orbit.srp.epoch", self.epoch))

    @classmethod
    def parse(cls, table) -> SolarPressure:
        if isinstance(table, cls):
            return table
        path = "orbit.srp"
        t = _table(path, table, {"area_m2": None, "reflectivity": 0.0,
                                 "cp_offset_B_m": (0.0, 0.0, 0.0),
                                 "epoch": "2025-03-20T12:00:00"})
        return cls(area_m2=validation.number(f"{path}.area_m2", t["area_m2"], low=0.0,
                                             high=1e4, low_open=True),
                   reflectivity=validation.number(f"{path}.reflectivity", t["reflectivity"],
                                                  low=0.0, high=1.0),
                   cp_offset_B_m=_vector(f"{path}.cp_offset_B_m", t["cp_offset_B_m"], 100.0),
                   epoch=t["epoch"])


def parse_tables(orbit) -> dict:
    """The orbit's nested tables parsed (None where absent), with their prerequisites."""
    out = {"residual_dipole": None if orbit.residual_dipole is None
           else ResidualDipole.parse(orbit.residual_dipole),
           "drag": None if orbit.drag is None else Drag.parse(orbit.drag),
           "srp": None if orbit.srp is None else SolarPressure.parse(orbit.srp)}
    for name, value in out.items():
        if value is not None and orbit.model == "none":
            raise InvalidParameterError(
                f"[orbit.{name}] is given but orbit.model is 'none'; set model = 'circular'")
    if out["residual_dipole"] is not None and not orbit.magnetic_field:
        raise InvalidParameterError(
            "[orbit.residual_dipole] needs Earth's field: set orbit.magnetic_field = true")
    return out


# --------------------------------------------------------------------------- inertial forces


def drag_force_N(orbit, t, xp) -> tuple:
    """Aerodynamic force on the satellite, N, ECI: ``−½ ρ C_D A |v| v`` with v the orbit's
    velocity relative to the co-rotating atmosphere."""
    d = orbit.drag
    r_hat = orbit.direction_N(t, xp)
    t_hat = orbit.along_track_N(t, xp)
    speed = orbit.mean_motion * orbit.radius
    r = orbit.radius
    # v_rel = v − ω_E ẑ × r, with ẑ × r = (−r_y, r_x, 0)
    v = (speed * t_hat[0] + orbit.EARTH_RATE * r * r_hat[1],
         speed * t_hat[1] - orbit.EARTH_RATE * r * r_hat[0], speed * t_hat[2] + 0.0 * r_hat[2])
    rho = density(orbit.altitude_km) * d.density_scale
    c = -0.5 * rho * d.cd * d.area_m2 * xp.sqrt(k.dot(v, v))
    return k.scale(v, c)


def sun_and_shadow(orbit, t, xp) -> tuple:
    """(ŝ_N, lit): the Sun's unit direction (ECI) and 1.0 in sunlight, 0.0 in the Earth's
    cylindrical shadow (r·ŝ < 0 and |r − (r·ŝ)ŝ| < R_E)."""
    s_hat = sun_direction_N(orbit.srp.epoch_days + t / 86400.0, xp)
    r = k.scale(orbit.direction_N(t, xp), orbit.radius)
    along = k.dot(r, s_hat)
    perp = k.add(r, s_hat, -along)
    shadow = (along < 0.0) & (k.dot(perp, perp) < orbit.EARTH_RADIUS * orbit.EARTH_RADIUS)
    return s_hat, 1.0 - 1.0 * shadow


def srp_force_N(orbit, t, xp) -> tuple:
    """Solar radiation pressure force, N, ECI: ``−P C_R A ŝ`` in sunlight, 0 in shadow."""
    s_hat, lit = sun_and_shadow(orbit, t, xp)
    p = orbit.srp
    return k.scale(s_hat, -P_SUN * (1.0 + p.reflectivity) * p.area_m2 * lit)


# --------------------------------------------------------------------------- stage torque


class OrbitTorque:
    """The sum of the scene's orbit torques, for the integrators' ``torque_fn``.

    Per control step, :meth:`for_step` fetches the inertial vectors of the step's
    ``2·substeps + 1`` half-steps from the :class:`OrbitTable` at once (one gather per
    component for a batch), and ``.substep(j)`` gives substep j's ``torque_fn(s, q, ω)``,
    which reads half-step ``2j + 2s`` of them.
    """

    needs_rate = False  # every orbit torque is a function of (t, q)

    def __init__(self, table, body, substeps: int):
        import numpy as np

        orbit = table.orbit
        self.table, self.body, self.substeps = table, body, substeps
        self.gravity_gradient = orbit.gravity_gradient
        self.gg_scale = 3.0 * orbit.mean_motion ** 2
        res = orbit.residual_dipole
        self.residual = None if res is None else res.moment_B_Am2
        self.drag_cp = None if orbit.drag is None else orbit.drag.cp_offset_B_m
        self.srp_cp = None if orbit.srp is None else orbit.srp.cp_offset_B_m
        self.span = 2 * substeps + 1  # half-steps a control step touches
        offsets = np.arange(self.span)[:, None]
        offsets.setflags(write=False)
        self.offsets = offsets  # a plant constant (xp.const caches it on the device)

    @staticmethod
    def needed(orbit, actuators) -> bool:
        """Whether the scene applies any orbit torque (else the plant passes no torque_fn)."""
        return bool(orbit.enabled and (orbit.gravity_gradient or orbit.residual_dipole
                                       or orbit.drag or orbit.srp
                                       or any(a.gives_dipole for a in actuators)))

    def names(self, dipole) -> tuple:
        """The table vectors the torques read (dipole: whether a dipole acts)."""
        return tuple(name for name, on in (("direction", self.gravity_gradient),
                                           ("field", dipole is not None),
                                           ("drag", self.drag_cp is not None),
                                           ("srp", self.srp_cp is not None)) if on)

    def for_step(self, steps, dipole_B, xp, body=None) -> _StepTorque:
        """The torques of one control step: ``steps`` the control steps taken (int or (N,)
        ints), ``dipole_B`` the commanded dipole (A·m², body axes, held) or None; ``body``:
        the episode's whole body for the gravity gradient (domain randomization), or None for
        the scene's."""
        if self.residual is not None:
            dipole_B = self.residual if dipole_B is None else k.add(dipole_B, self.residual)
        return _StepTorque(self, 2 * (steps * self.substeps), dipole_B, xp, body)

    def torque_B(self, index, q, dipole_B, xp) -> tuple:
        """Σ orbit torques (N·m, body axes) at half-step ``index`` and attitude ``q`` (the
        residual dipole included)."""
        if self.residual is not None:
            dipole_B = self.residual if dipole_B is None else k.add(dipole_B, self.residual)
        rows = {name: [self.table.lookup(name, index, xp)] for name in self.names(dipole_B)}
        return self.sum(rows, 0, q, dipole_B)

    def sum(self, rows: dict, m: int, q, dipole_B, body=None) -> tuple:
        """Σ torques at attitude q from entry m of the inertial vectors ``rows`` (name →
        list of components); ``body``: the gravity gradient's, None for the scene's."""
        tau = None
        if self.gravity_gradient:
            r_B = k.rotate_inverse(q, rows["direction"][m])
            tau = k.scale(k.cross(r_B, (self.body if body is None else body).inertia_times(
                r_B)), self.gg_scale)
        if dipole_B is not None:
            tau = _sum(tau, k.cross(dipole_B, k.rotate_inverse(q, rows["field"][m])))
        if self.drag_cp is not None:
            tau = _sum(tau, k.cross(self.drag_cp, k.rotate_inverse(q, rows["drag"][m])))
        if self.srp_cp is not None:
            tau = _sum(tau, k.cross(self.srp_cp, k.rotate_inverse(q, rows["srp"][m])))
        return tau


def _sum(a, b):
    return b if a is None else k.add(a, b)


class _StepTorque:
    """One control step's inertial vectors, fetched once (see :class:`OrbitTorque`)."""

    __slots__ = ("body", "dipole", "owner", "rows")

    def __init__(self, owner: OrbitTorque, base, dipole, xp, body=None):
        self.owner, self.dipole, self.body = owner, dipole, body
        table, names = owner.table, owner.names(dipole)
        if type(base) is int:  # one satellite: rows of Python floats
            self.rows = {name: [table.lookup(name, base + m, xp) for m in range(owner.span)]
                         for name in names}
            return
        index = xp.minimum(base + xp.const(owner.offsets), table.last)  # (span, N)
        const = xp.const
        self.rows = {}
        for name in names:
            cols = [const(c)[index] for c in table.arrays[name]]
            self.rows[name] = [(cols[0][m], cols[1][m], cols[2][m]) for m in range(owner.span)]

    def substep(self, j: int) -> _Stage:
        """Substep j's ``torque_fn``."""
        return _Stage(self, 2 * j)


class _Stage:
    """One substep's ``torque_fn(s, q, ω)``: the torques at half-step ``2j + 2s``."""

    __slots__ = ("offset", "step")
    needs_rate = False

    def __init__(self, step: _StepTorque, offset: int):
        self.step, self.offset = step, offset

    def __call__(self, s, q, w):
        step = self.step
        return step.owner.sum(step.rows, self.offset + int(s + s), q, step.dipole, step.body)
