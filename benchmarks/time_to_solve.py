"""Time to solve: training wall time until a policy ends >= 99 % of 500 held-out episodes.

Run ``python -m benchmarks.time_to_solve [--paths NAME ...] [--seeds 0 1 2]`` (``--quick``: a
seconds-long smoke form, CI's, written as ``time_to_solve_quick``). Results:
``benchmarks/results/time_to_solve.json`` and ``.png``; docs/performance.md has the table.

Each path is one learner with one set of settings on ``rbenv/SatelliteReorient-v1`` and the
default scene (cubesat-12u). Training runs to the path's budget; every ``eval_every`` samples
the clock stops, the current policy acts on the held-out episodes (seeds 1,000,000 + i, the
report's, acting as ``rbenv evaluate`` acts: the mean throttle for a Gaussian policy) and the
clock restarts. The time to solve is the training wall time (evaluations excluded) at the first
evaluation >= the target; the samples are the env steps at that point. A path that never
reaches it records its best rate and its total time, so a miss is a measured value.

Wall times depend on the machine and its load: each run stores ``os.getloadavg()`` before and
after it, and the machine record.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import time

import numpy as np
from rbenv.agents.settings.shipped import REORIENT_V1_PPO

from benchmarks.common import RESULTS, pyplot, save_figure, table, write_json

ENV_ID = "rbenv/SatelliteReorient-v1"
HELD_OUT_SEED = 1_000_000
TARGET = 0.99


@dataclasses.dataclass(frozen=True)
class Path:
    """One learner and its settings. engine: sb3, sbx, torchrl, rsl_rl or skrl. hyperparams:
    over the registry's settings (sb3, sbx), fields of TorchRLConfig (torchrl) or the
    library's own config names (rsl_rl, skrl). budget: env steps at most. The sb3 and sbx
    paths train on Reorient-v1's own reward: the recipe's env options (the 2 M-step recipe's
    reward weights on cubesat-12u) are not applied."""

    name: str
    engine: str = "sb3"
    algo: str = "ppo"
    n_envs: int | None = None
    hyperparams: dict = dataclasses.field(default_factory=dict)
    budget: int = 1_500_000
    eval_every: int = 100_000
    threads: int = 1
    # Train on to the budget past the target (its final policy, the one a run ends with, is
    # evaluated there); else stop at the first evaluation >= the target.
    to_budget: bool = False


FAST = REORIENT_V1_PPO
PROBE = {"n_steps": 32, "batch_size": 2048, "n_epochs": 4, "learning_rate": 1e-3,
         "policy_kwargs": {"net_arch": [64, 64], "log_std_init": -1.0}}


def _ppo(**over) -> dict:
    """PROBE with some values replaced (policy_kwargs' net_arch by ``net``)."""
    net = over.pop("net", None)
    out = {**PROBE, **over}
    if net is not None:
        out["policy_kwargs"] = {**PROBE["policy_kwargs"], "net_arch": net}
    return out


PATHS = {p.name: p for p in [
    # Reorient-v1's fast recipe (REORIENT_V1_PPO, 600k steps): rbenv train's default on that id
    # until the 2 M-step recipe; the "Time to 99 %" table of docs/performance.md (its runs are
    # named sb3-shipped in time_to_solve.json).
    Path("sb3-v1-fast", n_envs=FAST["n_envs"], budget=FAST["n_timesteps"], eval_every=50_000,
         hyperparams={k: v for k, v in FAST.items() if k not in ("n_envs", "n_timesteps")}),
    Path("sb3-probe", n_envs=256, hyperparams=PROBE),
    Path("sb3-lr2e-3", n_envs=256, hyperparams=_ppo(learning_rate=2e-3)),
    Path("sb3-512x16-b4096-lr2e-3", n_envs=512,
         hyperparams=_ppo(n_steps=16, batch_size=4096, learning_rate=2e-3)),
    Path("sb3-b4096-e3-lr2e-3", n_envs=256, eval_every=50_000,
         hyperparams=_ppo(batch_size=4096, n_epochs=3, learning_rate=2e-3)),
    Path("sb3-1024x16-b4096-lr2e-3", n_envs=1024,
         hyperparams=_ppo(n_steps=16, batch_size=4096, learning_rate=2e-3)),
    Path("sb3-32x32-lr2e-3", n_envs=256, hyperparams=_ppo(learning_rate=2e-3, net=[32, 32])),
    Path("sb3-lr3e-3", n_envs=256, hyperparams=_ppo(learning_rate=3e-3)),
    Path("sb3-n16-lr2e-3", n_envs=256, eval_every=50_000,
         hyperparams=_ppo(n_steps=16, learning_rate=2e-3)),
    Path("sb3-n16-lr3e-3", n_envs=256, hyperparams=_ppo(n_steps=16, learning_rate=3e-3)),
    Path("sb3-n16-e2-lr3e-3", n_envs=256,
         hyperparams=_ppo(n_steps=16, n_epochs=2, learning_rate=3e-3)),
    Path("sb3-n16-b4096-e3-lr2e-3", n_envs=256, eval_every=50_000,
         hyperparams=_ppo(n_steps=16, batch_size=4096, n_epochs=3, learning_rate=2e-3)),
    Path("sb3-n16-b4096-e4-lr3e-3", n_envs=256, eval_every=50_000,
         hyperparams=_ppo(n_steps=16, batch_size=4096, n_epochs=4, learning_rate=3e-3)),
    Path("sb3-512x8-b4096-e3-lr2e-3", n_envs=512, eval_every=50_000,
         hyperparams=_ppo(n_steps=8, batch_size=4096, n_epochs=3, learning_rate=2e-3)),
    Path("sb3-n16-b4096-e3-lr2e-3-net32", n_envs=256, eval_every=50_000,
         hyperparams=_ppo(n_steps=16, batch_size=4096, n_epochs=3, learning_rate=2e-3,
                          net=[32, 32])),
    # Sample efficiency around sb3-b4096-e3-lr2e-3 (B), one change each.
    *[Path(f"B-{tag}", n_envs=256, eval_every=50_000, budget=1_200_000,
           hyperparams=_ppo(**{"batch_size": 4096, "n_epochs": 3, "learning_rate": 2e-3,
                              **over}))
      for tag, over in {
          "linlr3e-3": {"learning_rate": "lin_3e-3"},
          "linlr4e-3": {"learning_rate": "lin_4e-3"},
          "std-1.5": {"policy_kwargs": {"net_arch": [64, 64], "log_std_init": -1.5}},
          "std-2": {"policy_kwargs": {"net_arch": [64, 64], "log_std_init": -2.0}},
          "g0.98": {"gamma": 0.98},
          "g0.995": {"gamma": 0.995},
          "lam0.9": {"gae_lambda": 0.9},
          "e5": {"n_epochs": 5},
          "clip0.3": {"clip_range": 0.3},
          "net128": {"policy_kwargs": {"net_arch": [128, 128], "log_std_init": -1.0}},
          # Third sweep (2026-12-03, fourth session): seeds 1 and 2 first, the slow ones.
          "std-0.5": {"policy_kwargs": {"net_arch": [64, 64], "log_std_init": -0.5}},
          "std0": {"policy_kwargs": {"net_arch": [64, 64], "log_std_init": 0.0}},
          "lam0.98": {"gae_lambda": 0.98},
          "vf1": {"vf_coef": 1.0},
          "b8192-lr3e-3": {"batch_size": 8192, "learning_rate": 3e-3},
          "gn2": {"max_grad_norm": 2.0},
          "noortho": {"policy_kwargs": {"net_arch": [64, 64], "log_std_init": -1.0,
                                        "ortho_init": False}},
          "relu": {"policy_kwargs": {"net_arch": [64, 64], "log_std_init": -1.0,
                                     "activation_fn": "relu"}},
          "g0.98-std-0.5": {"gamma": 0.98, "policy_kwargs": {"net_arch": [64, 64],
                                                             "log_std_init": -0.5}},
      }.items()],
    # A linear learning rate that reaches 0 at the budget: the final policy is the one shipped.
    *[Path(f"B-linlr{lr}-{k}k", n_envs=256, eval_every=50_000, budget=k * 1000, to_budget=True,
           hyperparams=_ppo(batch_size=4096, n_epochs=3, learning_rate=f"lin_{lr}"))
      for lr in ("3e-3", "4e-3") for k in (600, 800)],
    # More envs, shorter rollouts, the same 8192 samples per update: cheaper per sample (each
    # Python step carries more satellites).
    Path("B-1024x8", n_envs=1024, eval_every=50_000, budget=1_200_000,
         hyperparams=_ppo(n_steps=8, batch_size=4096, n_epochs=3, learning_rate=2e-3)),
    Path("B-2048x4", n_envs=2048, eval_every=50_000, budget=1_200_000,
         hyperparams=_ppo(n_steps=4, batch_size=4096, n_epochs=3, learning_rate=2e-3)),
    *[Path(f"B-1024x8-linlr{lr}-{k}k", n_envs=1024, eval_every=50_000, budget=k * 1000,
           to_budget=True, hyperparams=_ppo(n_steps=8, batch_size=4096, n_epochs=3,
                                            learning_rate=f"lin_{lr}"))
      for lr in ("3e-3",) for k in (800,)],
    # The other libraries with sb3-b4096-e3-lr2e-3's settings, in their own names.
    Path("rsl_rl-b4096-e3-lr2e-3", engine="rsl_rl", n_envs=256, eval_every=50_000,
         hyperparams={"num_steps_per_env": 32, "num_mini_batches": 2,
                      "num_learning_epochs": 3, "learning_rate": 2e-3}),
    Path("skrl-b4096-e3-lr2e-3", engine="skrl", n_envs=256, eval_every=50_000,
         hyperparams={"rollouts": 32, "mini_batches": 2, "learning_epochs": 3,
                      "learning_rate": 2e-3}),
    Path("torchrl-b4096-e3-lr2e-3", engine="torchrl", eval_every=50_000,
         hyperparams={"num_envs": 256, "rollout": 32, "minibatch": 4096, "epochs": 3,
                      "lr": 2e-3, "hidden": 64}),
    # The same libraries with the third sweep's two changes (gamma 0.98, log std -0.5).
    Path("rsl_rl-g0.98-std-0.5", engine="rsl_rl", n_envs=256, eval_every=50_000,
         budget=800_000,
         hyperparams={"num_steps_per_env": 32, "num_mini_batches": 2, "num_learning_epochs": 3,
                      "learning_rate": 2e-3, "gamma": 0.98, "init_std": float(np.exp(-0.5))}),
    Path("skrl-g0.98-std-0.5", engine="skrl", n_envs=256, eval_every=50_000, budget=800_000,
         hyperparams={"rollouts": 32, "mini_batches": 2, "learning_epochs": 3,
                      "learning_rate": 2e-3, "discount_factor": 0.98, "log_std_init": -0.5}),
    Path("torchrl-g0.98-std-0.5", engine="torchrl", eval_every=50_000, budget=800_000,
         hyperparams={"num_envs": 256, "rollout": 32, "minibatch": 4096, "epochs": 3,
                      "lr": 2e-3, "hidden": 64, "gamma": 0.98, "log_std_init": -0.5}),
    # The same on a longer budget: the settings --engine torchrl ships for Reorient-v1.
    Path("torchrl-g0.98-std-0.5-1.2M", engine="torchrl", eval_every=50_000, budget=1_200_000,
         hyperparams={"num_envs": 256, "rollout": 32, "minibatch": 4096, "epochs": 3,
                      "lr": 2e-3, "hidden": 64, "gamma": 0.98, "log_std_init": -0.5}),
]}

# The off-policy learners, FastSAC/FastTD3's recipe on a CPU: more envs, fewer and larger
# gradient steps per env step, smaller networks. hyperparams: over the registry's settings of
# the algorithm (rbenv.agents.settings.tuned: 32 envs, batch 512, 8 gradient steps per vector
# step, [256, 256]); engine sbx is SBX (JAX) with SB3's settings names.
def _off(net=(64, 64), **over) -> dict:
    return {"policy_kwargs": {"net_arch": list(net)}, **over}


PATHS.update({p.name: p for p in [
    Path("sbx-sac-32e-64", engine="sbx", algo="sac", n_envs=32, budget=300_000,
         eval_every=25_000, hyperparams=_off()),
    Path("sb3-sac-32e-64", engine="sb3", algo="sac", n_envs=32, budget=300_000,
         eval_every=25_000, hyperparams=_off()),
    Path("sbx-sac-32e-128", engine="sbx", algo="sac", n_envs=32, budget=300_000,
         eval_every=25_000, hyperparams=_off(net=(128, 128))),
    Path("sbx-sac-256e-b1024-g16-64", engine="sbx", algo="sac", n_envs=256, budget=800_000,
         eval_every=50_000, hyperparams=_off(batch_size=1024, gradient_steps=16)),
    Path("sbx-td3-32e-64", engine="sbx", algo="td3", n_envs=32, budget=300_000,
         eval_every=25_000, hyperparams=_off()),
    Path("sbx-td3-256e-b1024-g16-64", engine="sbx", algo="td3", n_envs=256, budget=800_000,
         eval_every=50_000, hyperparams=_off(batch_size=1024, gradient_steps=16)),
    Path("sbx-td3-512e-b1024-g16-64", engine="sbx", algo="td3", n_envs=512, budget=800_000,
         eval_every=50_000, hyperparams=_off(batch_size=1024, gradient_steps=16)),
    Path("sb3-td3-256e-b1024-g16-64", engine="sb3", algo="td3", n_envs=256, budget=800_000,
         eval_every=50_000, hyperparams=_off(batch_size=1024, gradient_steps=16)),
    Path("sb3-sac-256e-b1024-g16-64", engine="sb3", algo="sac", n_envs=256, budget=800_000,
         eval_every=50_000, hyperparams=_off(batch_size=1024, gradient_steps=16)),
]})


def _quick_off_policy(path: Path) -> Path:
    """The seconds-long form of an off-policy path: 2048 samples of 64 envs, gradient steps
    from 1024 on, two evaluations."""
    return dataclasses.replace(path, budget=2_048, eval_every=1_024, n_envs=64, hyperparams={
        **path.hyperparams, "learning_starts": 1_024, "batch_size": 64, "gradient_steps": 2})


def _load() -> list[float]:
    return [round(x, 2) for x in os.getloadavg()]


# --- SB3 ---------------------------------------------------------------------------------------

def sb3_run(path: Path, seed: int, episodes: int = 500, log=print) -> dict:
    """Train ``path`` (SB3) with seed ``seed``; the held-out curve and the time to solve."""
    import torch
    from rbenv.agents.policies.evaluate import evaluate
    from rbenv.agents.policies.sb3 import RunPolicy
    from rbenv.agents.training.config import TrainConfig
    from rbenv.agents.training.sb3 import algo_class, make_vec_env, model_kwargs, set_threads
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.vec_env import VecNormalize

    torch.set_num_threads(path.threads)
    set_threads(path.threads)  # and XLA's (sbx)
    cfg = TrainConfig(env_id=ENV_ID, algo=path.algo, seed=seed, n_envs=path.n_envs,
                      hyperparams=dict(path.hyperparams), threads=path.threads,
                      timesteps=path.budget, recipe_env_kwargs=False).resolve()
    run_config = dataclasses.asdict(cfg)

    class Clocked(BaseCallback):
        """Held-out evaluation every eval_every samples, outside the training clock; stops
        training at the first evaluation >= TARGET."""

        def __init__(self):
            super().__init__()
            self.curve, self.paused, self.paused_cpu = [], 0.0, 0.0
            self.next = path.eval_every

        def _on_training_start(self) -> None:
            self.t0, self.cpu0 = time.perf_counter(), time.process_time()

        def _on_step(self) -> bool:
            if self.num_timesteps < self.next:
                return True
            self.next += path.eval_every
            return self.evaluate()

        def evaluate(self) -> bool:
            tick, tock = time.perf_counter(), time.process_time()
            train_s = tick - self.t0 - self.paused
            cpu_s = tock - self.cpu0 - self.paused_cpu
            policy = RunPolicy(self.model, self.model.get_vec_normalize_env(), run_config,
                               source="training model")
            rate = float(evaluate(policy, episodes=episodes, seed=HELD_OUT_SEED, env_id=ENV_ID,
                                  scene=cfg.scene, env_kwargs=cfg.env_kwargs,
                                  record=0).success.mean())
            self.curve.append({"samples": int(self.num_timesteps), "train_s": train_s,
                               "cpu_s": cpu_s, "success": rate})
            log(f"  {path.name} seed {seed}: {self.num_timesteps} samples, {train_s:.1f} s "
                f"({cpu_s:.1f} s CPU), held out {100 * rate:.1f} %")
            self.paused += time.perf_counter() - tick
            self.paused_cpu += time.process_time() - tock
            return rate < TARGET or path.to_budget

    load0 = _load()
    env = VecNormalize(make_vec_env(cfg, cfg.n_envs, seed),
                       gamma=cfg.hyperparams.get("gamma", 0.99),
                       **(cfg.normalize or {"norm_obs": False, "norm_reward": False}))
    model = algo_class(cfg.algo, path.engine)("MlpPolicy", env, seed=seed, device="cpu",
                                              **model_kwargs(cfg, env))
    cb = Clocked()
    model.learn(cfg.timesteps, callback=cb)
    if not cb.curve or cb.curve[-1]["samples"] != model.num_timesteps:
        cb.num_timesteps = model.num_timesteps  # the trained end of the budget
        cb.evaluate()
    env.close()
    return _summary(path, seed, cb.curve, load0)


# --- TorchRL ------------------------------------------------------------------------------------

DEVICE = "cpu"  # the torchrl paths' device (--device)


def torchrl_run(path: Path, seed: int, episodes: int = 500, log=print) -> dict:
    """Train ``path`` with TorchRL's PPO on the torch env (rbenv.agents.training.torchrl),
    env and learner on ``--device``."""
    from rbenv.agents.training import torchrl as trl

    load0 = _load()
    cfg = trl.TorchRLConfig(env_id=ENV_ID, seed=seed, timesteps=path.budget,
                            threads=path.threads, eval_episodes=episodes, device=DEVICE,
                            eval_every=path.eval_every, **path.hyperparams)
    result = trl.train(cfg, log=lambda msg: log("  " + msg))
    curve = [{"samples": p["samples"], "train_s": p["s"], "cpu_s": p["cpu_s"],
              "success": p["held_out_success"]}
             for p in result["curve"] if "held_out_success" in p]
    if not curve or curve[-1]["samples"] != result["samples"]:
        curve.append({"samples": result["samples"], "train_s": result["train_wall_s"],
                      "success": result["held_out_success"]})
    return _summary(path, seed, curve, load0)


# --- rsl_rl -------------------------------------------------------------------------------------

RSL_PPO = {"num_learning_epochs": 4, "num_mini_batches": 4, "clip_param": 0.2, "gamma": 0.99,
           "lam": 0.95, "value_loss_coef": 1.0, "entropy_coef": 0.0, "learning_rate": 1e-3,
           "max_grad_norm": 1.0, "schedule": "adaptive", "desired_kl": 0.01}


def _rsl_env(num_envs: int, seed: int):
    """rbenv's torch vector env (SAME_STEP autoreset) seen as an ``rsl_rl.env.VecEnv``: one
    observation group, ``"policy"``; timeouts in ``extras["time_outs"]``."""
    import gymnasium as gym
    import torch
    from rsl_rl.env import VecEnv
    from tensordict import TensorDict

    class RslEnv(VecEnv):
        def __init__(self):
            self.env = gym.make_vec(ENV_ID, num_envs=num_envs, backend="torch", device="cpu",
                                    autoreset_mode=gym.vector.AutoresetMode.SAME_STEP)
            self.num_envs, self.device, self.cfg = num_envs, "cpu", {}
            self.num_actions = self.env.single_action_space.shape[0]
            self.max_episode_length = 160
            self.episode_length_buf = torch.zeros(num_envs, dtype=torch.long)
            obs, _ = self.env.reset(seed=seed)
            self._obs = self._group(obs)

        def _group(self, obs):
            return TensorDict({"policy": obs.float()}, batch_size=[self.num_envs])

        def get_observations(self):
            return self._obs

        def step(self, actions):
            obs, reward, term, trunc, _ = self.env.step(actions.double())
            self._obs = self._group(obs)
            return self._obs, reward.float(), (term | trunc).long(), \
                {"time_outs": (trunc & ~term).float()}

    return RslEnv()


def rsl_rl_run(path: Path, seed: int, episodes: int = 500, log=print) -> dict:
    """Train ``path`` with rsl_rl's PPO (``OnPolicyRunner``) on the torch env."""
    import torch

    try:
        from rsl_rl.runners import OnPolicyRunner
    except ImportError:
        raise SystemExit(f"path {path.name!r} needs rsl_rl, in no extra of rbenv: pip install "
                         "rsl-rl-lib (5.5 was measured)") from None
    torch.set_num_threads(path.threads)
    torch.manual_seed(seed)
    hp = dict(path.hyperparams)
    steps, hidden = hp.pop("num_steps_per_env", 32), hp.pop("hidden_dims", [64, 64])
    init_std = hp.pop("init_std", float(np.exp(-1.0)))
    model = {"class_name": "MLPModel", "hidden_dims": hidden, "activation": "tanh",
             "obs_normalization": True}
    cfg = {"num_steps_per_env": steps, "save_interval": 10**9, "obs_groups": {},
           "algorithm": {"class_name": "PPO", **RSL_PPO, **hp},
           "actor": {**model, "distribution_cfg": {"class_name": "GaussianDistribution",
                                                   "init_std": init_std}},
           "critic": model, "multi_gpu": None, "check_for_nan": False}
    load0 = _load()
    env = _rsl_env(path.n_envs, seed)
    runner = OnPolicyRunner(env, cfg, log_dir=None, device="cpu")
    per_iter = path.n_envs * steps
    curve, train_s, cpu_s, samples = [], 0.0, 0.0, 0
    while samples < path.budget:
        t0, c0 = time.perf_counter(), time.process_time()
        iters = max(1, path.eval_every // per_iter)
        runner.learn(iters)
        train_s += time.perf_counter() - t0
        cpu_s += time.process_time() - c0
        samples += iters * per_iter
        actor = runner.alg.get_policy()

        def act(obs, actor=actor):
            actor(_groups(obs), stochastic_output=True)  # sets the distribution
            return actor.output_mean, actor.output_std

        rate = torch_success_rate(act, episodes)
        curve.append({"samples": samples, "train_s": train_s, "cpu_s": cpu_s, "success": rate})
        log(f"  {path.name} seed {seed}: {samples} samples, {train_s:.1f} s ({cpu_s:.1f} s "
            f"CPU), held out {100 * rate:.1f} %")
        if rate >= TARGET:
            break
    return _summary(path, seed, curve, load0)


# --- skrl ---------------------------------------------------------------------------------------

# SB3's PPO defaults in skrl's names (the paths' hyperparams override them): VecNormalize's
# observation scaling as a running scaler; SB3 scales rewards, skrl the value targets.
SKRL_PPO = {"discount_factor": 0.99, "gae_lambda": 0.95, "ratio_clip": 0.2, "value_clip": 0.0,
            "grad_norm_clip": 0.5, "value_loss_scale": 0.5, "entropy_loss_scale": 0.0,
            "time_limit_bootstrap": True}


def _skrl_models(obs_space, act_space, hidden: list[int], log_std_init: float):
    """A Gaussian policy (state-independent log std) and a value net, tanh MLPs as SB3's."""
    import torch
    from skrl.models.torch import DeterministicMixin, GaussianMixin, Model

    def mlp(n_in: int, n_out: int) -> torch.nn.Sequential:
        layers, width = [], n_in
        for h in hidden:
            layers += [torch.nn.Linear(width, h), torch.nn.Tanh()]
            width = h
        return torch.nn.Sequential(*layers, torch.nn.Linear(width, n_out))

    class Policy(GaussianMixin, Model):
        def __init__(self):
            Model.__init__(self, observation_space=obs_space, action_space=act_space,
                           device="cpu")
            GaussianMixin.__init__(self, clip_log_std=False)
            self.net = mlp(self.num_observations, self.num_actions)
            self.log_std = torch.nn.Parameter(torch.full((self.num_actions,), log_std_init))

        def compute(self, inputs, role=""):
            return self.net(inputs["observations"]), {"log_std": self.log_std}

    class Value(DeterministicMixin, Model):
        def __init__(self):
            Model.__init__(self, observation_space=obs_space, action_space=act_space,
                           device="cpu")
            DeterministicMixin.__init__(self)
            self.net = mlp(self.num_observations, 1)

        def compute(self, inputs, role=""):
            return self.net(inputs["observations"]), {}

    return {"policy": Policy(), "value": Value()}


def skrl_run(path: Path, seed: int, episodes: int = 500, log=print) -> dict:
    """Train ``path`` with skrl's PPO on the torch env (float32, CPU), through skrl's own
    trainer loop (act, step, record_transition, post_interaction) with the clock stopped for
    each held-out evaluation. SAME_STEP autoreset: a truncated sub-env's transition is recorded
    with its final observation (``info["final_obs"]``), so the time-limit bootstrap is right."""
    import gymnasium as gym
    import torch

    try:
        from skrl.agents.torch.base import ExperimentCfg
        from skrl.agents.torch.ppo import PPO
        from skrl.memories.torch import RandomMemory
        from skrl.resources.preprocessors.torch import RunningStandardScaler
        from skrl.utils import set_seed
    except ImportError:
        raise SystemExit(f"path {path.name!r} needs skrl, in no extra of rbenv: pip install "
                         "skrl (2.1.1 was measured)") from None
    torch.set_num_threads(path.threads)
    set_seed(seed)
    hp = dict(path.hyperparams)
    hidden, log_std_init = hp.pop("hidden", [64, 64]), hp.pop("log_std_init", -1.0)
    load0 = _load()
    env = gym.make_vec(ENV_ID, num_envs=path.n_envs, backend="torch", device="cpu",
                       dtype="float32", autoreset_mode=gym.vector.AutoresetMode.SAME_STEP)
    obs_space, act_space = env.single_observation_space, env.single_action_space
    low, high = (torch.as_tensor(b) for b in (act_space.low, act_space.high))
    rollouts = hp["rollouts"]
    agent = PPO(models=_skrl_models(obs_space, act_space, hidden, log_std_init),
                memory=RandomMemory(memory_size=rollouts, num_envs=path.n_envs, device="cpu"),
                observation_space=obs_space, action_space=act_space, device="cpu",
                cfg={**SKRL_PPO, **hp,  # no TensorBoard files, no checkpoints
                     "experiment": ExperimentCfg(write_interval=0, checkpoint_interval=0),
                     "observation_preprocessor": RunningStandardScaler,
                     "observation_preprocessor_kwargs": {"size": obs_space, "device": "cpu"},
                     "value_preprocessor": RunningStandardScaler,
                     "value_preprocessor_kwargs": {"size": 1, "device": "cpu"}})
    agent.init()
    agent.enable_training_mode(True)

    def act(obs, agent=agent):
        inputs = {"observations": agent._observation_preprocessor(obs), "states": None}
        mean, out = agent.policy.compute(inputs, role="policy")
        return mean, out["log_std"].exp().expand_as(mean)

    obs, _ = env.reset(seed=seed)
    col = lambda x: x.reshape(-1, 1)  # noqa: E731 (skrl's (N, 1) rewards and flags)
    curve, train_s, cpu_s, samples, step = [], 0.0, 0.0, 0, 0
    steps = path.budget // path.n_envs
    while step < steps:
        t0, c0 = time.perf_counter(), time.process_time()
        for _ in range(max(1, path.eval_every // path.n_envs)):
            agent.pre_interaction(timestep=step, timesteps=steps)
            with torch.no_grad():
                actions, _ = agent.act(obs, None, timestep=step, timesteps=steps)
                nxt, reward, term, trunc, info = env.step(torch.clamp(actions, low, high))
                recorded = torch.where(info["_final_obs"][:, None], info["final_obs"], nxt)
                agent.record_transition(
                    observations=obs, states=None, actions=actions, rewards=col(reward),
                    next_observations=recorded, next_states=None, terminated=col(term),
                    truncated=col(trunc), infos={}, timestep=step, timesteps=steps)
            agent.post_interaction(timestep=step, timesteps=steps)
            obs, step = nxt, step + 1
        train_s += time.perf_counter() - t0
        cpu_s += time.process_time() - c0
        samples = step * path.n_envs
        agent.enable_training_mode(False)
        rate = torch_success_rate(act, episodes)
        agent.enable_training_mode(True)
        curve.append({"samples": samples, "train_s": train_s, "cpu_s": cpu_s, "success": rate})
        log(f"  {path.name} seed {seed}: {samples} samples, {train_s:.1f} s ({cpu_s:.1f} s "
            f"CPU), held out {100 * rate:.1f} %")
        if rate >= TARGET:
            break
    env.close()
    return _summary(path, seed, curve, load0)


def _groups(obs):
    """The observation TensorDict rsl_rl's models read (one group, "policy")."""
    from tensordict import TensorDict

    return TensorDict({"policy": obs}, batch_size=[obs.shape[0]])


def torch_success_rate(act, episodes: int) -> float:
    """Held-out success of a torch policy ``act(obs float32) -> (mean, std)`` on the torch env,
    acting with the mean throttle E[clip(mean + std eps, 0, 1)] (as ``rbenv evaluate``)."""
    import gymnasium as gym
    import torch
    from rbenv.agents.policies.sb3 import expected_throttle

    env = gym.make_vec(ENV_ID, num_envs=episodes, backend="torch", device="cpu",
                       autoreset_mode=gym.vector.AutoresetMode.SAME_STEP)  # final_info
    obs, _ = env.reset(seed=HELD_OUT_SEED)
    ended = torch.zeros(episodes, dtype=torch.bool)
    success = torch.zeros_like(ended)
    with torch.no_grad():
        while not bool(ended.all()):
            mean, std = act(obs.float())
            action = torch.as_tensor(expected_throttle(mean.numpy(), std.numpy()))
            obs, _, term, trunc, info = env.step(action.double())
            done = (term | trunc) & ~ended
            success |= done & info["final_info"]["is_success"]
            ended |= done
    return float(success.float().mean())


def _summary(path: Path, seed: int, curve: list[dict], load0: list[float]) -> dict:
    solved = next((p for p in curve if p["success"] >= TARGET), None)
    return {"path": path.name, "seed": seed, "curve": curve,
            "solved": solved is not None,
            "time_to_solve_s": solved["train_s"] if solved else None,
            "cpu_to_solve_s": solved.get("cpu_s") if solved else None,
            "samples_to_solve": solved["samples"] if solved else None,
            "best_success": max(p["success"] for p in curve),
            "final_success": curve[-1]["success"],
            "train_s": curve[-1]["train_s"], "samples": curve[-1]["samples"],
            "samples_per_s": curve[-1]["samples"] / max(curve[-1]["train_s"], 1e-9),
            "load_before": load0, "load_after": _load()}


RUNNERS = {"sb3": sb3_run, "torchrl": torchrl_run, "rsl_rl": rsl_rl_run, "sbx": sb3_run,
           "skrl": skrl_run}


def run(names: list[str], seeds: list[int], episodes: int = 500, out: str = "time_to_solve",
        quick: bool = False) -> dict:
    """Each path x seed; the JSON is rewritten after every run (a checkpoint of the study)."""
    path_json = RESULTS / f"{out}.json"
    previous = json.loads(path_json.read_text()) if path_json.is_file() and not quick else {}
    runs = [r for r in previous.get("runs", [])
            if not (r["path"] in names and r["seed"] in seeds)]
    for name in names:
        path = PATHS[name]
        if quick and path.algo != "ppo":
            path = _quick_off_policy(path)
        elif quick and path.engine == "skrl":  # 64 envs x 16 steps per rollout, 8 rollouts
            path = dataclasses.replace(path, budget=8_192, eval_every=4_096, n_envs=64,
                                       hyperparams={**path.hyperparams, "rollouts": 16})
        elif quick:
            path = dataclasses.replace(path, budget=8_192, eval_every=4_096, n_envs=64,
                                       hyperparams={**path.hyperparams, "n_steps": 16,
                                                    "batch_size": 512})
        for seed in seeds:
            print(f"{name} seed {seed} (load {_load()})", flush=True)
            runs.append(RUNNERS[path.engine](path, seed, episodes))
            write_json(out, _result(runs))
    result = _result(runs)
    write_json(out, result)
    _plot(result, out)
    return result


def merge(names: list[str], out: str = "time_to_solve") -> dict:
    """One result from several studies' JSON (run side by side): a later file's run of the same
    path and seed replaces an earlier one."""
    runs: dict = {}
    for name in names:
        for r in json.loads((RESULTS / f"{name}.json").read_text())["runs"]:
            runs[r["path"], r["seed"]] = r
    result = _result(list(runs.values()))
    write_json(out, result)
    _plot(result, out)
    return result


def _result(runs: list[dict]) -> dict:
    return {"env_id": ENV_ID, "scene": "cubesat-12u", "target": TARGET,
            "paths": {n: dataclasses.asdict(PATHS[n]) for n in dict.fromkeys(
                r["path"] for r in runs) if n in PATHS},
            "runs": runs, "table": _rows(runs)}


def _rows(runs: list[dict]) -> list[dict]:
    rows = []
    for name in dict.fromkeys(r["path"] for r in runs):
        mine = [r for r in runs if r["path"] == name]
        solved = [r for r in mine if r["solved"]]
        times = [r["time_to_solve_s"] for r in solved]
        rows.append({"path": name, "seeds": len(mine), "solved": len(solved),
                     "time_to_solve_s_max": max(times) if times else None,
                     "time_to_solve_s_median": float(np.median(times)) if times else None,
                     "cpu_to_solve_s_max": max((r["cpu_to_solve_s"] or 0 for r in solved),
                                               default=None),
                     "samples_to_solve_max": max((r["samples_to_solve"] for r in solved),
                                                 default=None),
                     "samples_per_s_median": float(np.median([r["samples_per_s"]
                                                              for r in mine])),
                     "best_success_min": min(r["best_success"] for r in mine)})
    return rows


def markdown(result: dict) -> str:
    """The table of docs/performance.md: per path, each seed's samples, CPU and wall seconds
    to the target (or its best rate where missed), and the load average over the run."""
    lines = ["| path | engine | solved | samples to 99 % (k) | CPU s to 99 % | wall s to 99 % "
             "| samples/s (CPU) | load (1 min) |", "|" + "---|" * 8]
    for row in result["table"]:
        runs = sorted((r for r in result["runs"] if r["path"] == row["path"]),
                      key=lambda r: r["seed"])

        def each(fn, runs=runs):
            return ", ".join(fn(r) for r in runs)

        def missed(r):
            return f"miss ({100 * r['best_success']:.1f} % at {r['samples'] // 1000}k)"

        engine = PATHS[row["path"]].engine if row["path"] in PATHS else "?"
        rate = np.median([r["samples"] / max(r["curve"][-1].get("cpu_s") or np.nan, 1e-9)
                          for r in runs])
        lines.append(
            f"| {row['path']} | {engine} | {row['solved']}/{row['seeds']} | "
            + each(lambda r: f"{r['samples_to_solve'] // 1000}" if r["solved"] else missed(r))
            + " | " + each(lambda r: f"{r['cpu_to_solve_s']:.1f}" if r["solved"]
                           and r.get("cpu_to_solve_s") else "—")
            + " | " + each(lambda r: f"{r['time_to_solve_s']:.0f}" if r["solved"] else "—")
            + f" | {rate / 1000:.0f} k | "
            + each(lambda r: f"{r['load_before'][0]:.0f}–{r['load_after'][0]:.0f}") + " |")
    return "\n".join(lines)


def _plot(result: dict, out: str) -> None:
    """Held-out success against samples (left) and training CPU seconds (right): wall time
    on a shared machine says more about the load than about the learner."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5), sharey=True)
    colors: dict = {}
    for r in result["runs"]:
        c = colors.setdefault(r["path"], f"C{len(colors) % 10}")
        first = r["seed"] == min(q["seed"] for q in result["runs"] if q["path"] == r["path"])
        ys = [100 * p["success"] for p in r["curve"]]
        axes[0].plot([p["samples"] / 1e6 for p in r["curve"]], ys, "o-", color=c, ms=3, lw=1,
                     label=r["path"] if first else None)
        if all(p.get("cpu_s") is not None for p in r["curve"]):
            axes[1].plot([p["cpu_s"] for p in r["curve"]], ys, "o-", color=c, ms=3, lw=1)
    for ax in axes:
        ax.axhline(100 * TARGET, color="k", ls=":", lw=1)
    axes[0].set_xlabel("env steps (M)")
    axes[1].set_xlabel("training CPU time (s, one thread, evaluations excluded)")
    axes[0].set_ylabel("held-out success (%, 500 episodes)")
    fig.suptitle(f"{ENV_ID}, cubesat-12u: time to {100 * TARGET:.0f} % (one line per seed)")
    axes[0].legend(fontsize=7)
    save_figure(fig, out)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--paths", nargs="+", default=None, choices=sorted(PATHS))
    p.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    p.add_argument("--episodes", type=int, default=500)
    p.add_argument("--out", default="time_to_solve", help="results name (JSON and PNG)")
    p.add_argument("--quick", action="store_true", help="a seconds-long smoke run (CI)")
    p.add_argument("--merge", nargs="+", default=None, metavar="NAME",
                   help="combine these results (benchmarks/results/NAME.json) into --out")
    p.add_argument("--device", default="cpu",
                   help="torch device of the torchrl paths (env and learner), e.g. cuda")
    args = p.parse_args(argv)
    global DEVICE
    DEVICE = args.device
    if args.merge:
        result = merge(args.merge, args.out)
    elif args.quick:
        result = run(args.paths or ["sb3-v1-fast"], [0], episodes=20, out="time_to_solve_quick",
                     quick=True)
    else:
        result = run(args.paths or list(PATHS), args.seeds, args.episodes, out=args.out)
    print(table(result["table"], list(result["table"][0])))
    print(markdown(result))


if __name__ == "__main__":
    main()
