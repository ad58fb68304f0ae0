"""Behaviour cloning: start a PPO run from a scripted controller, then let PPO improve it.

    python -m rbenv.agents.training.clone RUN --expert innocube-slew [--rollouts 4]
        [--epochs 40] [--log-std -2.0] [--noise 0.05]

``RUN`` is an SB3 PPO run folder with a checkpoint (``rbenv train --algo ppo ... --timesteps
8192`` makes one in a few seconds). From its latest checkpoint the scripted ``--expert`` (a
baseline name of the run's task, e.g. ``innocube-slew``) flies the run's own training envs for
``--rollouts`` × the episode length steps, each executed action disturbed by Gaussian noise of
``--noise`` (action units) so the data covers the states just off the expert's path; the
observation and return normalisation (VecNormalize) learns its statistics from these steps.
Then, in ``--epochs`` passes over the data, the policy's mean action is fitted to the expert's
(mean squared error) and its value function to the discounted normalised returns of the
rollouts, and the policy's log standard deviation is set to ``--log-std``. The result is
written over that checkpoint (same step count) and as the run's final policy, so ``rbenv
evaluate --policy RUN`` flies the clone and ``rbenv train --resume --out RUN --timesteps N``
fine-tunes it with PPO. ``clone.json`` in the run records the settings and the fit.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch
from rbenv.agents.policies import runfolder, weights
from rbenv.agents.policies.evaluate import make_policy
from rbenv.agents.policies.runfolder import RunFolderError, atomic_write
from rbenv.agents.training.config import TrainConfig, resumed_config
from rbenv.agents.training.sb3 import load_checkpoint, make_vec_env, save_checkpoint, set_threads
from rbenv.core.errors import InvalidParameterError

CLONE_RECORD = "clone.json"


def rollouts(env, expert, steps: int, noise: float, seed: int) -> dict:
    """``steps`` steps of every training env flown by ``expert`` (actions + noise):
    ``{"obs": raw observations (T, N, d), "action": the expert's (T, N, a), "reward":
    normalised rewards (T, N), "done": (T, N)}``; ``env`` (VecNormalize, training on)
    updates its statistics from them."""
    rng = np.random.default_rng(seed)
    low, high = env.action_space.low, env.action_space.high
    env.reset()
    out = {"obs": [], "action": [], "reward": [], "done": []}
    for _ in range(steps):
        raw = env.get_original_obs()
        action, _ = expert.predict(raw, deterministic=True)
        action = np.asarray(action, np.float32)
        flown = np.clip(action + noise * rng.standard_normal(action.shape), low, high)
        _, reward, done, _ = env.step(flown.astype(np.float32))
        for key, value in (("obs", raw), ("action", action), ("reward", reward),
                           ("done", done)):
            out[key].append(np.asarray(value))
    return {k: np.array(v) for k, v in out.items()}


def discounted_returns(reward: np.ndarray, done: np.ndarray, gamma: float) -> np.ndarray:
    """(T, N) discounted returns to each episode's end (the last steps' tails, cut by the
    data's end, are not bootstrapped)."""
    ret = np.zeros_like(reward, dtype=np.float64)
    running = np.zeros(reward.shape[1])
    for t in range(len(reward) - 1, -1, -1):
        running = reward[t] + gamma * running * (1.0 - done[t])
        ret[t] = running
    return ret


def fit(model, obs: np.ndarray, action: np.ndarray, ret: np.ndarray, epochs: int,
        batch: int, lr: float, seed: int) -> dict:
    """Fit the policy's mean action to ``action`` and its value to ``ret`` (normalised
    observations ``obs``, (M, d)); returns the final mean squared errors."""
    policy = model.policy
    torch.manual_seed(seed)
    o = torch.as_tensor(obs, dtype=torch.float32)
    a = torch.as_tensor(action, dtype=torch.float32)
    r = torch.as_tensor(ret, dtype=torch.float32)
    opt = torch.optim.Adam(policy.parameters(), lr=lr)
    gen = torch.Generator().manual_seed(seed)
    for _ in range(epochs):
        for idx in torch.randperm(len(o), generator=gen).split(batch):
            mean_loss, value_loss = _losses(policy, o[idx], a[idx], r[idx])
            opt.zero_grad()
            (mean_loss + 0.5 * value_loss).backward()
            opt.step()
    with torch.no_grad():
        mean_loss, value_loss = _losses(policy, o, a, r)
    return {"action_mse": float(mean_loss), "value_mse": float(value_loss),
            "return_var": float(r.var())}


