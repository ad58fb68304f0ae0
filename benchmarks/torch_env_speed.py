"""Env speed of the torch backend: env-steps/s against N, resets, memory, float32, training.

Run ``rbenv bench env_speed --backend torch --device DEV [--compile] [--quick]`` (or
``python -m benchmarks.torch_env_speed ...``). In one run, on ``--device``:

* env-steps/s of the torch vector env (default scene, float64) against N, eager and, with
  ``--compile``, under ``torch.compile``: with all thrusters off (no episode ends) and with one
  fixed random throttle for every step (reset-heavy: sub-envs lose control and autoreset);
  N = 2^10 … 2^24 on a GPU, 2^10 … 2^16 on a CPU, 2^10 and 2^12 with ``--quick`` (compiled:
  N ≥ 2^20 on a GPU, N = 4096 alone on a CPU, where one compilation takes about a minute). On a CPU
  the NumPy vector env runs at the same N in the same rounds, and each rate is also given as a
  ratio to NumPy's (the target: compiled torch ≥ NumPy at N = 4096);
* memory per sub-env: on CUDA the peak allocated bytes over a reset and ten steps; on a CPU the
  peak RSS growth in a fresh interpreter;
* float32: its rate, and its accuracy against float64 from the same episode starts and actions
  (observation gap and attitude-error gap after one episode of 160 steps);
* the training throughput of ``rbenv train --engine torchrl`` on the device (samples/s over a
  few PPO batches, collection and updates included).

Timings: best of interleaved rounds of wall time, with ``torch.cuda.synchronize`` around each
batch on CUDA; one torch thread on a CPU. Writes ``torch_env_speed_<device type>.json`` and
``.png``.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time

import gymnasium as gym
import numpy as np
import torch

from benchmarks.common import pyplot, save_figure, table, write_json

# The first release's id: the committed results (and the A/B against an older checkout)
# measured it; v1 has its episodes, with another observation and reward.
REORIENT_V0 = "rbenv/SatelliteReorient-v0"

_MEMORY_PROBE = r"""
import sys, torch, gymnasium as gym, rbenv
torch.set_num_threads(1)
def peak_kib():
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("VmHWM:"))
n = int(sys.argv[1])
before = peak_kib()
env = gym.make_vec("rbenv/SatelliteReorient-v0", num_envs=n, backend="torch",
                   autoreset_mode=gym.vector.AutoresetMode.SAME_STEP)
env.reset(seed=0)
a = torch.rand(n, 12, dtype=torch.float64, generator=torch.Generator().manual_seed(0))
for _ in range(10):
    env.step(a.clone())
