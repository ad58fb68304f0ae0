"""``rbenv train --engine torchrl``: PPO from TorchRL on the torch-native vector env, one device.

The env (:class:`rbenv.envs.torch_env.TorchVectorEnv`) and the learner share ``--device``: the
collector's actions, observations, rewards and flags are tensors there, and no array crosses
to the host per step. The pieces are TorchRL's own (``Collector``, ``GAE``, ``ClipPPOLoss``,
``ProbabilisticActor`` with a state-independent Normal scale, as SB3's ``MlpPolicy``); this
module adds only the env adapter and the loop that feeds them, as TorchRL's
``sota-implementations/ppo`` scripts do.

:class:`RbenvTorchRLEnv` is a batched ``EnvBase`` (batch size ``[num_envs]``) over the env in
DISABLED autoreset mode: TorchRL resets the finished sub-envs itself through the ``"_reset"``
mask, which becomes ``reset(options={"reset_mask": mask})``. It passes
``torchrl.envs.utils.check_env_specs``. Observations leave as float32 (the networks'
dtype) whatever the physics dtype.

The held-out evaluation is :func:`success_rate`: the same 500 seeded episodes as ``rbenv
evaluate`` (seeds 1,000,000 + i: sub-env i of a torch env reset with seed 1,000,000), acting
with the mean throttle of the Gaussian policy (:func:`rbenv.agents.policies.sb3.expected_throttle`,
as ``rbenv evaluate`` acts for a PPO run in throttle mode).
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import gymnasium as gym
import torch
from gymnasium.vector import AutoresetMode
from rbenv.core.errors import InvalidParameterError
from tensordict import TensorDict
from tensordict.nn import AddStateIndependentNormalScale, TensorDictModule
from torch import nn
from torchrl.collectors import Collector
from torchrl.data import Bounded, Composite, Unbounded
from torchrl.data import Categorical as DiscreteSpec
from torchrl.envs import EnvBase
from torchrl.modules import IndependentNormal, ProbabilisticActor, ValueOperator
from torchrl.objectives import ClipPPOLoss
from torchrl.objectives.value import GAE

import rbenv

__all__ = ["RbenvTorchRLEnv", "TorchRLConfig", "success_rate", "train"]

HELD_OUT_SEED = 1_000_000


class RbenvTorchRLEnv(EnvBase):
    """A batched TorchRL env over ``gym.make_vec(env_id, backend="torch")`` (see module doc).

    env_kwargs: the torch env's options (scene, dtype, compile, ...).
    """

    def __init__(self, env_id: str = rbenv.ENV_ID, num_envs: int = 64, device="cpu",
                 seed: int = 0, **env_kwargs):
        super().__init__(device=device, batch_size=torch.Size([num_envs]))
        self.env = gym.make_vec(env_id, num_envs=num_envs, backend="torch", device=device,
                                autoreset_mode=AutoresetMode.DISABLED, **env_kwargs)
        n = num_envs
        d = self.env.single_observation_space.shape[0]
        k = self.env.single_action_space.shape[0]
        self.observation_spec = Composite(
            observation=Unbounded((n, d), dtype=torch.float32, device=device), shape=(n,),
            device=device)
        self.action_spec = Bounded(-1.0, 1.0, (n, k), dtype=torch.float32, device=device)
        self.reward_spec = Unbounded((n, 1), dtype=torch.float32, device=device)
        flag = DiscreteSpec(2, (n, 1), dtype=torch.bool, device=device)
        self.done_spec = Composite(done=flag, terminated=flag.clone(), truncated=flag.clone(),
                                   shape=(n,), device=device)
        self._seed_next = int(seed)
        self._started = False

    def _flags(self, terminated, truncated) -> dict:
        return {"done": (terminated | truncated).unsqueeze(-1),
                "terminated": terminated.unsqueeze(-1), "truncated": truncated.unsqueeze(-1)}

    def _reset(self, tensordict=None, **kwargs):
        mask = None if tensordict is None else tensordict.get("_reset", None)
        if not self._started or mask is None or bool(mask.all()):
            obs, _ = self.env.reset(seed=self._seed_next if not self._started else None)
            self._started = True
        else:
            obs, _ = self.env.reset(options={"reset_mask": mask.reshape(-1)})
        false = torch.zeros(self.batch_size, dtype=torch.bool, device=self.device)
        return TensorDict({"observation": obs.float(), **self._flags(false, false)},
                          batch_size=self.batch_size, device=self.device)

    def _step(self, tensordict):
        obs, reward, terminated, truncated, _ = self.env.step(tensordict.get("action"))
        return TensorDict({"observation": obs.float(), "reward": reward.float().unsqueeze(-1),
                           **self._flags(terminated, truncated)},
                          batch_size=self.batch_size, device=self.device)

    def _set_seed(self, seed):
        self._seed_next, self._started = int(seed or 0), False
        return seed


@dataclass
class TorchRLConfig:
    """A TorchRL PPO run; defaults chosen for the default scene on a CPU (docs/torch.md)."""

    env_id: str = rbenv.ENV_ID
    scene: str | None = None
    device: str = "cpu"
    timesteps: int = 800_000
    num_envs: int = 256
    rollout: int = 64  # steps per sub-env per batch
    minibatch: int = 2048
    epochs: int = 5
    lr: float = 1e-3
    gamma: float = 0.99
    lmbda: float = 0.95
    clip: float = 0.2
    hidden: int = 128
    log_std_init: float = -1.0
    seed: int = 0
    threads: int = 1
    compile: bool = False
    eval_episodes: int = 500
    eval_every: int = 0  # samples between held-out evaluations during training (0: none)


class RunningNorm(nn.Module):
    """x ↦ clip((x − mean)/√(var + 1e-8), ±10) with running statistics (Chan's parallel
    update), SB3 VecNormalize's transform; the first layer of actor and critic, so a saved
    policy carries it. Updated between PPO iterations (:meth:`update`), never inside one."""

    def __init__(self, width: int):
        super().__init__()
        self.register_buffer("mean", torch.zeros(width))
        self.register_buffer("var", torch.ones(width))
        self.register_buffer("count", torch.tensor(1e-4))

    def forward(self, x):
        return torch.clamp((x - self.mean) / torch.sqrt(self.var + 1e-8), -10.0, 10.0)

    @torch.no_grad()
    def update(self, x):
        x = x.reshape(-1, x.shape[-1]) if x.ndim > 1 else x.reshape(-1, 1)
        n, mean, var = x.shape[0], x.mean(0), x.var(0, unbiased=False)
        total = self.count + n
        delta = mean - self.mean
        self.var.copy_((self.var * self.count + var * n
                        + delta * delta * self.count * n / total) / total)
        self.mean.add_(delta * n / total)
        self.count.copy_(total)


def _mlp(norm, n_in: int, n_out: int, hidden: int) -> nn.Sequential:
    return nn.Sequential(norm, nn.Linear(n_in, hidden), nn.Tanh(), nn.Linear(hidden, hidden),
                         nn.Tanh(), nn.Linear(hidden, n_out))


def make_modules(obs_dim: int, act_dim: int, cfg: TorchRLConfig):
    """The actor (Normal, state-independent scale) and the critic, sharing one observation
    normalizer, on ``cfg.device``."""
    norm = RunningNorm(obs_dim)
    net = nn.Sequential(_mlp(norm, obs_dim, act_dim, cfg.hidden),
                        AddStateIndependentNormalScale(act_dim, init_value=cfg.log_std_init,
                                                       scale_mapping="exp"))
    actor = ProbabilisticActor(
        TensorDictModule(net, in_keys=["observation"], out_keys=["loc", "scale"]),
        in_keys=["loc", "scale"], distribution_class=IndependentNormal,
        return_log_prob=True).to(cfg.device)
    critic = ValueOperator(_mlp(norm, obs_dim, 1, cfg.hidden),
                           in_keys=["observation"]).to(cfg.device)
    return actor, critic, norm


class ReturnScale:
    """Rewards divided by the running std of the discounted return (SB3 VecNormalize's
    ``norm_reward``), per sub-env, over a (N, T) batch in time order."""

    def __init__(self, num_envs: int, gamma: float, device):
        self.gamma = gamma
        self.ret = torch.zeros(num_envs, device=device)
        self.stats = RunningNorm(1).to(device)

    @torch.no_grad()
    def __call__(self, batch):
        reward = batch.get(("next", "reward"))  # (N, T, 1)
        done = batch.get(("next", "done"))
        rets = []
        for t in range(reward.shape[1]):
            self.ret = self.ret * self.gamma + reward[:, t, 0]
            rets.append(self.ret)
            self.ret = torch.where(done[:, t, 0], 0.0, self.ret)
        self.stats.update(torch.stack(rets).reshape(-1, 1))
        scaled = torch.clamp(reward / torch.sqrt(self.stats.var + 1e-8), -10.0, 10.0)
        batch.set(("next", "reward"), scaled)
        return batch


def train(cfg: TorchRLConfig, out: Path | None = None, log=print) -> dict:
    """Train PPO; returns (and writes to ``out/torchrl.json``) samples, wall times, throughput
    and the held-out success rate."""
    if cfg.timesteps < cfg.num_envs * cfg.rollout:
        raise InvalidParameterError(
            f"timesteps must be >= num_envs * rollout = {cfg.num_envs * cfg.rollout} (one "
            f"batch), got {cfg.timesteps}")
    torch.set_num_threads(cfg.threads)
    torch.manual_seed(cfg.seed)
    kwargs = {} if cfg.scene is None else {"scene": cfg.scene}
    env = RbenvTorchRLEnv(cfg.env_id, cfg.num_envs, cfg.device, cfg.seed, compile=cfg.compile,
                          **kwargs)
    obs_dim = env.observation_spec["observation"].shape[-1]
    actor, critic, norm = make_modules(obs_dim, env.action_spec.shape[-1], cfg)
    scale = ReturnScale(cfg.num_envs, cfg.gamma, cfg.device)
    gae = GAE(gamma=cfg.gamma, lmbda=cfg.lmbda, value_network=critic, average_gae=False)
    loss = ClipPPOLoss(actor, critic, clip_epsilon=cfg.clip, entropy_bonus=False,
                       critic_coeff=0.5, loss_critic_type="l2", normalize_advantage=True)
    opt = torch.optim.Adam(loss.parameters(), lr=cfg.lr)
    frames = cfg.num_envs * cfg.rollout
    collector = Collector(env, actor, frames_per_batch=frames, total_frames=cfg.timesteps,
                          device=cfg.device, auto_register_policy_transforms=False)
    t0, cpu0 = time.perf_counter(), time.process_time()
    collect_s = eval_s = eval_cpu_s = 0.0
    samples, curve, next_eval = 0, [], cfg.eval_every
    tick = time.perf_counter()
    for i, batch in enumerate(collector):
        collect_s += time.perf_counter() - tick
        samples += batch.numel()
        reward = float(batch.get(("next", "reward")).mean())
        _update(scale(batch), gae, loss, opt, cfg)
        norm.update(batch.get("observation"))  # for the next iteration's rollout and update
        point = {"samples": samples, "s": time.perf_counter() - t0 - eval_s,
                 "cpu_s": time.process_time() - cpu0 - eval_cpu_s, "reward": reward}
        if cfg.eval_every and samples >= next_eval:  # held-out success, timed apart
            tick, tock = time.perf_counter(), time.process_time()
            point["held_out_success"] = success_rate(actor, cfg, kwargs)
            eval_s += time.perf_counter() - tick
            eval_cpu_s += time.process_time() - tock
            next_eval += cfg.eval_every
        if i % 10 == 0 or "held_out_success" in point:
            curve.append(point)
            log(f"torchrl ppo: {samples} samples, {point['s']:.0f} s, reward/step "
                f"{reward:.3f}" + (f", held-out success {point['held_out_success']:.3f}"
                                   if "held_out_success" in point else ""))
        tick = time.perf_counter()
    train_s = time.perf_counter() - t0 - eval_s
    collector.shutdown()
    rate = success_rate(actor, cfg, kwargs)
    result = {"config": asdict(cfg), "samples": samples, "train_wall_s": train_s,
              "eval_wall_s": eval_s,
              "collect_wall_s": collect_s, "samples_per_s": samples / train_s,
              "held_out_success": rate, "episodes": cfg.eval_episodes, "curve": curve,
              "torch": torch.__version__}
    log(f"torchrl ppo: {samples} samples in {train_s:.1f} s ({samples / train_s:.0f}/s); "
        f"held-out success {100 * rate:.1f} % of {cfg.eval_episodes}")
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        (out / "torchrl.json").write_text(json.dumps(result, indent=2))
        torch.save({"actor": actor.state_dict(), "critic": critic.state_dict()},
                   out / "torchrl_modules.pt")
    return result


def _update(batch, gae, loss, opt, cfg: TorchRLConfig) -> None:
    """PPO epochs over one batch: GAE, then minibatches of ClipPPOLoss (TorchRL's)."""
    with torch.no_grad():
        gae(batch)
    flat = batch.reshape(-1)
    n = flat.numel()
    for _ in range(cfg.epochs):
        order = torch.randperm(n, device=flat.device)
        for start in range(0, n, cfg.minibatch):
            parts = loss(flat[order[start:start + cfg.minibatch]])
            total = parts["loss_objective"] + parts["loss_critic"]
            opt.zero_grad(set_to_none=True)
            total.backward()
            nn.utils.clip_grad_norm_(loss.parameters(), 0.5)
            opt.step()


@torch.no_grad()
def success_rate(actor, cfg: TorchRLConfig, env_kwargs: dict) -> float:
    """The fraction of the held-out episodes (seeds 1,000,000 + i) the policy ends in
    success, acting with its mean throttle (first episode of each sub-env)."""
    from rbenv.agents.policies.sb3 import expected_throttle

    n = cfg.eval_episodes
    env = gym.make_vec(cfg.env_id, num_envs=n, backend="torch", device=cfg.device,
                       autoreset_mode=AutoresetMode.SAME_STEP, **env_kwargs)  # final_info
    obs, _ = env.reset(seed=HELD_OUT_SEED)
    module = actor.module[0]  # the (loc, scale) network
    ended = torch.zeros(n, dtype=torch.bool, device=cfg.device)
    success = torch.zeros_like(ended)
    scene = env.unwrapped.plant.scene
    thrusters_only = set(scene.actuators) == {"thrusters"}
    while not bool(ended.all()):
        loc, scale = module.module(obs.float())
        action = loc
        if thrusters_only and env.unwrapped.plant.action_mode == "throttle":
            action = torch.as_tensor(expected_throttle(loc.cpu().numpy(), scale.cpu().numpy()))
        obs, _, term, trunc, info = env.step(action.to(cfg.device, torch.float64))
        done = (term | trunc) & ~ended
        success |= done & info["final_info"]["is_success"]
        ended |= done
    return float(success.float().mean())


def train_from_config(run, options) -> int:
    """``rbenv train --engine torchrl``: the run's shared fields (task, scene, seed, timesteps,
    out, threads, report_episodes) and its options (device, quick)."""
    cfg = TorchRLConfig(env_id=run.env_id, scene=run.scene, device=options.device,
                        seed=run.seed, threads=run.threads or 1,
                        eval_episodes=run.report_episodes,
                        **({"timesteps": run.timesteps} if run.timesteps else {}))
    if options.quick:
        cfg.timesteps, cfg.num_envs, cfg.eval_episodes = 16_384, 256, 50
    train(cfg, Path(run.out) if run.out else None)
    return 0
