"""The torch-native vector env (rbenv.envs.torch_env) against the NumPy vector env, on CPU.

Same seeds, same actions, SAME_STEP autoreset on both: every observation, reward, flag, info
value, final observation and state field agrees within 1e-12, for every task, scene and action
mode the torch backend supports, across autoresets (episodes are cut to a few steps); and in
NEXT_STEP, the default of both, for every task on the default scene. Scenes
with per-step noise run as a variant with those per-step draws zeroed (as
test_gymnasium_contract does); implicit integrators are replaced by RK4. What the backend does
not support is refused by name (checked below). CUDA: skipped here, and said so.
"""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode, VectorEnv
from rbenv.core.errors import InvalidParameterError, NonFiniteError

import rbenv

torch = pytest.importorskip("torch", reason="torch is not installed (train extra)")

N = 6
EPISODE = 7  # steps: a short rollout crosses several autoresets
STEPS = 24
QUIET = """base = "{scene}"
[disturbance]
noise_sigma = 0.0
[faults]
p_step = 0.0
[sensor_noise]
model = "none"
attitude = 0.0
rate = 0.0
[sensors]
attitude = "true"
gyro_bias_sigma_dps = 0.0
gyro_bias_walk_dps_sqrt_s = 0.0
gyro_noise_dps = 0.0
delay_steps = 0
"""
UNSUPPORTED_TASKS = ("rbenv/SatelliteDesaturate-v0", "rbenv/SatelliteDesaturate-v1")
CASES = [(env_id, scene, mode)
         for env_id in sorted(rbenv.ENV_IDS) if env_id not in UNSUPPORTED_TASKS
         for scene in rbenv.list_scenes() for mode in ("throttle", "on_off")
         if rbenv.envs.registry.get(env_id).runs_on(scene)
         and (mode != "on_off" or not rbenv.load_scene(scene).actuators)]  # thrusters alone


@pytest.fixture(scope="module")
def scene_path(tmp_path_factory):
    """A scene name, or for a noisy scene the path of its variant without per-step noise."""
    folder = tmp_path_factory.mktemp("scenes")

    def path(scene: str):
        if not gym.make(rbenv.ENV_ID, scene=scene).unwrapped.plant.noisy:
            return scene
        file = folder / f"{scene}-quiet.toml"
        file.write_text(QUIET.format(scene=scene))
        return str(file)

    return path


def _kwargs(scene, mode, scene_path, autoreset=AutoresetMode.SAME_STEP) -> dict:
    kwargs = {"scene": scene_path(scene), "action_mode": mode, "max_episode_steps": EPISODE,
              "autoreset_mode": autoreset}
    if rbenv.load_scene(scene).physics.integrator in ("midpoint", "splitting"):
        kwargs["integrator"] = "rk4"
    if rbenv.load_scene(scene).randomization is not None:
        kwargs["randomize"] = False
    return kwargs


def _close(t, n, what, atol=1e-12):
    assert isinstance(t, torch.Tensor), f"{what}: not a tensor"
    np.testing.assert_allclose(t.numpy().astype(float), np.asarray(n, dtype=float), rtol=0,
                               atol=atol, err_msg=what)


NEXT_STEP_CASES = [(env_id, "cubesat-12u", "throttle", AutoresetMode.NEXT_STEP)
                   for env_id in sorted(rbenv.ENV_IDS) if env_id not in UNSUPPORTED_TASKS]


@pytest.mark.slow
@pytest.mark.parametrize("restart", ["index", "mask"])
@pytest.mark.parametrize(("env_id", "scene", "mode", "autoreset"),
                         [(*case, AutoresetMode.SAME_STEP) for case in CASES] + NEXT_STEP_CASES)
