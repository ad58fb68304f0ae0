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

A run (:class:`TorchRLSession`, through :func:`rbenv.agents.training.engine.run`) has the run
folder of every other back end: its lock, ``config.json``, checkpoints every
``--checkpoint-every`` samples, the periodic evaluation and ``--stop-success``, ``--resume``
from the newest complete checkpoint, ``training.json`` and the report. The policy is written
as an SB3 PPO policy (:func:`save_policy`: the actor's and critic's layers copied into SB3's
``MlpPolicy`` of the same shape, the observation normaliser as ``obs_stats.npz``), so
``rbenv evaluate``, ``load_policy`` and ``rbenv export`` read it unchanged; each checkpoint
adds ``policy_<N>.torchrl.pt``, the learner's whole state (weights, Adam's moments, the
return scaler) as tensors, which a resume restores (read with ``weights_only=True``).

Evaluation acts with the mean throttle of the Gaussian policy
(:func:`rbenv.agents.policies.sb3.expected_throttle`, as ``rbenv evaluate`` acts for a PPO run in
throttle mode), on the first episode of each sub-env of a torch env: the periodic validation on
seeds ``seed + 10,000 + i``, :func:`success_rate` (the benchmarks' held-out figure) on the
500 seeds 1,000,000 + i of ``rbenv evaluate``.
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import ClassVar

import gymnasium as gym
import numpy as np
import torch
from gymnasium.vector import AutoresetMode
from rbenv.agents.policies import runfolder, weights
from rbenv.agents.policies.runfolder import RunFolderError, atomic_write
from rbenv.agents.policies.sb3 import SB3Policy
from rbenv.agents.training import engine
from rbenv.agents.training.config import SessionOptions, TorchRLConfig, TorchRLRunConfig
from rbenv.agents.training.report import Trained, write_report
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

__all__ = ["Learner", "RbenvTorchRLEnv", "TorchRLConfig", "TorchRLSession", "save_policy",
           "success_rate", "train"]

HELD_OUT_SEED = 1_000_000
VALIDATION_SEED_OFFSET = 10_000  # the periodic evaluation's episodes: seed + this + i
STATE_FORMAT = 1


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



class Learner:
    """TorchRL's PPO for one :class:`TorchRLConfig`: the batched env (seeded ``env_seed``, by
    default the config's seed), actor, critic, return scaling, GAE, loss and Adam.
    :meth:`batches` collects and trains; :meth:`state` and :meth:`load_state` are its whole
    training state as tensors."""

    def __init__(self, cfg: TorchRLConfig, env_seed: int | None = None):
        cfg.check()
        self.cfg = cfg
        torch.set_num_threads(cfg.threads)
        torch.manual_seed(cfg.seed if env_seed is None else env_seed)
        self.env = RbenvTorchRLEnv(cfg.env_id, cfg.num_envs, cfg.device,
                                   cfg.seed if env_seed is None else env_seed,
                                   compile=cfg.compile, **self.env_kwargs)
        obs_dim = self.env.observation_spec["observation"].shape[-1]
        self.actor, self.critic, self.norm = make_modules(
            obs_dim, self.env.action_spec.shape[-1], cfg)
        self.scale = ReturnScale(cfg.num_envs, cfg.gamma, cfg.device)
        self.gae = GAE(gamma=cfg.gamma, lmbda=cfg.lmbda, value_network=self.critic,
                       average_gae=False)
        self.loss = ClipPPOLoss(self.actor, self.critic, clip_epsilon=cfg.clip,
                                entropy_bonus=False, critic_coeff=0.5, loss_critic_type="l2",
                                normalize_advantage=True)
        self.opt = torch.optim.Adam(self.loss.parameters(), lr=cfg.lr)
        self.updates = 0  # gradient steps taken over the run

    @property
    def env_kwargs(self) -> dict:
        """The torch env's options: the scene (if set) and the config's env_kwargs."""
        return {**({} if self.cfg.scene is None else {"scene": self.cfg.scene}),
                **self.cfg.env_kwargs}

    def batches(self, frames: int):
        """Collect ``frames`` samples (rounded up to whole batches of num_envs x rollout);
        after each batch, one PPO update. Yields (samples in the batch, its mean reward per
        step, seconds spent collecting it)."""
        cfg = self.cfg
        batch = cfg.num_envs * cfg.rollout
        collector = Collector(self.env, self.actor, frames_per_batch=batch,
                              total_frames=-(-frames // batch) * batch, device=cfg.device,
                              auto_register_policy_transforms=False)
        try:
            tick = time.perf_counter()
            for batch in collector:
                collect_s = time.perf_counter() - tick
                reward = float(batch.get(("next", "reward")).mean())
                self.updates += _update(self.scale(batch), self.gae, self.loss, self.opt, cfg)
                self.norm.update(batch.get("observation"))  # for the next rollout and update
                yield batch.numel(), reward, collect_s
                tick = time.perf_counter()
        finally:
            collector.shutdown()

    def state(self, samples: int) -> dict:
        """The whole training state after ``samples`` samples: tensors and plain values."""
        return {"format": STATE_FORMAT, "samples": int(samples), "updates": self.updates,
                "actor": self.actor.state_dict(), "critic": self.critic.state_dict(),
                "optimizer": self.opt.state_dict(),
                "return_scale": {"ret": self.scale.ret, "stats": self.scale.stats.state_dict()}}

    def load_state(self, state: dict) -> None:
        """Restore :meth:`state`'s output (onto this learner's device)."""
        self.actor.load_state_dict(state["actor"])
        self.critic.load_state_dict(state["critic"])
        self.opt.load_state_dict(state["optimizer"])
        self.scale.ret = state["return_scale"]["ret"].to(self.cfg.device)
        self.scale.stats.load_state_dict(state["return_scale"]["stats"])
        self.updates = int(state["updates"])


def train(cfg: TorchRLConfig, log=print) -> dict:
    """Train PPO without a run folder (the benchmarks' form); returns samples, wall times,
    throughput, the curve and the held-out success rate."""
    learner = Learner(cfg)
    t0, cpu0 = time.perf_counter(), time.process_time()
    collect_s = eval_s = eval_cpu_s = 0.0
    samples, curve, next_eval = 0, [], cfg.eval_every
    for i, (n, reward, collect) in enumerate(learner.batches(cfg.timesteps)):
        collect_s += collect
        samples += n
        point = {"samples": samples, "s": time.perf_counter() - t0 - eval_s,
                 "cpu_s": time.process_time() - cpu0 - eval_cpu_s, "reward": reward}
        if cfg.eval_every and samples >= next_eval:  # held-out success, timed apart
            tick, tock = time.perf_counter(), time.process_time()
            point["held_out_success"] = success_rate(learner.actor, cfg, learner.env_kwargs)
            eval_s += time.perf_counter() - tick
            eval_cpu_s += time.process_time() - tock
            next_eval += cfg.eval_every
        if i % 10 == 0 or "held_out_success" in point:
            curve.append(point)
            log(f"torchrl ppo: {samples} samples, {point['s']:.0f} s, reward/step "
                f"{reward:.3f}" + (f", held-out success {point['held_out_success']:.3f}"
                                   if "held_out_success" in point else ""))
    train_s = time.perf_counter() - t0 - eval_s
    rate = success_rate(learner.actor, cfg, learner.env_kwargs)
    log(f"torchrl ppo: {samples} samples in {train_s:.1f} s ({samples / train_s:.0f}/s); "
        f"held-out success {100 * rate:.1f} % of {cfg.eval_episodes}")
    return {"config": asdict(cfg), "samples": samples, "train_wall_s": train_s,
            "eval_wall_s": eval_s,
            "collect_wall_s": collect_s, "samples_per_s": samples / train_s,
            "held_out_success": rate, "episodes": cfg.eval_episodes, "curve": curve,
            "torch": torch.__version__}


def _update(batch, gae, loss, opt, cfg: TorchRLConfig) -> int:
    """PPO epochs over one batch: GAE, then minibatches of ClipPPOLoss (TorchRL's); returns
    the number of gradient steps."""
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
    return cfg.epochs * -(-n // cfg.minibatch)


@torch.no_grad()
def evaluate_episodes(actor, cfg: TorchRLConfig, env_kwargs: dict, episodes: int,
                      seed: int) -> dict:
    """The first episode of each of ``episodes`` sub-envs of a torch env reset with ``seed``
    (episode i: seed + i), acting with the policy's mean throttle: per episode the return
    (``results``), length (``ep_lengths``) and success (``successes``), as lists."""
    from rbenv.agents.policies.sb3 import expected_throttle

    env = gym.make_vec(cfg.env_id, num_envs=episodes, backend="torch", device=cfg.device,
                       autoreset_mode=AutoresetMode.SAME_STEP, **env_kwargs)  # final_info
    obs, _ = env.reset(seed=seed)
    module = actor.module[0]  # the (loc, scale) network
    ended = torch.zeros(episodes, dtype=torch.bool, device=cfg.device)
    success = torch.zeros_like(ended)
    returns = torch.zeros(episodes, dtype=torch.float64, device=cfg.device)
    lengths = torch.zeros(episodes, dtype=torch.int64, device=cfg.device)
    thrusters_only = set(env.unwrapped.plant.scene.actuators) == {"thrusters"}
    while not bool(ended.all()):
        loc, scale = module.module(obs.float())
        action = loc
        if thrusters_only and env.unwrapped.plant.action_mode == "throttle":
            action = torch.as_tensor(expected_throttle(loc.cpu().numpy(), scale.cpu().numpy()))
        obs, reward, term, trunc, info = env.step(action.to(cfg.device, torch.float64))
        returns += torch.where(ended, 0.0, reward.to(torch.float64))
        lengths += (~ended).to(torch.int64)
        done = (term | trunc) & ~ended
        success |= done & info["final_info"]["is_success"]
        ended |= done
    env.close()
    return {"results": returns.cpu().tolist(), "ep_lengths": lengths.cpu().tolist(),
            "successes": success.cpu().tolist()}


def success_rate(actor, cfg: TorchRLConfig, env_kwargs: dict) -> float:
    """The fraction of the held-out episodes (the ``cfg.eval_episodes`` seeds 1,000,000 + i)
    the policy ends in success (:func:`evaluate_episodes`)."""
    outcome = evaluate_episodes(actor, cfg, env_kwargs, cfg.eval_episodes, HELD_OUT_SEED)
    return float(np.mean(outcome["successes"]))


# --- the run-folder engine --------------------------------------------------------------------

@dataclass(frozen=True)
class TorchRLSession(SessionOptions):
    """The TorchRL back end (:class:`rbenv.agents.training.engine.Backend`) with the options of
    one training session (``device``; ``quick`` is applied by the CLI to a new run's config)."""

    packages: ClassVar[tuple[str, ...]] = ("torchrl", "tensordict", "torch")

    def __post_init__(self):
        check_device(self.device)

    def check(self, cfg: TorchRLRunConfig) -> None:
        """Nothing beyond :meth:`TorchRLRunConfig.resolve`, which checks every learner field."""

    def fit(self, cfg: TorchRLRunConfig, out: Path, resume: bool) -> dict:
        return fit(cfg, out, resume, self)

    def report(self, out: Path, cfg: TorchRLRunConfig, summary: dict) -> Path:
        return write_report(out, cfg, summary, Trained(
            SB3Policy(out), name="ppo (TorchRL)", title=f"PPO (TorchRL) on `{cfg.scene}`",
            setup=f"{cfg.hyperparams['n_envs']} envs on {summary.get('device', self.device)}",
            load=f"`rbenv.agents.policies.load_policy({str(out)!r})`: an SB3 PPO policy with "
                 "the observation normalisation (`obs_stats.npz`) that the bare weights lack"))

    def load_hint(self, out: Path) -> str:
        return runfolder.LOAD_HINT.replace("PATH", repr(str(out)))


def check_device(device: str) -> None:
    """``device`` a torch device this machine has; else an error naming it and the rule."""
    try:
        kind = torch.device(device)
    except (RuntimeError, TypeError) as e:
        raise InvalidParameterError(f"device must be a torch device such as cpu, cuda or "
                                    f"cuda:1, got {device!r} ({e})") from None
    if kind.type == "cpu":
        return
    backend = getattr(torch, kind.type, None)
    count = backend.device_count() if hasattr(backend, "device_count") else 0
    if count == 0 or (kind.index is not None and kind.index >= count):
        raise InvalidParameterError(
            f"device {device!r} is not on this machine (torch {torch.__version__} sees "
            f"{count} {kind.type} device(s)); pass --device cpu, or install a torch build "
            f"for {kind.type}")


def fit(cfg: TorchRLRunConfig, out: Path, resume: bool, session: TorchRLSession) -> dict:
    """Train under the engine's lock (from the newest checkpoint if ``resume``); evaluate
    every ``eval_every`` samples, stopping at ``stop_success``; checkpoint every
    ``checkpoint_every``; save the final policy; return the summary."""
    ckpt_dir = out / runfolder.CHECKPOINTS
    learner_cfg = cfg.learner(session.device)
    loaded = load_checkpoint(ckpt_dir, session.device) if resume else None
    done = 0 if loaded is None else loaded[0]["samples"]
    # A resumed session draws new episodes (seed + samples done), as SB3's resume starts new ones.
    learner = Learner(learner_cfg, env_seed=cfg.seed + done)
    clock = engine.WallClock(0.0 if loaded is None else loaded[1].wall_time_s or 0.0)
    if loaded is not None:
        learner.load_state(loaded[0])
        print(f"resuming torchrl ppo in {str(out)!r} from {done} timesteps "
              f"({loaded[1].model.name})")
    elif resume:
        print(f"no checkpoint in {str(ckpt_dir)!r} yet; starting {str(out)!r} from 0 timesteps")
    log = out / runfolder.EVAL_LOG
    history = engine.load_eval_history(log, done)
    next_eval = engine.next_multiple(done, cfg.eval_every)
    next_ckpt = engine.next_multiple(done, cfg.checkpoint_every)
    steps, stopped = done, None
    if cfg.timesteps > done:
        with contextlib.closing(learner.batches(cfg.timesteps - done)) as batches:
            for i, (n, reward, _) in enumerate(batches):
                steps += n
                if steps >= next_eval:
                    stopped = _evaluate(learner, cfg, log, history, steps)
                    next_eval = engine.next_multiple(steps, cfg.eval_every)
                if steps >= next_ckpt:
                    save_checkpoint(learner, ckpt_dir, steps, clock.total())
                    next_ckpt = engine.next_multiple(steps, cfg.checkpoint_every)
                if session.progress and (i % 10 == 0 or stopped):
                    print(f"torchrl ppo: {steps:,} of {cfg.timesteps:,} timesteps, "
                          f"{clock.session():.0f} s, reward/step {reward:.3f}")
                if stopped:
                    break
    latest = runfolder.latest_checkpoint(ckpt_dir)
    if latest is None or latest["timesteps"] != steps:
        save_checkpoint(learner, ckpt_dir, steps, clock.total())
    if stopped:
        print(f"stopped by --stop-success {cfg.stop_success:g} at {steps:,} of "
              f"{cfg.timesteps:,} timesteps: {100 * stopped['success_rate']:.0f} % of "
              f"{stopped['episodes']} validation episodes; the policy evaluated then is the "
              "run's final one (--stop-success 0 trains on to the end)")
    save_policy(learner, out / runfolder.FINAL_MODEL, out / runfolder.FINAL_STATS, steps)
    return {**engine.session_summary(cfg, steps, done, clock), "device": session.device,
            "gradient_updates": learner.updates, "trained": learner.updates > 0,
            **({"stopped_at_success": stopped} if stopped else {})}


def _evaluate(learner: Learner, cfg: TorchRLRunConfig, log: Path, history: dict,
              steps: int) -> dict | None:
    """The periodic validation at ``steps``, logged; the stop record if it reaches
    ``cfg.stop_success``."""
    outcome = evaluate_episodes(learner.actor, learner.cfg, learner.env_kwargs,
                                cfg.eval_episodes, cfg.seed + VALIDATION_SEED_OFFSET)
    engine.record_evaluation(log, history, steps, outcome)
    rate = float(np.mean(outcome["successes"]))
    if cfg.stop_success and rate >= cfg.stop_success:
        return {"timesteps": int(steps), "success_rate": rate, "episodes": cfg.eval_episodes}
    return None


# --- policy files and checkpoints -------------------------------------------------------------

def state_path(model: Path) -> Path:
    """The learner's training state beside a checkpoint's ``policy_<N>.pt``."""
    return Path(model).with_suffix(".torchrl.pt")


def save_checkpoint(learner: Learner, directory: Path, steps: int,
                    wall_time_s: float | None) -> None:
    """Write policy_<steps>.pt/.json, obs_stats_<steps>.npz and policy_<steps>.torchrl.pt, then
    point latest.json at them."""
    directory.mkdir(parents=True, exist_ok=True)
    model, stats = directory / f"policy_{steps}.pt", directory / f"obs_stats_{steps}.npz"
    atomic_write(state_path(model), lambda p: torch.save(_to_cpu(learner.state(steps)), p))
    save_policy(learner, model, stats, steps)
    engine.point_latest(directory, steps, wall_time_s, model=model.name, stats=stats.name)


def load_checkpoint(directory: Path, device: str):
    """(training state, checkpoint) of the newest checkpoint whose files are complete and
    load, or None if there is none; an unusable one is reported and the next older tried."""
    tried = []
    for ckpt in runfolder.checkpoints(directory):
        path = state_path(ckpt.model)
        try:
            if not (path.is_file() and ckpt.model.is_file() and ckpt.stats.is_file()):
                raise RunFolderError(f"it is incomplete ({str(path)!r} and the policy files "
                                     "are written together)")
            state = torch.load(path, map_location=device, weights_only=True)
            if not isinstance(state, dict) or state.get("format") != STATE_FORMAT \
                    or state.get("samples") != ckpt.steps:
                raise RunFolderError(f"{str(path)!r} is not the TorchRL state of "
                                     f"{ckpt.steps} timesteps")
        except Exception as e:  # torn, foreign or hostile: torch refuses non-tensor objects
            print(f"checkpoint at {ckpt.steps} timesteps is unusable: {e}")
            tried.append(path.name)
            continue
        return state, ckpt
    if tried:
        raise RunFolderError(f"no usable checkpoint in {str(directory)!r} (tried "
                             f"{', '.join(tried)}); pass --force without --resume to start over")
    return None


def _to_cpu(tree):
    if isinstance(tree, torch.Tensor):
        return tree.detach().cpu()
    if isinstance(tree, dict):
        return {k: _to_cpu(v) for k, v in tree.items()}
    if isinstance(tree, list | tuple):
        return type(tree)(_to_cpu(v) for v in tree)
    return tree


def save_policy(learner: Learner, model: Path, stats: Path, steps: int) -> None:
    """The actor and critic as an SB3 PPO policy (``model``: ``.pt`` and ``.json``, see
    :mod:`rbenv.agents.policies.weights`) and the observation normaliser as VecNormalize's
    statistics (``stats``): what ``rbenv evaluate``, ``load_policy`` and export read."""
    cfg, env = learner.cfg, learner.env.env
    config = {"format": weights.FORMAT, "algo": "ppo", "policy": weights.POLICY,
              "engine": "torchrl",
              "policy_kwargs": {"net_arch": {"pi": [cfg.hidden] * 2, "vf": [cfg.hidden] * 2},
                                "activation_fn": "tanh", "log_std_init": cfg.log_std_init},
              "observation_space": weights.space_to_json(_float32(env.single_observation_space)),
              "action_space": weights.space_to_json(_float32(env.single_action_space)),
              "num_timesteps": int(steps), "n_updates": learner.updates, "episode_num": 0}
    with torch.random.fork_rng(devices=[]):  # SB3's initialisation draws: not the run's
        policy = weights.build_model(config).policy
    actor_net = learner.actor.module[0].module  # Sequential(mlp, state-independent scale)
    layers = weights.linear_layers
    with torch.no_grad():
        _copy([*layers(policy.mlp_extractor.policy_net), policy.action_net],
              layers(actor_net[0]))
        _copy([*layers(policy.mlp_extractor.value_net), policy.value_net],
              layers(learner.critic.module))
        policy.log_std.copy_(actor_net[1].state_independent_scale.detach().cpu())
    tensors = {"format": weights.FORMAT, "params": {"policy": policy.state_dict()},
               "variables": {}}
    norm, ret = learner.norm, learner.scale.stats
    vecnormalize = SimpleNamespace(
        obs_rms=_moments(norm), ret_rms=_moments(ret, scalar=True), clip_obs=10.0,
        clip_reward=10.0, gamma=cfg.gamma, epsilon=1e-8, norm_obs=True, norm_reward=True)
    atomic_write(stats, lambda p: weights.save_stats(vecnormalize, p))
    atomic_write(Path(model), lambda p: weights.save_tensors(tensors, p))
    runfolder.write_json(weights.config_path(model), config)


def _float32(space: gym.spaces.Box) -> gym.spaces.Box:
    """The torch env's space (in its physics dtype) as the NumPy env's: float32, as the
    networks see it and as SB3's policies of the other engines record it."""
    return gym.spaces.Box(space.low.astype(np.float32), space.high.astype(np.float32),
                          dtype=np.float32)


def _copy(targets: list[nn.Linear], sources: list[nn.Linear]) -> None:
    for target, source in zip(targets, sources, strict=True):
        target.weight.copy_(source.weight.detach().cpu())
        target.bias.copy_(source.bias.detach().cpu())


def _moments(norm: RunningNorm, scalar: bool = False) -> SimpleNamespace:
    """A RunningNorm's statistics as SB3's RunningMeanStd fields (float64 arrays)."""
    mean, var = (norm.mean.detach().cpu().double().numpy(),
                 norm.var.detach().cpu().double().numpy())
    if scalar:
        mean, var = mean.reshape(()), var.reshape(())
    return SimpleNamespace(mean=mean, var=var, count=float(norm.count))
