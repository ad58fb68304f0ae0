"""The step runs through the array namespace alone: a third backend, used only here.

``StrictArray`` is a NumPy array that refuses every direct ``np.`` call: any ufunc that is not
a Python operator (``+``, ``*``, ``<``, ``&``, ``@``, ...) and every NumPy function called on it
raise :class:`DirectNumpyCall`, unless the strict namespace itself makes the call. ``STRICT``
has the names of :class:`rbenv.core.backend.NumpyNamespace`, each unwrapping, calling NumPy and
wrapping the result. ``transition.step`` (actuation, physics, target motion, evaluation,
observation and info) then runs on strict arrays for every task and scene, and must give the
NumPy backend's numbers bit for bit. An array that comes back plain was made by a direct
NumPy call, and fails the test too.

Out of its reach, and named: the torque mode's allocators (NumPy and SciPy on the host), the
implicit integrators (``midpoint``'s Newton and ``splitting``'s frame cache decide per batch
in NumPy), episode starts (:mod:`rbenv.satellite.draws` hashes uint64 counters in NumPy) and the
randomized inertia of domain randomization (``BatchBody`` multiplies (N, 3, 3) matrices).
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from rbenv.core import backend
from rbenv.core.backend import NUMPY

import rbenv
from rbenv.envs import transition
from rbenv.satellite.plant import StepNoise

OPERATORS = {np.add, np.subtract, np.multiply, np.true_divide, np.negative, np.positive,
             np.less, np.less_equal, np.greater, np.greater_equal, np.equal, np.not_equal,
             np.bitwise_and, np.bitwise_or, np.invert, np.matmul, np.power, np.absolute}


class DirectNumpyCall(AssertionError):
    """A NumPy function or non-operator ufunc was called on a strict array."""


class StrictArray(np.ndarray):
    """An ndarray on which only Python operators work directly."""

    def __array_ufunc__(self, ufunc, method, *inputs, **kwargs):
        if not _Guard.inside and not (method == "__call__" and ufunc in OPERATORS):
            raise DirectNumpyCall(f"direct NumPy call {ufunc.__name__}.{method} on a strict "
                                  "array: route it through the namespace")
        args = [_plain(x) for x in inputs]
        if "out" in kwargs:
            kwargs["out"] = tuple(_plain(x) for x in kwargs["out"])
        return _wrap(getattr(ufunc, method)(*args, **kwargs))

    def __array_function__(self, func, types, args, kwargs):
        if not _Guard.inside:
            raise DirectNumpyCall(f"direct NumPy call np.{func.__name__} on a strict array")
        return _wrap(func(*[_plain(a) for a in args], **kwargs))


class _Guard:
    inside = 0

    def __enter__(self):
        _Guard.inside += 1

    def __exit__(self, *exc):
        _Guard.inside -= 1


def _plain(x):
    return x.view(np.ndarray) if isinstance(x, StrictArray) else x


def _wrap(x):
    if isinstance(x, tuple):
        return tuple(_wrap(c) for c in x)
    return x.view(StrictArray) if type(x) is np.ndarray else x


def _strict(fn):
    def call(*args, **kwargs):
        with _Guard():
            return _wrap(fn(*[_plain(a) for a in args],
                            **{k: _plain(v) for k, v in kwargs.items()}))
    return staticmethod(call)


class StrictNamespace:
    """:class:`rbenv.core.backend.NumpyNamespace`'s names over strict arrays."""

    name = "strict"


for _name in [n for n in dir(backend.NumpyNamespace) if not n.startswith("_") and n != "name"]:
    setattr(StrictNamespace, _name, _strict(getattr(backend.NUMPY, _name)))


def _clamp_into(x, low, high):  # in place on the plain view: x stays the caller's strict array
    with _Guard():
        np.maximum(_plain(x), low, out=_plain(x))
        np.minimum(_plain(x), high, out=_plain(x))
    return x


StrictNamespace.clamp_into = staticmethod(_clamp_into)
STRICT = StrictNamespace()


@pytest.fixture(autouse=True)
def _registered():
    backend.register(StrictArray, STRICT)
    yield
    backend._BY_TYPE.pop(StrictArray, None)


def _to_strict(value):
    if isinstance(value, tuple):
        return tuple(_to_strict(v) for v in value)
    if isinstance(value, np.ndarray):
        return value.copy().view(StrictArray)
    return value