def test_torch_episodes_equal_the_numpy_episodes(env_id, scene, mode, autoreset, restart,
                                                 scene_path):
    """restart: the CPU's autoreset by index, or the device path (all rows drawn, masked)."""
    kwargs = _kwargs(scene, mode, scene_path, autoreset)
    ne = gym.make_vec(env_id, num_envs=N, **kwargs)
    te = gym.make_vec(env_id, num_envs=N, backend="torch", **kwargs)
    te.unwrapped._index_restart = restart == "index"
    assert isinstance(te, VectorEnv) and te.unwrapped.device.type == "cpu"
    obs_n, info_n = ne.reset(seed=11)
    obs_t, info_t = te.reset(seed=11)
    _close(obs_t.float(), obs_n, "reset obs")
    rng = np.random.default_rng(3)
    ended = 0
    for i in range(STEPS):
        action = rng.uniform(-1.5, 1.5, ne.action_space.shape)
        action[i % N] = 1.0  # full thrust on one sub-env: some episodes fail early
        obs_n, r_n, term_n, trunc_n, info_n = ne.step(action)
        obs_t, r_t, term_t, trunc_t, info_t = te.step(torch.as_tensor(action))
        where = f"step {i}"
        _close(obs_t.float(), obs_n, f"{where} obs")
        _close(r_t, r_n, f"{where} reward")
        assert term_t.tolist() == term_n.tolist(), where
        assert trunc_t.tolist() == trunc_n.tolist(), where
        done = term_n | trunc_n
        ended += int(done.sum())
        if autoreset is AutoresetMode.SAME_STEP:
            assert info_t["_final_obs"].tolist() == done.tolist(), where
            for j in np.flatnonzero(done):
                _close(info_t["final_obs"][j].float(), info_n["final_obs"][j],
                       f"{where} final")
        for key, value in info_n.items():
            if not key.startswith("_") and not key.startswith("final"):
                _close(info_t[key], value, f"{where} info[{key!r}]")
        for name, value in vars(ne.unwrapped._st).items():
            if value is not None and name != "model":
                got = getattr(te.unwrapped._st, name)
                pairs = zip(got, value, strict=True) if isinstance(value, tuple) \
                    else [(got, value)]
                for a, b in pairs:
                    _close(a, b, f"{where} state {name}")
    assert ended >= N, f"only {ended} episodes ended: the test would not cross autoresets"


def test_float32_runs_and_stays_close_to_float64():
    """float32 is an option: same episode starts (the draws are float64, then cast), and
    after 30 steps the observations stay within 1e-4 of float64's (measured: docs/torch.md)."""
    envs = [gym.make_vec(rbenv.ENV_ID, num_envs=8, backend="torch", dtype=d)
            for d in ("float64", "float32")]
    obs = [e.reset(seed=1)[0] for e in envs]
    assert obs[1].dtype == torch.float32
    action = torch.rand(envs[0].action_space.shape, generator=torch.Generator().manual_seed(0),
                        dtype=torch.float64)
    for _ in range(30):
        obs = [e.step(action.clone())[0] for e in envs]
    gap = (obs[0] - obs[1].double()).abs().max().item()
    assert 0.0 < gap < 1e-4, gap


@pytest.mark.parametrize(("option", "value", "named"), [
    ("integrator", "midpoint", "integrator='midpoint'"),
    ("action_mode", "torque", "action_mode='torque'"),
    ("randomize", {"inertia_scale": 0.2}, "randomize={'inertia_scale': 0.2}"),
    ("scene", "microsat-100kg", "scene='microsat-100kg'"),
    ("render_mode", "rgb_array", "render_mode='rgb_array'"),
    ("dtype", "float16", "dtype must be one of ['float32', 'float64'] (or the torch dtype), "
                         "got 'float16'"),
    ("device", "cuda:7" if not torch.cuda.is_available() else "nope",
     "device must be a torch device available here"),
    ("backend", "jax", "backend must be 'numpy' or 'torch', got 'jax'")])
def test_what_is_not_supported_is_refused_by_name(option, value, named):
    kwargs = {"backend": "torch", option: value}
    if option == "scene":
        kwargs["integrator"] = "rk4"
    with pytest.raises(InvalidParameterError) as err:
        gym.make_vec(rbenv.ENV_ID, num_envs=2, **kwargs)
    assert named in str(err.value)


