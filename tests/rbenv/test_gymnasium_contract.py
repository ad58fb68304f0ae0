"""Gymnasium's own generic env and vector-env tests, ported to every rbenv id and scene.

Source: Farama-Foundation/Gymnasium at v1.4.0 (the version CI installs), files
``tests/envs/test_envs.py``, ``tests/envs/test_action_dim_check.py``,
``tests/vector/test_vector_env.py``, ``tests/vector/test_autoreset_mode.py``,
``tests/vector/test_vector_env_info.py``, ``tests/vector/test_sync_vector_env.py`` and the
checks of ``SyncVectorEnv.reset``/``step``. Each test names the test it ports. Where Gymnasium
runs a test on CartPole or a ``GenericTestEnv``, it runs here on every id in
``rbenv.ENV_IDS`` x every scene in ``rbenv.list_scenes()`` (x every autoreset mode for the
vector tests); the reference is Gymnasium's ``SyncVectorEnv`` over the same single envs,
compared with ``data_equivalence`` as Gymnasium compares ``AsyncVectorEnv`` with it.

Scenes with per-step noise (sensor noise, disturbance noise, mid-episode faults) draw it for
the whole batch from the vector env's own generator (documented in
:class:`rbenv.envs.vector_env.AttitudeVectorEnv`), so a native/sync comparison on them runs on the
scene with those per-step draws set to zero; everything drawn per episode stays on.
"""

from __future__ import annotations

import pickle
import re
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env, data_equivalence
from gymnasium.vector import AutoresetMode, SyncVectorEnv

import rbenv

IDS = sorted(rbenv.ENV_IDS)
SCENES = rbenv.list_scenes()
# Every id on every scene it runs on (desaturation needs wheels: rbenv.tasks.spec.TaskSpec.needs).
PAIRS = [(i, s) for i in IDS for s in SCENES if rbenv.envs.registry.get(i).runs_on(s)]
MODES = list(AutoresetMode)
N = 3  # sub-envs
EPISODE = 4  # steps per episode, so that a short rollout crosses autoresets
STEPS = 10
SEED = 5
QUIET = """base = "{scene}"
[disturbance]
noise_sigma = 0.0
[faults]
p_step = 0.0
[sensor_noise]
attitude = 0.0
rate = 0.0
[sensors]
gyro_noise_dps = 0.0
gyro_bias_walk_dps_sqrt_s = 0.0
"""


@pytest.fixture(scope="module")
def quiet_scenes(tmp_path_factory) -> dict:
    """Each shipped scene, or for a noisy one a variant with zero per-step noise."""
    out = {}
    for scene in SCENES:
        plant = gym.make(rbenv.ENV_ID, scene=scene).unwrapped.plant
        if plant.noisy:
            path = tmp_path_factory.mktemp("scenes") / f"{scene}-quiet.toml"
            text = QUIET.format(scene=scene)
            if not (plant.actuator("thrusters") and plant.actuator("thrusters").p_fault):
                text = text.replace("[faults]\np_step = 0.0\n", "")
            if not plant.dist_noise:
                text = text.replace("[disturbance]\nnoise_sigma = 0.0\n", "")
            if not plant.gyro_noisy:
                text = text.replace("[sensors]\ngyro_noise_dps = 0.0\n"
                                    "gyro_bias_walk_dps_sqrt_s = 0.0\n", "")
            path.write_text(text)
            out[scene] = str(path)
        else:
            out[scene] = scene
    return out


def _native(env_id, scene, mode, **kwargs):
    return gym.make_vec(env_id, num_envs=N, vectorization_mode="vector_entry_point",
                        autoreset_mode=mode, scene=scene, max_episode_steps=EPISODE, **kwargs)


def _time_limit():
    """Gymnasium's own TimeLimit. Importing rl_zoo3 (the ecosystem tests do) replaces
    ``gymnasium.wrappers.TimeLimit`` process-wide with a subclass that reports an episode that
    ends and times out at once as not truncated; the reference must be Gymnasium's."""
    return next(c for c in gym.wrappers.TimeLimit.__mro__
                if c.__module__.startswith("gymnasium.") and c.__name__ == "TimeLimit")


