"""Stable-Baselines3 models from a run folder behind one ``predict()``: :class:`RunPolicy`.

:func:`load_run_policy` resolves a run folder, its ``policy.pt`` or a checkpoint ``policy_<N>.pt``
(:func:`rbenv.agents.policies.runfolder.locate`), loads the model without pickle
(:mod:`rbenv.agents.policies.weights`) and pairs it with its own observation statistics::

    from rbenv.agents.policies import load_policy
    policy = load_policy("runs/ppo-cubesat-12u-seed0")       # or .../checkpoints/policy_N.pt
    env = policy.make_env()                                   # the run's task, scene and env kwargs
    obs, _ = env.reset(seed=0)
    action, _ = policy.predict(obs)                           # observations normalised inside

The bare weights give a policy that expects normalised observations: it fails silently on raw
ones. Torch and Stable-Baselines3 (the train extra) are imported only when a model is loaded.
"""

from __future__ import annotations

import functools
import pickle
import zipfile
from pathlib import Path
from typing import Literal, get_args

import numpy as np
from rbenv.agents.policies import weights
from rbenv.agents.policies.runfolder import (
    RunFolderError,
    TrainedOn,
    locate,
    require_trust,
)
from rbenv.core import validation
from rbenv.core.errors import InvalidParameterError
from scipy.special import ndtr  # the standard normal CDF (scipy.stats.norm.cdf's own kernel)

import rbenv


def check_model_file(path: Path) -> None:
    """Cheap integrity check of a model file, an SB3 ``.zip`` or a torch ``.pt`` (both zip
    archives): the CRCs of every member; raises naming it. Nothing is unpickled."""
    try:
        with zipfile.ZipFile(path) as z:
            bad = z.testzip()
            names = set(z.namelist())
    except (OSError, zipfile.BadZipFile, EOFError, ValueError) as e:
        raise RunFolderError(f"model file {str(path)!r} is missing or not a valid zip: {e}"
                             ) from None
    torch_file = any(n.endswith("/data.pkl") for n in names)
    complete = torch_file if Path(path).suffix == ".pt" else {"data", "policy.pth"} <= names
    if bad is not None or not complete:
        raise RunFolderError(f"model file {str(path)!r} is corrupt "
                             f"({'bad member ' + bad if bad else 'members missing'})")


def load_stats(path: Path, venv=None, *, trust_pickle: bool = False):
    """Observation statistics from ``path``: ``.npz`` (no pickle), or a legacy
    ``vecnormalize*.pkl`` only with ``trust_pickle``. With ``venv``: a ``VecNormalize`` over
    it; without: an object with ``normalize_obs`` and ``obs_rms``. Errors name the file."""
    path = Path(path)
    if path.suffix != ".pkl":
        stats = weights.load_stats(path)
        return stats if venv is None else stats.vecnormalize(venv)
    if not path.is_file():
        raise RunFolderError(f"normalisation statistics {str(path)!r} do not exist")
    require_trust(path, "a pickled VecNormalize", trust_pickle)
    return _unpickle_stats(path, venv)


def _unpickle_stats(path: Path, venv):
    from stable_baselines3.common.vec_env import VecNormalize  # the train extra

    try:
        with open(path, "rb") as f:
            stats = pickle.load(f)
    except Exception as e:  # a corrupt pickle can raise almost anything
        raise RunFolderError(f"normalisation statistics {str(path)!r} are corrupt: "
                             f"{type(e).__name__}: {e}") from None
    if not isinstance(stats, VecNormalize):
        raise RunFolderError(f"{str(path)!r} holds a {type(stats).__name__}, not VecNormalize "
                             "statistics")
    if venv is not None:
        stats.set_venv(venv)
    return stats


def load_model(path: Path, algo: str | None = None, *, env=None, hyperparams=None,
               seed: int | None = None, trust_pickle: bool = False):
    """A model from ``policy*.pt`` + its ``.json`` (no pickle), or from an SB3 ``.zip`` (PPO or
    SAC; ``algo`` if known) only with ``trust_pickle``; raises naming the file.

    With ``env``, the model is rebuilt for training on it, with ``hyperparams`` (the run's)
    and ``seed``, and every saved state (optimizers too) is restored; without, it is built for
    inference from the saved spaces.
    """
    path = Path(path)
    check_model_file(path)
    if path.suffix == ".pt":
        return weights.load_model(path, env=env, hyperparams=hyperparams, seed=seed)
    require_trust(path, "a Stable-Baselines3 .zip (it holds cloudpickled objects)",
                  trust_pickle)
    return _load_zip(path, algo, env)


