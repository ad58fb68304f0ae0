"""What every actuator is: a component of the plant with its own action, state and scene table.

An actuator turns its slice of the action into a command, and its state plus the command into
its :class:`Contribution` to the equations of motion over one control step. The plant sums the
contributions of its actuators and integrates (:mod:`rbenv.satellite.plant`)::

    I ω̇_B = −ω_B × (I ω_B + h_B) − ḣ_B + τ_B        (h_B: internal angular momentum)

Thrusters (:mod:`rbenv.satellite.actuators.thrusters`) store no momentum (h = ḣ = None); wheels
(:mod:`rbenv.satellite.actuators.wheels`) do; magnetorquers
(:mod:`rbenv.satellite.actuators.magnetorquers`) give a dipole. A new actuator is one module
with a class that satisfies :class:`Actuator` (mixing in :class:`ActuatorDefaults` for what it
lacks), its scene table parser and maker, and one entry in
:data:`rbenv.satellite.actuators.ACTUATORS` (or one :func:`rbenv.satellite.actuators.register`
call).

Values are components as in :mod:`rbenv.core.kernels`: Python floats for one satellite, (N,) arrays
for N; ``xp`` is the :mod:`rbenv.core.backend` namespace that matches them.
"""

from __future__ import annotations

from typing import ClassVar, NamedTuple, Protocol, runtime_checkable

import numpy as np

from rbenv.core.backend import FLOAT
from rbenv.core.errors import InvalidParameterError

__all__ = ["Actuator", "ActuatorDefaults", "Contribution"]


class Contribution(NamedTuple):
    """One actuator's share of a control step, held constant over the step (body frame).

    torque_B: 3 components, N·m. force_B: 3 components, N, through the centre of mass, or None
    (no translation modelled). momentum_B: internal angular momentum h_B, 3 components, N·m·s,
    or None (stores none). momentum_rate_B: ḣ_B, 3 components, N·m, or None. effort: the
    fraction of the actuator's full effort rate spent in the step, in [0, 1] (propellant flow
    for thrusters, electrical power for wheels and magnetorquers); tasks price it. dipole_B:
    magnetic dipole, 3 components, A·m², or None; its torque ``m_B × R(q)ᵀ B_N(t)`` depends on
    the attitude, so the plant evaluates it at every integrator stage (build with all six
    values when bypassing the constructor, ``tuple.__new__``).
    """

    torque_B: tuple
    force_B: tuple | None
    momentum_B: tuple | None
    momentum_rate_B: tuple | None
    effort: object
    dipole_B: tuple | None = None