@pytest.mark.parametrize("env_id", UNSUPPORTED_TASKS)
def test_the_desaturate_task_is_refused_by_name(env_id):
    with pytest.raises(InvalidParameterError, match="task='desaturate"):
        gym.make_vec(env_id, num_envs=2, backend="torch")


def test_bad_actions_raise_named_errors():
    env = gym.make_vec(rbenv.ENV_ID, num_envs=3, backend="torch")
    env.reset(seed=0)
    with pytest.raises(TypeError, match="actions must be real numbers"):
        env.step(np.full(env.action_space.shape, "a"))
    with pytest.raises(InvalidParameterError, match=r"actions must have shape \(3, 12\)"):
        env.step(np.zeros((3, 11)))
    with pytest.raises(InvalidParameterError, match=r"shape \(3, 12\), got \(3, 11\)"):
        env.step(torch.zeros(3, 11))


@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_the_random_action_loop_runs_on_the_envs_own_samples(dtype):
    """``action_space.sample()`` (NumPy, in the env's dtype, like the observations) is a valid
    action: it is copied to the device and gives the tensor action's step exactly."""
    envs = [gym.make_vec(rbenv.ENV_ID, num_envs=3, backend="torch", dtype=dtype)
            for _ in range(2)]
    np_dtype = np.dtype(dtype)
    for env in envs:
        assert env.action_space.dtype == env.observation_space.dtype == np_dtype
        assert env.single_action_space.dtype == np_dtype
        env.reset(seed=5)
    env.action_space.seed(0)
    for _ in range(4):
        a = envs[0].action_space.sample()
        assert a.dtype == np_dtype and envs[0].action_space.contains(a)
        obs, reward, *_ = envs[0].step(a)
        want, want_reward, *_ = envs[1].step(torch.from_numpy(a))
        assert obs.dtype == getattr(torch, dtype)
        assert torch.equal(obs, want) and torch.equal(reward, want_reward)


def test_nan_action_raises_at_the_step_and_is_flagged_when_deferred():
    a = torch.zeros(3, 12, dtype=torch.float64)
    a[1, 4] = float("nan")
    env = gym.make_vec(rbenv.ENV_ID, num_envs=3, backend="torch")
    env.reset(seed=0)
    with pytest.raises(InvalidParameterError, match="NaN"):
        env.step(a.clone())
    lazy = gym.make_vec(rbenv.ENV_ID, num_envs=3, backend="torch", check_every=0)
    lazy.reset(seed=0)
    info = lazy.step(a.clone())[4]  # no host read: the flag is a tensor
    assert info["diverged"].tolist() == [False, True, False]
    assert lazy.unwrapped.diverged.tolist() == [False, True, False]
    with pytest.raises(InvalidParameterError, match="NaN"):
        lazy.unwrapped.check()


def test_divergence_raises_the_numpy_error():
    env = gym.make_vec(rbenv.DETUMBLE_ID, num_envs=2, backend="torch", check_every=0)
    env.reset(seed=0, options={"omega_B": np.array([[1e6, 0, 0], [0, 0, 0.1]])})
    env.unwrapped._st.omega_B = tuple(c * 1e300 for c in env.unwrapped._st.omega_B)
    env.step(torch.zeros(env.action_space.shape, dtype=torch.float64))
    assert env.unwrapped.diverged[0]
    with pytest.raises(NonFiniteError):
        env.reset(seed=1)  # a sync point


def test_disabled_mode_resets_by_tensor_mask():
    kw = {"backend": "torch", "autoreset_mode": "Disabled", "max_episode_steps": 2}
    env = gym.make_vec(rbenv.ENV_ID, num_envs=3, **kw)
    first, _ = env.reset(seed=4)
    a = torch.zeros(env.action_space.shape, dtype=torch.float64)
    env.step(a)
    _, _, _, trunc, _ = env.step(a)
    assert trunc.all()
    with pytest.raises(gym.error.ResetNeeded):
        env.step(a)
    mask = torch.tensor([True, False, True])
    obs, _ = env.reset(options={"reset_mask": mask})
    # Sub-env 0 starts its second episode: another start than its first.
    assert not torch.equal(obs[0], first[0])
    with pytest.raises(TypeError, match=r"torch bool tensor or a NumPy bool array.*list"):
        env.reset(options={"reset_mask": [True, True, True]})
    with pytest.raises(TypeError, match=r"NumPy bool array.*int64"):
        env.reset(options={"reset_mask": np.ones(3, dtype=np.int64)})