def _load_zip(path: Path, algo: str | None, env):
    known = weights.model_classes()
    classes = (known[algo],) if algo in known else tuple(known.values())
    errors = []
    for cls in classes:
        try:
            return cls.load(path, device="cpu", **({} if env is None else {"env": env}))
        except Exception as e:  # wrong algorithm or a corrupt member
            errors.append(f"{cls.__name__}: {type(e).__name__}: {e}")
    raise RunFolderError(f"model file {str(path)!r} could not be loaded as "
                         f"{' or '.join(c.__name__ for c in classes)}: {'; '.join(errors)}")


# How a trained policy acts when evaluated (RunPolicy; a run config's policy_action).
PolicyAction = Literal["auto", "mean_throttle", "mode"]
POLICY_ACTIONS: tuple[str, ...] = get_args(PolicyAction)
NO_CONFIG = ("see its config.json; a model without one (a foreign SB3 .zip) needs its task, "
             "scene and options named (--env-id, --scene, --env-kwargs)")


class RunPolicy(TrainedOn):
    """A trained model with its observation statistics, behind SB3's ``predict`` interface.

    Works on one observation ``(obs_dim,)`` or a batch ``(n, obs_dim)``; observations are the
    raw ones a ``gym.make``/``gym.make_vec`` env returns.

    action: what ``predict(..., deterministic=True)`` returns. ``"mode"``: SB3's deterministic
    action (the Gaussian's mean μ; the env clips it). ``"mean_throttle"``: the mean action
    E[clip(μ + σε, low, high)] of the stochastic policy that was trained, each entry between
    the bounds where the env clips it (a thruster's throttle [0, 1], a wheel's or a rod's
    [-1, 1]; :func:`expected_throttle`). ``"auto"`` (default): the run's ``policy_action``
    (its config.json, :class:`rbenv.agents.training.config.RunConfig`) where it names one;
    else ``mean_throttle`` for an
    unsquashed Gaussian policy (PPO, A2C) acting in throttle mode on a scene with thrusters,
    where clip(μ, 0, 1) switches off every thruster whose mean is below zero but which the
    trained policy fires through its noise, and ``mode`` otherwise.
    """

    def __init__(self, model, vecnormalize=None, config: dict | None = None,
                 source: str = "model", action: str = "auto"):
        self.model, self.vecnormalize = model, vecnormalize
        self.config, self.source = config, source
        self.action = self._resolve_action(action)

    def _resolve_action(self, action: str) -> str:
        validation.choice("action", action, POLICY_ACTIONS)
        gaussian = _is_unsquashed_gaussian(self.model)
        if action == "auto":  # the run's own choice (config.json's policy_action), if any
            action = (self.config or {}).get("policy_action") or "auto"
            validation.choice("policy_action", action, POLICY_ACTIONS)
        if action == "auto":
            throttle = self.env_kwargs.get("action_mode", "throttle") == "throttle" \
                and _has_thrusters(self.config)
            return "mean_throttle" if gaussian and throttle else "mode"
        if action == "mean_throttle" and not gaussian:
            raise InvalidParameterError(
                f"action 'mean_throttle' needs an unsquashed Gaussian policy (PPO, A2C); "
                f"{type(self.model).__name__} from {self.source} has none; use 'mode'")
        return action

    def normalize(self, obs: np.ndarray) -> np.ndarray:
        """Observations as the policy saw them in training."""
        obs = np.asarray(obs)
        expected = self.model.observation_space.shape
        if obs.shape[-len(expected):] != expected:
            where = self.env_kwargs or NO_CONFIG
            raise InvalidParameterError(
                f"observation shape {obs.shape} does not match the policy's {expected} "
                f"({self.source}); evaluate it in the env it was trained on: {where}")
        return obs if self.vecnormalize is None else self.vecnormalize.normalize_obs(obs)

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        if deterministic and self.action == "mean_throttle":
            return self.mean_throttle(observation), state
        return self.model.predict(self.normalize(observation), state=state,
                                  episode_start=episode_start, deterministic=deterministic)

    def mean_throttle(self, observation) -> np.ndarray:
        """E[clip(μ + σε, 0, 1)] for one observation (n_act,) or a batch (n, n_act), float32."""
        import torch  # the train extra, like the model itself

        obs = np.asarray(self.normalize(observation), dtype=np.float32)
        batch = obs.ndim > 1
        with torch.no_grad():
            dist = self.model.policy.get_distribution(
                torch.as_tensor(obs if batch else obs[None])).distribution
            mean, std = dist.mean.numpy(), dist.stddev.numpy()
        out = expected_throttle(mean, std, *self.clip_bounds).astype(np.float32)
        return out if batch else out[0]

    @functools.cached_property
    def clip_bounds(self) -> tuple:
        """(low, high) per action entry, where the env clips them: the plant's action bounds
        (thrusters [0, 1], wheels and rods [-1, 1]); (0, 1) for a run of unknown config or
        whose scene file is gone."""
        if self.config is None:
            return 0.0, 1.0
        try:
            env = self.make_env()
        except ValueError:
            return 0.0, 1.0
        try:
            return env.unwrapped.plant.action_bounds
        finally:
            env.close()