print((peak_kib() - before) * 1024 / n)
"""


def _sync(device) -> None:
    if device.type == "cuda":
        torch.cuda.synchronize(device)


def _stepper(env, action, device):
    """A no-argument callable: one step of ``env`` with ``action`` (a copy: the env owns it)."""
    env.reset(seed=0)
    numpy = isinstance(action, np.ndarray)

    def step():
        env.step(action if numpy else action.clone())

    for _ in range(20):  # past the first episode ends (and the compilation)
        step()
    _sync(device)
    return step


def _best(fns: dict, device, rounds: int, min_time: float) -> dict:
    """Wall seconds per call of each function, the minimum over interleaved rounds."""
    loops = {}
    for name, fn in fns.items():
        n, t = 1, 0.0
        while True:
            t0 = time.perf_counter()
            for _ in range(n):
                fn()
            _sync(device)
            t = time.perf_counter() - t0
            if t >= min_time:
                break
            n *= 2
        loops[name] = n
    best = dict.fromkeys(fns, float("inf"))
    for _ in range(rounds):
        for name, fn in fns.items():
            t0 = time.perf_counter()
            for _ in range(loops[name]):
                fn()
            _sync(device)
            best[name] = min(best[name], (time.perf_counter() - t0) / loops[name])
    return best


def _cases(n: int, device, compile_: bool, numpy: bool) -> dict:
    """(compile_: whether to time the compiled env at this N as well)"""
    """name -> (stepper, n) for one N: off / reset-heavy, eager [compiled] [NumPy]."""
    gen = torch.Generator().manual_seed(2)
    fixed = torch.rand(12, generator=gen, dtype=torch.float64) * 2 - 1
    actions = {"off": torch.full((n, 12), -1.0, dtype=torch.float64),
               "reset-heavy": fixed.expand(n, 12).clone()}
    out = {}
    for load, a in actions.items():
        kinds = [("eager", False)] + ([("compiled", True)] if compile_ else [])
        for kind, c in kinds:
            env = gym.make_vec(REORIENT_V0, num_envs=n, backend="torch", device=device,
                               compile=c)
            out[f"torch {kind} {load} N={n}"] = (_stepper(env, a.to(device), device), n)
        if numpy:
            env = gym.make_vec(REORIENT_V0, num_envs=n,
                               autoreset_mode=gym.vector.AutoresetMode.SAME_STEP)
            out[f"numpy {load} N={n}"] = (_stepper(env, a.numpy().astype(np.float32),
                                                   device), n)
    return out


def speed(sizes, device, compile_: bool, rounds: int) -> list[dict]:
    numpy = device.type == "cpu"
    rows = []
    for n in sizes:
        # Each compilation (two graphs per env) takes about a minute on this CPU: compiled at
        # N = 4096 only there (the comparison point); on a GPU at 2^20 and up, to keep
        # the whole GPU set near its 10-minute budget (not yet run on a GPU).
        compiled = compile_ and (n == 4096 if numpy else n >= 2**20)
        cases = _cases(n, device, compiled, numpy)
        best = _best({k: v[0] for k, v in cases.items()}, device, rounds, 0.3)
        rates = {k: n / t for k, t in best.items()}
        for name, r in rates.items():
            row = {"case": name, "num_envs": n, "env_steps_per_s": r}
            load = "off" if " off " in name else "reset-heavy"
            ref = rates.get(f"numpy {load} N={n}")
            if ref and not name.startswith("numpy"):
                row["ratio_to_numpy"] = r / ref
            rows.append(row)
        print(table([r for r in rows if r["num_envs"] == n],
                    ["case", "env_steps_per_s", "ratio_to_numpy"]), flush=True)
    return rows


def memory(n: int, device) -> dict:
    if device.type == "cuda":
        torch.cuda.reset_peak_memory_stats(device)
        before = torch.cuda.max_memory_allocated(device)
        env = gym.make_vec(REORIENT_V0, num_envs=n, backend="torch", device=device,
                           autoreset_mode=gym.vector.AutoresetMode.SAME_STEP)
        env.reset(seed=0)
        a = torch.rand(n, 12, dtype=torch.float64, device=device)
        for _ in range(10):
            env.step(a.clone())
        peak = torch.cuda.max_memory_allocated(device) - before
        return {"num_envs": n, "bytes_per_sub_env": peak / n, "measure": "cuda peak allocated"}
    out = subprocess.run([sys.executable, "-c", _MEMORY_PROBE, str(n)], check=True,
                         capture_output=True, text=True)
    return {"num_envs": n, "bytes_per_sub_env": float(out.stdout.strip().splitlines()[-1]),
            "measure": "peak RSS growth, fresh interpreter"}


def float32_cost(device, n: int = 4096, steps: int = 160) -> dict:
    """float32 against float64 from the same starts and actions, after ``steps`` steps
    (episodes truncated later, so every sub-env runs one episode)."""
    envs = {d: gym.make_vec(REORIENT_V0, num_envs=n, backend="torch", device=device, dtype=d,
                            max_episode_steps=steps + 1, check_every=0,
                            autoreset_mode=gym.vector.AutoresetMode.SAME_STEP)
            for d in ("float64", "float32")}
    for e in envs.values():
        e.reset(seed=7)
    gen = torch.Generator().manual_seed(3)
    gap_obs = torch.zeros(n, dtype=torch.float64, device=device)
    alive = torch.ones(n, dtype=torch.bool, device=device)
    for _ in range(steps):
        a = (torch.rand(n, 12, generator=gen, dtype=torch.float64) * 0.2 - 0.1).to(device)
        out = {d: e.step(a.clone()) for d, e in envs.items()}
        alive &= ~(out["float64"][2] | out["float32"][2])  # both still in their episode
        gap = (out["float64"][0] - out["float32"][0].double()).abs().amax(dim=1)
        gap_obs = torch.where(alive, torch.maximum(gap_obs, gap), gap_obs)
    err = {d: envs[d].unwrapped  # attitude error now, deg
           for d in envs}
    e64 = err["float64"]._st.angle * (180 / np.pi)
    e32 = err["float32"]._st.angle.double() * (180 / np.pi)
    d_err = (e64 - e32).abs()[alive]
    g = gap_obs[alive]
    return {"num_envs": n, "steps": steps, "sub_envs_compared": int(alive.sum()),
            "obs_gap_max": float(g.max()), "obs_gap_median": float(g.median()),
            "attitude_error_gap_deg_median": float(d_err.median()),
            "attitude_error_gap_deg_p95": float(d_err.quantile(0.95)),
            "attitude_error_gap_deg_max": float(d_err.max())}


def float32_speed(device, n: int, rounds: int) -> list[dict]:
    a = torch.full((n, 12), -1.0, dtype=torch.float64).to(device)
    cases = {d: _stepper(gym.make_vec(REORIENT_V0, num_envs=n, backend="torch",
                                      device=device, dtype=d,
                                      autoreset_mode=gym.vector.AutoresetMode.SAME_STEP),
                         a, device)
             for d in ("float64", "float32")}
    best = _best(cases, device, rounds, 0.3)
    return [{"dtype": d, "num_envs": n, "env_steps_per_s": n / t} for d, t in best.items()]


def training(device, quick: bool) -> dict:
    from rbenv.agents.training.torchrl import TorchRLConfig, train

    cfg = TorchRLConfig(device=str(device), timesteps=16_384 if quick else 262_144,
                        num_envs=256 if quick else 1024, eval_episodes=20)
    res = train(cfg, log=lambda m: None)
    return {k: res[k] for k in ("samples", "train_wall_s", "collect_wall_s", "samples_per_s")} \
        | {"num_envs": cfg.num_envs, "rollout": cfg.rollout, "epochs": cfg.epochs,
           "minibatch": cfg.minibatch}


def plot(rows: list[dict], name: str, device) -> None:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 5))
    kinds = sorted({r["case"].rsplit(" N=", 1)[0] for r in rows})
    for kind in kinds:
        pts = sorted((r["num_envs"], r["env_steps_per_s"]) for r in rows
                     if r["case"].rsplit(" N=", 1)[0] == kind)
        ax.plot(*zip(*pts, strict=True), marker="o", label=kind,
                ls="--" if kind.startswith("numpy") else "-")
    ax.set_xscale("log", base=2)
    ax.set_yscale("log")
    ax.set_xlabel("N (sub-envs)")
    ax.set_ylabel("env-steps per second")
    ax.set_title(f"rbenv torch backend on {device} (best of interleaved rounds, one run)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, name)


def main(argv=None) -> dict:
    p = argparse.ArgumentParser(prog="rbenv bench env_speed --backend torch")
    p.add_argument("--backend", choices=("torch",), default="torch")
    p.add_argument("--device", default="cpu")
    p.add_argument("--compile", action="store_true")
    p.add_argument("--quick", action="store_true")
    args = p.parse_args(argv)
    device = torch.device(args.device)
    if device.type == "cpu":
        torch.set_num_threads(1)
    if args.quick:
        sizes, rounds = [2**10, 2**12], 2
    elif device.type == "cpu":
        sizes, rounds = [2**10, 2**12, 2**14, 2**16], 3
    else:
        sizes, rounds = [2**k for k in range(10, 25, 2)], 3
    rows = speed(sizes, device, args.compile, rounds)
    mem = memory(2**12 if args.quick else 2**16, device)
    print(f"memory: {mem['bytes_per_sub_env']:.0f} bytes per sub-env at N = {mem['num_envs']}")
    f32 = float32_cost(device, n=256 if args.quick else 4096,
                       steps=20 if args.quick else 160)
    f32_rates = float32_speed(device, 2**12, rounds)
    print(f32, f32_rates)
    train = training(device, args.quick)
    print(f"training: {train['samples_per_s']:.0f} samples/s")
    name = f"torch_env_speed_{device.type}" + ("_quick" if args.quick else "")
    command = "python -m rbenv bench env_speed --backend torch --device " + args.device + \
        (" --compile" if args.compile else "") + (" --quick" if args.quick else "")
    data = {"command": command, "device": str(device), "torch": torch.__version__,
            "threads": torch.get_num_threads(), "speed": rows, "memory": mem,
            "float32_accuracy": f32, "float32_speed": f32_rates, "training": train,
            "notes": "best of interleaved rounds of wall time; actions fixed; SAME_STEP "
                     "autoreset; float64 unless stated"}
    path = write_json(name, data)
    plot(rows, name, device)
    print(f"wrote {path}")
    return data


if __name__ == "__main__":
    main()
