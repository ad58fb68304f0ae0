"""Behaviour cloning: start a PPO run from a scripted controller, then let PPO improve it.

    python -m rbenv.agents.training.clone RUN --expert innocube-slew [--rollouts 4]
        [--epochs 40] [--log-std -2.0] [--noise 0.05] [--expert-kwargs JSON]
        [--dagger 0] [--dagger-epochs 20] [--lr 1e-3]

``RUN`` is an SB3 PPO run folder with a checkpoint (``rbenv train --algo ppo ... --timesteps
8192`` makes one in a few seconds). From its latest checkpoint the scripted ``--expert`` (a
baseline name of the run's task, e.g. ``innocube-slew``; ``--expert-kwargs`` sets its fields,
e.g. ``'{"rate_gain": 1.2}'``) flies the run's own training envs for ``--rollouts`` × the
episode length steps, each executed action disturbed by Gaussian noise of ``--noise`` (action
units) so the data covers the states just off the expert's path; the observation and return
normalisation (VecNormalize) learns its statistics from these steps. Then, in ``--epochs``
passes over the data, the policy's mean action is fitted to the expert's (mean squared error)
and its value function to the discounted normalised returns of the rollouts. ``--dagger N``
then adds N rounds of DAgger (Ross, Gordon & Bagnell 2011): the clone itself flies as many
steps (its mean action, the same noise), the expert labels the states the clone reached, and
the policy is fitted again, ``--dagger-epochs`` passes over all the data so far, so the clone
learns to recover from its own mistakes, not only the expert's. Last, the policy's log
standard deviation is set to ``--log-std``. The result is written over that checkpoint (same
step count) and as the run's final policy, so ``rbenv evaluate --policy RUN`` flies the clone
and ``rbenv train --resume --out RUN --timesteps N`` fine-tunes it with PPO. ``clone.json`` in
the run records the settings and the fit.
"""

from __future__ import annotations

import dataclasses
import json
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch
from rbenv.agents.baselines.controllers import BASELINES, env_parts
from rbenv.agents.policies import runfolder, weights
from rbenv.agents.policies.evaluate import make_policy
from rbenv.agents.policies.runfolder import RunFolderError, atomic_write
from rbenv.agents.training.config import TrainConfig, resumed_config
from rbenv.agents.training.sb3 import load_checkpoint, make_vec_env, save_checkpoint, set_threads
from rbenv.core.errors import InvalidParameterError

CLONE_RECORD = "clone.json"


