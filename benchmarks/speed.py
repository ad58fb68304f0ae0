"""Throughput: core body-steps/s against N, the env against Gymnasium peers, and MuJoCo.

1. Core: body-steps per second for each integrator, N = 1 … 16384 (N = 1 is the float path),
   with a fit ``t(N) = a + b·N`` that separates per-call Python/NumPy overhead (a) from the
   per-body cost (b), and an estimate of how many NumPy temporaries a step creates.
2. Env: single-env step as a ratio to ``Pendulum-v1``; vector env against ``SyncVectorEnv``
   (from ``benchmarks.env_speed``).
3. MuJoCo (optional ``bench`` extra): the same free body, inertia and body torques, stepped by
   an ``mj_step`` loop and by ``mujoco.rollout`` (one thread), as ratios in the same run.
Run: ``python -m benchmarks.speed`` or ``rbenv bench speed``.
"""

from __future__ import annotations

import numpy as np

from benchmarks.common import best_time, components, pyplot, save_figure, table, write_json
from core import INTEGRATORS, RigidBody, quaternion

MOMENTS = (5.0, 10.0, 13.0)
SIZES = (1, 4, 16, 64, 256, 1024, 4096, 16384)
H = 0.01
ROLLOUT_STEPS = 20


def _batch(n: int):
    rng = np.random.default_rng(0)
    q = quaternion.random(rng, (n,))
    w = rng.normal(0.0, 1.0, (n, 3))
    tau = rng.normal(0.0, 0.1, (n, 3))
    return tuple(components(a[0] if n == 1 else a) for a in (q, w, tau))


def core_throughput(body: RigidBody) -> dict:
    """Seconds per step for each integrator and N; plus overhead/per-body fit on arrays."""
    out = {}
    for name, it in INTEGRATORS.items():
        rows = []
        for n in SIZES:
            q, w, tau = _batch(n)
            t = best_time(lambda it=it, q=q, w=w, tau=tau: it.advance(body, q, w, H, tau))
            rows.append({"N": n, "seconds_per_step": t, "body_steps_per_s": n / t})
        arr = [r for r in rows if r["N"] >= 16]
        b, a = np.polyfit([r["N"] for r in arr], [r["seconds_per_step"] for r in arr], 1)
        out[name] = {"rows": rows, "overhead_s": float(a), "per_body_s": float(b)}
    return out


def ufunc_costs() -> dict:
    """Cost of one binary NumPy ufunc call: fixed overhead and per element (for attribution)."""
    small = np.ones(16)
    big = np.ones(16384)
    t_small = best_time(lambda: small * small)
    t_big = best_time(lambda: big * big)
    return {"overhead_s": t_small, "per_element_s": (t_big - t_small) / 16384}


def limits(core: dict, ufunc: dict) -> list[dict]:
    """Attribute the cost at each N to Python/NumPy call overhead or per-element work."""
    rows = []
    for name, res in core.items():
        calls = res["overhead_s"] / ufunc["overhead_s"]
        temporaries = res["per_body_s"] / ufunc["per_element_s"]
        crossover = res["overhead_s"] / res["per_body_s"]
        rows.append({"integrator": name, "ufunc calls per step (est.)": calls,
                     "array passes per body (est.)": temporaries,
                     "N where per-body work = overhead": crossover})
    return rows


def _mujoco_model(integrator: str):
    import mujoco

    xml = f"""<mujoco><option timestep="{H}" gravity="0 0 0" integrator="{integrator}"/>
      <worldbody><body name="sat"><freejoint name="free"/>
        <inertial pos="0 0 0" mass="1" diaginertia="{MOMENTS[0]} {MOMENTS[1]} {MOMENTS[2]}"/>
      </body></worldbody>
      <actuator><motor joint="free" gear="0 0 0 1 0 0"/><motor joint="free" gear="0 0 0 0 1 0"/>
        <motor joint="free" gear="0 0 0 0 0 1"/></actuator></mujoco>"""
    return mujoco.MjModel.from_xml_string(xml)


