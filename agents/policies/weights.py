"""Pickle-free files for trained models: weights as tensors, everything else as JSON or .npz.

Loading a file never runs code from it. A model is written as

* ``<name>.pt``: ``torch.save`` of a dict of tensors and plain containers only (the state
  dicts SB3's ``get_parameters`` returns: the policy, which holds SAC's target networks, and
  every optimizer, plus SAC's entropy coefficient), read back with
  ``torch.load(weights_only=True)``, which refuses any other object;
* ``<name>.json``: what rebuilds the policy around those weights: the algorithm, the policy
  class name and keyword arguments, the observation and action spaces, and the training
  counters (``num_timesteps``, gradient updates, episodes). A resume rebuilds the algorithm
  with the run's hyperparameters (its ``config.json``) and restores every saved state.

Observation-normalisation statistics (SB3's ``VecNormalize``) are an ``.npz`` of arrays read
with ``allow_pickle=False``, and an off-policy replay buffer is an ``.npz`` of its arrays.

An SBX model (SAC or TD3 in JAX, ``rbenv train --engine sbx``) is written in the same two files
and loads as the same SB3 policy: its flax weights are copied into SB3's torch modules of the
same architecture (a flax ``Dense`` kernel is the transpose of a torch ``Linear`` weight), so
evaluation, reports and export read it unchanged; ``<name>.json`` says ``"engine": "sbx"``.
Its complete training state (weights, target networks, Adam moments, SAC's entropy
coefficient), which a resume restores, is a third file, ``<name>.jax.npz``: every array of the
flax train states, named by its path in the state tree.

What a resume restores from these files: the weights, the optimizers' state (Adam moments and
step counts), SAC's entropy coefficient and its optimizer, the observation and return
statistics, the replay buffer, ``num_timesteps``, the gradient-update and episode counters.
What it does not restore (nor did SB3's ``.zip``): random-number-generator states, the
episode-statistics buffer used for logging, and episodes in progress (the vector env starts
new ones).

This module imports torch and Stable-Baselines3 only when a function needs them.
"""

from __future__ import annotations

import contextlib
import json
from pathlib import Path
from typing import Literal, get_args

import gymnasium as gym
import numpy as np
from rbenv.agents.policies.runfolder import RunFolderError, atomic_write, write_json

from rbenv.satellite import usage

FORMAT = 1
Algo = Literal["ppo", "sac", "td3", "tqc", "crossq"]  # every algorithm of rbenv train (--algo)
ALGOS: tuple[str, ...] = get_args(Algo)
POLICY = "MlpPolicy"
_STATS_FIELDS = ("obs_mean", "obs_var", "obs_count", "ret_mean", "ret_var", "ret_count",
                 "clip_obs", "clip_reward", "gamma", "epsilon", "norm_obs", "norm_reward")
_BUFFER_FIELDS = ("observations", "next_observations", "actions", "rewards", "dones",
                  "timeouts")


class ModelFileError(RunFolderError):
    """A model, statistics or buffer file is missing, corrupt, or not in rbenv's format."""


# --- spaces -----------------------------------------------------------------------------------

def space_to_json(space) -> dict:
    """A ``gymnasium.spaces.Box`` as JSON (the only space rbenv's policies see)."""
    if not isinstance(space, gym.spaces.Box):
        raise ModelFileError(f"only Box spaces can be saved, got {space!r}")
    return {"type": "Box", "low": space.low.tolist(), "high": space.high.tolist(),
            "shape": list(space.shape), "dtype": str(space.dtype)}


def space_from_json(data, what: str):
    try:
        if data["type"] != "Box":
            raise ValueError(f"type must be 'Box', got {data['type']!r}")
        dtype = np.dtype(data["dtype"])
        if dtype.kind != "f":
            raise ValueError(f"dtype must be a float type, got {dtype}")
        return gym.spaces.Box(np.asarray(data["low"], dtype), np.asarray(data["high"], dtype),
                              tuple(int(s) for s in data["shape"]), dtype)
    except (KeyError, TypeError, ValueError) as e:
        raise ModelFileError(f"{what} is not a valid Box space: {e}") from None