def _sync(env_id, scene, mode):
    limit = _time_limit()
    return SyncVectorEnv([lambda: limit(gym.make(env_id, scene=scene, disable_env_checker=True)
                                        .unwrapped, EPISODE) for _ in range(N)],
                         autoreset_mode=mode)


def _rollout(env, mode, actions):
    """Every result of a seeded rollout: reset, steps, and (DISABLED) partial resets."""
    out = [("reset", env.reset(seed=SEED))]
    for t, a in enumerate(actions):
        step = env.step(a)
        out.append((f"step {t}", step))
        done = step[2] | step[3]
        if mode is AutoresetMode.DISABLED and done.any():
            out.append((f"reset_mask after step {t}", env.reset(options={"reset_mask": done})))
    return out


def _actions(env, seed=0):
    rng = np.random.default_rng(seed)
    shape = (STEPS, *env.action_space.shape)
    return rng.uniform(-1.0, 1.0, shape).astype(env.action_space.dtype)


_pairs: dict = {}


def _rollouts(env_id, scene, mode):
    """(native, sync) rollouts of one case, cached: two tests read each."""
    key = (env_id, scene, mode)
    if key not in _pairs:
        native, sync = _native(env_id, scene, mode), _sync(env_id, scene, mode)
        acts = _actions(native)
        _pairs[key] = (_rollout(native, mode, acts), _rollout(sync, mode, acts))
        native.close()
        sync.close()
    return _pairs[key]


# --- tests/vector/test_vector_env.py::test_vector_env_equal --------------------------------------
# (Gymnasium: AsyncVectorEnv == SyncVectorEnv step by step; here the native vector env, with
# tests/vector/test_autoreset_mode.py::test_autoreset_disabled's reset_mask=terminations loop)

@pytest.mark.parametrize("mode", MODES, ids=[m.value for m in MODES])
@pytest.mark.parametrize(("env_id", "scene"), PAIRS)
def test_vector_env_equal(env_id, scene, mode, quiet_scenes):
    """Everything exactly as Sync's, bit for bit: observations, rewards, flags, info values,
    keys, masks, dtypes and masked-out zeros (issue 19: one satellite steps exactly as one
    sub-env of a batch; rbenv.core.backend.matmul and FLOAT's NumPy transcendentals)."""
    native, sync = _rollouts(env_id, quiet_scenes[scene], mode)
    assert [name for name, _ in native] == [name for name, _ in sync]
    ended = 0
    for (name, got), (_, want) in zip(native, sync, strict=True):
        assert data_equivalence(got, want, exact=True), f"{name}: {got} != {want}"
        if name.startswith("step"):
            ended += int(np.sum(got[2] | got[3]))
    assert ended >= N  # every sub-env crossed at least one episode end


# --- tests/vector/test_autoreset_mode.py::test_autoreset_metadata / test_make_vec_autoreset ----

@pytest.mark.parametrize("mode", MODES, ids=[m.value for m in MODES])
def test_autoreset_metadata(mode):
    for given in (mode, mode.value):
        envs = _native(rbenv.ENV_ID, SCENES[0], given)
        assert envs.metadata["autoreset_mode"] == mode
        assert envs.autoreset_mode == mode
        envs.close()


# --- SyncVectorEnv.reset's reset_mask checks (Gymnasium raises them; no test of its own) --------

def _reset_mask_errors(env, ours: bool = True):
    """The exception type each bad reset_mask raises from ``env`` (ours: TypeError or
    ValueError naming the option; Gymnasium's SyncVectorEnv before 1.3 asserts instead)."""
    bad = {"list": [True] * N, "ints": np.ones(N, int), "floats": np.ones(N),
           "shape": np.ones(N + 1, bool), "all False": np.zeros(N, bool)}
    env.reset(seed=0)
    out = {}
    for name, mask in bad.items():
        with pytest.raises((TypeError, ValueError) if ours else Exception) as err:
            env.reset(options={"reset_mask": mask})
        out[name] = err.type
        if ours and name != "list":
            assert "reset_mask" in str(err.value), name
    return out


