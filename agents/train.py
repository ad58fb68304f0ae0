"""``rbenv train``: PPO or SAC on the native vector env, with checkpoints, resume and a report.

Layout of a run directory::

    config.json             resolved configuration (written first; --resume reads it)
    checkpoints/            model_<steps>.zip + vecnormalize_<steps>.pkl, latest.json
    eval/evaluations.npz    EvalCallback log: mean reward and success rate over training
    model.zip, vecnormalize.pkl    the final policy and its observation/reward statistics
    report.md, *.png        trained policy beside the PD and bang-bang baselines

Checkpoints are written to a temporary file and renamed, and ``latest.json`` is updated only
after both files of a checkpoint exist, so a run killed at any moment resumes from the last
complete checkpoint.
"""

from __future__ import annotations

import json
import os
import platform
import time
import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.callbacks import BaseCallback, CallbackList, EvalCallback
from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

import rbenv
from agents.sb3 import SB3VecEnv

DEFAULT_HYPERPARAMS = {
    "ppo": {"n_steps": 64, "batch_size": 1024, "n_epochs": 5, "learning_rate": 5e-4,
            "gamma": 0.99, "gae_lambda": 0.95, "clip_range": 0.2, "ent_coef": 0.0,
            "policy_kwargs": {"net_arch": [128, 128], "log_std_init": -1.0}},
    "sac": {"learning_rate": 1e-3, "buffer_size": 300_000, "batch_size": 256,
            "learning_starts": 5_000, "train_freq": 1, "gradient_steps": 1, "gamma": 0.99,
            "tau": 0.01, "policy_kwargs": {"net_arch": [256, 256]}},
}
DEFAULT_N_ENVS = {"ppo": 64, "sac": 8}
DEFAULT_TIMESTEPS = {"ppo": 2_000_000, "sac": 200_000}


@dataclass
class TrainConfig:
    """Everything that defines a training run; saved as ``config.json`` in the run directory."""

    algo: str = "ppo"
    timesteps: int | None = None
    n_envs: int | None = None
    seed: int = 0
    scene: str = "cubesat-12u"
    out: str | None = None
    env_kwargs: dict = field(default_factory=dict)
    hyperparams: dict = field(default_factory=dict)
    checkpoint_every: int = 200_000  # timesteps
    eval_every: int = 200_000  # timesteps
    eval_episodes: int = 100
    report_episodes: int = 500
    report_seed: int = 1_000_000

    def resolve(self) -> TrainConfig:
        """Fill defaults that depend on the algorithm; validate names."""
        if self.algo not in DEFAULT_HYPERPARAMS:
            raise ValueError(f"algo must be 'ppo' or 'sac', got {self.algo!r}")
        self.timesteps = int(self.timesteps or DEFAULT_TIMESTEPS[self.algo])
        self.n_envs = int(self.n_envs or DEFAULT_N_ENVS[self.algo])
        if self.timesteps <= 0 or self.n_envs <= 0:
            raise ValueError(f"timesteps and n_envs must be > 0, got {self.timesteps}, "
                             f"{self.n_envs}")
        self.hyperparams = {**DEFAULT_HYPERPARAMS[self.algo], **self.hyperparams}
        self.out = self.out or f"runs/{self.algo}-{self.scene}-seed{self.seed}"
        return self


def make_vec_env(cfg: TrainConfig, n_envs: int, seed: int) -> VecMonitor:
    """SB3 view of the native vector env (same-step autoreset), monitored."""
    venv = gym.make_vec(rbenv.ENV_ID, num_envs=n_envs, vectorization_mode="vector_entry_point",
                        autoreset_mode=AutoresetMode.SAME_STEP, scene=cfg.scene,
                        **cfg.env_kwargs)
    env = VecMonitor(SB3VecEnv(venv), info_keywords=("is_success",))
    env.seed(seed)
    return env