# --- models -----------------------------------------------------------------------------------

def algo_name(model) -> str:
    name = type(model).__name__.lower()
    if name not in ALGOS:
        raise ModelFileError(f"only {', '.join(a.upper() for a in ALGOS)} models can be saved, "
                             f"got {type(model).__name__}")
    return name


def model_config(model) -> dict:
    """The JSON that, with the weights, rebuilds ``model``'s policy (see the module doc)."""
    from rbenv.agents.policies import activations  # torch: the model has imported it

    kwargs = activations.to_names(model.policy_kwargs)
    if is_jax_model(model) and kwargs.get("use_sde") is False:
        del kwargs["use_sde"]  # SBX's SAC adds it; SB3's TD3 policy, which loads it, has none
    config = {"format": FORMAT, "algo": algo_name(model), "policy": POLICY,
              **({"engine": "sbx"} if is_jax_model(model) else {}),
              "policy_kwargs": kwargs,
              "observation_space": space_to_json(model.observation_space),
              "action_space": space_to_json(model.action_space),
              "num_timesteps": int(model.num_timesteps),
              "n_updates": int(getattr(model, "_n_updates", 0)),
              "episode_num": int(getattr(model, "_episode_num", 0))}
    try:
        json.dumps(config, allow_nan=False)
    except (TypeError, ValueError) as e:
        raise ModelFileError(f"the model's policy_kwargs are not plain JSON "
                             f"({e}); only JSON-valued options can be saved without pickle"
                             ) from None
    return config


def model_tensors(model) -> dict:
    """The state dicts and torch variables of ``model``: tensors and plain containers only
    (an SBX model: the SB3 policy's state dict holding its weights, :func:`sb3_policy_state`)."""
    from stable_baselines3.common.save_util import recursive_getattr  # the train extra

    if is_jax_model(model):
        return {"format": FORMAT, "params": {"policy": sb3_policy_state(model)},
                "variables": {}}

    variables = {name: recursive_getattr(model, name).detach().cpu()
                 for name in model._get_torch_save_params()[1]}
    return {"format": FORMAT, "params": model.get_parameters(), "variables": variables}


def save_tensors(tensors: dict, path: Path) -> None:
    import torch  # the train extra

    with open(path, "wb") as f:
        torch.save(tensors, f)


