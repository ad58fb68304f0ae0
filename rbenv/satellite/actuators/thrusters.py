"""Thrusters: body-fixed nozzles at lever arms, fired as duty cycles over a control step.

An actuator of the plant (:mod:`rbenv.satellite.actuators.base`). Its scene table is ``[thrusters]``
(positions, directions, max_force, isp), parsed here (:func:`parse_thrusters`) into a
:class:`ThrusterTable`; the module owns standard gravity ``G0``, which defines the specific
impulse. Three action modes turn its action
slice into throttles u in [0, 1]: ``throttle`` (one entry per thruster, ``clip(a, 0, 1)``),
``on_off`` (``a > 0`` fires at full throttle) and ``torque`` (a body torque as a fraction of the
per-axis authority, turned into throttles by an allocator, :mod:`rbenv.satellite.allocation`).
Faults (thrusters stuck off, at reset or mid-episode), a one-step control delay and the episode's
randomized layout (:mod:`rbenv.satellite.randomization`) act on the throttles before they fire.

Its effort is the thrust fraction ``Σu_iF_i / ΣF_i`` (propellant flow relative to all thrusters
at full throttle); it accounts the impulse ``Σu_iF_i·dt`` and the propellant
``impulse / (Isp g0)``. It stores no angular momentum.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from rbenv.core import validation
from rbenv.core.backend import FLOAT, NUMPY, row_product, rows
from rbenv.core.errors import InvalidParameterError, describe
from rbenv.core.forces import MAX_THRUSTERS, ThrusterLayout
from rbenv.satellite.actuators import tables
from rbenv.satellite.actuators.base import ActuatorDefaults, Contribution, nan_action_error
from rbenv.satellite.allocation import axis_authority, make_allocator, validate_torque_matrix

__all__ = ["ACTION_MODES", "ALLOCATORS", "G0", "ThrusterTable", "Thrusters", "action_matrix",
           "make_thrusters", "nan_action_error", "parse_thrusters"]

G0 = 9.80665  # m/s², standard gravity (defines specific impulse)
DEFAULT_ISP = 65.0  # s, thrusters.isp when the table omits it (cold gas, scene_schema)
ACTION_MODES = ("throttle", "on_off", "torque")
ALLOCATORS = ("pinv", "nnls", "lp")
# tuple.__new__ builds a NamedTuple without its Python-level __new__ (fields given in order).
_new = tuple.__new__
_COORD = 1e3  # m, |position| components (the scene's bound on coordinates)


@dataclass(frozen=True, eq=False)
class ThrusterTable:
    """The scene's ``[thrusters]`` table, validated: the layout (body axes, positions m,
    directions, max_force N, com_B m) and the specific impulse isp (s)."""

    layout: ThrusterLayout
    isp: float

    @property
    def n(self) -> int:
        return self.layout.n

    def drawing(self) -> dict:
        """Keyword arguments of :class:`rbenv.envs.rendering.Renderer`: the mount points relative
        to the centre of mass (the drawing's origin) and the force directions."""
        lay = self.layout
        return {"thruster_positions_B": lay.positions_B - lay.com_B,
                "thruster_directions_B": lay.directions_B}


def parse_thrusters(table: dict, com_B: np.ndarray) -> ThrusterTable:
    """The ``[thrusters]`` table: positions (m, body axes, the parts' origin), directions
    (normalised by the layout), max_force (N, one or per thruster), isp (s, default
    ``DEFAULT_ISP``). The layout must
    torque the body both ways about every axis."""
    tables.keys("thrusters", table, {"positions", "directions", "max_force", "isp"}, ())
    pos = validation.finite_array("thrusters.positions", table.get("positions"))
    if pos.ndim != 2 or pos.shape[1] != 3 or len(pos) == 0:
        raise InvalidParameterError(
            f"thrusters.positions must be a list of [x, y, z] (m), got shape {pos.shape}"
        )
    n = len(pos)
    if n > MAX_THRUSTERS:
        raise InvalidParameterError(
            f"thrusters.positions lists {n} thrusters; the limit is {MAX_THRUSTERS}"
        )
    pos = tables.bounded_array("thrusters.positions", pos, (n, 3), bound=_COORD)
    dirs = tables.safe_to_square(
        tables.bounded_array("thrusters.directions", table.get("directions"), (n, 3)))
    fmax = validation.finite_array("thrusters.max_force", table.get("max_force"))
    fmax = np.broadcast_to(fmax, (n,)) if fmax.ndim == 0 else fmax
    fmax = tables.bounded_array("thrusters.max_force", fmax, (n,), bound=1e4)
    if (fmax <= 0).any():
        i = int(np.argmax(fmax <= 0))
        raise InvalidParameterError(f"thrusters.max_force[{i}] must be > 0 N, got {fmax[i]!r}")
    lengths = np.linalg.norm(dirs, axis=1)
    if (lengths == 0).any():
        i = int(np.argmax(lengths == 0))
        raise InvalidParameterError(f"thrusters.directions[{i}] must be non-zero, got "
                                    f"{describe(dirs[i])}")
    isp = validation.number("thrusters.isp", table.get("isp", DEFAULT_ISP), low=1.0, high=1e5)
    layout = ThrusterLayout(positions_B=pos, directions_B=dirs, max_force=fmax, com_B=com_B)
    validate_torque_matrix(layout.torque_matrix_B, name="thrusters")
    return ThrusterTable(layout, isp)


@dataclass(frozen=True, eq=False)
class Thrusters(ActuatorDefaults):
    """The scene's thrusters with their action mode, precomputed for the per-step path.

    layout: :class:`rbenv.core.forces.ThrusterLayout` (body axes). isp: s. ``action_matrix`` (n, 4
    or 7) maps throttles to ``[τ_B (3, N·m), Σu_iF_i (N), F_B (3, N, translation only)]``.
    """

    scene_table: ClassVar[str] = "thrusters"
    info_keys: ClassVar[tuple] = ("fuel_kg", "impulse_Ns")
    start_stream: ClassVar[str] = "plant"  # its start draws follow the plant's bias slots

    layout: object
    isp: float
    control_dt: float  # s
    translation: bool = False
    fault_model: str = "none"  # "none" | "random"
    p_reset: float = 0.0  # probability a thruster starts failed (random faults)
    p_fault: float = 0.0  # per-step fault probability (0: none)
    delay: bool = False  # a one-step control delay is possible (randomization)
    action_mode: str = "throttle"
    allocator_name: str = "pinv"
    n: int = field(init=False)
    action_shape: tuple = field(init=False)
    action_bounds: tuple = field(init=False, repr=False)
    action_matrix: np.ndarray = field(init=False, repr=False)
    allocator: object = field(init=False, repr=False)
    torque_authority: np.ndarray = field(init=False, repr=False)
    inv_total_thrust: float = field(init=False)  # 1/N: thrust fraction = Σu_iF_i / ΣF_i
    fuel_per_impulse: float = field(init=False)  # kg/(N·s) = 1 / (Isp g0)
    state_fields: dict = field(init=False, repr=False)
    start_slots: int = field(init=False)
    step_uniforms: int = field(init=False)  # n with mid-episode faults: one uniform each

    def __post_init__(self):
        validation.choice("action_mode", self.action_mode, ACTION_MODES)
        validation.choice("allocator", self.allocator_name, ALLOCATORS)
        lay = self.layout
        torque = self.action_mode == "torque"
        shape = (3,) if torque else (lay.n,)
        low, high = np.full(shape, -1.0 if torque else 0.0), np.ones(shape)
        for arr in (low, high):  # arrays: clipping against them is cheaper than scalars
            arr.setflags(write=False)
        # health: 1 (working) / 0 (failed) per thruster, with faults only. throttle: the
        # throttles fired in the last step. pending: throttles commanded last step (delay
        # only). fuel_kg, impulse_Ns: cumulative.
        fields = {"health": "row", "throttle": "row", "pending": "row", "fuel_kg": "f",
                  "impulse_Ns": "f"}
        values = {"n": lay.n, "action_shape": shape, "action_bounds": (low, high),
                  "allocator": None, "torque_authority": None,
                  "action_matrix": action_matrix(lay.torque_matrix_B, lay.max_force,
                                                 lay.force_matrix_B if self.translation
                                                 else None),
                  "inv_total_thrust": 1.0 / float(lay.max_force.sum()),
                  "fuel_per_impulse": 1.0 / (self.isp * G0), "state_fields": fields,
                  # The plant's stream: slots 0-5 are its disturbance bias, then one uniform
                  # per thruster with random faults (kept there: seeded episodes unchanged).
                  "start_slots": lay.n if self.fault_model == "random" else 0,
                  "step_uniforms": lay.n if self.p_fault else 0}
        if torque:
            values["allocator"] = make_allocator(self.allocator_name, lay.torque_matrix_B)
            values["torque_authority"] = axis_authority(lay.torque_matrix_B)
        for name, value in values.items():
            object.__setattr__(self, name, value)

    # ------------------------------------------------------------------- command

    def command(self, a: np.ndarray, in_place: bool = False, xp=NUMPY) -> np.ndarray:
        """Throttles (duty cycles) in [0, 1] from an action, (n,) or (N, n) (torque: (…, 3)).

        throttle: ``clip(a, 0, 1)`` (a ≤ 0 is off). on_off: ``a > 0`` fires at full throttle.
        torque: ``clip(a, -1, 1) · authority`` (N·m per axis) through the allocator. NaN is
        rejected; in throttle mode by the adapters from the propagated NaN thrust, which the
        state's finiteness flag catches (no extra check on the hot path). ``in_place``: the
        caller owns ``a`` and lets throttle mode clip it in place (the vector env's batch).
        xp: the state's namespace (the action's rows are :func:`rbenv.core.backend.rows` of it). The
        allocators of torque mode are NumPy (SciPy for nnls and lp).
        """
        rx = rows(xp)
        mode = self.action_mode
        low, high = self.action_bounds
        if mode == "throttle":
            return rx.clamp_into(a, low, high) if in_place else rx.clamp(a, low, high)
        if rx.isnan_any(a):
            raise nan_action_error(a)
        if mode == "on_off":
            return rx.to_float(a > 0.0)
        return self.allocator(rx.clamp(a, low, high) * self.torque_authority)

    # ------------------------------------------------------------------- per step

    def actuate(self, st, u: np.ndarray, noise, xp) -> Contribution:
        """The wrench of throttles ``u`` after faults and delay; sets health, pending,
        throttle, impulse_Ns and fuel_kg on ``st`` (the new state)."""
        if st.health is not None or st.pending is not None:
            u = self._faults_and_delay(st, u, noise.faults, rows(xp))
        st.throttle = u
        # Each product is taken as the batch takes it, so that one satellite's wrench equals
        # one sub-env's to the bit (row_product and matmul: BLAS's gemm for both; einsum:
        # NumPy's own loop).
        if st.model is None:  # the scene's matrix, shared by every sub-env
            if xp is FLOAT:  # a list of floats: the kernels index it alike
                parts = row_product(u, self.action_matrix)
            else:
                parts = tuple(rows(xp).matmul(rows(xp).const(self.action_matrix).T, u.T))
        elif xp is FLOAT:  # this episode's matrix (domain randomization, delays)
            parts = np.einsum("i,ik->k", u, st.model.action_matrix).tolist()
        else:  # per-sub-env matrices: (N, n) × (N, n, k)
            parts = tuple(rows(xp).einsum("ni,nik->kn", u, st.model.action_matrix))
        thrust = parts[3]
        impulse = thrust * self.control_dt
        st.impulse_Ns = st.impulse_Ns + impulse
        st.fuel_kg = st.fuel_kg + impulse * self.fuel_per_impulse
        force = (parts[4], parts[5], parts[6]) if len(parts) > 4 else None
        return _new(Contribution, ((parts[0], parts[1], parts[2]), force, None, None,
                                   thrust * self.inv_total_thrust, None))

    def _faults_and_delay(self, st, u: np.ndarray, fault_draw, rx) -> np.ndarray:
        """Throttles that actually fire: mid-episode faults, failed thrusters, control delay."""
        if st.health is not None:
            if fault_draw is not None:
                st.health = st.health * (fault_draw >= self.p_fault)
            u = u * st.health
        if st.pending is not None:
            fired = rx.where(rx.expand_dims(st.model.delayed, -1), st.pending, u)
            st.pending = u
            u = fired
        return u

    # ------------------------------------------------------------------- start, sensing

    def sample_start(self, draws) -> dict:
        """Zero propellant and throttles; ``health`` (m, n) of 1/0 with random faults
        (stream "plant", uniforms from slot 6); ``pending`` zeros with a control delay."""
        m, xp = draws.n, draws.xp
        zero = xp.zeros(m)
        health = None
        if self.fault_model == "random":
            u = draws.uniform_array("plant", self.n, offset=6)
            health = rows(xp).to_float(u.T >= self.p_reset)
        return {"health": health, "fuel_kg": zero, "impulse_Ns": zero,
                "throttle": rows(xp).zeros((m, self.n)),
                "pending": rows(xp).zeros((m, self.n)) if self.delay else None}

    def render_values(self, st, index: int | None) -> dict:
        """The throttles fired in the last step (plumes)."""
        throttle = st.throttle if index is None else st.throttle[index]
        return {"throttle": np.asarray(throttle, dtype=float)}

    def info(self, st, xp, out: dict) -> None:
        """fuel_kg and impulse_Ns (cumulative); failed_thrusters with the fault model."""
        out["fuel_kg"] = st.fuel_kg
        out["impulse_Ns"] = st.impulse_Ns
        if st.health is not None:
            out["failed_thrusters"] = self.n - rows(xp).sum(st.health, axis=-1)


def make_thrusters(scene, action_mode: str = "throttle", allocator: str = "pinv") -> Thrusters:
    """The scene's thrusters (its ``[thrusters]``, faults and randomization) in a mode."""
    faults, rnd, table = scene.faults, scene.randomization, scene.actuators["thrusters"]
    return Thrusters(layout=table.layout, isp=table.isp,
                     control_dt=scene.physics.control_dt,
                     translation=scene.physics.translation, fault_model=faults.model,
                     p_reset=faults.p_reset if faults.model == "random" else 0.0,
                     p_fault=faults.p_step if faults.model == "random" else 0.0,
                     delay=bool(rnd.enabled and rnd.delay_probability > 0.0),
                     action_mode=action_mode, allocator_name=allocator)


def action_matrix(torque_matrix_B, max_force, force_matrix_B=None) -> np.ndarray:
    """(n, 4) or (n, 7) read-only map from throttles to ``[τ_B, Σu_iF_i, F_B]``.

    torque_matrix_B: (3, n) N·m per unit throttle; max_force: (n,) N; force_matrix_B: (3, n)
    N per unit throttle, or None without translation.
    """
    cols = [np.asarray(torque_matrix_B).T, np.asarray(max_force)[:, None]]
    if force_matrix_B is not None:
        cols.append(np.asarray(force_matrix_B).T)
    matrix = np.ascontiguousarray(np.hstack(cols), dtype=float)
    matrix.setflags(write=False)
    return matrix


