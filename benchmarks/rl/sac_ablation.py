"""Why SAC/TD3 fail on cubesat-12u and what fixes them; PPO's propellant against the PD's.

Each variant trains one SB3 model on the native rbenv vector env (same-step autoreset, through
:class:`rbenv.agents.training.sb3_vec_env.SB3VecEnv`), then evaluates the deterministic policy on
the held-out seeded
episodes ``1_000_000 + i`` (i < 500), as ``rbenv evaluate`` does. Env-side changes under study
are prototyped here as SB3 ``VecEnv`` wrappers, so the env package itself is untouched:

* ``action_map="affine"``: throttle = (a + 1) / 2 instead of clip(a, 0, 1), so a tanh-squashed
  policy has no dead half of its action box (the env still clips, after the map);
* ``curriculum``: the maximum initial angle grows linearly from ``start_deg`` to 180° over the
  first ``frac`` of training, through the env's ``set_initial_ranges``.

One JSON per variant under ``benchmarks/results/rl/<study>/``; a variant whose JSON exists is
skipped, so a killed study resumes. ``summary`` writes ``summary.md`` from the JSONs.

    python -m benchmarks.rl.sac_ablation run sac-default sac-affine ...
    python -m benchmarks.rl.sac_ablation list
    python -m benchmarks.rl.sac_ablation summary
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import platform
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from rbenv.agents.policies.sb3 import expected_throttle
from rbenv.agents.training.sb3_vec_env import SB3VecEnv

from rbenv.hyperparams.ppo import hyperparams as _ppo_settings

# The first release's id: the committed results (and the A/B against an older checkout)
# measured it; v1 has its episodes, with another observation and reward.
REORIENT_V0 = "rbenv/SatelliteReorient-v0"

RESULTS = Path(__file__).resolve().parents[1] / "results" / "rl"
EVAL_SEED = 1_000_000
EVAL_EPISODES = 500
CURVE_SEED = 2_000_000  # intermediate evaluations: disjoint from the held-out seeds
CURVE_EPISODES = 100

_SAC = {"learning_rate": 1e-3, "buffer_size": 300_000, "batch_size": 256,
        "learning_starts": 5_000, "train_freq": 1, "gradient_steps": 1, "gamma": 0.99,
        "tau": 0.01, "policy_kwargs": {"net_arch": [256, 256]}}
_TD3 = {"learning_rate": 1e-3, "buffer_size": 300_000, "batch_size": 256,
        "learning_starts": 5_000, "train_freq": 1, "gradient_steps": 8, "gamma": 0.99,
        "tau": 0.01, "policy_kwargs": {"net_arch": [128, 128]}}
# PPO's shipped settings (rbenv/hyperparams/ppo.py, the one source; model arguments only).
_PPO = {k: copy.deepcopy(v) for k, v in _ppo_settings["rbenv/SatelliteReorient-v0"].items()
        if k not in ("policy", "n_envs", "n_timesteps", "normalize", "monitor_kwargs")}


def _v(algo, steps, hp, n_envs=8, action_map="clip", curriculum=None, env_kwargs=None,
       noise=0.1, study="sac"):
    return {"algo": algo, "timesteps": steps, "n_envs": n_envs, "hyperparams": hp,
            "action_map": action_map, "curriculum": curriculum,
            "env_kwargs": env_kwargs or {}, "action_noise_sigma": noise, "study": study}


_CUR = {"start_deg": 20.0, "frac": 0.5}
_UTD1 = {**_SAC, "gradient_steps": 8, "policy_kwargs": {"net_arch": [128, 128]}}
_FIX = {**_UTD1, "n_steps": 3}
_TORQUE = {"action_mode": "torque", "allocator": "nnls"}

VARIANTS = {
    # ---- SAC, 50k env steps: one change at a time from the shipped defaults
    "sac-default": _v("sac", 50_000, _SAC),
    "sac-affine": _v("sac", 50_000, _SAC, action_map="affine"),
    "sac-utd1": _v("sac", 50_000, _UTD1),
    "sac-utd1-curr": _v("sac", 50_000, _UTD1, curriculum=_CUR),
    "sac-affine-utd1": _v("sac", 50_000, _UTD1, action_map="affine"),
    # ---- candidate fix: one gradient step per env step, curriculum, 3-step returns
    "sac-fix": _v("sac", 40_000, _FIX, curriculum=_CUR),
    "td3-fix": _v("td3", 40_000, {**_TD3, "n_steps": 3}, curriculum=_CUR, study="td3"),
    # ---- action design: 3 torque actions in [-1, 1], NNLS allocation (no dead zone, no
    # redundant thrusters, zero action = no firing)
    "sac-torque": _v("sac", 40_000, _FIX, curriculum=_CUR, env_kwargs=_TORQUE),
    "td3-torque": _v("td3", 40_000, {**_TD3, "n_steps": 3}, curriculum=_CUR,
                     env_kwargs=_TORQUE, study="td3"),
    # ---- full runs of the best recipe (torque actions), as long as the 30-min budget allows
    "td3-final": _v("td3", 55_000, {**_TD3, "n_steps": 3}, curriculum=_CUR, env_kwargs=_TORQUE,
                    study="td3"),
    "td3-long": _v("td3", 120_000, {**_TD3, "n_steps": 3}, curriculum=_CUR, env_kwargs=_TORQUE,
                   study="td3"),
    "sac-long": _v("sac", 120_000, _FIX, curriculum=_CUR, env_kwargs=_TORQUE),
    "sac-final": _v("sac", 55_000, _FIX, curriculum=_CUR, env_kwargs=_TORQUE),
    "ppo-torque": _v("ppo", 2_000_000, _PPO, n_envs=64, study="ppo", env_kwargs=_TORQUE),
    # ---- precision: a 20x steeper attitude term (0.2 -> 4.0 per rad/pi), so the last degrees
    # are worth about as much as the hold bonus instead of 0.0025 per step at 2 degrees
    "td3-precise": _v("td3", 55_000, {**_TD3, "n_steps": 3}, curriculum=_CUR, study="td3",
                      env_kwargs={**_TORQUE, "reward_weights": {"attitude": 4.0}}),
    "sac-precise": _v("sac", 55_000, _FIX, curriculum=_CUR,
                      env_kwargs={**_TORQUE, "reward_weights": {"attitude": 4.0}}),
    # ---- a near-target pull instead: the precision term +w·θ_s/(θ_s + θ), weight 1
    "td3-pull": _v("td3", 55_000, {**_TD3, "n_steps": 3}, curriculum=_CUR, study="td3",
                   env_kwargs={**_TORQUE, "reward_weights": {"precision": 1.0}}),
    "sac-pull": _v("sac", 55_000, _FIX, curriculum=_CUR,
                   env_kwargs={**_TORQUE, "reward_weights": {"precision": 1.0}}),
    "sac-pull-long": _v("sac", 240_000, _FIX, curriculum=_CUR,
                        env_kwargs={**_TORQUE, "reward_weights": {"precision": 1.0}}),
    "sac-pull3-long": _v("sac", 240_000, _FIX, curriculum=_CUR,
                         env_kwargs={**_TORQUE, "reward_weights": {"precision": 3.0}}),
    # ---- TQC (sb3-contrib): SAC with a distributional critic that drops the top quantiles,
    # on the best SAC recipe (torque actions, curriculum, one update per env step)
    "tqc-final": _v("tqc", 55_000, _UTD1, curriculum=_CUR, env_kwargs=_TORQUE, study="tqc"),
    # ---- PPO, shipped budget (2M env steps, 64 envs): the fuel weight of the reward
    **{f"ppo-fuel{w:g}": _v("ppo", 2_000_000, _PPO, n_envs=64, study="ppo",
                           env_kwargs={"reward_weights": {"fuel": w}})
       for w in (0.05, 0.5, 1.0, 2.0)},
}


# --------------------------------------------------------------------------- env wrappers


def throttle_action(a: np.ndarray, action_map: str) -> np.ndarray:
    """The env action for policy output ``a`` in [-1, 1]: identity, or (a + 1) / 2."""
    if action_map == "clip":
        return a
    if action_map == "affine":
        return 0.5 * (np.clip(a, -1.0, 1.0) + 1.0)
    raise ValueError(f"action_map must be 'clip' or 'affine', got {action_map!r}")


class MappedVecEnv(SB3VecEnv):
    """:class:`SB3VecEnv` whose actions pass through :func:`throttle_action` first."""

    def __init__(self, venv, action_map: str):
        super().__init__(venv)
        self.action_map = action_map

    def step_async(self, actions: np.ndarray) -> None:
        super().step_async(throttle_action(np.asarray(actions), self.action_map))


def make_env(spec: dict, n_envs: int, seed: int):
    from stable_baselines3.common.vec_env import VecMonitor

    venv = gym.make_vec(REORIENT_V0, num_envs=n_envs, vectorization_mode="vector_entry_point",
                        autoreset_mode=AutoresetMode.SAME_STEP, **spec["env_kwargs"])
    env = VecMonitor(MappedVecEnv(venv, spec["action_map"]), info_keywords=("is_success",))
    env.seed(seed)
    return env


# --------------------------------------------------------------------------- evaluation


def _act(model, obs: np.ndarray, mode: str) -> np.ndarray:
    """Policy action: ``deterministic`` (SB3's mean), ``stochastic``, or ``expected`` (PPO)."""
    if mode != "expected":
        return model.predict(obs, deterministic=mode == "deterministic")[0]
    import torch

    with torch.no_grad():
        dist = model.policy.get_distribution(torch.as_tensor(obs, dtype=torch.float32))
        mean = dist.distribution.mean.numpy()
        std = dist.distribution.stddev.numpy()
    return expected_throttle(mean, std)


def evaluate(model, vecnorm, spec: dict, episodes: int, seed: int,
             mode: str = "deterministic") -> dict:
    """The policy (see :func:`_act`) on ``episodes`` seeded episodes (i: seed + i), first done."""
    envs = gym.make_vec(REORIENT_V0, num_envs=episodes, vectorization_mode="vector_entry_point",
                        **{k: v for k, v in spec["env_kwargs"].items()
                           if k not in ("max_initial_angle_deg",)})
    cfg = envs.config
    if mode == "stochastic":
        import torch

        torch.manual_seed(seed)  # the policy's samples come from torch's global generator
    obs, _ = envs.reset(seed=seed)
    alive = np.ones(episodes, bool)
    success = np.zeros(episodes, bool)
    lost = np.zeros(episodes, bool)
    fuel = np.zeros(episodes)
    t_end = np.zeros(episodes)
    err = np.zeros(episodes)
    while alive.any():
        action = _act(model, vecnorm.normalize_obs(obs), mode)
        obs, _, term, trunc, info = envs.step(throttle_action(action, spec["action_map"]))
        done = (term | trunc) & alive
        idx = np.flatnonzero(done)
        success[idx] = np.asarray(info["is_success"])[idx]
        lost[idx] = np.asarray(info["rate_dps"])[idx] > np.degrees(cfg.scene.episode.rate_limit)
        fuel[idx] = np.asarray(info["fuel_kg"])[idx]
        t_end[idx] = np.asarray(info["time_s"])[idx]
        err[idx] = np.asarray(info["attitude_error_deg"])[idx]
        alive &= ~done
    envs.close()
    hold, dt = cfg.scene.episode.hold_time, cfg.control_dt
    settle = t_end[success] - hold + dt
    return {"mode": mode, "episodes": episodes, "seed": seed,
            "success_rate": float(success.mean()),
            "loss_of_control_rate": float(lost.mean()),
            "fuel_mean_g": float(1000 * fuel.mean()),
            "settle_time_median_s": float(np.median(settle)) if len(settle) else None,
            "final_error_median_deg": float(np.median(err))}


def baseline(policy: str, env_kwargs=None, episodes: int = EVAL_EPISODES) -> dict:
    """The scripted baseline on the held-out episodes (same summary keys as :func:`evaluate`)."""
    from rbenv.agents.policies.evaluate import evaluate as run

    r = run(policy, episodes=episodes, seed=EVAL_SEED, env_kwargs=env_kwargs, record=0)
    s = r.summary()
    return {"episodes": episodes, "seed": EVAL_SEED, "success_rate": s["success_rate"],
            "fuel_mean_g": 1000 * s["fuel"]["mean"],
            "settle_time_median_s": s["settle_time_s"]["median"],
            "final_error_median_deg": s["final_error_deg"]["median"]}


# --------------------------------------------------------------------------- training


def _callback(spec: dict, curve: list, eval_every: int):
    from stable_baselines3.common.callbacks import BaseCallback

    class Monitor(BaseCallback):
        """Curriculum schedule, training-episode outcomes and a held-aside learning curve."""

        def _on_training_start(self):
            self.t0, self.next_eval, self.window = time.time(), eval_every, []
            self._curriculum()

        def _curriculum(self):
            cur = spec["curriculum"]
            if not cur:
                return
            frac = min(self.num_timesteps / (cur["frac"] * spec["timesteps"]), 1.0)
            deg = cur["start_deg"] + frac * (180.0 - cur["start_deg"])
            self.training_env.env_method("set_initial_ranges", max_initial_angle_deg=deg)

        def _on_step(self):
            for info, done in zip(self.locals["infos"], self.locals["dones"], strict=True):
                if done and "rate_dps" in info:
                    self.window.append((bool(info.get("is_success", False)),
                                        info["rate_dps"] > 10.0, info["time_s"]))
            if self.num_timesteps >= self.next_eval:
                self.next_eval += eval_every
                self._curriculum()
                w = np.array(self.window[-200:], float) if self.window else np.zeros((1, 3))
                point = {"timesteps": int(self.num_timesteps),
                         "wall_s": round(time.time() - self.t0, 1),
                         "train_success": float(w[:, 0].mean()),
                         "train_loss_of_control": float(w[:, 1].mean()),
                         "train_episode_s": float(w[:, 2].mean())}
                log_ent = getattr(self.model, "log_ent_coef", None)
                if log_ent is not None:
                    point["ent_coef"] = float(log_ent.exp().item())
                vn = self.model.get_vec_normalize_env()
                point["eval_success"] = evaluate(self.model, vn, spec, CURVE_EPISODES,
                                                 CURVE_SEED)["success_rate"]
                curve.append(point)
                print(json.dumps(point), flush=True)
            return True

    return Monitor()


def train_and_evaluate(name: str, spec: dict, seed: int = 0) -> dict:
    import stable_baselines3
    import torch
    from stable_baselines3 import PPO, SAC, TD3
    from stable_baselines3.common.noise import NormalActionNoise
    from stable_baselines3.common.vec_env import VecNormalize

    torch.set_num_threads(1)
    if spec["algo"] == "tqc":
        from sb3_contrib import TQC  # the ecosystem extra
    algo = {"ppo": PPO, "sac": SAC, "td3": TD3}.get(spec["algo"]) or TQC
    env = VecNormalize(make_env(spec, spec["n_envs"], seed),
                       gamma=spec["hyperparams"].get("gamma", 0.99))
    hp = copy.deepcopy(spec["hyperparams"])  # SB3 writes into policy_kwargs
    if spec["algo"] == "td3":
        n_act = env.action_space.shape[0]
        hp["action_noise"] = NormalActionNoise(np.zeros(n_act),
                                               spec["action_noise_sigma"] * np.ones(n_act))
    model = algo("MlpPolicy", env, seed=seed, device="cpu", **hp)
    curve: list = []
    eval_every = max(spec["timesteps"] // 10, 1)
    start = time.time()
    model.learn(spec["timesteps"], callback=_callback(spec, curve, eval_every))
    wall = time.time() - start
    result = evaluate(model, env, spec, EVAL_EPISODES, EVAL_SEED)
    other = {m: evaluate(model, env, spec, EVAL_EPISODES, EVAL_SEED, m)
             for m in (("stochastic", "expected") if spec["algo"] == "ppo" else ())}
    keep = os.environ.get("RL_STUDY_MODELS")  # optional: keep the policy for inspection
    if keep:
        Path(keep).mkdir(parents=True, exist_ok=True)
        model.save(Path(keep) / f"{name}.zip")
        env.save(str(Path(keep) / f"{name}-vecnormalize.pkl"))
    env.close()
    return {"variant": name, "spec": spec, "train_seed": seed, "train_wall_s": round(wall, 1),
            "result": result, "result_other_modes": other, "curve": curve,
            "versions": {"python": platform.python_version(),
                         "stable_baselines3": stable_baselines3.__version__,
                         "torch": torch.__version__, "torch_threads": torch.get_num_threads()}}


# --------------------------------------------------------------------------- summary


def _row(name: str, data: dict) -> str:
    s, r = data["spec"], data["result"]
    hp = s["hyperparams"]
    ratio = hp.get("gradient_steps", 0) / s["n_envs"] if s["algo"] != "ppo" else None
    cur = s["curriculum"]
    cur_txt = f"{cur['start_deg']:.0f}°→180° over {cur['frac']:.0%}" if cur else "—"
    arch = hp.get("policy_kwargs", {}).get("net_arch")
    settle = r["settle_time_median_s"]
    design = {"clip": "12 throttles clip(a, 0, 1)", "affine": "12 throttles (a + 1)/2"}[
        s["action_map"]]
    if s["env_kwargs"].get("action_mode") == "torque":
        design = f"torque ({s['env_kwargs'].get('allocator', 'pinv')})"
    env_kw = {k: v for k, v in s["env_kwargs"].items() if k not in ("action_mode", "allocator")}
    return (f"| {name} | {s['algo']} | {s['timesteps'] // 1000}k | {design} | "
            f"{'—' if ratio is None else f'{ratio:g}'} | {arch} | {cur_txt} | "
            f"{json.dumps(env_kw) if env_kw else '—'} | "
            f"{_extra(hp, s['algo'])} | {100 * r['success_rate']:.1f}% | "
            f"{100 * r['loss_of_control_rate']:.1f}% | {r['fuel_mean_g']:.2f} | "
            f"{'—' if settle is None else f'{settle:.1f}'} | {r['final_error_median_deg']:.3g} | "
            f"{data['train_wall_s'] / 60:.1f} |")


_SHOWN = {"gradient_steps", "policy_kwargs", "buffer_size", "batch_size", "train_freq", "gamma",
          "tau", "n_steps", "n_epochs", "gae_lambda", "clip_range"}


def _extra(hp: dict, algo: str) -> str:
    """Hyperparameters that differ from the family's base dict (for the table)."""
    extra = {k: v for k, v in hp.items() if k not in _SHOWN and not _is_base(k, v)}
    if algo != "ppo" and hp.get("n_steps", 1) > 1:
        extra["n-step returns"] = hp["n_steps"]
    pk = {k: v for k, v in hp.get("policy_kwargs", {}).items()
          if k != "net_arch" and not (k == "use_sde" and v is False)}
    extra.update(pk)
    return ", ".join(f"{k}={v}" for k, v in extra.items()) or "—"


def _is_base(key, value) -> bool:
    return any(base.get(key) == value for base in (_SAC, _TD3, _PPO))


def summary(directory: Path = RESULTS) -> Path:
    lines = ["| variant | algo | env steps | action design | grad steps / env step | net | "
             "curriculum | env kwargs | other | success | loss of control | fuel (g) | "
             "settle median (s) | final error median (deg) | train wall (min) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    base = []
    for path in sorted(directory.glob("*/*.json")):
        data = json.loads(path.read_text())
        if "variant" in data:
            name = data["variant"]
            if data.get("train_seed", 0):
                name += f" (seed {data['train_seed']})"
            lines.append(_row(name, data))
            for mode, result in data.get("result_other_modes", {}).items():
                lines.append(_row(f"{name} [{mode}]", {**data, "result": result}))
        elif "baseline" in data:
            r = data["result"]
            base.append(f"| {data['baseline']} | {json.dumps(data['env_kwargs'])} | "
                        f"{100 * r['success_rate']:.1f}% | {r['fuel_mean_g']:.2f} | "
                        f"{r['settle_time_median_s']:.1f} |")
    text = "# SAC / TD3 / PPO study on cubesat-12u\n\n"
    text += (f"Held-out evaluation: {EVAL_EPISODES} episodes, seeds {EVAL_SEED:,} + i, "
             "deterministic policy. Generated by `python -m benchmarks.rl.sac_ablation "
             "summary`.\n\n")
    if base:
        text += ("| baseline | env kwargs | success | fuel (g) | settle median (s) |\n"
                 "|---|---|---|---|---|\n" + "\n".join(base) + "\n\n")
    text += "\n".join(lines) + "\n"
    out = directory / "summary.md"
    out.write_text(text)
    return out


def explore(episodes: int = EVAL_EPISODES) -> dict:
    """Loss of control under the random exploration SAC/TD3 start with (no training).

    Uniform actions on [-1, 1] (SB3's warm-up before ``learning_starts``) and SAC's initial
    policy, tanh(N(0, 1)), through each action design; TD3's N(0, 0.1) noise around zero.
    """
    rng = np.random.default_rng(0)
    draws = {"uniform": lambda shape: rng.uniform(-1.0, 1.0, shape),
             "tanh_normal": lambda shape: np.tanh(rng.standard_normal(shape)),
             "normal_0.1": lambda shape: np.clip(0.1 * rng.standard_normal(shape), -1, 1)}
    designs = {"throttle clip": ({}, "clip"), "throttle affine": ({}, "affine"),
               "torque nnls": (_TORQUE, "clip")}
    out = {}
    for design, (kw, action_map) in designs.items():
        for draw_name, draw in draws.items():
            envs = gym.make_vec(REORIENT_V0, num_envs=episodes,
                                vectorization_mode="vector_entry_point", **kw)
            envs.reset(seed=EVAL_SEED)
            shape = (episodes, envs.single_action_space.shape[0])
            alive, lost = np.ones(episodes, bool), np.zeros(episodes, bool)
            fuel, t_end = np.zeros(episodes), np.zeros(episodes)
            while alive.any():
                _, _, term, trunc, info = envs.step(throttle_action(draw(shape), action_map))
                done = (term | trunc) & alive
                idx = np.flatnonzero(done)
                limit_dps = np.degrees(envs.config.scene.episode.rate_limit)
                lost[idx] = np.asarray(info["rate_dps"])[idx] > limit_dps
                fuel[idx] = np.asarray(info["fuel_kg"])[idx]
                t_end[idx] = np.asarray(info["time_s"])[idx]
                alive &= ~done
            envs.close()
            out[f"{design} / {draw_name}"] = {
                "loss_of_control_rate": float(lost.mean()),
                "time_to_loss_median_s": float(np.median(t_end[lost])) if lost.any() else None,
                "fuel_mean_g": float(1000 * fuel.mean())}
    return out


def _modes(name: str, models: Path) -> None:
    import pickle

    import torch
    from stable_baselines3 import PPO

    torch.set_num_threads(1)
    spec = VARIANTS[name]
    out = RESULTS / spec["study"] / f"{name}.json"
    data = json.loads(out.read_text())
    model = PPO.load(models / f"{name}.zip", device="cpu")
    with open(models / f"{name}-vecnormalize.pkl", "rb") as f:
        vecnorm = pickle.load(f)
    data["result_other_modes"] = {m: evaluate(model, vecnorm, spec, EVAL_EPISODES, EVAL_SEED, m)
                                  for m in ("stochastic", "expected")}
    out.write_text(json.dumps(data, indent=2) + "\n")
    print(json.dumps(data["result_other_modes"]))
    summary()


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="cmd", required=True)
    run = sub.add_parser("run")
    run.add_argument("variants", nargs="+")
    run.add_argument("--seed", type=int, default=0)
    sub.add_parser("list")
    sub.add_parser("explore")
    sub.add_parser("summary")
    modes = sub.add_parser("modes", help="re-evaluate a saved PPO model in every action mode")
    modes.add_argument("variant")
    modes.add_argument("models", help="directory holding <variant>.zip and "
                                      "<variant>-vecnormalize.pkl (RL_STUDY_MODELS)")
    base = sub.add_parser("baseline")
    base.add_argument("policy")
    base.add_argument("--env-kwargs", default="{}")
    args = parser.parse_args(argv)
    if args.cmd == "list":
        for name, spec in VARIANTS.items():
            print(name, json.dumps(spec))
        return
    if args.cmd == "summary":
        print(summary().read_text())
        return
    if args.cmd == "explore":
        data = explore()
        path = RESULTS / "explore.json"
        path.write_text(json.dumps(data, indent=2) + "\n")
        print(json.dumps(data, indent=1))
        return
    if args.cmd == "modes":
        _modes(args.variant, Path(args.models))
        return
    if args.cmd == "baseline":
        kw = json.loads(args.env_kwargs)
        tag = "-".join(f"{k}{v}" for k, v in kw.get("reward_weights", {}).items())
        out = RESULTS / "baselines" / f"{args.policy}{'-' + tag if tag else ''}.json"
        out.parent.mkdir(parents=True, exist_ok=True)
        data = {"baseline": args.policy, "env_kwargs": kw, "result": baseline(args.policy, kw)}
        out.write_text(json.dumps(data, indent=2) + "\n")
        print(json.dumps(data))
        return
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    for name in args.variants:
        spec = VARIANTS[name]
        suffix = "" if args.seed == 0 else f"-seed{args.seed}"
        out = RESULTS / spec["study"] / f"{name}{suffix}.json"
        if out.exists():
            print(f"skip {name}: {out} exists")
            continue
        out.parent.mkdir(parents=True, exist_ok=True)
        print(f"== {name}: {json.dumps(spec)}", flush=True)
        data = train_and_evaluate(name, spec, args.seed)
        tmp = out.with_suffix(".tmp")
        tmp.write_text(json.dumps(data, indent=2) + "\n")
        os.replace(tmp, out)
        print(json.dumps({"variant": name, **data["result"], "wall_s": data["train_wall_s"]}),
              flush=True)
        summary()


if __name__ == "__main__":
    main()