def test_numpy_reset_mask_resets_as_the_tensor_mask():
    """Gymnasium users pass a NumPy mask (issue 44, item 5): it resets the same rows, to the
    same starts, as the equal torch mask, and is refused by name when all False."""
    kw = {"backend": "torch", "autoreset_mode": "Disabled", "max_episode_steps": 2}
    outs = []
    for mask in (torch.tensor([True, False, True]), np.array([True, False, True])):
        env = gym.make_vec(rbenv.ENV_ID, num_envs=3, **kw)
        env.reset(seed=4)
        a = np.zeros(env.action_space.shape)
        env.step(a)
        stepped, *_ = env.step(a)
        obs, _ = env.reset(options={"reset_mask": mask})
        assert torch.equal(obs[1], stepped[1])  # the row left out keeps its state
        assert not torch.equal(obs[0], stepped[0])
        outs.append(obs)
    assert torch.equal(outs[0], outs[1])
    with pytest.raises(ValueError, match="at least one True"):
        env.reset(options={"reset_mask": np.zeros(3, dtype=bool)})
    first = gym.make_vec(rbenv.ENV_ID, num_envs=3, **kw)
    with pytest.raises(gym.error.ResetNeeded, match="first reset"):
        first.reset(seed=0, options={"reset_mask": np.array([True, False, True])})
    obs, _ = first.reset(seed=4, options={"reset_mask": np.ones(3, dtype=bool)})
    env = gym.make_vec(rbenv.ENV_ID, num_envs=3, **kw)
    assert torch.equal(obs, env.reset(seed=4)[0])


@pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device on this machine")
def test_cuda_episodes_are_reproducible():  # pragma: no cover (needs a GPU)
    outs = []
    for _ in range(2):
        env = gym.make_vec(rbenv.ENV_ID, num_envs=64, backend="torch", device="cuda")
        obs, _ = env.reset(seed=3)
        a = torch.full(env.action_space.shape, 0.3, dtype=torch.float64, device="cuda")
        for _ in range(20):
            obs = env.step(a.clone())[0]
        outs.append(obs.cpu())
    assert torch.equal(outs[0], outs[1])


@pytest.mark.slow
def test_compiled_step_is_one_graph_and_matches_eager():
    """compile=True: one graph for the step and one for the autoreset, across steps and
    autoresets (no recompilation, no graph break: fullgraph=True would raise and fall back
    with a warning), results as eager's."""
    kw = {"backend": "torch", "max_episode_steps": 3, "num_envs": 4}
    envs = [gym.make_vec(rbenv.DETUMBLE_ID, compile=c, **kw) for c in (True, False)]
    for e in envs:
        e.reset(seed=2)
    a = torch.linspace(-1, 1, 4 * 12, dtype=torch.float64).reshape(4, 12)
    for _ in range(7):  # two autoresets
        outs = [e.step(a.clone()) for e in envs]
        np.testing.assert_allclose(outs[0][0].numpy(), outs[1][0].numpy(), rtol=0, atol=1e-12)
        assert outs[0][3].tolist() == outs[1][3].tolist()
    for fn in (envs[0].unwrapped._step_fn, envs[0].unwrapped._restart_fn):
        assert fn.fallback is None, fn.fallback
        assert fn.compiles == 1  # the step and the autoreset: one graph each