def mujoco_compare(core: dict) -> dict | None:
    """MuJoCo mj_step loop and rollout (one thread) vs our kernels, same body and torques."""
    try:
        import mujoco
        from mujoco import rollout
    except ImportError:
        return None
    out = {"version": mujoco.__version__, "rows": []}
    pairs = (("Euler", "semi_implicit"), ("RK4", "rk4"), ("implicitfast", "midpoint"))
    for mj_name, ours in pairs:
        model = _mujoco_model(mj_name)
        data = mujoco.MjData(model)
        # Slow spin: timing loops run ~1e5 steps on one state, and MuJoCo's explicit Euler
        # diverges within ~1e4 steps at h·|ω| = 0.02 (see the stability benchmark).
        data.qvel[3:] = (0.02, 0.03, 0.2)
        data.ctrl[:] = (0.1, 0.2, 0.3)
        t_loop = best_time(lambda model=model, data=data: mujoco.mj_step(model, data))
        ours_1 = next(r for r in core[ours]["rows"] if r["N"] == 1)["seconds_per_step"]
        out["rows"].append({"mujoco": f"mj_step loop ({mj_name})", "ours": ours, "N": 1,
                            "mujoco_body_steps_per_s": 1 / t_loop,
                            "ours_body_steps_per_s": 1 / ours_1,
                            "ours_over_mujoco": t_loop / ours_1})
        nstate = mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        steps = ROLLOUT_STEPS
        for n in (64, 1024, 4096):
            state0 = np.zeros(nstate)
            mujoco.mj_getState(model, data, state0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
            init = np.tile(state0, (n, 1))
            ctrl = np.tile(np.array([0.1, 0.2, 0.3]), (n, steps, 1))
            state_out = np.empty((n, steps, nstate))
            sens_out = np.empty((n, steps, 0))
            t = best_time(lambda model=model, data=data, init=init, ctrl=ctrl, s=state_out,
                          so=sens_out: rollout.rollout(model, data, init, ctrl, state=s,
                                                       sensordata=so, nstep=ROLLOUT_STEPS))
            ours_n = next(r for r in core[ours]["rows"] if r["N"] == n)["seconds_per_step"]
            mj_step_time = t / steps
            out["rows"].append({"mujoco": f"rollout ({mj_name}, 1 thread)", "ours": ours, "N": n,
                                "mujoco_body_steps_per_s": n / mj_step_time,
                                "ours_body_steps_per_s": n / ours_n,
                                "ours_over_mujoco": mj_step_time / ours_n})
    return out


def env_compare() -> dict:
    """Single env vs Pendulum-v1 and native vector env vs SyncVectorEnv (same run)."""
    from benchmarks import env_speed

    return {"single_env": env_speed.single_env(), "vector_env": env_speed.vector_env()}


def plot(core: dict, mj: dict | None):
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 5))
    for k, (name, res) in enumerate(core.items()):
        ax.loglog([r["N"] for r in res["rows"]], [r["body_steps_per_s"] for r in res["rows"]],
                  "o-", color=f"C{k}", label=f"rbenv {name}")
    if mj:
        schemes = sorted({r["mujoco"].split("(")[1].split(",")[0].rstrip(")") for r in mj["rows"]})
        for k, scheme in enumerate(schemes):
            rows = sorted((r for r in mj["rows"] if f"({scheme}" in r["mujoco"]),
                          key=lambda r: r["N"])
            ax.loglog([r["N"] for r in rows], [r["mujoco_body_steps_per_s"] for r in rows],
                      "s--", color=f"C{k + 5}", label=f"MuJoCo {mj['version']} {scheme}")
    ax.set_xlabel("bodies stepped per call (N)")
    ax.set_ylabel("body-steps per second (one core)")
    ax.set_title("Core throughput, one core (N = 1: our float path / MuJoCo's mj_step loop;\n"
                 "N > 1: our batched kernels / MuJoCo's rollout with one thread)", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    return fig


def main() -> dict:
    body = RigidBody(mass=1.0, inertia=np.diag(MOMENTS))
    core = core_throughput(body)
    ufunc = ufunc_costs()
    lim = limits(core, ufunc)
    mj = mujoco_compare(core)
    env = env_compare()
    rows = [{"integrator": n, **{f"N={r['N']}": r["body_steps_per_s"] for r in res["rows"]}}
            for n, res in core.items()]
    print("body-steps per second")
    print(table(rows, ["integrator", *[f"N={n}" for n in SIZES]]))
    print(table(lim, ["integrator", "ufunc calls per step (est.)", "array passes per body (est.)",
                      "N where per-body work = overhead"]))
    if mj:
        print(table(mj["rows"], ["mujoco", "ours", "N", "mujoco_body_steps_per_s",
                                 "ours_body_steps_per_s", "ours_over_mujoco"]))
    print(table(env["single_env"], ["env", "us_per_step", "ratio_to_pendulum"]))
    print(table(env["vector_env"], ["env", "env_steps_per_s", "us_per_env_step", "ratio_to_sync"]))
    data = {"core": core, "ufunc": ufunc, "limits": lim, "mujoco": mj, "env": env}
    write_json("speed", data)
    save_figure(plot(core, mj), "speed")
    return data


if __name__ == "__main__":
    main()