def read_config(path: Path) -> dict:
    """A model's JSON configuration; :class:`ModelFileError` naming the file if unusable."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise ModelFileError(f"model configuration {str(path)!r} does not exist") from None
    except (OSError, UnicodeDecodeError, ValueError) as e:
        raise ModelFileError(f"model configuration {str(path)!r} is not valid JSON: {e}"
                             ) from None
    if not isinstance(data, dict) or data.get("algo") not in ALGOS \
            or data.get("policy") != POLICY or data.get("format") != FORMAT:
        raise ModelFileError(f"model configuration {str(path)!r} must be an object with format "
                             f"{FORMAT}, algo one of {list(ALGOS)} and policy {POLICY!r}")
    if not isinstance(data.get("policy_kwargs"), dict) \
            or not isinstance(data.get("num_timesteps"), int):
        raise ModelFileError(f"model configuration {str(path)!r}: 'policy_kwargs' must be an "
                             "object and 'num_timesteps' an integer")
    return data


def read_tensors(path: Path) -> dict:
    """The tensors of a ``.pt`` model file, loaded with ``weights_only=True`` (no code runs)."""
    import torch  # the train extra

    path = Path(path)
    if not path.is_file():
        raise ModelFileError(f"model weights {str(path)!r} do not exist")
    try:
        data = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as e:  # a corrupt or hostile file: torch refuses it, naming the reason
        raise ModelFileError(f"model weights {str(path)!r} are corrupt or hold objects other "
                             f"than tensors (refused): {type(e).__name__}: {e}") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT \
            or not isinstance(data.get("params"), dict):
        raise ModelFileError(f"model weights {str(path)!r} are not rbenv model weights "
                             f"(format {FORMAT})")
    return data


def build_model(config: dict, env=None, hyperparams: dict | None = None,
                seed: int | None = None, verbose: int = 0):
    """A new SB3 model from ``config`` (:func:`model_config`): for training on ``env`` with
    ``hyperparams``, or, with no env, for inference with the saved spaces."""
    jax = config.get("engine") == "sbx" and env is not None  # trained on: SBX; else SB3's
    cls = (jax_model_classes() if jax else model_classes())[config["algo"]]
    kwargs = {k: v for k, v in (hyperparams or {}).items() if k != "policy_kwargs"}
    from rbenv.agents.policies import activations  # the train extra: torch

    kwargs["policy_kwargs"] = activations.to_classes(config["policy_kwargs"])
    if env is not None:
        return cls(POLICY, env, seed=seed, device="cpu", verbose=verbose, **kwargs)
    # For inference the policy alone is built (as SB3's _setup_model builds it): no buffers.
    model = cls(POLICY, None, device="cpu", _init_setup_model=False, **kwargs)
    model.observation_space = space_from_json(config["observation_space"], "observation_space")
    model.action_space = space_from_json(config["action_space"], "action_space")
    model.n_envs = 1
    model._setup_lr_schedule()
    extra = {"use_sde": model.use_sde} if config["algo"] == "ppo" else {}
    model.policy = model.policy_class(model.observation_space, model.action_space,
                                      model.lr_schedule, **extra, **model.policy_kwargs)
    model.policy.set_training_mode(False)
    return model


def restore(model, config: dict, tensors: dict, path: Path, *, full: bool = True) -> None:
    """Load ``tensors`` (``full``: every state dict and variable; else the policy's alone, for
    inference) and the counters of ``config`` into ``model``; errors name ``path``."""
    from stable_baselines3.common.save_util import recursive_setattr  # the train extra

    try:
        if full and is_jax_model(model):
            restore_jax_state(model, jax_state_path(path))
        elif full:
            model.set_parameters(tensors["params"], exact_match=True, device="cpu")
            for name, value in (tensors.get("variables") or {}).items():
                recursive_setattr(model, f"{name}.data", value.data)
        else:
            model.policy.load_state_dict(tensors["params"]["policy"])
    except ModelFileError:
        raise
    except Exception as e:  # missing keys or shapes that do not fit the config
        raise ModelFileError(f"model weights {str(path)!r} do not fit their configuration: "
                             f"{type(e).__name__}: {e}") from None
    model.num_timesteps = int(config["num_timesteps"])
    model._n_updates = int(config.get("n_updates", 0))
    model._episode_num = int(config.get("episode_num", 0))


def config_path(weights: Path) -> Path:
    """The JSON configuration beside ``<name>.pt``: ``<name>.json``."""
    return Path(weights).with_suffix(".json")


def load_model(path: Path, env=None, hyperparams: dict | None = None,
               seed: int | None = None, verbose: int = 0):
    """A model from ``<name>.pt`` and ``<name>.json``; with ``env``, ready to train on."""
    config = read_config(config_path(path))
    tensors = read_tensors(path)
    try:
        model = build_model(config, env, hyperparams, seed, verbose)
    except ModelFileError:
        raise
    except Exception as e:  # hyperparameters SB3 refuses
        raise ModelFileError(f"model configuration {str(config_path(path))!r} does not build "
                             f"a model: {type(e).__name__}: {e}") from None
    restore(model, config, tensors, path, full=env is not None)
    return model


# --- observation statistics -------------------------------------------------------------------

def save_stats(vecnormalize, path: Path) -> None:
    """VecNormalize's statistics and options as an ``.npz`` of arrays. Without observation
    normalisation SB3 keeps no ``obs_rms``: the file then holds the identity (mean 0, var 1,
    count 0), which ``norm_obs`` False tells every reader to skip."""
    v = vecnormalize
    obs_rms = getattr(v, "obs_rms", None)
    if obs_rms is None:
        from stable_baselines3.common.running_mean_std import RunningMeanStd  # the train extra

        obs_rms = RunningMeanStd(shape=v.observation_space.shape)
        obs_rms.count = 0.0
    arrays = {"obs_mean": obs_rms.mean, "obs_var": obs_rms.var, "obs_count": obs_rms.count,
              "ret_mean": v.ret_rms.mean, "ret_var": v.ret_rms.var, "ret_count": v.ret_rms.count,
              "clip_obs": v.clip_obs, "clip_reward": v.clip_reward, "gamma": v.gamma,
              "epsilon": v.epsilon, "norm_obs": v.norm_obs, "norm_reward": v.norm_reward}
    with open(path, "wb") as f:
        np.savez(f, **{k: np.asarray(a) for k, a in arrays.items()})


class ObsStats:
    """Saved observation statistics, normalising as ``VecNormalize.normalize_obs`` does."""

    def __init__(self, fields: dict):
        from stable_baselines3.common.running_mean_std import RunningMeanStd  # the train extra

        self.obs_rms = RunningMeanStd(shape=fields["obs_mean"].shape)
        self.obs_rms.mean, self.obs_rms.var = fields["obs_mean"], fields["obs_var"]
        self.obs_rms.count = float(fields["obs_count"])
        self.ret_rms = RunningMeanStd(shape=())
        self.ret_rms.mean, self.ret_rms.var = fields["ret_mean"], fields["ret_var"]
        self.ret_rms.count = float(fields["ret_count"])
        self.clip_obs, self.clip_reward = float(fields["clip_obs"]), float(fields["clip_reward"])
        self.gamma, self.epsilon = float(fields["gamma"]), float(fields["epsilon"])
        self.norm_obs, self.norm_reward = bool(fields["norm_obs"]), bool(fields["norm_reward"])

    def normalize_obs(self, obs: np.ndarray) -> np.ndarray:
        if not self.norm_obs:
            return obs
        scaled = (obs - self.obs_rms.mean) / np.sqrt(self.obs_rms.var + self.epsilon)
        return np.clip(scaled, -self.clip_obs, self.clip_obs).astype(np.float32)

    def vecnormalize(self, venv, training: bool = True):
        """A ``VecNormalize`` over ``venv`` holding these statistics."""
        from stable_baselines3.common.vec_env import VecNormalize  # the train extra

        v = VecNormalize(venv, training=training, norm_obs=self.norm_obs,
                         norm_reward=self.norm_reward, clip_obs=self.clip_obs,
                         clip_reward=self.clip_reward, gamma=self.gamma, epsilon=self.epsilon)
        v.obs_rms, v.ret_rms = self.obs_rms, self.ret_rms
        return v


@contextlib.contextmanager
def open_npz(path):
    """``np.load(path, allow_pickle=False)`` of an ``.npz``, as a context, that closes the file
    also when the archive is torn (``np.load`` of a path leaves it open when the zip cannot be
    read)."""
    with open(path, "rb") as f, np.load(f, allow_pickle=False) as data:
        yield data


def load_stats(path: Path) -> ObsStats:
    """Statistics from an ``.npz`` (``allow_pickle=False``); errors name the file."""
    path = Path(path)
    if not path.is_file():
        raise ModelFileError(f"normalisation statistics {str(path)!r} do not exist")
    try:
        with open_npz(path) as data:
            fields = {k: data[k] for k in _STATS_FIELDS}
        return ObsStats(fields)
    except Exception as e:  # torn, foreign or incomplete file
        raise ModelFileError(f"normalisation statistics {str(path)!r} are corrupt or "
                             f"incomplete: {type(e).__name__}: {e}") from None


# --- replay buffer ----------------------------------------------------------------------------

def save_replay_buffer(model, path: Path) -> None:
    buf = model.replay_buffer
    arrays = {k: getattr(buf, k) for k in _BUFFER_FIELDS if getattr(buf, k, None) is not None}
    with open(path, "wb") as f:
        np.savez(f, pos=np.asarray(buf.pos), full=np.asarray(buf.full), **arrays)


def load_replay_buffer(model, path: Path) -> int:
    """Fill ``model.replay_buffer`` from ``path``; returns its size. Errors name the file."""
    buf = model.replay_buffer
    try:
        with open_npz(path) as data:
            loaded = {k: data[k] for k in _BUFFER_FIELDS if getattr(buf, k, None) is not None}
            pos, full = int(data["pos"]), bool(data["full"])
        for key, value in loaded.items():
            if value.shape != getattr(buf, key).shape:
                raise ValueError(f"{key} has shape {value.shape}, the buffer "
                                 f"{getattr(buf, key).shape}")
    except Exception as e:  # torn, foreign, or a buffer of another size
        raise ModelFileError(f"replay buffer {str(path)!r} is unusable: {type(e).__name__}: "
                             f"{e}") from None
    for key, value in loaded.items():  # all checked first: never a half-filled buffer
        setattr(buf, key, value.astype(getattr(buf, key).dtype, copy=False))
    buf.pos, buf.full = pos, full
    return buf.size()


def save_model(model, path: Path) -> None:
    """Write ``<name>.pt`` and ``<name>.json`` for ``model`` (an SBX model: also
    ``<name>.jax.npz``), each atomically (json last)."""
    config = model_config(model)
    atomic_write(Path(path), lambda p: save_tensors(model_tensors(model), p))
    if is_jax_model(model):
        atomic_write(jax_state_path(path), lambda p: save_jax_state(model, p))
    write_json(config_path(path), config)


def model_classes() -> dict:
    """``rbenv train``'s algorithms by name (TQC and CrossQ only if sb3-contrib is installed)."""
    from stable_baselines3 import PPO, SAC, TD3  # the train extra

    classes = {"ppo": PPO, "sac": SAC, "td3": TD3}
    try:
        from sb3_contrib import TQC, CrossQ  # also in the train extra
    except ImportError:
        return classes
    return {**classes, "tqc": TQC, "crossq": CrossQ}


