"""The plant: one satellite and its actuators, whatever the task asks of it.

The plant splits an action among its actuators (:mod:`rbenv.satellite.actuators`), sums their
contributions (body torque and force, internal angular momentum, magnetic dipole) and integrates the
attitude (and the centre of mass, when the scene models translation) over one control step
with the scene's integrator and substeps, under the disturbance torque. It also measures the
state for the observation (sensor noise) and draws its own part of an episode start
(disturbance bias, domain randomization, and each actuator's part). It knows nothing of targets
or rewards: that is the task's business (:mod:`rbenv.tasks`). It knows no actuator by name:
it asks each, through :class:`rbenv.satellite.actuators.base.Actuator`, for its action slice
and bounds, its contribution and draw, its state, observation part, reset options, per-step
random draws and the spin inertia it carries; :meth:`Plant.actuator` hands out one by its
scene table.

A step that leaves the state non-finite is not an exception here: :meth:`Plant.advance`
returns a per-satellite flag, and the adapters turn it into :class:`NonFiniteError`
(:func:`rbenv.envs.transition.raise_diverged`).

States are component tuples as in :mod:`rbenv.core.kernels`: Python floats for the single env, (N,)
arrays for the vector env; ``xp`` is the matching :mod:`rbenv.core.backend` namespace.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from rbenv.core import INTEGRATORS, validation
from rbenv.core import kernels as k
from rbenv.core.body import RigidBody, bus_inertia
from rbenv.core.dynamics import check_finite_state, translate
from rbenv.core.errors import InvalidParameterError, NonFiniteError, RbenvValueError
from rbenv.satellite import sensing
from rbenv.satellite.actuators import (
    ACTION_MODES,
    ACTUATORS,
    ALLOCATORS,
    DEFAULT_ACTION_MODE,
    Contribution,
    make_actuators,
)
from rbenv.satellite.disturbances import OrbitTorque
from rbenv.satellite.orbit import OrbitTable
from rbenv.satellite.randomization import Randomization, check_applies, draw_episode_model
from rbenv.satellite.scene import Scene

__all__ = ["NO_NOISE", "PLANT_FIELDS", "Plant", "StepNoise", "make_plant"]


class StepNoise(NamedTuple):
    """Per-step random draws: the actuators' uniforms (u or (N, u), ``Plant.step_uniforms``:
    faults), disturbance normals (3 components), sensor normals (6 components, then the
    actuators' sensors' ``sensor_normals``), gyro normals (6 components); each None when the
    model is off."""

    faults: object
    disturbance: tuple | None
    sensor: tuple | None
    gyro: tuple | None = None  # 6 normals of the gyro (rbenv.satellite.sensing), or None


# The plant's own state fields and their storage kinds (rbenv.satellite.state). q: body→world
# quaternion. omega_B: body rate, rad/s. x, v: centre-of-mass position (m) and velocity (m/s),
# with translation only. bias: disturbance bias torque, N·m (random model only). steps: control
# steps taken. model: the episode's randomized physics
# (rbenv.satellite.randomization.EpisodeModel) or None. The actuators declare their own fields.
PLANT_FIELDS = {"q": "c4", "omega_B": "c3", "x": "c3", "v": "c3", "bias": "c3", "steps": "i",
                "model": "obj", "field_B_T": "c3",  # field_B_T: Earth's field now, T (orbit)
                **sensing.FIELDS}  # sensing as flown (rbenv.satellite.sensing), None when off
_ZERO = (0.0, 0.0, 0.0)
_BIAS_SLOTS = 6  # slots 0-5 of stream "plant": the disturbance bias (three normals)


@dataclass(frozen=True, eq=False)
class Plant:
    """Scene plus actuation options, with everything the per-step code needs precomputed.

    Build with :func:`make_plant`. ``actuators``: the scene's actuators (rbenv.satellite.actuators),
    in action order.

    Keep its attributes at 29 or fewer: CPython 3.11 shares an instance's attribute keys with
    its class up to that count, and past it every attribute read on the per-step path is slower
    (measured: 30 attributes cost 0.3 % more instructions per single-env step).
    """

    scene: Scene
    action_mode: str = DEFAULT_ACTION_MODE
    allocator_name: str = "pinv"
    compiled: bool = False  # step with core.compiled (numba) instead of NumPy
    actuators: tuple = field(init=False)
    accounting: tuple = field(init=False, repr=False)  # actuators with work after the physics
    sole_actuator: object = field(init=False, repr=False)  # the only actuator, or None
    # (actuator, its action slice, its slice of the step's uniforms or None: all of them)
    actuation: tuple = field(init=False, repr=False)
    observers: tuple = field(init=False, repr=False)  # (actuator, its sensor normals' slice)
    step_uniforms: int = field(init=False)  # uniforms the actuators draw per step
    body: object = field(init=False, repr=False)  # the integrated body (less the spin inertia)
    orbit: object = field(init=False, repr=False)  # rbenv.satellite.orbit.Orbit, or None
    orbit_table: object = field(init=False, repr=False)  # rbenv.satellite.orbit.OrbitTable, or None
    # rbenv.satellite.disturbances.OrbitTorque: the orbit's torques of (t, q), evaluated at every
    # integrator stage; None without them (the kernels then run as for a free body).
    orbit_torque: object = field(init=False, repr=False)
    eclipse_known: bool = field(init=False)  # the scene models the Sun: info has "eclipse"
    action_shape: tuple = field(init=False)
    action_slices: tuple = field(init=False, repr=False)  # each actuator's slice of the action
    advance_kernel: object = field(init=False, repr=False)
    # Scene scalars read every step, flattened (one attribute lookup instead of three).
    h: float = field(init=False)  # s, integrator step
    substeps: int = field(init=False)
    control_dt: float = field(init=False)  # s
    disturbance_torque: tuple | None = field(init=False)  # N·m, constant model only
    dist_noise: float = field(init=False)  # N·m, 1σ per-step disturbance noise (0: none)
    sensor_noise: tuple | None = field(init=False)  # (attitude rad, rate rad/s) or None
    sensor_draws: int = field(init=False)  # standard normals per sensor draw (6 and sensors')
    randomization: Randomization | None = field(init=False)
    sensors: object = field(init=False)  # rbenv.satellite.scene.Sensors when on, else None
    gyro_noisy: bool = field(init=False)  # a step draws the gyro's normals
    noisy: bool = field(init=False)  # a step draws random numbers (faults, noise)

    def __post_init__(self):
        validation.choice("action_mode", self.action_mode, ACTION_MODES)
        validation.choice("allocator", self.allocator_name, ALLOCATORS)
        values = _scene_scalars(self.scene)
        acts = make_actuators(self.scene, action_mode=self.action_mode,
                              allocator=self.allocator_name)
        if not acts:
            raise InvalidParameterError(
                f"scene {self.scene.name!r} has no actuator; give it one of the tables "
                f"{sorted(ACTUATORS)}")
        widths = [int(np.prod(a.action_shape)) for a in acts]
        edges = np.cumsum([0, *widths]).tolist()
        values.update(actuators=acts, action_shape=(edges[-1],) if len(acts) > 1
                      else acts[0].action_shape,
                      action_slices=tuple(slice(a, b) for a, b in itertools.pairwise(edges)))
        values["accounting"] = tuple(a for a in acts if a.needs_account)
        values["sole_actuator"] = acts[0] if len(acts) == 1 else None
        values.update(_draw_slices(acts, values["sensor_noise"] is not None))
        values["actuation"] = tuple(zip(acts, values["action_slices"], values.pop("uniforms"),
                                        strict=True))
        values["body"] = _integrated_body(self.scene, acts)
        values["orbit"] = self.scene.orbit if self.scene.orbit.enabled else None
        values["orbit_table"] = None if values["orbit"] is None else OrbitTable(
            values["orbit"], self.scene.physics.h, self.scene.episode_steps
            * self.scene.physics.substeps)
        values["orbit_torque"] = OrbitTorque(values["orbit_table"], self.scene.body,
                                             values["substeps"]) \
            if OrbitTorque.needed(self.scene.orbit, acts) else None
        values["eclipse_known"] = values["orbit"] is not None and values["orbit"].srp is not None
        if values["randomization"] is not None:
            check_applies(values["randomization"], self.scene)
        sensors = self.scene.sensors
        values["sensors"] = sensors if sensors.enabled else None
        # The estimator's gyro (attitude = "estimator") draws from its own stream.
        values["gyro_noisy"] = sensors.attitude == "gyro" and bool(
            sensors.gyro_noise_dps or sensors.gyro_bias_walk_dps_sqrt_s)
        values["noisy"] = bool(values["step_uniforms"] or values["dist_noise"]
                               or values["sensor_noise"] is not None or values["gyro_noisy"])
        _check_integrator_supports(self.scene, values["randomization"])
        if validation.flag("compiled", self.compiled):
            stores = [a.scene_table for a in acts if a.stores_momentum]
            if stores:
                raise InvalidParameterError(
                    f"compiled=True compiles rigid-body kernels only, but the actuators "
                    f"{stores} store angular momentum; use compiled=False")
            values["advance_kernel"] = _compiled_advance(self.scene, values["randomization"],
                                                         values["orbit_torque"])
        for name, value in values.items():
            object.__setattr__(self, name, value)

    # ------------------------------------------------------------------- declarations

    @property
    def translation(self) -> bool:
        """Whether the centre of mass moves (the scene models translation)."""
        return self.scene.physics.translation

    def eclipse(self, st, xp):
        """True (bool, or (N,) bools) where the satellite is in the Earth's cylindrical
        shadow now."""
        return self.orbit_table.lit(2 * st.steps * self.substeps, xp) == 0.0

    def actuator(self, table: str):
        """The actuator that the scene table ``table`` configures (``"wheels"``), or None."""
        return next((a for a in self.actuators if a.scene_table == table), None)

    @property
    def observed(self) -> bool:
        """Whether some actuator adds to the observation (``observers`` is not empty)."""
        return bool(self.observers)

    @property
    def torque_authority(self):
        """(3,) N·m per unit torque action (torque mode) of the first actuator that takes a
        body torque, else None."""
        return next((a.torque_authority for a in self.actuators
                     if a.torque_authority is not None), None)

    @property
    def action_bounds(self) -> tuple:
        """(low, high) arrays of the action space: the actuators' bounds, concatenated."""
        if len(self.actuators) == 1:
            return self.actuators[0].action_bounds
        return tuple(np.concatenate([np.ravel(a.action_bounds[i]) for a in self.actuators])
                     for i in (0, 1))

    @property
    def state_parts(self) -> tuple:
        """(owner, fields) of the plant and each actuator, for
        :class:`rbenv.satellite.state.Layout`."""
        return (("plant", PLANT_FIELDS),
                *((f"actuator {a.scene_table!r}", a.state_fields) for a in self.actuators))

    @property
    def reset_options(self) -> dict:
        """The plant's names in ``reset(options=...)`` and their widths: its actuators'
        (:attr:`rbenv.satellite.actuators.base.Actuator.reset_options`)."""
        out = {}
        for act in self.actuators:
            out.update(act.reset_options)
        return out

    def check_start(self, start: dict) -> None:
        """Each actuator checks (and settles) its part of a start given by reset options."""
        for act in self.actuators:
            if act.reset_options:
                act.check_start(start)

    @property
    def start_slots(self) -> int:
        """Slots of stream "plant" that :meth:`sample_start` draws: 0–5 the disturbance bias
        (three normals), then those of the actuators that draw from it."""
        return _BIAS_SLOTS + sum(a.start_slots for a in self.actuators
                                 if a.start_stream == "plant")

    @property
    def block_slots(self) -> dict:
        """Stream → slots an episode start draws from it (the plant's and actuators' hints)."""
        out = {"plant": self.start_slots}
        if self.sensors is not None:
            out["gyro"] = 6
        for a in self.actuators:
            if a.start_stream != "plant":
                out[a.start_stream] = a.start_slots
        return out

    # ------------------------------------------------------------------- actuation

    def actuate(self, st, action: np.ndarray, noise, xp, in_place: bool = False) -> Contribution:
        """The actuators' summed contribution under ``action`` (each takes its slice); they
        set their own fields on ``st``. ``in_place``: the caller owns ``action``."""
        act = self.sole_actuator
        if act is not None:
            return act.actuate(st, act.command(action, in_place, xp), noise, xp)
        parts = [a.actuate(st, a.command(action[..., s], False, xp), noise if u is None or
                           noise.faults is None else noise._replace(faults=noise.faults[..., u]),
                           xp)
                 for a, s, u in self.actuation]
        return sum_contributions(parts)

    # ------------------------------------------------------------------- motion

    def advance(self, st, c: Contribution, dist_noise, xp):
        """Advance ``st`` (the new state) over one control step under ``c`` and the
        disturbance; returns the divergence flag (bool, or (N,) bool).

        The actuators' torque plus the disturbance (constant torque, or bias + ``dist_noise``)
        drives ``substeps`` integrator steps; with translation the centre of mass moves under
        the body force rotated to the world frame at each substep. The flag is set where a
        state component, or the square of the rate, position or speed, is not finite.
        """
        tau = c.torque_B
        if st.bias is not None:
            tau = k.add(tau, st.bias)
            if dist_noise is not None:
                tau = k.add(tau, dist_noise, self.dist_noise)
        elif self.disturbance_torque is not None:
            tau = k.add(tau, self.disturbance_torque)
        body = self.body if st.model is None else st.model.body
        h, advance = self.h, self.advance_kernel
        q, w = st.q, st.omega_B
        h_int, h_dot = c.momentum_B, c.momentum_rate_B
        table = self.orbit_table
        step_torque = None if self.orbit_torque is None else self.orbit_torque.for_step(
            st.steps, c.dipole_B, xp, None if st.model is None else st.model.whole_body)
        try:
            for j in range(self.substeps):
                if st.x is not None:  # actuators without a force push nothing
                    self._translate(st, body, k.rotate(q, _ZERO if c.force_B is None
                                                       else c.force_B))
                if step_torque is not None:  # torques of (t, q), at every stage
                    q, w = advance(body, q, w, h, tau, None, h_int, h_dot,
                                   step_torque.substep(j))
                elif h_int is None and h_dot is None:
                    q, w = advance(body, q, w, h, tau, None)
                else:  # internal momentum (spinning rotors), moving linearly over the step
                    q, w = advance(body, q, w, h, tau, None, h_int, h_dot)
                if h_int is not None and h_dot is not None:
                    h_int = k.add(h_int, h_dot, h)
        except RbenvValueError:
            raise
        except (OverflowError, ZeroDivisionError, ValueError):  # e.g. int() of an inf or NaN
            q = (float("nan"),) * 4
        # Squares, not components: a rate or speed whose square overflows is caught too, so
        # no task ever computes |ω| = inf from a "finite" state.
        sq = w[0] * w[0] + w[1] * w[1] + w[2] * w[2]
        if st.x is not None:
            x, v = st.x, st.v
            sq = sq + (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]) + (v[0] * v[0] + v[1] * v[1]
                                                                   + v[2] * v[2])
        st.q, st.omega_B = q, w
        st.steps = st.steps + 1
        if table is not None:  # the actuators' bookkeeping and the field come with the orbit
            if st.field_B_T is not None:
                st.field_B_T = table.field_B(q, 2 * st.steps * self.substeps, xp)
        for act in self.accounting:
            act.account(st, c, self.control_dt, xp)
        return xp.not_finite((*q, sq))

    def _translate(self, st, body, force_W: tuple) -> None:
        """Move the centre of mass one integrator step under force_W (N, world frame)."""
        name, h = self.scene.physics.integrator, self.h
        moved = [translate(name, body, st.x[i], st.v[i], h, force_W[i]) for i in range(3)]
        st.x = tuple(m[0] for m in moved)
        st.v = tuple(m[1] for m in moved)

    def divergence_error(self, q, w) -> NonFiniteError:
        """The NonFiniteError for a diverged state (q, ω_B), naming the integrator and step:
        some state component, or the square of the rate, position or speed, is not finite."""
        name = self.scene.physics.integrator
        try:
            check_finite_state(q, w, name, self.h)
        except NonFiniteError as exc:
            return exc
        return NonFiniteError(
            f"simulation diverged: the body rate, or the centre-of-mass position or velocity, "
            f"is beyond float64 (its square overflows) after a step with integrator={name!r}, "
            f"dt={self.h!r}; the torque, force or step is too large")

    # ------------------------------------------------------------------- sensing

    def measure(self, st, noise) -> tuple[tuple, tuple]:
        """Measured (q, ω_B): the true state, or with noise ``q ⊗ exp(σ_att·n[:3])`` and
        ``ω_B + σ_rate·n[3:]`` (noise: 6 standard-normal components)."""
        if noise is None:
            return st.q, st.omega_B
        s_att, s_rate = self.sensor_noise
        q = k.qnormalize(k.qmul(st.q, k.exp(k.scale(noise[:3], s_att))))
        return q, k.add(st.omega_B, noise[3:], s_rate)

    def draw_sensor_noise(self, rng: np.random.Generator, batch: int | None):
        """6 standard-normal components, then the actuators' sensors' (one satellite, or
        (batch,) arrays), or None."""
        return None if self.sensor_noise is None else _components(rng, self.sensor_draws,
                                                                  batch)

    def draw_step_noise(self, rng: np.random.Generator, batch: int | None) -> StepNoise:
        """This step's random draws from ``rng``: one satellite (batch None) or ``batch``.

        Order: the actuators' uniforms, disturbance normals, sensor normals (each only when
        modelled).
        """
        if not self.noisy:
            return NO_NOISE
        n = self.step_uniforms
        faults = dist = sensor = gyro = None
        if n:
            faults = rng.random(n if batch is None else (batch, n))
        if self.dist_noise:
            dist = _components(rng, 3, batch)
        if self.sensor_noise is not None:
            sensor = _components(rng, self.sensor_draws, batch)
        if self.gyro_noisy:
            gyro = _components(rng, sensing.STEP_NORMALS, batch)
        return StepNoise(faults, dist, sensor, gyro)

    def sense(self, st, noise: StepNoise) -> None:
        """After the physics of a step: the sensors' part (rbenv.satellite.sensing), when on."""
        sensing.sense(self.sensors, st, noise.gyro, self.control_dt)

    # ------------------------------------------------------------------- episode start

    def sample_start(self, draws) -> dict:
        """The plant's and its actuators' part of an episode start for ``draws.n`` envs.

        ``bias``: 3 components, N·m, or None (stream "plant", slots 0–5); ``model``: an
        :class:`rbenv.satellite.randomization.EpisodeModel` of the randomized physics, or None; zero
        ``steps`` (and position and velocity with translation); then each actuator's fields.
        """
        sc = self.scene
        bias = model = None
        if sc.disturbance.model == "random":
            bias = k.scale(draws.normal("plant", 3), sc.disturbance.bias_sigma)
        if self.randomization is not None:
            model = draw_episode_model(self, draws)
        zero = draws.xp.zeros(draws.n)
        out = {"bias": bias, "model": model, "steps": zero}
        if self.orbit is not None and self.orbit.magnetic_field:
            out["field_B_T"] = (zero, zero, zero)  # set from the attitude by complete_start
        if self.translation:
            out["x"] = out["v"] = (zero, zero, zero)
        for act in self.actuators:
            out.update(act.sample_start(draws))
        if self.sensors is not None:  # the bias now (its stream); the rest needs q and ω
            out.update(sensing.start(self.sensors, _ZERO, _ZERO, draws))
        return out

    def complete_start(self, start: dict, xp) -> None:
        """Derived start values that need the task's attitude: the field in body axes, and
        the sensors' first measurement."""
        if "field_B_T" in start:
            start["field_B_T"] = self.orbit_table.field_B(start["q"], 0, xp)
        if self.sensors is not None:
            w = k.add(start["omega_B"], start["gyro_bias"])
            start.update(sensed_q=start["q"], latest_q=start["q"], sensed_omega_B=w,
                         latest_omega_B=w)

    @property
    def observation_structure(self) -> dict:
        """The actuators' observation parts (name → width), in action order."""
        out = {}
        for act in self.actuators:
            out.update(act.observation_structure)
        return out

    def observe(self, st, xp, sensor_noise=None) -> tuple:
        """The actuators' observation components; ``sensor_noise``: this step's sensor normals
        (after the first 6, each actuator's sensor takes its ``sensor_normals``)."""
        out = ()
        for act, sensed in self.observers:
            out = out + act.observe(st, xp, None if sensor_noise is None or sensed is None
                                    else sensor_noise[sensed])
        return out


