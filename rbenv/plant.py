"""The plant: one satellite and its actuators, whatever the task asks of it.

The plant turns an action into thruster throttles (with faults and an optional one-step control
delay), throttles into a body wrench, and the wrench plus the disturbance torque into motion
over one control step (integrator substeps, and the centre of mass when the scene models
translation). It also measures the state for the observation (sensor noise) and draws its own
part of an episode start (disturbance bias, reset faults, domain randomization). It knows
nothing of targets or rewards: that is the task's business (:mod:`rbenv.tasks`).

States are component tuples as in :mod:`core.kernels`: Python floats for the single env, (N,)
arrays for the vector env; ``xp`` is the matching :mod:`core.backend` namespace.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from core import INTEGRATORS, validation
from core import kernels as k
from core.backend import FLOAT
from core.dynamics import check_finite_state, translate
from core.errors import InvalidParameterError, NonFiniteError, RbenvValueError
from rbenv.randomization import Randomization, draw_episode_model
from rbenv.scene import G0, Scene

__all__ = ["ACTION_MODES", "NO_NOISE", "STATE_FIELDS", "Plant", "StepNoise", "Wrench", "make_plant"]

ACTION_MODES = ("throttle", "on_off", "torque")
ALLOCATORS = ("pinv", "nnls", "lp")


class Wrench(NamedTuple):
    """What the thrusters apply over a control step (body frame).

    torque_B: 3 components, N·m. thrust_N: Σ u_i F_i, N (sets propellant use). force_B: 3
    components, N, or None when the scene does not model translation.
    """

    torque_B: tuple
    thrust_N: object
    force_B: tuple | None


# tuple.__new__ builds a NamedTuple without its Python-level __new__: a third of the cost on the
# per-step path (the fields are given in order, as the class declares them).
_new = tuple.__new__


class StepNoise(NamedTuple):
    """Per-step random draws: fault uniforms (n or (N, n)), disturbance normals (3
    components), sensor normals (6 components); each None when the model is off."""

    faults: object
    disturbance: tuple | None
    sensor: tuple | None


# The plant's state fields and their storage kinds (rbenv.state). q: body→world quaternion.
# w: ω_B, rad/s. x, v: centre-of-mass position (m) and velocity (m/s), with translation only.
# bias: disturbance bias torque, N·m (random model only). health: 1 (working) / 0 (failed) per
# thruster (fault model only). fuel_kg, impulse_Ns: cumulative. throttle: the throttles applied
# in the last step. steps: control steps taken. model: the episode's randomized physics
# (rbenv.randomization.EpisodeModel) or None. pending: throttles commanded last step, with a
# control delay only.
STATE_FIELDS = {"q": "c4", "w": "c3", "x": "c3", "v": "c3", "bias": "c3", "health": "row",
                "fuel_kg": "f", "impulse_Ns": "f", "throttle": "row", "steps": "i",
                "model": "obj", "pending": "row"}


@dataclass(frozen=True, eq=False)
class Plant:
    """Scene plus actuation options, with everything the per-step code needs precomputed.

    Build with :func:`make_plant`. ``action_matrix`` (n, 4 or 7) maps throttles to
    ``[τ_B (3, N·m), Σ u_i F_i (N), F_B (3, N, only with translation)]``.
    """

    scene: Scene
    action_mode: str = "throttle"
    allocator_name: str = "pinv"
    compiled: bool = False  # step with core.compiled (numba) instead of NumPy (vector env)
    n: int = field(init=False)
    action_shape: tuple = field(init=False)
    action_matrix: np.ndarray = field(init=False, repr=False)
    allocator: object = field(init=False, repr=False)
    torque_authority: np.ndarray = field(init=False, repr=False)
    advance: object = field(init=False, repr=False)
    action_bounds: tuple = field(init=False, repr=False)
    # Scene scalars read every step, flattened (one attribute lookup instead of three).
    h: float = field(init=False)  # s, integrator step
    substeps: int = field(init=False)
    control_dt: float = field(init=False)  # s
    fuel_per_impulse: float = field(init=False)  # kg/(N·s) = 1 / (Isp g0)
    inv_total_thrust: float = field(init=False)  # 1/N: thrust fraction = Σu_iF_i / ΣF_i
    disturbance_torque: tuple | None = field(init=False)  # N·m, constant model only
    p_fault: float = field(init=False)  # per-step fault probability (0: none)
    dist_noise: float = field(init=False)  # N·m, 1σ per-step disturbance noise (0: none)
    sensor_noise: tuple | None = field(init=False)  # (attitude rad, rate rad/s) or None
    randomization: Randomization | None = field(init=False)
    noisy: bool = field(init=False)  # a step draws random numbers (faults, noise)

    def __post_init__(self):
        validation.choice("action_mode", self.action_mode, ACTION_MODES)
        validation.choice("allocator", self.allocator_name, ALLOCATORS)
        values = {**_scene_scalars(self.scene), **self._actuation()}
        values["noisy"] = bool(values["p_fault"] or values["dist_noise"]
                               or values["sensor_noise"] is not None)
        _check_integrator_supports(self.scene, values["randomization"])
        if validation.flag("compiled", self.compiled):
            values["advance"] = _compiled_advance(self.scene, values["randomization"])
        for name, value in values.items():
            object.__setattr__(self, name, value)

    def _actuation(self) -> dict:
        """Action shape and bounds, throttle→wrench matrix, and the torque-mode allocator."""
        sc, thr = self.scene, self.scene.thrusters
        torque = self.action_mode == "torque"
        shape = (3,) if torque else (thr.n,)
        low, high = np.full(shape, -1.0 if torque else 0.0), np.ones(shape)
        for arr in (low, high):  # arrays: clipping against them is cheaper than scalars
            arr.setflags(write=False)
        values = {"n": thr.n, "action_shape": shape, "action_bounds": (low, high),
                  "allocator": None, "torque_authority": None,
                  "action_matrix": action_matrix(thr.torque_matrix_B, thr.max_force,
                                                 thr.force_matrix_B if sc.physics.translation
                                                 else None)}
        if torque:
            from rbenv.allocation import axis_authority, make_allocator

            values["allocator"] = make_allocator(self.allocator_name, thr.torque_matrix_B)
            values["torque_authority"] = axis_authority(thr.torque_matrix_B)
        return values

    @property
    def translation(self) -> bool:
        """Whether the centre of mass moves (the scene models translation)."""
        return self.scene.physics.translation

    # ------------------------------------------------------------------- actuation

    def throttle(self, a: np.ndarray, in_place: bool = False) -> np.ndarray:
        """Throttles (duty cycles) in [0, 1] from an action, (n,) or (N, n) (torque: (…, 3)).

        throttle: ``clip(a, 0, 1)`` (a ≤ 0 is off). on_off: ``a > 0`` fires at full throttle.
        torque: ``clip(a, -1, 1) · authority`` (N·m per axis) through the allocator. NaN is
        rejected; in throttle mode by :func:`rbenv.transition.step` from the propagated NaN
        thrust, which the state's finiteness check catches (no extra check on the hot path).
        ``in_place``: the caller owns ``a`` and
        lets throttle mode clip it in place (no temporaries: the vector env's batch).
        """
        mode = self.action_mode
        low, high = self.action_bounds
        if mode == "throttle":
            if in_place:
                np.maximum(a, low, out=a)
                return np.minimum(a, high, out=a)
            return np.minimum(np.maximum(a, low), high)
        if np.isnan(a).any():
            raise nan_action_error(a)
        if mode == "on_off":
            return (a > 0.0).astype(float)
        return self.allocator(np.minimum(np.maximum(a, low), high) * self.torque_authority)

    def apply_faults_and_delay(self, st, u: np.ndarray, fault_draw) -> np.ndarray:
        """Throttles that actually fire: mid-episode faults, failed thrusters, control delay."""
        if st.health is not None:
            if fault_draw is not None:
                st.health = st.health * (fault_draw >= self.p_fault)
            u = u * st.health
        if st.pending is not None:
            delayed = st.model.delayed
            fired = np.where(np.expand_dims(delayed, -1), st.pending, u)  # bool or (N,)
            st.pending = u
            u = fired
        return u

    def wrench(self, st, u: np.ndarray, xp) -> Wrench:
        """The body wrench of throttles u, (n,) or (N, n), held over the step."""
        matrix = self.action_matrix if st.model is None else st.model.action_matrix
        if xp is FLOAT:
            parts = (u @ matrix).tolist()  # a list of floats: the kernels index it alike
        elif matrix.ndim == 2:
            parts = tuple(matrix.T @ u.T)
        else:  # per-sub-env matrices (domain randomization): (N, n) × (N, n, k)
            parts = tuple(np.einsum("ni,nik->kn", u, matrix))
        force = (parts[4], parts[5], parts[6]) if len(parts) > 4 else None
        return _new(Wrench, ((parts[0], parts[1], parts[2]), parts[3], force))

    # ------------------------------------------------------------------- motion

    def advance_state(self, st, wrench: Wrench, dist_noise, xp) -> None:
        """Advance ``st`` over one control step under ``wrench`` and the disturbance.

        The thruster torque plus the disturbance (constant torque, or bias + ``dist_noise``)
        drives ``substeps`` integrator steps; with translation the centre of mass moves under
        the body force rotated to the world frame at each substep. Raises NonFiniteError if
        any state component is not finite afterwards. Propellant: ``Σu_iF_i·dt / (Isp g0)``.
        """
        tau = wrench.torque_B
        if st.bias is not None:
            tau = k.add(tau, st.bias)
            if dist_noise is not None:
                tau = k.add(tau, dist_noise, self.dist_noise)
        elif self.disturbance_torque is not None:
            tau = k.add(tau, self.disturbance_torque)
        body = self.scene.body if st.model is None else st.model.body
        h, advance = self.h, self.advance
        q, w = st.q, st.w
        try:
            for _ in range(self.substeps):
                if st.x is not None:
                    self._translate(st, body, k.rotate(q, wrench.force_B))
                q, w = advance(body, q, w, h, tau, None)
        except RbenvValueError:
            raise
        except (OverflowError, ZeroDivisionError, ValueError):  # e.g. int() of an inf or NaN
            self._raise_non_finite((float("nan"),) * 4, w)
        # Squares, not components: a rate or speed whose square overflows is caught too, so
        # no task ever computes |ω| = inf from a "finite" state.
        sq = w[0] * w[0] + w[1] * w[1] + w[2] * w[2]
        if st.x is not None:
            x, v = st.x, st.v
            sq = sq + (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]) + (v[0] * v[0] + v[1] * v[1]
                                                                   + v[2] * v[2])
        if not xp.all_finite((*q, sq)):
            self._raise_non_finite(q, w)
        st.q, st.w = q, w
        impulse = wrench.thrust_N * self.control_dt
        st.impulse_Ns = st.impulse_Ns + impulse
        st.fuel_kg = st.fuel_kg + impulse * self.fuel_per_impulse
        st.steps = st.steps + 1

    def _translate(self, st, body, force_W: tuple) -> None:
        """Move the centre of mass one integrator step under force_W (N, world frame)."""
        name, h = self.scene.physics.integrator, self.h
        moved = [translate(name, body, st.x[i], st.v[i], h, force_W[i]) for i in range(3)]
        st.x = tuple(m[0] for m in moved)
        st.v = tuple(m[1] for m in moved)

    def _raise_non_finite(self, q, w) -> None:
        """Raise NonFiniteError naming the integrator and step: some state component, or the
        square of the rate, position or speed, is not finite."""
        name = self.scene.physics.integrator
        check_finite_state(q, w, name, self.h)
        raise NonFiniteError(
            f"simulation diverged: the body rate, or the centre-of-mass position or velocity, "
            f"is beyond float64 (its square overflows) after a step with integrator={name!r}, "
            f"dt={self.h!r}; the torque, force or step is too large")

    # ------------------------------------------------------------------- sensing

    def measure(self, st, noise) -> tuple[tuple, tuple]:
        """Measured (q, ω_B): the true state, or with noise ``q ⊗ exp(σ_att·n[:3])`` and
        ``ω_B + σ_rate·n[3:]`` (noise: 6 standard-normal components)."""
        if noise is None:
            return st.q, st.w
        s_att, s_rate = self.sensor_noise
        q = k.qnormalize(k.qmul(st.q, k.exp(k.scale(noise[:3], s_att))))
        return q, k.add(st.w, noise[3:], s_rate)

    def draw_sensor_noise(self, rng: np.random.Generator, batch: int | None):
        """6 standard-normal components (one satellite, or (batch,) arrays), or None."""
        return None if self.sensor_noise is None else _components(rng, 6, batch)

    def draw_step_noise(self, rng: np.random.Generator, batch: int | None) -> StepNoise:
        """This step's random draws from ``rng``: one satellite (batch None) or ``batch``.

        Order: fault uniforms, disturbance normals, sensor normals (each only when modelled).
        """
        if not self.noisy:
            return NO_NOISE
        n = self.n
        faults = dist = sensor = None
        if self.p_fault:
            faults = rng.random(n if batch is None else (batch, n))
        if self.dist_noise:
            dist = _components(rng, 3, batch)
        if self.sensor_noise is not None:
            sensor = _components(rng, 6, batch)
        return StepNoise(faults, dist, sensor)

    # ------------------------------------------------------------------- episode start

    @property
    def start_slots(self) -> int:
        """Slots of stream "plant" that :meth:`sample_start` draws: 0–5 the disturbance bias
        (three normals), then one uniform per thruster with random faults."""
        return 6 + (self.n if self.scene.faults.model == "random" else 0)

    def sample_start(self, draws) -> dict:
        """The plant's part of an episode start for ``draws.n`` envs, from stream "plant".

        ``bias``: 3 components, N·m, or None; ``health``: (N, n) of 1/0, or None; ``model``:
        an :class:`rbenv.randomization.EpisodeModel` of the randomized physics, or None.
        """
        sc = self.scene
        bias = health = model = None
        if sc.disturbance.model == "random":
            bias = k.scale(draws.normal("plant", 3), sc.disturbance.bias_sigma)
        if sc.faults.model == "random":
            u = draws.uniform_array("plant", self.n, offset=6)
            health = (u.T >= sc.faults.p_reset).astype(float)
        if self.randomization is not None:
            model = draw_episode_model(self, draws)
        return {"bias": bias, "health": health, "model": model}


NO_NOISE = StepNoise(None, None, None)


def _scene_scalars(sc: Scene) -> dict:
    """The scene's per-step scalars, flattened for the hot path (one attribute lookup)."""
    dist, faults, sensor = sc.disturbance, sc.faults, sc.sensor_noise
    return {
        "h": sc.physics.h, "substeps": sc.physics.substeps, "control_dt": sc.physics.control_dt,
        "fuel_per_impulse": 1.0 / (sc.isp * G0),
        "inv_total_thrust": 1.0 / float(sc.thrusters.max_force.sum()),
        "disturbance_torque": tuple(dist.torque.tolist()) if dist.model == "constant" else None,
        "p_fault": faults.p_step if faults.model == "random" else 0.0,
        "dist_noise": dist.noise_sigma if dist.model == "random" else 0.0,
        "sensor_noise": (sensor.attitude, sensor.rate) if sensor.model == "gaussian" else None,
        "advance": INTEGRATORS[sc.physics.integrator].advance,
        "randomization": sc.randomization if sc.randomization.enabled else None,
    }


def _check_integrator_supports(sc: Scene, rnd: Randomization | None) -> None:
    """Refuse integrator and randomization pairs that cannot run together."""
    if rnd is not None and (rnd.inertia_scale or rnd.inertia_rotation_deg) \
            and sc.physics.integrator == "splitting":
        raise InvalidParameterError(
            "integrator 'splitting' rotates about the principal axes of one fixed inertia, "
            "so it cannot step randomized inertias (randomization.inertia_scale or "
            "inertia_rotation_deg > 0); use 'rk4' or 'midpoint'")


def _compiled_advance(sc: Scene, rnd: Randomization | None):
    """The numba-compiled kernel of the scene's integrator (the extra ``rbenv[fast]``)."""
    from core import compiled

    if rnd is not None and (rnd.inertia_scale or rnd.inertia_rotation_deg):
        raise InvalidParameterError(
            "compiled=True compiles one fixed inertia into the loop, so it cannot step "
            "randomized inertias; use compiled=False")
    return compiled.get(sc.physics.integrator).advance


def _components(rng: np.random.Generator, count: int, batch: int | None) -> tuple:
    if batch is None:
        return tuple(rng.standard_normal(count).tolist())
    return tuple(rng.standard_normal((count, batch)))


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


def nan_action_error(action) -> InvalidParameterError:
    """The named error (a ValueError) for an action containing NaN, naming the first bad index."""
    bad = np.argwhere(np.isnan(np.asarray(action, dtype=float)))
    where = tuple(int(i) for i in bad[0]) if len(bad) else ()
    return InvalidParameterError(
        f"action must not contain NaN (got NaN at index {where}); actions outside [-1, 1] are "
        "clipped to the action space, but NaN has no meaning"
    )


def make_plant(scene, *, integrator=None, control_dt=None, substeps=None,
               action_mode="throttle", allocator="pinv", randomize=None,
               compiled=False) -> Plant:
    """Resolve env options against a scene (name, path or Scene) into a :class:`Plant`.

    integrator, control_dt (s), substeps: override the scene's physics. action_mode:
    "throttle" | "on_off" | "torque". allocator: "pinv" | "nnls" | "lp" (torque mode).
    randomize: None keeps the scene's domain randomization; a dict overrides its fields
    (see :class:`rbenv.randomization.Randomization`); False turns it off. compiled: step the
    batch with the numba-compiled kernels (``rbenv[fast]``; rk4, euler, semi_implicit,
    euler_seed).
    """
    from rbenv.scene import load_scene

    sc = load_scene("cubesat-12u" if scene is None else scene)
    sc = sc.with_physics(integrator=integrator, control_dt=control_dt, substeps=substeps)
    if randomize is not None:
        sc = sc.with_randomization(randomize)
    return Plant(scene=sc, action_mode=action_mode, allocator_name=allocator, compiled=compiled)