# --- SBX (JAX) models -------------------------------------------------------------------------

def jax_model_classes() -> dict:
    """SBX's algorithms by name (``rbenv train --engine sbx``); without SBX, an error naming
    the sbx extra (:func:`rbenv.satellite.usage.require`)."""
    sbx = usage.require("sbx", "rbenv train --engine sbx")
    return {"sac": sbx.SAC, "td3": sbx.TD3}


def is_jax_model(model) -> bool:
    """An SBX model: its policy holds flax train states (``qf_state``), not torch modules."""
    return hasattr(getattr(model, "policy", None), "qf_state")


def jax_state_path(weights: Path) -> Path:
    """The training state beside ``<name>.pt``: ``<name>.jax.npz``."""
    return Path(weights).with_suffix(".jax.npz")


def _jax_states(model) -> dict:
    """The flax train states of an SBX model by name (SAC's entropy coefficient among them)."""
    states = {"actor_state": model.policy.actor_state, "qf_state": model.policy.qf_state}
    if getattr(model, "ent_coef_state", None) is not None:
        states["ent_coef_state"] = model.ent_coef_state
    return states


def _leaves(states: dict) -> dict:
    """Every array of ``states`` by its path (``qf_state.params['params']...``)."""
    import jax

    out = {}
    for name, state in states.items():
        for path, leaf in jax.tree_util.tree_flatten_with_path(state)[0]:
            out[name + jax.tree_util.keystr(path)] = np.asarray(leaf)
    return out