def test_reset_mask_errors_are_syncs():
    mode = AutoresetMode.DISABLED
    native = _native(rbenv.ENV_ID, SCENES[0], mode)
    got = _reset_mask_errors(native)
    want = _reset_mask_errors(_sync(rbenv.ENV_ID, SCENES[0], mode), ours=False)
    # Where Sync raises a typed error (Gymnasium >= 1.3; 1.2.2 asserts), ours is the same kind.
    typed = [k for k, v in want.items() if issubclass(v, (TypeError, ValueError))]
    assert {k: issubclass(got[k], TypeError) for k in typed} == \
        {k: issubclass(want[k], TypeError) for k in typed}
    assert {k for k, v in got.items() if issubclass(v, TypeError)} == {"list", "ints", "floats"}


def test_reset_mask_messages_name_the_option_and_rule():
    native = _native(rbenv.ENV_ID, SCENES[0], AutoresetMode.DISABLED)
    native.reset(seed=0)
    with pytest.raises(TypeError, match=r"reset_mask.*NumPy bool array.*type list"):
        native.reset(options={"reset_mask": [True] * N})
    with pytest.raises(TypeError, match=r"reset_mask.*bool array.*dtype int64"):
        native.reset(options={"reset_mask": np.ones(N, np.int64)})
    with pytest.raises(ValueError, match=r"reset_mask.*at least one True.*\[False, False"):
        native.reset(options={"reset_mask": np.zeros(N, bool)})


# --- tests/vector/test_vector_env_info.py::test_vector_return_info (partial reset) -------------

def test_partial_reset_info_is_zero_where_masked():
    """Sub-envs not reset have ``_key`` False and a zero value, as Sync's ``_add_info``."""
    native = _native(rbenv.ENV_ID, "cubesat-12u", AutoresetMode.DISABLED)
    native.reset(seed=SEED)
    for _ in range(2):
        native.step(-np.ones(native.action_space.shape, np.float32))  # thrusters off
    mask = np.array([False, True, False])
    _, info = native.reset(options={"reset_mask": mask})
    assert "time_s" in info  # nonzero in the sub-envs that were not reset
    for key, value in info.items():
        if not key.startswith("_"):
            np.testing.assert_array_equal(info["_" + key], mask, err_msg=key)
            assert not np.any(value[~mask]), key


# --- vector step: named errors for wrong actions (issue 19 item 4) -------------------------------

@pytest.mark.parametrize("action, error, pattern", [
    (np.zeros((N - 1, 12)), ValueError, r"actions must have shape \(3, 12\).*shape \(2, 12\)"),
    (np.zeros(12), ValueError, r"actions must have shape \(3, 12\).*shape \(12,\)"),
    (None, TypeError, r"actions must be an array of shape \(3, 12\).*None"),
    (np.zeros((N, 12), complex), TypeError, r"actions must be real numbers.*complex128"),
    ([["0.5"] * 12] * N, TypeError, r"actions must be real numbers.*<U3"),
    ([[0.0] * 12, [0.0] * 11, [0.0] * 12], ValueError, r"actions must be a rectangular"),
], ids=["batch (2, 12)", "single (12,)", "None", "complex", "numeric strings", "ragged"])
def test_vector_step_names_the_bad_action(action, error, pattern):
    native = _native(rbenv.ENV_ID, SCENES[0], AutoresetMode.NEXT_STEP)
    native.reset(seed=0)
    with pytest.raises(error, match=pattern):
        native.step(action)
    native.step(np.zeros((N, 12)))  # still usable


# --- tests/vector/test_sync_vector_env.py::test_sync_vector_env_seed ------------------------------

def test_action_space_seeding_is_deterministic():
    one, two = (_native(rbenv.ENV_ID, SCENES[0], AutoresetMode.NEXT_STEP) for _ in range(2))
    one.action_space.seed(123)
    two.action_space.seed(123)
    for _ in range(5):
        assert np.array_equal(one.action_space.sample(), two.action_space.sample())


# --- tests/envs/test_envs.py::test_all_env_api (gymnasium.utils.env_checker.check_env) ---------

