"""Detumble: stop a satellite tumbling about a random axis, with as little propellant as can be.

``rbenv/SatelliteDetumble-v0``. The attitude is uniform on SO(3) (it does not matter), the body
rate has a uniformly random direction and a magnitude uniform between ``min_rate_fraction`` and
``max_rate_fraction`` of the rate limit (the scene's ``[tasks.detumble]`` table, or
``task_options``). Success: |ω| < ``success_rate`` held for the hold time; failure: |ω| above
the rate limit. Fuel counts: its weight is ten times the reorientation task's.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import ClassVar

from rbenv.core import kernels as k
from rbenv.core import validation
from rbenv.tasks import v1
from rbenv.tasks.base import _DEG, Task, Weights, option_table, unit
from rbenv.tasks.spec import TaskSpec


@dataclass(frozen=True)
class DetumbleWeights(Weights):
    """Reward weights (per control step; ω the body rate, L the rate limit).

    rate ``−w·|ω|/L``; progress ``w·(|ω|_prev − |ω|)/L`` (potential-based); fuel
    ``−w·Σu_iF_i/ΣF_i``; hold ``+w`` per step below the success rate; failure ``−w`` once.
    """

    rate: float = 0.2
    progress: float = 10.0
    fuel: float = 0.5
    hold: float = 1.0
    failure: float = 25.0


@dataclass(frozen=True, eq=False)
class Detumble(Task):
    """Bring |ω| below the success rate and keep it there (see the module docstring)."""

    name: ClassVar[str] = "detumble"
    observation_structure: ClassVar[dict] = {"omega_B": 3}
    start_slots: ClassVar[int] = 15
    error_info_key: ClassVar[str] = "rate_dps"
    WeightsType: ClassVar[type] = DetumbleWeights
    state_fields: ClassVar[dict] = {"rate": "f", "hold": "i"}
    reset_options: ClassVar[dict] = {"q": 4, "omega_B": 3}
    OPTIONS: ClassVar[dict] = {"min_rate_fraction": 0.3, "max_rate_fraction": 0.8}

    weights: DetumbleWeights = DetumbleWeights()
    min_rate: float = 0.0  # rad/s
    max_rate: float = 0.0  # rad/s

    def observation_scale(self) -> dict:
        return {"omega_B": self.rate_limit}

    def with_initial_ranges(self, max_initial_angle_deg=None, max_initial_rate=None):
        """Curriculum: ``max_initial_rate`` (rad/s) caps the initial tumble; angle unused."""
        if max_initial_rate is None:
            return self
        rate = validation.number("max_initial_rate", max_initial_rate, low=0.0,
                                 high=self.rate_limit, high_open=True)
        return replace(self, max_rate=rate, min_rate=min(self.min_rate, rate))

    def sample_start(self, draws) -> dict:
        """Attitude uniform; rate direction uniform, magnitude uniform in [min, max].

        Stream "task": normals 0–3 attitude, 4–6 rate direction, then uniform slot 14.
        """
        g = draws.normal("task", 7)
        (u,) = draws.uniform("task", 1, offset=14)
        rate = self.min_rate + (self.max_rate - self.min_rate) * u
        return {"q": k.qnormalize(g[0:4]), "omega_B": k.scale(unit(g[4:7], draws.xp), rate)}

    def complete_start(self, start: dict, xp) -> None:
        w = start["omega_B"]
        rate = xp.sqrt(k.dot(w, w))
        start.update(rate=rate, hold=0 * rate)

    def observe(self, st, q, w, xp) -> tuple:
        """ω_B / rate_limit, clipped to [-1, 1] (3)."""
        s = self.inv_rate_limit
        clip = xp.clip
        return (clip(w[0] * s, -1.0, 1.0), clip(w[1] * s, -1.0, 1.0), clip(w[2] * s, -1.0, 1.0))

    def _update_errors(self, st, xp) -> tuple:
        """After a step: (|ω| in rad/s, inside the threshold, failure: |ω| > rate limit); sets
        the hold counter (not ``st.rate``, which still holds the rate before the step)."""
        w = st.omega_B
        rate = xp.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
        inside = rate < self.success_rate
        st.hold = xp.where(inside, st.hold + 1, 0)
        return rate, inside, rate > self.rate_limit

    def evaluate(self, st, effort, xp):
        wt = self.weights
        rate, inside, failure = self._update_errors(st, xp)
        inv_limit = self.inv_rate_limit
        terms = tuple.__new__(self.Terms, (
            -wt.rate * xp.minimum(rate * inv_limit, 1.0),
            wt.progress * inv_limit * (st.rate - rate),
            -wt.fuel * effort,
            wt.hold * inside,
            -wt.failure * failure,
        ))
        st.rate = rate
        return terms, st.hold >= self.hold_steps, failure

    def info(self, st, xp) -> dict:
        """rate_dps."""
        return {"rate_dps": st.rate * _DEG}


@dataclass(frozen=True)
class DetumbleV1Weights(v1.V1Weights):
    """v1 weights of detumble: the error is the rate itself, so no separate rate term; fuel
    2.0 (PPO: 100 %, 0.43 g against the PD's 0.67 g; benchmarks/results/rl/v1)."""

    rate: float = 0.0
    fuel: float = 2.0


@dataclass(frozen=True, eq=False)
class DetumbleV1(Detumble):
    """Detumble, v1 observation and reward (:mod:`rbenv.tasks.v1`); same episodes as v0."""

    name: ClassVar[str] = "detumble_v1"
    scene_table: ClassVar[str] = "detumble"
    observation_structure: ClassVar[dict] = {"omega_B": 3, "omega_fine": 3}
    WeightsType: ClassVar[type] = DetumbleV1Weights

    weights: DetumbleV1Weights = DetumbleV1Weights()

    def observation_scale(self) -> dict:
        return {"omega_B": self.rate_limit, "omega_fine": 1.0}

    def observe(self, st, q, w, xp) -> tuple:
        """ω_B/L clipped (3), fine(ω, |ω|, ω_s) (3)."""
        return v1.rate_features(w, self.inv_rate_limit, self.success_rate, xp)

    def evaluate(self, st, effort, xp):
        """v1 terms (error ψ(|ω|) on [0, L], progress on it), success, failure."""
        prev = xp.minimum(st.rate, self.rate_limit)
        rate, _, failure = self._update_errors(st, xp)
        success = st.hold >= self.hold_steps
        now = xp.minimum(rate, self.rate_limit)
        L, w_s = self.rate_limit, self.success_rate
        drop = v1.log_scale_drop(prev, now, w_s, L, xp)
        psi = v1.log_scale(now, w_s, L, xp)
        st.rate = rate
        return v1.terms(self.weights, drop, psi, 0.0 * psi, effort, success, failure), \
            success, failure


def make_detumble(plant, reward_weights=None, max_initial_angle_deg=None,
                  max_initial_rate=None, task_options=None) -> Detumble:
    """The detumble task on ``plant``; ``max_initial_rate`` (rad/s) overrides the top rate."""
    return _make(Detumble, plant, reward_weights, max_initial_angle_deg, max_initial_rate,
                 task_options)


def make_detumble_v1(plant, reward_weights=None, max_initial_angle_deg=None,
                     max_initial_rate=None, task_options=None) -> DetumbleV1:
    """The v1 detumble task (options as :func:`make_detumble`)."""
    return _make(DetumbleV1, plant, reward_weights, max_initial_angle_deg, max_initial_rate,
                 task_options)


def _make(cls, plant, reward_weights, max_initial_angle_deg, max_initial_rate, task_options):
    opts = option_table(plant.scene, cls, task_options)
    limit = plant.scene.episode.rate_limit
    lo = validation.number("tasks.detumble.min_rate_fraction", opts["min_rate_fraction"],
                           low=0.0, high=1.0, high_open=True)
    hi = validation.number("tasks.detumble.max_rate_fraction", opts["max_rate_fraction"],
                           low=lo, high=1.0, high_open=True)
    task = cls(plant=plant, weights=cls.WeightsType.from_mapping(reward_weights),
               min_rate=lo * limit, max_rate=hi * limit)
    return task.with_initial_ranges(max_initial_angle_deg, max_initial_rate)


ENV_DOC = """Stop a tumbling satellite with thrusters, spending as little propellant as possible.

    Made by ``gym.make("rbenv/SatelliteDetumble-v0", **kwargs)``; arguments as
    :class:`SatelliteReorientEnv`, with ``max_initial_rate`` (rad/s) the largest initial
    tumble and ``task_options`` a dict overriding the scene's ``[tasks.detumble]`` table
    (``min_rate_fraction``, ``max_rate_fraction``: the initial |ω| is uniform between these
    fractions of the rate limit, about a uniformly random axis).

    **Action**: as the reorientation env. **Observation** ``Box(-1, 1, (3,), float32)``,
    ``{"omega_B": 3}``: ``ω_B / rate_limit``, clipped.

    **Reward**: rate ``−0.2·|ω|/L``, progress ``10·(|ω|_prev − |ω|)/L``, fuel
    ``−0.5·Σu_iF_i/ΣF_i``, hold ``+1`` per step below the success rate, failure ``−25`` on
    loss of control (``reward_weights`` overrides these).

    **Episode end**: ``terminated`` with success when |ω| < ``success_rate`` is held for the
    hold time; ``terminated`` without success when |ω| > rate limit; ``truncated`` at the
    scene's duration. **Info**: ``rate_dps``, ``fuel_kg``, ``impulse_Ns``, ``time_s``,
    ``is_success``, ``reward_<term>``. **Reset options**: ``{"q": (4,), "omega_B": (3,)}``.

    **Version History**

    * v0, orbit torques evaluated where they act (a physics fix, same version): on a scene
      with an orbit (``cubesat-6u-rw``) the gravity gradient and the rods' ``m × B`` (the
      field fixed in inertial axes, the dipole command held) are evaluated at every
      integrator stage instead of held over the substep in body axes, so its episodes
      change: with idle wheels and random rod commands (seed 1,000,000) the attitude moves
      by 0.40 rad after its 1600 s at 10 s × 4. Scenes without an orbit are bit-identical.
    * v0: first release.
    """

# The env entry: registered by rbenv/__init__.py (rbenv.envs.registry); trained with the settings
# of rbenv.agents.settings.
SPEC = TaskSpec(env_id="rbenv/SatelliteDetumble-v0", task=Detumble, make=make_detumble,
                env_doc=ENV_DOC)

ENV_DOC_V1 = """Stop a tumbling satellite with thrusters (v1 observation and reward).

    Made by ``gym.make("rbenv/SatelliteDetumble-v1", **kwargs)``; arguments, action, episode
    end, info and reset options as ``rbenv/SatelliteDetumble-v0``, and the same episodes for
    the same seed; ``task_options`` as v0's (``min_rate_fraction``, ``max_rate_fraction``,
    read from the scene's ``[tasks.detumble]`` table).

    **Observation** ``Box(-1, 1, (6,), float32)``, ``observation_structure``
    ``{"omega_B": 3, "omega_fine": 3}``: ``ω_B / rate_limit`` clipped, then
    ``ω_B / (ω_s + |ω|)`` (length 1/2 at the success rate ω_s).

    **Reward** (:mod:`rbenv.tasks.v1`; ``ψ(|ω|) = log(1 + |ω|/ω_s)/log(1 + L/ω_s)``): error
    ``−0.1·ψ(|ω|)``, fuel ``−2.0·Σu_iF_i/ΣF_i``, progress ``10·(ψ_prev − ψ)``, success
    ``+20`` once when the hold completes, failure ``−25`` on loss of control (the ``rate``
    term has weight 0; ``reward_weights`` overrides these). Nothing is paid for staying below
    the success rate without completing the hold.

    """ + v1.version_history("rbenv/SatelliteDetumble-v0")

SPEC_V1 = TaskSpec(env_id="rbenv/SatelliteDetumble-v1", task=DetumbleV1, make=make_detumble_v1,
                   env_doc=ENV_DOC_V1)