NO_NOISE = StepNoise(None, None, None)


def _add(a, b):
    """Sum of two optional 3-component vectors (None is zero)."""
    if a is None:
        return b
    return a if b is None else k.add(a, b)


def sum_contributions(parts) -> Contribution:
    """The contributions of several actuators as one (torques, forces, momenta and their
    rates add; efforts add, each a fraction of its own actuator's full rate)."""
    total = parts[0]
    for c in parts[1:]:
        total = Contribution(k.add(total.torque_B, c.torque_B), _add(total.force_B, c.force_B),
                             _add(total.momentum_B, c.momentum_B),
                             _add(total.momentum_rate_B, c.momentum_rate_B),
                             total.effort + c.effort, _add(total.dipole_B, c.dipole_B))
    return total


def _draw_slices(acts: tuple, sensor_noise: bool) -> dict:
    """Where each actuator's random draws sit in a step's: ``uniforms``, per actuator, its
    slice of the step's uniforms (None: it draws none, or it is the only one that draws, and
    takes them all); ``step_uniforms``, their count; ``observers``, (actuator, slice of the
    sensor normals or None) of those that observe; ``sensor_draws``, sensor normals per step."""
    counts = [a.step_uniforms for a in acts]
    edges = np.cumsum([0, *counts]).tolist()
    several = sum(1 for c in counts if c) > 1
    uniforms = tuple(slice(a, b) if several and b > a else None
                     for a, b in itertools.pairwise(edges))
    observers, first = [], 6  # normals 0-5: the attitude and rate sensors (measure)
    for act in acts:
        width = act.sensor_normals if sensor_noise else 0
        if act.observation_structure:
            observers.append((act, slice(first, first + width) if width else None))
        first += width
    return {"uniforms": uniforms, "step_uniforms": edges[-1], "observers": tuple(observers),
            "sensor_draws": first}


