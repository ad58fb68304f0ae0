"""The step on torch tensors (CPU, float64) equals the NumPy step: the same kernels, plant,
actuators and tasks through the torch namespace (:mod:`rbenv.core.torch_backend`), no formula
restated. Issue 20's first item; its vector env, compilation and training are not built yet.

Out of reach today (named, not faked): the torque mode's allocators, the implicit integrators,
episode starts (rbenv.satellite.draws), and domain randomization's per-episode model (NumPy arrays).
CUDA: skipped here (no GPU on this machine) and said so.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from rbenv.core.backend import NUMPY, namespace

import rbenv
from rbenv.envs import transition
from rbenv.satellite.plant import StepNoise

torch = pytest.importorskip("torch", reason="torch is not installed (train extra)")
from rbenv.core.torch_backend import TORCH  # noqa: E402

IMPLICIT = ("midpoint", "splitting")


def _to_torch(value):
    if isinstance(value, tuple):
        return tuple(_to_torch(v) for v in value)
    if isinstance(value, np.ndarray):
        return torch.as_tensor(value.copy())
    return value


def _to_numpy(value):
    if isinstance(value, tuple):
        return tuple(_to_numpy(v) for v in value)
    if isinstance(value, torch.Tensor):
        return value.numpy()
    return value


def _leaves(value):
    if isinstance(value, dict):
        for v in value.values():
            yield from _leaves(v)
    elif isinstance(value, tuple):
        for v in value:
            yield from _leaves(v)
    elif isinstance(value, (np.ndarray, torch.Tensor)):
        yield value


def _close(a, b, where):
    a, b = list(_leaves(a)), list(_leaves(b))
    assert len(a) == len(b), where
    for x, y in zip(a, b, strict=True):
        assert isinstance(x, torch.Tensor), f"{where}: a NumPy array came back"
        np.testing.assert_allclose(x.numpy().astype(float), np.asarray(y, dtype=float),
                                   rtol=0, atol=1e-12, err_msg=where)


CASES = [(env_id, scene, mode)
         for env_id in rbenv.ENV_IDS for scene in rbenv.list_scenes()
         for mode in ("throttle", "on_off")
         if rbenv.envs.registry.get(env_id).runs_on(scene)
         and (mode != "on_off" or not rbenv.load_scene(scene).actuators)]  # on/off: thrusters


def test_torch_tensors_dispatch_to_the_torch_namespace():
    assert namespace(torch.zeros(3, dtype=torch.float64)) is TORCH
    assert namespace(np.zeros(3)) is NUMPY


@pytest.mark.slow
@pytest.mark.parametrize(("env_id", "scene", "mode"), CASES)
def test_the_step_on_torch_equals_the_numpy_step(env_id, scene, mode):
    kwargs = {"scene": scene, "action_mode": mode}
    if rbenv.load_scene(scene).physics.integrator in IMPLICIT:
        kwargs["integrator"] = "rk4"
    if scene == "cubesat-12u-dr":  # the episode model of domain randomization is NumPy's
        kwargs["randomize"] = False
    env = gym.make_vec(env_id, num_envs=5, **kwargs).unwrapped
    env.reset(seed=2)
    plant, task = env.plant, env.task
    st_n = env._st
    st_t = st_n.copy()
    for name, value in vars(st_n).items():
        if name != "model":
            setattr(st_t, name, _to_torch(value))
    rng = np.random.default_rng(0)
    for i in range(20):
        action = rng.uniform(-1.2, 1.2, env.action_space.shape)
        noise = plant.draw_step_noise(np.random.default_rng(i), 5)
        new_n, out_n = transition.step(plant, task, st_n, action.copy(), noise, NUMPY)
        noise_t = StepNoise(*(None if c is None else _to_torch(c) for c in noise))
        new_t, out_t = transition.step(plant, task, st_t, torch.as_tensor(action), noise_t,
                                       TORCH, own_action=True)
        assert not np.any(out_n.diverged)
        _close(out_t.obs, out_n.obs, "obs")
        _close(out_t.reward, out_n.reward, "reward")
        _close(out_t.info, out_n.info, "info")
        for name in vars(new_n):
            if name != "model":
                _close(getattr(new_t, name), getattr(new_n, name), name)
        st_n, st_t = new_n, new_t


@pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device on this machine")
def test_the_namespace_keeps_tensors_on_their_device():  # pragma: no cover (needs a GPU)
    from rbenv.core.torch_backend import TorchNamespace

    gpu = TorchNamespace(device="cuda")
    x = torch.ones(4, dtype=torch.float64, device="cuda")
    assert gpu.clamp(x, np.zeros(4), np.ones(4)).device.type == "cuda"