@runtime_checkable
class Actuator(Protocol):
    """The interface the plant calls; each actuator is a frozen dataclass built from a scene.

    Declarations (class or instance attributes):

    * ``scene_table``: the TOML table that configures it (``"thrusters"``);
    * ``action_shape`` and ``action_bounds``: its slice of the action and its (low, high);
    * ``state_fields``: its episode state, name → :mod:`rbenv.satellite.state` kind (names must not
      clash with the plant's, the task's or another actuator's: the layout refuses them);
    * ``observation_structure``: name → width of its part of the observation ({} for none);
    * ``info_keys``: the info entries it adds;
    * ``start_stream`` and ``start_slots``: the stream of
      :class:`rbenv.satellite.draws.EpisodeDraws` that :meth:`sample_start` draws from (its
      ``scene_table``, or ``"plant"`` after the plant's own slots) and how many slots (a hint);
    * ``needs_account``: whether :meth:`account` must run after the physics;
    * ``stores_momentum``: whether its contribution carries internal angular momentum;
    * ``gives_dipole``: whether its contribution carries a magnetic dipole (the plant then
      evaluates the orbit's torques at every integrator stage);
    * ``spin_inertia_B``: (3, 3) kg·m², the part of the scene's inertia that spins with its
      rotors (the plant integrates the bus without it), or None;
    * ``torque_authority``: (3,) N·m per unit action when its action is a body torque, or None;
    * ``step_uniforms``: uniforms in [0, 1) it draws per step (``noise.faults`` in
      :meth:`actuate`, its own slice);
    * ``sensor_normals``: standard normals its sensor draws per step (``sensed`` in
      :meth:`observe`);
    * ``reset_options``: its names in ``reset(options=...)`` → width (values of its state
      fields), checked by :meth:`check_start`.
    """

    scene_table: ClassVar[str]
    start_stream: ClassVar[str]
    needs_account: ClassVar[bool]
    stores_momentum: ClassVar[bool]
    gives_dipole: ClassVar[bool]
    action_shape: tuple
    action_bounds: tuple
    state_fields: dict
    observation_structure: dict
    info_keys: tuple
    start_slots: int
    spin_inertia_B: object
    torque_authority: object
    step_uniforms: int
    sensor_normals: int
    reset_options: dict

    def command(self, action, in_place: bool = False, xp=None):
        """The physical command from its (clipped) action slice; NaN raises a named error.
        xp: the state's namespace (the action is an array: :func:`rbenv.core.backend.rows` of
        it)."""

    def actuate(self, st, command, noise, xp) -> Contribution:
        """Its contribution under ``command`` from state ``st``; sets its own fields on ``st``
        (the transition's new state) for what happens before the physics (faults, delay)."""

    def account(self, st, contribution: Contribution, dt: float, xp) -> None:
        """After the physics: its bookkeeping over the step (propellant, energy), on ``st``."""

    def sample_start(self, draws) -> dict:
        """Its part of an episode start (values of its state fields) for ``draws.n`` envs."""

    def observe(self, st, xp, sensed=None) -> tuple:
        """Its observation components (empty when ``observation_structure`` is {}); ``sensed``:
        standard normals for its sensor's noise this step (3 components), or None."""

    def info(self, st, xp, out: dict) -> None:
        """Write its info values into ``out`` (units in the key names)."""

    def check_start(self, start: dict) -> None:
        """Refuse (named error) or settle a start whose values came from reset options."""

    def render_values(self, st, index: int | None) -> dict:
        """Its keyword arguments of :meth:`rbenv.envs.rendering.Renderer.frame` for one satellite
        (sub-env ``index`` of a batch state, or None for a single env's)."""


class ActuatorDefaults:
    """The declarations and methods of an actuator without the feature: mix it in and override
    what the actuator has (class attributes, or dataclass fields set in ``__post_init__``)."""

    observation_structure: ClassVar[dict] = {}
    info_keys: ClassVar[tuple] = ()
    needs_account: ClassVar[bool] = False
    stores_momentum: ClassVar[bool] = False
    gives_dipole: ClassVar[bool] = False
    start_slots: ClassVar[int] = 0
    spin_inertia_B: ClassVar[object] = None
    torque_authority: ClassVar[object] = None
    step_uniforms: ClassVar[int] = 0
    sensor_normals: ClassVar[int] = 0
    reset_options: ClassVar[dict] = {}

    def account(self, st, contribution: Contribution, dt: float, xp) -> None:
        """Nothing after the physics."""

    def sample_start(self, draws) -> dict:
        """No state of its own."""
        return {}

    def observe(self, st, xp, sensed=None) -> tuple:
        """No observation of its own."""
        return ()

    def info(self, st, xp, out: dict) -> None:
        """No info of its own."""

    def check_start(self, start: dict) -> None:
        """No reset options to check."""

    def render_values(self, st, index: int | None) -> dict:
        """Nothing to draw."""
        return {}


def one_row(components, index: int | None) -> np.ndarray:
    """A state field of components (floats, or (N,) arrays with ``index`` the row) as one
    satellite's (k,) float array."""
    return np.array([float(c if index is None else c[index]) for c in components])


def nan_action_error(action) -> InvalidParameterError:
    """The named error (a ValueError) for an action containing NaN, naming the first bad index."""
    bad = np.argwhere(np.isnan(np.asarray(action, dtype=float)))
    where = tuple(int(i) for i in bad[0]) if len(bad) else ()
    return InvalidParameterError(
        f"action must not contain NaN (got NaN at index {where}); actions outside [-1, 1] are "
        "clipped to the action space, but NaN has no meaning"
    )


def action_components(a, xp) -> tuple:
    """An action (n,) or (N, n) as n components (floats or (N,) arrays); NaN is refused."""
    c = tuple(a.tolist()) if xp is FLOAT else tuple(a.T)
    bad = c[0] != c[0]
    for ci in c[1:]:
        bad = bad | (ci != ci)
    if xp.any(bad):
        raise nan_action_error(a)
    return c