def _state(st, convert):
    new = st.copy()
    for name, value in vars(st).items():
        if name != "model":
            setattr(new, name, convert(value))
    return new


def _noise(plant, rng, n, convert):
    noise = plant.draw_step_noise(rng, n)
    return StepNoise(*(None if c is None else convert(c) for c in noise))


def _leaves(value):
    if isinstance(value, dict):
        for v in value.values():
            yield from _leaves(v)
    elif isinstance(value, tuple):
        for v in value:
            yield from _leaves(v)
    elif isinstance(value, np.ndarray):
        yield value


def _same(a, b):
    a, b = list(_leaves(a)), list(_leaves(b))
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(_plain(x), y)


IMPLICIT = ("midpoint", "splitting")
CASES = [(env_id, scene, mode, integ)
         for env_id in rbenv.ENV_IDS for scene in rbenv.list_scenes()
         for mode, integ in (("throttle", None), ("on_off", None), ("throttle", "euler"),
                             ("throttle", "semi_implicit"), ("throttle", "euler_seed"))
         if (mode != "on_off" or (rbenv.load_scene(scene).thrusters is not None  # wheels
                                  and "wheels" not in rbenv.load_scene(scene).actuators))
         and rbenv.envs.registry.get(env_id).runs_on(scene)]


# The explicit integrators blow up on some scenes under these actions, on purpose: both
# backends must flag the same divergence, and NumPy reports the overflow on the way.
@pytest.mark.slow
@pytest.mark.filterwarnings("ignore:(overflow|invalid value) encountered:RuntimeWarning")
@pytest.mark.parametrize(("env_id", "scene", "mode", "integrator"), CASES)
def test_the_step_runs_under_a_strict_namespace_bit_for_bit(env_id, scene, mode, integrator):
    if integrator is None and rbenv.load_scene(scene).physics.integrator in IMPLICIT:
        integrator = "rk4"  # the scene's own integrator is out of reach (module docstring)
    kwargs = {"scene": scene, "action_mode": mode, "integrator": integrator}
    if scene == "cubesat-12u-dr":  # randomized inertia is out of reach: everything else stays
        kwargs["randomize"] = {"inertia_scale": 0.0, "inertia_rotation_deg": 0.0}
    env = gym.make_vec(env_id, num_envs=6, **kwargs).unwrapped
    env.reset(seed=5)
    plant, task = env.plant, env.task
    rng = np.random.default_rng(0)
    st_n, st_s = env._st, _state(env._st, _to_strict)
    for i in range(25):
        action = rng.uniform(-1.2, 1.2, env.action_space.shape)
        noise_rng = np.random.default_rng(i)
        new_n, out_n = transition.step(plant, task, st_n, action.copy(),
                                       _noise(plant, noise_rng, 6, lambda c: c), NUMPY)
        noise_rng = np.random.default_rng(i)
        new_s, out_s = transition.step(plant, task, st_s, _to_strict(action),
                                       _noise(plant, noise_rng, 6, _to_strict), STRICT,
                                       own_action=True)
        np.testing.assert_array_equal(_plain(out_s.diverged), out_n.diverged)
        if np.any(out_n.diverged):  # an explicit integrator blew up: both backends flag it
            break
        plain = [name for name, v in vars(new_s).items()
                 if name != "model" and any(type(x) is np.ndarray for x in _leaves(v))]
        assert not plain, f"fields made by a direct NumPy call: {plain}"
        assert not [k for k, v in out_s.info.items() if type(v) is np.ndarray], out_s.info
        _same(out_s.obs, out_n.obs)
        _same(out_s.reward, out_n.reward)
        _same(out_s.info, out_n.info)
        for name in vars(new_n):
            if name != "model":
                _same(getattr(new_s, name), getattr(new_n, name))
        st_n, st_s = new_n, new_s


def test_a_direct_numpy_call_on_a_strict_array_is_caught():
    a = np.ones(3).view(StrictArray)
    assert type(a + a) is StrictArray  # operators work
    with pytest.raises(DirectNumpyCall):
        np.sqrt(a)
    with pytest.raises(DirectNumpyCall):
        np.where(a > 0, a, a)
    with pytest.raises(DirectNumpyCall):
        a.sum()
    assert type(STRICT.sqrt(a)) is StrictArray