def rollouts(env, expert, steps: int, noise: float, seed: int, pilot=None) -> dict:
    """``steps`` steps of every training env flown by ``pilot`` (None: ``expert``; else an
    SB3 model, its mean action on the normalised observation) with Gaussian action noise of
    ``noise``: ``{"obs": raw observations (T, N, d), "action": the expert's for them
    (T, N, a), "reward": normalised rewards (T, N), "done": (T, N)}``; ``env`` (VecNormalize,
    training on) updates its statistics from them."""
    rng = np.random.default_rng(seed)
    low, high = env.action_space.low, env.action_space.high
    env.reset()
    out = {"obs": [], "action": [], "reward": [], "done": []}
    for _ in range(steps):
        raw = env.get_original_obs()
        action, _ = expert.predict(raw, deterministic=True)
        action = np.asarray(action, np.float32)
        if pilot is not None:
            action_flown, _ = pilot.predict(env.normalize_obs(raw), deterministic=True)
        else:
            action_flown = action
        flown = np.clip(action_flown + noise * rng.standard_normal(action.shape), low, high)
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
          seed: int = 0, expert_kwargs: dict | None = None, dagger: int = 0,
          dagger_epochs: int = 20) -> dict:
    """Clone ``expert`` into the PPO run ``out`` (see the module); returns the record."""
    out = Path(out)
    cfg = resumed_config(TrainConfig, out)
    if cfg.algo != "ppo":
        raise InvalidParameterError(f"clone starts a PPO run; {str(out)!r} trains {cfg.algo!r}")
    for name, value, least in (("rollouts", rollouts_per_env, 1), ("epochs", epochs, 1),
                               ("dagger", dagger, 0), ("dagger_epochs", dagger_epochs, 1)):
        if not isinstance(value, int) or value < least:
            raise InvalidParameterError(f"clone: {name} must be an integer >= {least}, "
                                        f"got {value!r}")
    set_threads(cfg.threads)
    ckpt_dir = out / runfolder.CHECKPOINTS
    loaded = load_checkpoint(cfg, ckpt_dir, make_vec_env(cfg, cfg.n_envs, cfg.seed))
    if loaded is None:
        raise RunFolderError(f"no checkpoint in {str(ckpt_dir)!r}: make one with rbenv train "
                             f"--out {out} --timesteps 8192 first")
    model, env, ckpt = loaded
    probe = gym.make_vec(cfg.env_id, num_envs=1, vectorization_mode="vector_entry_point",
                         scene=cfg.scene, **cfg.env_kwargs)
    teacher = _expert(expert, probe, expert_kwargs)
    started = time.perf_counter()
    steps = rollouts_per_env * probe.unwrapped.plant.scene.episode_steps
    probe.close()
    raw, action, ret, fits, flown_s = [], [], [], [], 0.0
    for rnd in range(dagger + 1):
        tick = time.perf_counter()
        data = rollouts(env, teacher, steps, noise, seed + rnd, model if rnd else None)
        flown_s += time.perf_counter() - tick
        raw.append(data["obs"].reshape(-1, data["obs"].shape[-1]))
        action.append(np.clip(data["action"].reshape(-1, data["action"].shape[-1]), -1.0, 1.0))
        ret.append(discounted_returns(data["reward"], data["done"], model.gamma).reshape(-1))
        obs = env.normalize_obs(np.concatenate(raw))
        fits.append(fit(model, obs, np.concatenate(action), np.concatenate(ret),
                        epochs if rnd == 0 else dagger_epochs, batch, lr, seed + rnd))
    result = fits[-1]
    with torch.no_grad():
        model.policy.log_std.fill_(log_std)
    save_checkpoint(model, ckpt_dir, ckpt.steps, ckpt.wall_time_s)
    weights.save_model(model, out / runfolder.FINAL_MODEL)
    atomic_write(out / runfolder.FINAL_STATS, lambda p: weights.save_stats(env, p))
    env.close()
    record = {"expert": expert, "checkpoint_steps": ckpt.steps, "samples": len(obs),
              "rollout_steps": steps, "noise": noise, "epochs": epochs, "batch": batch,
              "lr": lr, "log_std": log_std, "seed": seed, **result,
              "rollout_s": round(flown_s, 1),
              "wall_time_s": round(time.perf_counter() - started, 1)}
    if expert_kwargs:
        record["expert_kwargs"] = dict(expert_kwargs)
    if dagger:
        record.update(dagger=dagger, dagger_epochs=dagger_epochs,
                      action_mse_per_round=[f["action_mse"] for f in fits])
    (out / CLONE_RECORD).write_text(json.dumps(record, indent=2) + "\n")
    return record


def _expert(name: str, env, kwargs: dict | None):
    """The scripted policy ``name`` of ``env``'s task, its fields set from ``kwargs``."""
    if not kwargs:
        return make_policy(name, env)
    if not isinstance(kwargs, dict):
        raise InvalidParameterError(f"clone: expert_kwargs must be a dict of field -> value, "
                                    f"got {kwargs!r}")
    task = env_parts(env)[1].name
    if name not in BASELINES[task]:
        raise InvalidParameterError(f"clone: expert_kwargs set the fields of a scripted "
                                    f"baseline of {task} ({sorted(BASELINES[task])}), got "
                                    f"expert {name!r}")
    cls = BASELINES[task][name]
    known = {f.name for f in dataclasses.fields(cls) if f.init}
    unknown = sorted(set(kwargs) - known)
    if unknown:
        raise InvalidParameterError(f"clone: expert_kwargs has unknown field(s) {unknown} of "
                                    f"{cls.__name__}; fields are {sorted(known)}")
    plant, task_obj = env_parts(env)
    return cls(plant, task_obj, **kwargs)


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
    p.add_argument("--lr", type=float, default=1e-3, help="Adam's learning rate of the fit")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--expert-kwargs", type=json.loads, default=None,
                   help="JSON of the expert's fields, e.g. '{\"rate_gain\": 1.2}'")
    p.add_argument("--dagger", type=int, default=0,
                   help="rounds of DAgger: the clone flies, the expert labels")
    p.add_argument("--dagger-epochs", type=int, default=20, help="passes per DAgger round")
    args = p.parse_args(argv)
    record = clone(args.run, args.expert, rollouts_per_env=args.rollouts, epochs=args.epochs,
                   log_std=args.log_std, noise=args.noise, lr=args.lr,
                   seed=args.seed, expert_kwargs=args.expert_kwargs, dagger=args.dagger,
                   dagger_epochs=args.dagger_epochs)
    print(json.dumps(record, indent=2))
    return record


if __name__ == "__main__":
    main(sys.argv[1:])