class AtomicCheckpoint(BaseCallback):
    """Every ``every`` timesteps save model + VecNormalize atomically and update latest.json."""

    def __init__(self, directory: Path, every: int):
        super().__init__()
        self.directory, self.every, self._next = Path(directory), every, None

    def _on_training_start(self) -> None:
        self.directory.mkdir(parents=True, exist_ok=True)
        self._next = (self.num_timesteps // self.every + 1) * self.every

    def _on_step(self) -> bool:
        if self.num_timesteps >= self._next:
            save_checkpoint(self.model, self.directory, self.num_timesteps)
            self._next += self.every
        return True


def _atomic(path: Path, write) -> None:
    tmp = path.with_name(path.name + ".tmp")
    write(tmp)
    os.replace(tmp, path)


def save_checkpoint(model, directory: Path, steps: int) -> None:
    """Write model_<steps>.zip and vecnormalize_<steps>.pkl, then point latest.json at them."""
    directory = Path(directory)
    model_path = directory / f"model_{steps}.zip"
    stats_path = directory / f"vecnormalize_{steps}.pkl"
    _atomic(model_path, lambda p: _save_to(model, p))
    _atomic(stats_path, model.get_vec_normalize_env().save)
    _atomic(directory / "latest.json",
            lambda p: p.write_text(json.dumps({"timesteps": steps, "model": model_path.name,
                                               "vecnormalize": stats_path.name})))


def latest_checkpoint(directory: Path) -> dict | None:
    """The last complete checkpoint recorded in latest.json, or None."""
    pointer = Path(directory) / "latest.json"
    if not pointer.exists():
        return None
    info = json.loads(pointer.read_text())
    if not (Path(directory) / info["model"]).exists():
        return None
    return info


def _algo_class(name: str):
    from stable_baselines3 import PPO, SAC

    return {"ppo": PPO, "sac": SAC}[name]


def _versions() -> dict:
    import stable_baselines3
    import torch

    return {"python": platform.python_version(), "numpy": np.__version__,
            "gymnasium": gym.__version__, "stable_baselines3": stable_baselines3.__version__,
            "torch": torch.__version__}


def train(cfg: TrainConfig, *, resume: bool = False, progress_bar: bool = True,
          report: bool = True, verbose: int = 0) -> Path:
    """Train (or resume) and save the run; returns the run directory."""
    out = Path(cfg.out) if cfg.out else None
    if resume and out is not None and (out / "config.json").exists():
        # The saved run defines the experiment; only a new total of timesteps may be given.
        saved = json.loads((out / "config.json").read_text())
        known = TrainConfig.__dataclass_fields__
        new_total = cfg.timesteps
        cfg = TrainConfig(**{k: v for k, v in saved.items() if k in known})
        cfg.timesteps = new_total or cfg.timesteps
    cfg.resolve()
    out = Path(cfg.out)
    (out / "checkpoints").mkdir(parents=True, exist_ok=True)
    if not (resume and (out / "config.json").exists()):
        (out / "config.json").write_text(json.dumps({**asdict(cfg), "versions": _versions()},
                                                    indent=2) + "\n")
    algo = _algo_class(cfg.algo)
    base = make_vec_env(cfg, cfg.n_envs, cfg.seed)
    ckpt = latest_checkpoint(out / "checkpoints") if resume else None
    if ckpt is not None:
        env = VecNormalize.load(str(out / "checkpoints" / ckpt["vecnormalize"]), base)
        model = algo.load(out / "checkpoints" / ckpt["model"], env=env, device="cpu")
        done = int(ckpt["timesteps"])
        print(f"resuming {cfg.algo} from {done} timesteps ({out / 'checkpoints'})")
    else:
        env = VecNormalize(base, gamma=cfg.hyperparams.get("gamma", 0.99))
        model = algo("MlpPolicy", env, seed=cfg.seed, device="cpu", verbose=verbose,
                     **cfg.hyperparams)
        done = 0
    eval_env = VecNormalize(make_vec_env(cfg, min(cfg.eval_episodes, 50), cfg.seed + 10_000),
                            training=False, norm_reward=False)
    per_call = cfg.n_envs
    callbacks = CallbackList([
        AtomicCheckpoint(out / "checkpoints", cfg.checkpoint_every),
        EvalCallback(eval_env, n_eval_episodes=cfg.eval_episodes,
                     eval_freq=max(cfg.eval_every // per_call, 1), log_path=str(out / "eval"),
                     deterministic=True, verbose=verbose, warn=False),
    ])
    start = time.time()
    remaining = max(cfg.timesteps - done, 0)
    if remaining:
        with warnings.catch_warnings():
            # SB3's progress bar is tqdm.rich, which warns that it is experimental on every run.
            warnings.filterwarnings("ignore", message="rich is experimental")
            model.learn(remaining, callback=callbacks, progress_bar=progress_bar,
                        reset_num_timesteps=ckpt is None)
    wall = time.time() - start
    _atomic(out / "model.zip", lambda p: _save_to(model, p))
    _atomic(out / "vecnormalize.pkl", env.save)
    summary = {"timesteps": int(model.num_timesteps), "wall_time_s": wall,
               "resumed_from": done if ckpt else None}
    (out / "training.json").write_text(json.dumps(summary, indent=2) + "\n")
    env.close()
    eval_env.close()
    if report:
        from agents.report import write_report

        write_report(out, cfg, summary)
    return out


def _save_to(model, path: Path) -> None:
    # model.save appends ".zip" to a path without it, so write through an open file.
    with open(path, "wb") as f:
        model.save(f)