def _integrated_body(scene: Scene, actuators: tuple):
    """The scene's body, or its inertia less the spin inertia its actuators carry (their
    spin momentum is the integrators' internal momentum)."""
    spin = [a.spin_inertia_B for a in actuators if a.spin_inertia_B is not None]
    if not spin:
        return scene.body
    try:
        return RigidBody(mass=scene.body.mass, inertia=bus_inertia(scene.body.inertia, sum(spin)))
    except RbenvValueError as exc:
        tables = [a.scene_table for a in actuators if a.spin_inertia_B is not None]
        raise InvalidParameterError(
            f"{tables[0]}.inertia: the scene's inertia less the spin inertia Σ J ĝĝᵀ of "
            f"{tables} must still be a rigid body's (the bus carries them), but "
            f"{exc}") from None


def _scene_scalars(sc: Scene) -> dict:
    """The scene's per-step scalars, flattened for the hot path (one attribute lookup)."""
    dist, sensor = sc.disturbance, sc.sensor_noise
    return {
        "h": sc.physics.h, "substeps": sc.physics.substeps, "control_dt": sc.physics.control_dt,
        "disturbance_torque": tuple(dist.torque.tolist()) if dist.model == "constant" else None,
        "dist_noise": dist.noise_sigma if dist.model == "random" else 0.0,
        "sensor_noise": (sensor.attitude, sensor.rate) if sensor.model == "gaussian" else None,
        "advance_kernel": INTEGRATORS[sc.physics.integrator].advance,
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


def _compiled_advance(sc: Scene, rnd: Randomization | None, orbit_torque):
    """The numba-compiled kernel of the scene's integrator (the extra ``rbenv[fast]``)."""
    from rbenv.core import compiled

    if orbit_torque is not None:
        raise InvalidParameterError(
            "compiled=True compiles rigid-body kernels under a held torque, but the scene's "
            "orbit torques (orbit.gravity_gradient, [orbit.residual_dipole], [orbit.drag], "
            "[orbit.srp], an actuator's dipole) are evaluated at every integrator stage; use "
            "compiled=False")
    if rnd is not None and (rnd.inertia_scale or rnd.inertia_rotation_deg):
        raise InvalidParameterError(
            "compiled=True compiles one fixed inertia into the loop, so it cannot step "
            "randomized inertias; use compiled=False")
    return compiled.get(sc.physics.integrator).advance


def _components(rng: np.random.Generator, count: int, batch: int | None) -> tuple:
    if batch is None:
        return tuple(rng.standard_normal(count).tolist())
    return tuple(rng.standard_normal((count, batch)))


def make_plant(scene, *, integrator=None, control_dt=None, substeps=None,
               action_mode=DEFAULT_ACTION_MODE, allocator="pinv", randomize=None,
               compiled=False) -> Plant:
    """Resolve env options against a scene (name, path or Scene) into a :class:`Plant`.

    integrator, control_dt (s), substeps: override the scene's physics. action_mode: one of
    :data:`rbenv.satellite.actuators.ACTION_MODES`. allocator: one of
    :data:`rbenv.satellite.actuators.ALLOCATORS` (torque mode).
    randomize: None keeps the scene's domain randomization; a dict overrides its fields
    (see :class:`rbenv.satellite.randomization.Randomization`); False turns it off. compiled: step
    the batch with the numba-compiled kernels (``rbenv[fast]``; rk4, euler, semi_implicit,
    euler_seed).
    """
    from rbenv.satellite.scene import load_scene

    sc = load_scene("cubesat-12u" if scene is None else scene)
    sc = sc.with_physics(integrator=integrator, control_dt=control_dt, substeps=substeps)
    if randomize is not None:
        sc = sc.with_randomization(randomize)
    return Plant(scene=sc, action_mode=action_mode, allocator_name=allocator, compiled=compiled)