def save_jax_state(model, path: Path) -> None:
    """Every array of an SBX model's train states as an ``.npz`` (no pickle)."""
    with open(path, "wb") as f:
        np.savez(f, **_leaves(_jax_states(model)))


def restore_jax_state(model, path: Path) -> None:
    """Load ``path`` (:func:`save_jax_state`) into an SBX model built with the same settings:
    every array must be there with the shape and dtype the model has; else an error naming
    the file and the array."""
    import jax

    path = Path(path)
    if not path.is_file():
        raise ModelFileError(f"SBX training state {str(path)!r} does not exist")
    try:
        with open_npz(path) as data:
            saved = {k: data[k] for k in data.files}
    except Exception as e:  # torn or foreign
        raise ModelFileError(f"SBX training state {str(path)!r} is corrupt: "
                             f"{type(e).__name__}: {e}") from None
    states = _jax_states(model)
    for name, state in states.items():
        paths, treedef = jax.tree_util.tree_flatten_with_path(state)
        leaves = []
        for key, leaf in paths:
            key = name + jax.tree_util.keystr(key)
            value = saved.get(key)
            # The kind, not the width: a new state's step counter is a Python int.
            if value is None or value.shape != np.shape(leaf) \
                    or value.dtype.kind != np.asarray(leaf).dtype.kind:
                raise ModelFileError(
                    f"SBX training state {str(path)!r} does not fit the model: {key} is "
                    f"{'missing' if value is None else f'{value.dtype}{list(value.shape)}'}, "
                    f"the model's {np.asarray(leaf).dtype}{list(np.shape(leaf))}")
            leaves.append(jax.numpy.asarray(value))
        states[name] = jax.tree_util.tree_unflatten(treedef, leaves)
    model.policy.actor_state, model.policy.qf_state = states["actor_state"], states["qf_state"]
    if "ent_coef_state" in states:
        model.ent_coef_state = states["ent_coef_state"]