def _is_unsquashed_gaussian(model) -> bool:
    """True for an SB3 actor-critic policy whose actions are a diagonal Gaussian (PPO, A2C)."""
    from stable_baselines3.common.distributions import DiagGaussianDistribution  # train extra

    return type(getattr(getattr(model, "policy", None), "action_dist", None)) \
        is DiagGaussianDistribution


def expected_throttle(mean: np.ndarray, std: np.ndarray, low=0.0, high=1.0) -> np.ndarray:
    """E[clip(mean + std·ε, low, high)], ε ~ N(0, 1): the mean action of a clipped Gaussian
    policy (a thruster's throttle by default: ``low, high = 0, 1``).

    With the env's ``throttle = clip(a, 0, 1)`` the deterministic action clip(mean, 0, 1) is
    *not* the mean throttle of the stochastic policy: a mean below 0 gives 0, while the policy
    it was trained as fires that thruster a fraction of the time. mean, std: same shape; low,
    high: the env's clip bounds, broadcast against them (a wheel's or a rod's are -1, 1).
    """
    # In float64, as scipy.stats.norm evaluates float32 arguments.
    lo, hi = (np.asarray(z, np.float64) for z in ((low - mean) / std, (high - mean) / std))
    return (mean * (ndtr(hi) - ndtr(lo)) + std * (_normal_pdf(lo) - _normal_pdf(hi))
            + high * ndtr(-hi) + low * ndtr(lo))


def _normal_pdf(x):
    """The standard normal density, as scipy.stats.norm.pdf computes it."""
    return np.exp(-x ** 2 / 2.0) / np.sqrt(2 * np.pi)


def _has_thrusters(config) -> bool:
    """Whether the run's scene has thrusters (a throttle action is a duty cycle in [0, 1];
    a wheel's or a rod's action spans [-1, 1])."""
    scene = (config or {}).get("scene")
    if scene is None:
        return True
    try:
        sc = rbenv.load_scene(scene)
    except ValueError:  # a scene file that is gone: keep the thruster default
        return True
    return sc.thrusters is not None


def load_run_policy(path, action: str = "auto", *, trust_pickle: bool = False) -> RunPolicy:
    """A ready policy from a run folder, its ``policy.pt`` or a checkpoint ``policy_<N>.pt``.

    The model comes with its own observation statistics and the run's configuration
    (``policy.make_env()`` builds the env it was trained on). A final model without statistics
    beside it (a model trained without VecNormalize) is used as is, with a warning; a
    checkpoint without its own statistics is an error. Nothing is unpickled: a pickle-based
    file (an older run's ``model.zip``/``vecnormalize.pkl``, a foreign SB3 ``.zip``) raises
    :class:`UntrustedPickleError` unless ``trust_pickle=True``.
    """
    files = locate(path)
    algo = (files.config or {}).get("algo")
    if files.stats is not None and files.stats.suffix == ".pkl":
        require_trust(files.stats, "a pickled VecNormalize", trust_pickle)
    model = load_model(files.model, algo,
                       trust_pickle=trust_pickle)
    stats = load_stats(files.stats, trust_pickle=trust_pickle) if files.stats else None
    return RunPolicy(model, stats, files.config, source=str(files.model), action=action)


class SB3Policy(RunPolicy):
    """A saved SB3 model with its observation statistics, behind the ``predict`` interface.

    ``model_path`` is a run folder, a final ``policy.pt`` (statistics: ``obs_stats.npz``
    beside it) or a checkpoint ``policy_<N>.pt`` (statistics: its own ``obs_stats_<N>.npz``);
    ``vecnormalize_path`` overrides the statistics; ``action`` as :class:`RunPolicy` (default:
    the run's ``policy_action``, else the mean throttle for PPO/A2C in throttle mode).
    Pickle-based files (an older run's ``model.zip``/``vecnormalize.pkl``, a foreign SB3
    ``.zip``) load only with
    ``trust_pickle=True``. Same as :func:`load_run_policy`, with a statistics override.
    """

    def __init__(self, model_path, vecnormalize_path=None, action: str = "auto",
                 trust_pickle: bool = False):
        files = locate(model_path)
        algo = (files.config or {}).get("algo")
        stats = vecnormalize_path or files.stats
        model = load_model(files.model, algo, trust_pickle=trust_pickle)
        super().__init__(model, load_stats(stats, trust_pickle=trust_pickle)
                         if stats else None, files.config, source=str(files.model),
                         action=action)
