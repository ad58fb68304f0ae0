"""A torch-native vector env: the same transition on (N,) tensors of one device.

``gym.make_vec(ID, num_envs=N, backend="torch", device="cpu")`` (or ``"cuda"``; ``dtype``
``"float64"`` by default, ``"float32"`` as an option) returns a :class:`TorchVectorEnv`, a
``gymnasium.vector.VectorEnv`` whose ``step`` takes an (N, k) action tensor and returns
tensors on its device: obs (N, d) in the env's dtype, reward (N,), terminated and truncated
(N,) bool, and ``info``, a dict of (N,) tensors with a ``_key`` mask each, as the NumPy env.
Its spaces are Gymnasium Boxes in the env's dtype (actions and observations alike), so
``action_space.sample()`` is a NumPy array; ``step`` takes it too and copies it to the device.

``gym.make(ID, backend="torch")`` gives one satellite of it as a ``gymnasium.Env`` with NumPy at
its boundary (:class:`TorchEnv`), for the env checkers and single-env tools.

The physics is not restated: the plant, actuators, tasks and integrators of
:mod:`rbenv.envs.transition` run through the torch namespace (:mod:`rbenv.core.torch_backend`), and
episode starts come from :mod:`rbenv.satellite.torch_draws`, the counter-based draws on the device.

**Autoreset on the device**, the three modes of the NumPy env (:mod:`rbenv.envs.vector`, one
implementation for both). NEXT_STEP (default, :data:`rbenv.envs.options.AUTORESET_DEFAULT`): a
sub-env that ended restarts on the following step, whose action it ignores. SAME_STEP: a
sub-env that ends returns its new episode's first observation; the last one is in
``info["final_obs"]``, an (N, d) tensor whose rows are valid where ``info["_final_obs"]`` is
True, and ``info["final_info"]`` holds the ending step's info, every key zero where a row did
not end, as the NumPy env's; both are in every SAME_STEP step (masks all False where no
sub-env ended: telling would read the host), where the NumPy env has them only on a step
where some sub-env ended. The info of a masked reset holds the reset rows alone (``_key`` is
the mask), as the NumPy env's.
On a CUDA (any non-CPU) device new episodes are drawn for every row and the ended ones
selected with ``torch.where``: no index list, no host round trip. On a CPU, where a host read
costs nothing, only the ended rows are drawn (by index), which is cheaper; the numbers are the
same. DISABLED: nothing resets by itself; ``reset(options={"reset_mask": mask})`` with an
(N,) bool tensor.

**Seeding.** ``reset(seed=s)`` seeds sub-env i with s + i, as the NumPy env: on CPU in float64
every episode equals the NumPy vector env's (and so the single env's with seed s + i) to
round-off, for the same actions.

**Divergence.** A step whose state leaves the floats, or whose action holds NaN, sets the
sub-env's row of ``info["diverged"]`` and of :attr:`TorchVectorEnv.diverged` (sticky, an (N,)
bool tensor); the step itself never reads a tensor on the host. The env raises the NumPy env's
errors (:class:`rbenv.core.errors.NonFiniteError`, or the named NaN-action error) at its sync
points: every ``check_every`` steps (default 1: the step that diverged raises, as the NumPy
env), at ``reset()`` and at :meth:`TorchVectorEnv.check`. ``check_every=0`` checks only at
reset and on request, for a device whose host syncs are costly.

**The estimator.** A scene with ``[estimator]`` runs its sensors and MEKF on the device
(:mod:`rbenv.envs.torch_estimated`): the observation is the estimate's, and ``info`` carries
the NumPy env's estimator keys ((N, ...) tensors). Their noise is drawn on the host from the
NumPy env's stream, so with the same seed an episode equals the NumPy vector env's to
round-off; a step then copies those draws to the device, and an autoreset reads the ended rows
on the host (on every device); ``compile=True`` is refused with it.

**Not supported yet** (refused by name at construction): the implicit integrators (midpoint,
splitting), the desaturate task (its wheel-load start is NumPy row operations), the torque
action mode (its allocators are NumPy/SciPy), domain randomization,
per-step noise (sensor noise, disturbance noise, mid-episode thruster faults), rendering and
the numba ``compiled`` kernels.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import gymnasium as gym
import numpy as np
import torch
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from rbenv.core import validation
from rbenv.core.errors import InvalidParameterError
from rbenv.core.torch_backend import TorchNamespace
from rbenv.envs import transition
from rbenv.envs.adapter import (
    action_array,
    autoreset_mode_of,
)
from rbenv.envs.options import AUTORESET_DEFAULT, take
from rbenv.envs.vector import Step, VectorContract
from rbenv.satellite.plant import NO_NOISE
from rbenv.satellite.state import State
from rbenv.satellite.torch_draws import TorchDraws

__all__ = ["DTYPES", "TorchEnv", "TorchVectorEnv"]

DTYPES = {"float64": torch.float64, "float32": torch.float32}
IMPLICIT = ("midpoint", "splitting")
_COMPONENTS = ("c3", "c4", "cn")


class DeferredTorchNamespace(TorchNamespace):
    """The torch namespace with the step's host reads removed: ``any`` and ``isnan_any``
    answer False without reading the device (the transition's divergence test, the action NaN
    tests). The env computes those flags as tensors instead and raises at its sync points."""

    @staticmethod
    def any(x) -> bool:
        return False

    @staticmethod
    def isnan_any(x) -> bool:
        return False

    def const(self, value):
        """:meth:`TorchNamespace.const`; under ``torch.compile`` the NumPy constant is traced
        as a tensor (the cache's ``id``/``dtype`` reads would break the graph)."""
        if not torch.compiler.is_compiling() or not isinstance(value, np.ndarray):
            return super().const(value)
        t = torch.as_tensor(value, device=self.device)
        return t.to(self.dtype) if t.is_floating_point() else t


def _device(device) -> torch.device:
    """``device`` as a torch device that this machine has, else a named error."""
    if not isinstance(device, (str, torch.device)):
        raise TypeError(f"device must be a torch device or its name ('cpu', 'cuda', "
                        f"'cuda:1', ...), got {type(device).__name__} {validation.show(device)}")
    try:
        dev = torch.device(device)
        torch.empty(0, device=dev)
    except (RuntimeError, AssertionError) as exc:
        raise InvalidParameterError(
            f"device must be a torch device available here ('cpu'"
            f"{', cuda' if torch.cuda.is_available() else ''}), got {device!r}: "
            f"{str(exc).splitlines()[0]}") from None
    return dev


def _refuse(option: str, value, rule: str):
    raise InvalidParameterError(
        f"backend='torch' does not support {option}={value!r} yet: {rule}")


def check_supported(plant, task, render_mode, compiled) -> None:
    """Raise, naming the option and value, for what the torch backend cannot run yet."""
    sc = plant.scene
    if task.table_name() == "desaturate":  # v0 and v1
        _refuse("task", task.name, "its wheel-load start is drawn with NumPy row operations")
    integrator = sc.physics.integrator
    if integrator in IMPLICIT:
        _refuse("integrator", integrator, "the implicit integrators (Newton iterations, "
                "frame caches) are NumPy-only; pass integrator='rk4' (or another explicit one)")
    if plant.action_mode == "torque":
        _refuse("action_mode", "torque", "the thrust allocators are NumPy/SciPy; use "
                "'throttle' or 'on_off'")
    if plant.randomization is not None:
        drawn = {f.name: getattr(plant.randomization, f.name)
                 for f in dataclasses.fields(plant.randomization)
                 if getattr(plant.randomization, f.name)}
        _refuse("randomize", drawn, f"the per-episode model of domain randomization is NumPy "
                f"(scene {sc.name!r} draws these); pass randomize=False")
    if plant.noisy:
        _refuse("scene", sc.name, "per-step noise (sensor noise, disturbance noise or "
                "mid-episode thruster faults) is drawn by NumPy's generator; pick a scene "
                "without it")
    if plant.sensors is not None:
        _refuse("scene", sc.name, "sensing as flown ([sensors]: gyro attitude, delay) is "
                "NumPy-only yet; pick a scene without it")
    if render_mode is not None:
        _refuse("render_mode", render_mode, "rendering reads the host; use the NumPy env")
    if compiled:
        _refuse("compiled", compiled, "the numba kernels are NumPy's; use compile=True for "
                "torch.compile")


class TorchVectorEnv(VectorContract):
    """``num_envs`` satellites stepped as torch tensors on ``device`` (see the module doc).

    Options: those of :class:`rbenv.envs.vector_env.AttitudeVectorEnv` (minus the unsupported ones,
    refused by name) plus ``device`` (a torch device, default "cpu"), ``dtype`` ("float64" or
    "float32"), ``compile`` (run the step under ``torch.compile``) and ``check_every`` (steps
    between divergence checks on the host; 0: only at reset and :meth:`check`).
    """

    metadata: ClassVar[dict] = {"render_modes": [], "autoreset_mode": AUTORESET_DEFAULT}
    mask_kind: ClassVar[str] = "a torch bool tensor or a NumPy bool array"

    def __init__(self, num_envs: int = 1, scene=None, **options):
        """Options: :data:`rbenv.envs.options.OPTIONS_OF` ``["torch"]`` (see the class doc)."""
        o = take(type(self).__name__, "torch", {"num_envs": num_envs, "scene": scene, **options})
        dtype = o["dtype"]
        self.num_envs = validation.count("num_envs", num_envs, low=1, high=2**24)
        if isinstance(dtype, torch.dtype):
            dtype = str(dtype).removeprefix("torch.")
        if dtype not in DTYPES:
            raise InvalidParameterError(f"dtype must be one of {sorted(DTYPES)} (or the torch "
                                        f"dtype), got {dtype!r}")
        self.device, self.dtype = _device(o["device"]), DTYPES[dtype]
        self.xp = DeferredTorchNamespace(self.device, self.dtype)
        self.autoreset_mode = autoreset_mode_of(o["autoreset_mode"])
        single_action, single_obs = self._setup({**o, "render_mode": None}, ())
        check_supported(self.plant, self.task, o["render_mode"], o["compiled"])
        # Both spaces in the env's dtype: what it returns, and what it computes actions in.
        self.single_action_space = gym.spaces.Box(-1.0, 1.0, single_action.shape,
                                                  np.dtype(dtype))
        self.single_observation_space = gym.spaces.Box(-1.0, 1.0, single_obs.shape,
                                                       np.dtype(dtype))
        self.metadata = {**type(self).metadata, "autoreset_mode": self.autoreset_mode,
                         "render_fps": 1.0 / self.plant.control_dt}
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self._max_steps = self._episode_steps(o["max_episode_steps"])
        self.check_every = validation.integer("check_every", o["check_every"], low=0)
        n, dev = self.num_envs, self.device
        self._seeds = None
        self._episodes = torch.zeros(n, dtype=torch.int64, device=dev)
        self._mask = torch.ones(n, dtype=torch.bool, device=dev)
        self.diverged = torch.zeros(n, dtype=torch.bool, device=dev)
        self._done = torch.zeros(n, dtype=torch.bool, device=dev)
        self._steps_since_check = 0
        self._st = None
        self._renderer = None
        self._step_fn, self._restart_fn = self._physics, self._restart_all
        self._index_restart = self.device.type == "cpu"
        self._estimation = None  # the MEKF in the loop, for scenes with [estimator]
        self._last_obs = None
        if self.plant.scene.estimator is not None:
            if o["compile"]:
                _refuse("compile", o["compile"], "the estimator's sensor noise is drawn on the "
                        "host each step (rbenv.envs.torch_estimated); use compile=False")
            from rbenv.envs.torch_estimated import TorchEstimatorLoop

            self._estimation = TorchEstimatorLoop(self.plant, self.task, self.xp, self._stack)
            self._index_restart = True  # the estimator's stream needs the ended rows' count
        if validation.flag("compile", o["compile"]):
            from rbenv.envs.torch_compile import CompiledStep

            self._step_fn = CompiledStep(self._physics)
            self._restart_fn = CompiledStep(self._restart_all)
            self._index_restart = False  # the compiled restart has fixed shapes

    # ------------------------------------------------------------------- helpers

    def _tensor(self, value, dtype=None, n=None) -> torch.Tensor:
        """A value as an (n,)-leading tensor (n: num_envs by default) in the env's dtype (or
        ``dtype``)."""
        dtype = dtype or self.dtype
        t = torch.as_tensor(value, device=self.device)
        t = t.to(dtype) if t.dtype != dtype else t
        return t.expand(n or self.num_envs).clone() if t.ndim == 0 else t

    def _field(self, kind: str, value, n=None):
        """One field of a batch state from its start value (:data:`rbenv.satellite.state.KINDS`), in
        tensors of its own: a start may share one zero array between fields, and aliased
        fields would make ``torch.compile`` guard on the aliasing (a recompilation)."""
        if kind in _COMPONENTS:
            return tuple(self._tensor(c, n=n).clone() for c in value)
        if kind == "i":
            return self._tensor(value, torch.int64, n).clone()
        if kind == "obj":
            raise InvalidParameterError("backend='torch' holds no per-episode model objects")
        return self._tensor(value, n=n).clone()

    def _state(self, start: dict, n=None) -> State:
        st = State()
        for name, kind in self._layout.kinds.items():
            value = start.get(name)
            setattr(st, name, None if value is None else self._field(kind, value, n))
        return st

    def _draw_starts(self, options=None, idx=None) -> State:
        """A new episode for every sub-env, or for those in ``idx`` (an index tensor), from
        their current seeds and episode counters."""
        seeds, episodes = self._seeds, self._episodes
        if idx is not None:
            seeds, episodes = seeds[idx], episodes[idx]
        draws = TorchDraws(seeds, episodes, self.xp)
        rows = np.arange(self.num_envs) if options else None
        return self._state(transition.start(self.plant, self.task, draws, options, rows=rows,
                                            num_envs=self.num_envs), draws.n)

    def _scatter(self, idx: torch.Tensor, new: State, old: State) -> State:
        """Rows ``idx`` from ``new`` (a state of len(idx)), the others from ``old`` (a new
        state: ``index_copy`` out of place)."""
        out = State()
        for name, kind in self._layout.kinds.items():
            a, b = getattr(new, name), getattr(old, name)
            if a is None or b is None:
                value = b
            elif kind in _COMPONENTS:
                value = tuple(y.index_copy(0, idx, x) for x, y in zip(a, b, strict=True))
            else:
                value = b.index_copy(0, idx, a)
            setattr(out, name, value)
        return out

    def _mux(self, mask: torch.Tensor, new: State, old: State) -> State:
        """Rows of ``new`` where ``mask``, else of ``old`` (a new state; no in-place writes)."""
        out = State()
        col = mask.unsqueeze(1)
        for name, kind in self._layout.kinds.items():
            a, b = getattr(new, name), getattr(old, name)
            if a is None or b is None:
                value = b
            elif kind in _COMPONENTS:
                value = tuple(torch.where(mask, x, y) for x, y in zip(a, b, strict=True))
            else:
                value = torch.where(col if a.ndim == 2 else mask, a, b)
            setattr(out, name, value)
        return out

    def _stack(self, comps: tuple, n=None) -> torch.Tensor:
        return torch.stack([self._tensor(c, n=n) for c in comps], dim=1)

    def _owner(self):
        return self._row_tensor

    def _row_tensor(self, value) -> torch.Tensor:
        """An info value as an (N,) tensor: floats in the env's dtype, bools and ints as they
        are (a 0-d one expanded)."""
        if not isinstance(value, torch.Tensor) or value.dtype.is_floating_point:
            return self._tensor(value)
        return value.expand(self.num_envs) if value.ndim == 0 else value

    # ------------------------------------------------------------------- torch rows

    def _sync(self) -> None:
        """A reset is a sync point: it raises for a divergence not yet reported."""
        self.check()

    def _seed_array(self, seeds) -> torch.Tensor:
        if isinstance(seeds, range):
            return torch.arange(seeds.start, seeds.stop, dtype=torch.int64, device=self.device)
        if max(seeds) >= 2**63:
            raise InvalidParameterError(f"seed must be < 2**63 on backend='torch', got "
                                        f"{max(seeds)}")
        return torch.tensor(seeds, dtype=torch.int64, device=self.device)

    @staticmethod
    def _where(mask, a, b) -> torch.Tensor:
        return torch.where(mask, a, b)

    @staticmethod
    def _keep(mask, value) -> torch.Tensor:
        shape = mask.shape + (1,) * (value.ndim - 1)
        return torch.where(mask.reshape(shape), value, torch.zeros_like(value))

    @staticmethod
    def _any(mask) -> bool:
        return bool(mask.any())  # a host read

    @staticmethod
    def _all(mask) -> bool:
        return bool(mask.all())  # a host read, at a reset

    def _mask_array(self, mask):
        """A torch tensor, or a NumPy array (as Gymnasium users pass it; actions are taken
        from NumPy too) copied to the env's device."""
        if isinstance(mask, np.ndarray):
            return torch.from_numpy(mask.copy()).to(self.device)
        return mask.to(self.device) if isinstance(mask, torch.Tensor) else None

    @staticmethod
    def _is_bool(array) -> bool:
        return array.dtype == torch.bool

    @staticmethod
    def _rows(mask) -> list[int]:
        return torch.nonzero(mask).reshape(-1).tolist()

    # ------------------------------------------------------------------- reset

    def _reset_rows(self, mask: torch.Tensor, options: dict) -> tuple:
        start = self._draw_starts(options)
        self._episodes = self._episodes + mask.to(torch.int64)
        self._st = start if self._st is None else self._mux(mask, start, self._st)
        self.diverged = torch.zeros_like(self.diverged)
        est = self._estimation
        obs = None if est is not None else \
            self._stack(transition.observe(self.plant, self.task, self._st, None, self.xp))
        zeros = torch.zeros(self.num_envs, dtype=self.dtype, device=self.device)
        values = transition.info(self.plant, self.task, self._st,
                                 transition.zero_terms(self.task, zeros),
                                 torch.zeros_like(self._mask), self.xp)
        if est is not None:  # the NumPy vector env's reset of the filter, same stream
            full = est.filter is None or bool(mask.all())
            est.reset(self._st, est.seed_key(int(self._seeds[0]), int(self._episodes[0]),
                                             self.num_envs),
                      rows=None if full else torch.nonzero(mask).reshape(-1))
            obs = est.observe(self._st)
            if not full:  # the other rows keep their observation
                obs = torch.where(mask.unsqueeze(1), obs, self._last_obs)
            values = est.add_info(self._st, values)
            self._last_obs = obs
        return obs, values

    # ------------------------------------------------------------------- step

    def _physics(self, st, action):
        """The transition on the batch: (new state, obs (N, d), reward, terminated, truncated,
        terms, success, diverged). No host reads (the step that ``compile=True`` compiles)."""
        new, out = transition.step(self.plant, self.task, st, action, NO_NOISE, self.xp,
                                   own_action=True, max_steps=self._max_steps,
                                   observe_truth=self._estimation is None)
        diverged = out.diverged | torch.isnan(action).any(dim=1)
        obs = None if out.obs is None else self._stack(out.obs)  # None: the estimator's
        return (new, obs, self._tensor(out.reward), out.terminated, out.truncated, out.terms,
                out.success, diverged)

    def _advance(self, a: torch.Tensor) -> Step:
        new, obs, reward, terminated, truncated, terms, success, diverged = \
            self._step_fn(self._st, a.clone())
        self.diverged = self.diverged | diverged
        self._last, self._step_diverged = (new, a), diverged
        if self._estimation is not None:  # measure the new truth, observe the estimate
            self._estimation.step(new)
            obs = self._estimation.observe(new)
        self._steps_since_check += 1
        if self.check_every and self._steps_since_check >= self.check_every:
            self.check()
        return Step(new, obs, reward, terminated, truncated, terms, success)

    def _restart(self, rows: torch.Tensor, s: Step, *, ended_before: bool) -> None:
        s.st, s.obs, s.terms, s.success = self._restart_rows(rows, s.st, s.obs, s.terms,
                                                             s.success)
        if ended_before:  # NEXT_STEP: these rows did not step; no host read
            s.reward = torch.where(rows, 0.0, s.reward)
            s.terminated = torch.where(rows, False, s.terminated)
            s.truncated = torch.where(rows, False, s.truncated)

    @staticmethod
    def _final_due(done) -> bool:
        """Always, with no host read: the final entries are in every SAME_STEP step, masked
        (all False where no sub-env ended), on every device alike."""
        return True

    @staticmethod
    def _final_obs(done: torch.Tensor, obs: torch.Tensor) -> torch.Tensor:
        return obs  # the ending step's (N, d), valid in the rows of done; the autoreset rebinds

    def _step_info(self, s: Step) -> dict:
        values = transition.info(self.plant, self.task, s.st, s.terms, s.success, self.xp)
        values["diverged"] = self._step_diverged
        if self._estimation is not None:
            values = self._estimation.add_info(s.st, values)
        return values

    def _finish(self, s: Step) -> None:
        if self._estimation is not None:  # a partial reset keeps the other rows' observation
            self._last_obs = s.obs

    def _restart_rows(self, done, st, obs, terms, success):
        """SAME_STEP autoreset of the rows where ``done``: new episodes, their observations,
        and zero terms and success there. On a CPU (``_index_restart``; host reads are free
        there) only the ended rows are drawn, by index; elsewhere every row is drawn and the
        ended ones selected by ``torch.where``, with no host read. The same numbers either way.
        With the estimator, by index on every device (its stream's draws for the restarted
        rows depend on their count: a host read).
        """
        est = self._estimation
        if self._index_restart or est is not None:
            idx = torch.nonzero(done).reshape(-1)
            if idx.numel():
                start = self._draw_starts(idx=idx)
                self._episodes = self._episodes.index_add(0, idx, torch.ones_like(idx))
                st = self._scatter(idx, start, st)
                if est is None:
                    first = self._stack(transition.observe(self.plant, self.task, start, None,
                                                           self.xp), idx.numel())
                else:  # the rows' filters restart (the NumPy env's order of draws)
                    est.reset(st, None, rows=idx)
                    first = est.observe(st)[idx]
                obs = obs.index_copy(0, idx, first)
                terms = type(terms)(*(self._tensor(t).index_fill(0, idx, 0.0) for t in terms))
                success = success.index_fill(0, idx, False)
            return st, obs, terms, success
        if self.device.type == "cpu" and not bool(done.any()):  # a free read on a CPU
            return st, obs, terms, success
        st, obs, terms, success, self._episodes = self._restart_fn(
            done, st, obs, terms, success, self._seeds, self._episodes)
        return st, obs, terms, success

    def _restart_all(self, done, st, obs, terms, success, seeds, episodes):
        """The device path of :meth:`_restart`, a pure function (``compile=True`` compiles
        it as a second graph): every row drawn, the ended ones selected."""
        draws = TorchDraws(seeds, episodes, self.xp)
        start = self._state(transition.start(self.plant, self.task, draws), draws.n)
        st = self._mux(done, start, st)
        first = self._stack(transition.observe(self.plant, self.task, start, None, self.xp))
        obs = torch.where(done.unsqueeze(1), first, obs)
        terms = type(terms)(*(torch.where(done, 0.0, self._tensor(t)) for t in terms))
        return st, obs, terms, success & ~done, episodes + done.to(torch.int64)

    def _actions(self, actions) -> torch.Tensor:
        """The action batch as a tensor of the env's dtype on its device; a named error for
        anything else (the shape and the type are checked, values are clipped by the plant).
        A NumPy array (``action_space.sample()``) or a list is copied to the device: a host
        transfer per step, which a tensor already on the device avoids."""
        shape = self.action_space.shape
        if not isinstance(actions, torch.Tensor):  # the NumPy env's checks, then the copy
            actions = torch.as_tensor(action_array(actions, shape, name="actions"))
        if tuple(actions.shape) != shape:
            raise InvalidParameterError(f"actions must have shape {shape}, got "
                                        f"{tuple(actions.shape)}")
        if not (actions.dtype.is_floating_point or actions.dtype in (torch.int32,
                                                                     torch.int64)):
            raise TypeError(f"actions must be real numbers of shape {shape}, got dtype "
                            f"{actions.dtype}")
        return actions.detach().to(device=self.device, dtype=self.dtype)

    def check(self) -> None:
        """A sync point: raise the NumPy env's error if some sub-env has diverged since the
        last reset (one host read of the sticky flag)."""
        self._steps_since_check = 0
        if self._st is None or not bool(self.diverged.any()):
            return
        i = int(torch.nonzero(self.diverged)[0, 0])
        st, a = getattr(self, "_last", (self._st, None))
        comps = tuple(float(c[i]) for c in st.q), tuple(float(c[i]) for c in st.omega_B)
        if a is not None and bool(torch.isnan(a[i]).any()):
            transition.raise_diverged(self.plant, st, a.cpu().numpy())
        raise self.plant.divergence_error(*comps)

    def render(self):
        return None

    def close_extras(self, **kwargs):
        self._step_fn = None


class TorchEnv(gym.Env):
    """One satellite on the torch backend, NumPy at its boundary: ``gym.make(ID,
    backend="torch", device=..., dtype=...)``.

    It is the torch vector env at ``num_envs=1`` (autoreset DISABLED) seen as a
    ``gymnasium.Env``, so Gymnasium's and SB3's env checkers, and every single-env tool, run the
    torch transition. ``step`` takes an action of ``action_space`` (a NumPy array, or a tensor)
    and returns an observation of ``observation_space`` (a NumPy array in the env's dtype), a
    float reward, bool flags and ``info`` of Python scalars, keyed as the NumPy env's (plus
    ``diverged``). ``reset(seed=s)`` gives the episode of the NumPy env's ``reset(seed=s)``, on
    CPU in float64 equal to round-off for the same actions. A step after the episode ended
    raises ``ResetNeeded``. Options: the torch vector env's. For speed, use the vector form:
    one satellite per torch call is slow.
    """

    metadata: ClassVar[dict] = {"render_modes": []}

    def __init__(self, scene=None, **options):
        """Options: :data:`rbenv.envs.options.OPTIONS_OF` ``["torch_single"]``."""
        o = take(type(self).__name__, "torch_single", {"scene": scene, **options})
        self.env = TorchVectorEnv(1, autoreset_mode=AutoresetMode.DISABLED, **o)
        if self.env._estimation is not None:  # the estimator's stream seeded as the single env's
            self.env._estimation.single_key = True
        # float32 actions, as the NumPy env's (what SB3 and the checkers expect of a
        # gymnasium.Env); the vector env's spaces are in its dtype.
        self.action_space = gym.spaces.Box(-1.0, 1.0, self.env.single_action_space.shape,
                                           np.float32)
        self.observation_space = self.env.single_observation_space
        self.metadata = {**type(self).metadata, "render_fps": self.env.metadata["render_fps"]}
        self.render_mode = None

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        obs, info = self.env.reset(seed=seed, options=options)
        return self._obs(obs), self._info(info)

    def step(self, action):
        shape = self.action_space.shape
        if not isinstance(action, torch.Tensor):  # NumPy arrays, lists: the NumPy env's checks
            a = torch.as_tensor(action_array(action, shape))
        elif tuple(action.shape) == shape:
            a = action
        else:
            raise InvalidParameterError(f"action must have shape {shape}, got "
                                        f"{tuple(action.shape)}")
        obs, reward, terminated, truncated, info = self.env.step(a.unsqueeze(0))
        return (self._obs(obs), float(reward[0]), bool(terminated[0]), bool(truncated[0]),
                self._info(info))

    def _obs(self, obs: torch.Tensor) -> np.ndarray:
        return obs[0].cpu().numpy().astype(self.observation_space.dtype, copy=False)

    @staticmethod
    def _info(info: dict) -> dict:
        """Python scalars, and NumPy arrays for the estimator's vectors and covariance."""
        out = {}
        for key, value in info.items():
            if not key.startswith("_"):
                row = value[0]
                out[key] = row.item() if row.ndim == 0 else row.cpu().numpy()
        return out

    def close(self):
        self.env.close()