def _dense_layers(params) -> list[tuple[np.ndarray, np.ndarray]]:
    """(kernel, bias) of each flax ``Dense`` layer in ``params``, in the order they apply: the
    first level down whose keys are ``Dense_0``, ``Dense_1``, ... (an ensemble of critics keeps
    its layers one level further down, stacked on a leading axis)."""
    while not any(k.startswith("Dense_") for k in params):
        if len(params) != 1:
            raise ModelFileError(f"cannot find the Dense layers among {sorted(params)}")
        params = next(iter(params.values()))
    names = sorted(params, key=lambda k: int(k.split("_")[1]))
    return [(np.asarray(params[k]["kernel"]), np.asarray(params[k]["bias"])) for k in names]


def _copy_linear(modules, layers) -> None:
    """Copy flax (kernel, bias) pairs into torch ``Linear`` modules, in order."""
    import torch

    if len(modules) != len(layers):
        raise ModelFileError(f"{len(layers)} Dense layers do not fit {len(modules)} Linear ones")
    with torch.no_grad():
        for module, (kernel, bias) in zip(modules, layers, strict=True):
            if module.weight.shape != kernel.T.shape:
                raise ModelFileError(f"a Dense kernel of shape {kernel.shape} does not fit a "
                                     f"Linear weight of shape {tuple(module.weight.shape)}")
            module.weight.copy_(torch.from_numpy(np.array(kernel.T)))  # a writable copy
            module.bias.copy_(torch.from_numpy(np.array(bias)))


def linear_layers(module) -> list:
    """The torch ``Linear`` modules of ``module``, in the order they apply."""
    import torch

    return [m for m in module.modules() if isinstance(m, torch.nn.Linear)]


def sb3_policy_state(model) -> dict:
    """The state dict of the SB3 policy (SAC's or TD3's, same spaces and ``net_arch``) that
    acts as the SBX ``model`` does: its actor, critics and target networks, copied."""
    config = model_config(model)
    extra = set(config["policy_kwargs"]) - {"net_arch"}
    if extra:
        raise ModelFileError(f"an SBX policy converts to SB3's only with net_arch as its "
                             f"policy_kwargs, got also {sorted(extra)}")
    sb3 = build_model({**config, "engine": "sb3"}).policy
    jax_policy = model.policy
    if config["algo"] == "sac":  # hidden layers, then the mean's and the log-std's heads
        _copy_linear([*linear_layers(sb3.actor.latent_pi), sb3.actor.mu, sb3.actor.log_std],
                     _dense_layers(jax_policy.actor_state.params))
    else:  # td3: a tanh network and its target
        _copy_linear(linear_layers(sb3.actor), _dense_layers(jax_policy.actor_state.params))
        _copy_linear(linear_layers(sb3.actor_target),
                     _dense_layers(jax_policy.actor_state.target_params))
    for critic, params in ((sb3.critic, jax_policy.qf_state.params),
                           (sb3.critic_target, jax_policy.qf_state.target_params)):
        stacked = _dense_layers(params)
        for k, q_net in enumerate(critic.q_networks):
            _copy_linear(linear_layers(q_net), [(w[k], b[k]) for w, b in stacked])
    return sb3.state_dict()
