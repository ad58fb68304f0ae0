"""Expose a Gymnasium vector env (SAME_STEP autoreset) as a Stable-Baselines3 ``VecEnv``.

SB3's VecEnv API predates Gymnasium 1.x: ``reset()`` returns only observations, ``step_wait``
returns ``(obs, rewards, dones, infos: list[dict])``, and a finished sub-env must already hold
the next episode's first observation, with the real last one in
``infos[i]["terminal_observation"]`` and ``infos[i]["TimeLimit.truncated"]`` set for timeouts
(PPO bootstraps from it, SAC replaces ``next_obs`` with it). Gymnasium's SAME_STEP autoreset
gives exactly that information as ``info["final_obs"]``/``info["final_info"]``; this adapter
renames it. The native rbenv vector env steps all satellites in one NumPy call, so training
does not pay for one Python env object per satellite.
"""

from __future__ import annotations

from collections.abc import Sequence

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env.base_vec_env import VecEnv


def _entry(batched: dict, i: int) -> dict:
    """Sub-env i's view of a Gymnasium dict-of-arrays info (honouring ``_key`` masks)."""
    out = {}
    for key, value in batched.items():
        if key.startswith("_"):
            continue
        mask = batched.get("_" + key)
        if mask is not None and not mask[i]:
            continue
        if isinstance(value, dict):
            out[key] = _entry(value, i)
        else:
            item = value[i]
            out[key] = item.item() if isinstance(item, np.generic) else item
    return out


class SB3VecEnv(VecEnv):
    """SB3 view of a Gymnasium ``VectorEnv`` created with ``autoreset_mode=SAME_STEP``.

    Seeding follows SB3: ``seed(s)`` makes the next ``reset()`` seed sub-env i with ``s + i``.
    Per-episode info of finished sub-envs (``is_success``, fuel, reward terms) is copied into
    their ``infos[i]`` so ``EvalCallback`` and ``VecMonitor(info_keywords=...)`` can read it.
    """

    def __init__(self, venv: gym.vector.VectorEnv):
        mode = venv.metadata.get("autoreset_mode")
        if mode != AutoresetMode.SAME_STEP:
            raise ValueError(
                f"SB3VecEnv needs a vector env with autoreset_mode=SAME_STEP, got {mode!r}; "
                "create it with gym.make_vec('rbenv/SatelliteReorient-v0', num_envs=N, "
                "autoreset_mode=AutoresetMode.SAME_STEP)"
            )
        self.venv = venv
        self.render_mode = getattr(venv, "render_mode", None)
        super().__init__(venv.num_envs, venv.single_observation_space, venv.single_action_space)
        self._actions: np.ndarray | None = None

    def reset(self) -> np.ndarray:
        seeds = list(self._seeds) if any(s is not None for s in self._seeds) else None
        options = self._options[0] if self._options and self._options[0] else None
        obs, info = self.venv.reset(seed=seeds, options=options)
        self.reset_infos = [_entry(info, i) for i in range(self.num_envs)]
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions)

    def step_wait(self):
        obs, rewards, terminated, truncated, info = self.venv.step(self._actions)
        dones = np.logical_or(terminated, truncated)
        infos: list[dict] = [{} for _ in range(self.num_envs)]
        if dones.any():
            final_obs = info.get("final_obs")
            final_info = info.get("final_info", {})
            for i in np.flatnonzero(dones):
                entry = _entry(final_info, int(i)) if final_info else {}
                entry["terminal_observation"] = final_obs[i]
                entry["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
                infos[i] = entry
        return obs, np.asarray(rewards, dtype=np.float32), dones, infos

    def close(self) -> None:
        self.venv.close()

    def render(self, mode: str | None = None):
        return self.venv.render()

    def _indices(self, indices) -> Sequence[int]:
        if indices is None:
            return range(self.num_envs)
        if isinstance(indices, int):
            return [indices]
        return indices

    def get_attr(self, attr_name: str, indices=None) -> list:
        value = getattr(self.venv, attr_name)
        return [value for _ in self._indices(indices)]

    def set_attr(self, attr_name: str, value, indices=None) -> None:
        setattr(self.venv, attr_name, value)

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs) -> list:
        result = getattr(self.venv, method_name)(*method_args, **method_kwargs)
        return [result for _ in self._indices(indices)]

    def env_is_wrapped(self, wrapper_class, indices=None) -> list[bool]:
        # The native vector env holds no per-sub-env Gymnasium wrappers.
        return [False for _ in self._indices(indices)]