def test_compile_falls_back_to_eager_with_a_warning(monkeypatch):
    from rbenv.envs import torch_compile

    env = gym.make_vec(rbenv.ENV_ID, num_envs=2, backend="torch", compile=True)
    env.reset(seed=0)
    step = env.unwrapped._step_fn

    def unavailable(*args):
        raise RuntimeError("no compiler on this platform")

    monkeypatch.setattr(step, "compiled", unavailable)
    with pytest.warns(RuntimeWarning, match="fell back to eager torch: RuntimeError: no comp"):
        obs = env.step(torch.zeros(2, 12, dtype=torch.float64))[0]
    assert step.fallback is not None and obs.shape == (2, env.single_observation_space.shape[0])
    assert torch_compile.CompiledStep  # the class the env uses


# --- the single form: gym.make(ID, backend="torch") ---------------------------------------------

SINGLE_CASES = sorted({(env_id, scene) for env_id, scene, _ in CASES})


def _single_kwargs(scene, scene_path) -> dict:
    kwargs = _kwargs(scene, "throttle", scene_path)
    for name in ("max_episode_steps", "autoreset_mode", "action_mode"):
        kwargs.pop(name)
    return kwargs


@pytest.mark.slow
@pytest.mark.parametrize(("env_id", "scene"), SINGLE_CASES)
def test_the_torch_env_passes_gymnasiums_and_sb3s_checkers(env_id, scene, scene_path):
    """Both checkers on the torch backend's single form, warnings as errors."""
    from gymnasium.utils.env_checker import check_env

    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker",
                                      reason="SB3's checker needs the train extra")
    kwargs = _single_kwargs(scene, scene_path)
    with gym.make(env_id, backend="torch", **kwargs) as env:
        assert type(env.unwrapped).__module__ == "rbenv.envs.torch_env"
        with warnings.catch_warnings():
            warnings.simplefilter("error", UserWarning)
            check_env(env.unwrapped, skip_render_check=True)
            sb3_checker.check_env(env.unwrapped)


@pytest.mark.slow
@pytest.mark.parametrize(("env_id", "scene"), SINGLE_CASES)
def test_the_torch_single_env_equals_the_numpy_single_env(env_id, scene, scene_path):
    """Same seed, same actions, a whole episode: rewards, flags and info to 1e-12, and the
    observation to the NumPy env's float32 rounding."""
    kwargs = _single_kwargs(scene, scene_path)
    env = gym.make(env_id, backend="torch", **kwargs).unwrapped
    ref = gym.make(env_id, **kwargs).unwrapped
    rng = np.random.default_rng(7)
    obs, info = env.reset(seed=11)
    want, want_info = ref.reset(seed=11)
    assert obs.dtype == np.float64 and env.observation_space.contains(obs)
    np.testing.assert_allclose(obs, want, rtol=0, atol=1e-7)
    assert set(info) - {"diverged"} == set(want_info)
    for _ in range(ref.plant.scene.episode_steps):
        a = rng.uniform(-1, 1, ref.action_space.shape).astype(ref.action_space.dtype)
        obs, reward, term, trunc, info = env.step(a)
        want, want_reward, want_term, want_trunc, want_info = ref.step(a)
        np.testing.assert_allclose(obs, want, rtol=0, atol=1e-7)
        assert abs(reward - want_reward) <= 1e-12 and (term, trunc) == (want_term, want_trunc)
        for key, value in want_info.items():
            assert abs(float(info[key]) - float(value)) <= 1e-12 * max(1.0, abs(value)), key
        if term or trunc:
            break
    with pytest.raises(gym.error.ResetNeeded):
        env.step(a)


def test_the_torch_single_env_refuses_batch_options_and_bad_actions_by_name():
    with pytest.raises(TypeError, match=r"num_envs.*make_vec"):
        gym.make(rbenv.ENV_ID, backend="torch", num_envs=4)
    with pytest.raises(InvalidParameterError, match="backend must be 'numpy' or 'torch'"):
        gym.make(rbenv.ENV_ID, backend="jax")
    env = gym.make(rbenv.ENV_ID, backend="torch").unwrapped
    env.reset(seed=0)
    with pytest.raises(InvalidParameterError, match=r"action.*shape \(12,\)"):
        env.step(np.zeros(3, np.float32))
    with pytest.raises(InvalidParameterError, match=r"action.*shape \(12,\)"):
        env.step(torch.zeros(3))