def _losses(policy, obs, action, ret):
    features = policy.extract_features(obs)
    latent_pi, latent_vf = policy.mlp_extractor(features)
    mean = policy.action_net(latent_pi)
    value = policy.value_net(latent_vf).squeeze(-1)
    return torch.mean((mean - action) ** 2), torch.mean((value - ret) ** 2)


def clone(out, expert: str, *, rollouts_per_env: int = 4, epochs: int = 40,
          log_std: float = -2.0, noise: float = 0.05, batch: int = 4096, lr: float = 1e-3,
          seed: int = 0) -> dict:
    """Clone ``expert`` into the PPO run ``out`` (see the module); returns the record."""
    out = Path(out)
    cfg = resumed_config(TrainConfig, out)
    if cfg.algo != "ppo":
        raise InvalidParameterError(f"clone starts a PPO run; {str(out)!r} trains {cfg.algo!r}")
    set_threads(cfg.threads)
    ckpt_dir = out / runfolder.CHECKPOINTS
    loaded = load_checkpoint(cfg, ckpt_dir, make_vec_env(cfg, cfg.n_envs, cfg.seed))
    if loaded is None:
        raise RunFolderError(f"no checkpoint in {str(ckpt_dir)!r}: make one with rbenv train "
                             f"--out {out} --timesteps 8192 first")
    model, env, ckpt = loaded
    probe = gym.make_vec(cfg.env_id, num_envs=1, vectorization_mode="vector_entry_point",
                         scene=cfg.scene, **cfg.env_kwargs)
    teacher = make_policy(expert, probe)
    started = time.perf_counter()
    steps = rollouts_per_env * probe.unwrapped.plant.scene.episode_steps
    probe.close()
    data = rollouts(env, teacher, steps, noise, seed)
    ret = discounted_returns(data["reward"], data["done"], model.gamma)
    obs = env.normalize_obs(data["obs"].reshape(-1, data["obs"].shape[-1]))
    action = np.clip(data["action"].reshape(-1, data["action"].shape[-1]), -1.0, 1.0)
    collected = time.perf_counter() - started
    result = fit(model, obs, action, ret.reshape(-1), epochs, batch, lr, seed)
    with torch.no_grad():
        model.policy.log_std.fill_(log_std)
    save_checkpoint(model, ckpt_dir, ckpt.steps, ckpt.wall_time_s)
    weights.save_model(model, out / runfolder.FINAL_MODEL)
    atomic_write(out / runfolder.FINAL_STATS, lambda p: weights.save_stats(env, p))
    env.close()
    record = {"expert": expert, "checkpoint_steps": ckpt.steps, "samples": len(obs),
              "rollout_steps": steps, "noise": noise, "epochs": epochs, "batch": batch,
              "lr": lr, "log_std": log_std, "seed": seed, **result,
              "rollout_s": round(collected, 1),
              "wall_time_s": round(time.perf_counter() - started, 1)}
    (out / CLONE_RECORD).write_text(json.dumps(record, indent=2) + "\n")
    return record


def main(argv=None) -> dict:
    import argparse

    p = argparse.ArgumentParser(prog="python -m rbenv.agents.training.clone",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("run", help="an SB3 PPO run folder with a checkpoint")
    p.add_argument("--expert", required=True, help="a scripted policy of the run's task")
    p.add_argument("--rollouts", type=int, default=4, help="episode lengths of data per env")
    p.add_argument("--epochs", type=int, default=40)
    p.add_argument("--log-std", type=float, default=-2.0)
    p.add_argument("--noise", type=float, default=0.05, help="action noise while flying")
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)
    record = clone(args.run, args.expert, rollouts_per_env=args.rollouts, epochs=args.epochs,
                   log_std=args.log_std, noise=args.noise, seed=args.seed)
    print(json.dumps(record, indent=2))
    return record


if __name__ == "__main__":
    main(sys.argv[1:])