@pytest.mark.parametrize(("env_id", "scene"), PAIRS)
def test_all_env_api(env_id, scene):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        # v0 ids have a v1: Gymnasium's registry calls them out of date (its convention).
        warnings.filterwarnings("ignore", ".*is out of date", DeprecationWarning)
        env = gym.make(env_id, scene=scene).unwrapped
        check_env(env, skip_render_check=True)
        env.close()
    assert [str(w.message) for w in caught] == []


# --- tests/envs/test_envs.py::test_all_env_passive_env_checker ---------------------------------

@pytest.mark.parametrize(("env_id", "scene"), PAIRS)
def test_all_env_passive_env_checker(env_id, scene):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        # v0 ids have a v1: Gymnasium's registry calls them out of date (its convention).
        warnings.filterwarnings("ignore", ".*is out of date", DeprecationWarning)
        env = gym.make(env_id, scene=scene)
        env.reset(seed=0)
        env.step(env.action_space.sample())
        env.close()
    assert [str(w.message) for w in caught] == []


# --- tests/envs/test_envs.py::test_env_determinism_rollout -------------------------------------

@pytest.mark.parametrize(("env_id", "scene"), PAIRS)
def test_env_determinism_rollout(env_id, scene):
    env_1 = gym.make(env_id, scene=scene, disable_env_checker=True)
    env_2 = gym.make(env_id, scene=scene, disable_env_checker=True)
    assert data_equivalence(env_1.reset(seed=SEED), env_2.reset(seed=SEED), exact=True)
    env_1.action_space.seed(SEED)
    for t in range(STEPS):
        action = env_1.action_space.sample()
        step_1, step_2 = env_1.step(action), env_2.step(action)
        assert data_equivalence(step_1, step_2, exact=True), t
        assert env_1.observation_space.contains(step_1[0])
        if step_1[2] or step_1[3]:
            env_1.reset(seed=SEED)
            env_2.reset(seed=SEED)


# --- tests/envs/test_envs.py::test_pickle_env ---------------------------------------------------

@pytest.mark.parametrize(("env_id", "scene"), PAIRS)
def test_pickle_env(env_id, scene):
    env = gym.make(env_id, scene=scene)
    action = env.action_space.sample()
    env_reset, env_step = env.reset(seed=123), env.step(action)
    pickled = pickle.loads(pickle.dumps(env))
    assert data_equivalence(env_reset, pickled.reset(seed=123), exact=True)
    assert data_equivalence(env_step, pickled.step(action), exact=True)


# --- tests/envs/test_action_dim_check.py::test_box_actions_out_of_bound ------------------------

@pytest.mark.parametrize("env_id", IDS)
def test_box_actions_out_of_bound(env_id):
    """An out-of-bound action acts as the bound (rbenv clips actions to the action space)."""
    env, oob_env = (gym.make(env_id, disable_env_checker=True) for _ in range(2))
    env.reset(seed=42)
    oob_env.reset(seed=42)
    space = env.action_space
    for i in range(space.shape[0]):
        for bound, sign in ((space.high, 1.0), (space.low, -1.0)):
            oob = bound.copy()
            oob[i] += sign * np.asarray(1.0, dtype=space.dtype)  # OOB_VALUE = 100 there
            obs = env.step(bound)[0]
            assert np.array_equal(obs, oob_env.step(oob)[0]), (i, sign)


# --- make(): an unknown keyword names the valid options (issue 19 item 4) -------------------------

@pytest.mark.parametrize("env_id", IDS)
def test_make_with_an_unknown_option_lists_the_valid_ones(env_id):
    with pytest.raises(TypeError, match=re.escape("'foo'") + r".*valid options are.*"
                       r"action_mode.*scene"):
        gym.make(env_id, foo=1)


def test_returned_info_never_changes_afterwards():
    """Info arrays are the caller's (SyncVectorEnv builds fresh ones): a later partial reset,
    which rewrites the reset sub-envs' state in place, leaves them as returned."""
    native = _native(rbenv.ENV_ID, "cubesat-12u", AutoresetMode.DISABLED)
    native.reset(seed=SEED)
    info = native.step(np.ones(native.action_space.shape, np.float32))[4]
    kept = {k: v.copy() for k, v in info.items()}
    native.reset(options={"reset_mask": np.array([True, False, True])})
    assert kept["fuel_kg"].any()
    assert data_equivalence(info, kept, exact=True)
