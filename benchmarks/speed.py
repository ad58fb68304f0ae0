"""Throughput of the core: time per body-step against N, the compiled path, and MuJoCo.

1. Core: time per body-step for each integrator, N = 1 … 262 144 (N = 1 is the float path),
   with a fit ``t(N) = a + b·N`` that separates per-call Python/NumPy overhead (a) from the
   per-body cost (b): overhead stops dominating at N = a/b, marked on the chart. With numba
   (extra ``fast``), the compiled path (:mod:`rbenv.core.compiled`) beside it: its JIT cost, and the
   NumPy/compiled ratio at every N. Above 2·BATCH_CHUNK bodies, ``advance_batch`` (the step
   fed chunk by chunk, so its temporaries stay in cache) beside the one-call step. All timings
   at one N are interleaved, best of rounds (process CPU time).
2. MuJoCo (optional ``bench`` extra): the same free body, inertia and body torques, stepped by
   an ``mj_step`` loop and by ``mujoco.rollout`` (one thread), as ratios in the same run.
The env figures (single env against Pendulum-v1, vector env, resets, memory) are in
``benchmarks.env_speed``. Run: ``python -m benchmarks.speed`` or ``rbenv bench speed``.
"""

from __future__ import annotations

import subprocess
import sys
import time
from itertools import pairwise

import numpy as np
from rbenv.core import INTEGRATORS, RigidBody, compiled, quaternion
from rbenv.core.integrators import BATCH_CHUNK

from benchmarks.common import (
    best_times,
    components,
    pyplot,
    save_figure,
    table,
    write_json,
)

MOMENTS = (5.0, 10.0, 13.0)
SIZES = (1, 4, 16, 64, 256, 1024, 4096, 16384, 65536, 262144)
H = 0.01
ROLLOUT_STEPS = 20


def _batch(n: int):
    rng = np.random.default_rng(0)
    q = quaternion.random(rng, (n,))
    w = rng.normal(0.0, 1.0, (n, 3))
    tau = rng.normal(0.0, 0.1, (n, 3))
    return tuple(components(a[0] if n == 1 else a) for a in (q, w, tau))


def jit_costs(body: RigidBody) -> dict | None:
    """Seconds to import numba (fresh interpreter) and to compile each integrator's loop."""
    if not compiled.available():
        return None
    probe = "import time; t = time.perf_counter(); import numba; print(time.perf_counter() - t)"
    out = {"import_numba_s": float(subprocess.check_output([sys.executable, "-c", probe]))}
    q, w, tau = _batch(64)
    for name in compiled.COMPILED:
        t0 = time.perf_counter()
        compiled.get(name).advance(body, q, w, H, tau)
        out[name] = time.perf_counter() - t0
    return out


def core_throughput(body: RigidBody) -> dict:
    """Seconds per step of each integrator (NumPy, and compiled when numba is there) at each N.

    Plus, per NumPy integrator, the fit ``t(N) = a + b·N`` over N ≥ 16 (overhead a, per body b).
    """
    names = {name: it.advance for name, it in INTEGRATORS.items()}
    chunked = {f"{name} chunked": it.advance_batch for name, it in INTEGRATORS.items()
               if it.element_wise}
    if compiled.available():
        names.update({f"compiled {n}": compiled.get(n).advance for n in compiled.COMPILED})
    out = {name: {"rows": []} for name in {**names, **chunked}}
    for n in SIZES:
        q, w, tau = _batch(n)
        # advance_batch only differs from advance above 2·BATCH_CHUNK bodies.
        here = {**names, **chunked} if n > 2 * BATCH_CHUNK else names
        fns = {name: (lambda a=a, q=q, w=w, tau=tau: a(body, q, w, H, tau))
               for name, a in here.items()}
        t = best_times(fns, rounds=7 if n <= 16384 else 3)
        for name in here:
            out[name]["rows"].append({"N": n, "seconds_per_step": t[name],
                                      "ns_per_body_step": 1e9 * t[name] / n,
                                      "body_steps_per_s": n / t[name]})
    for name, res in out.items():
        if name not in chunked:
            res.update(_overhead_crossover(res["rows"]))
    return out


def _overhead_crossover(rows: list[dict]) -> dict:
    """Per-call overhead (the time of a call on N = 4 bodies) and the N where it stops dominating.

    Model-free: the crossover is the N at which a call costs twice the near-empty call, i.e.
    per-body work equals the overhead (log-interpolated between the measured sizes).
    """
    t = {r["N"]: r["seconds_per_step"] for r in rows}
    overhead = t[4]
    sizes = [n for n in SIZES if n >= 4]
    crossover = None
    for lo, hi in pairwise(sizes):
        if t[lo] < 2 * overhead <= t[hi]:
            f = np.log(2 * overhead / t[lo]) / np.log(t[hi] / t[lo])
            crossover = float(np.exp(np.log(lo) + f * np.log(hi / lo)))
            break
    return {"overhead_s": overhead, "per_body_s_at_4096": t[4096] / 4096,
            "crossover_N": crossover}


def compiled_ratios(core: dict, jit: dict | None) -> list[dict]:
    """Best NumPy time / compiled time per body-step at each N, and the body-steps to repay the JIT.

    Best NumPy: the one-call step, or ``advance_batch`` where that is faster (large N).
    """
    rows = []
    for name in compiled.COMPILED if jit else ():
        fast = {r["N"]: r["seconds_per_step"] for r in core[f"compiled {name}"]["rows"]}
        numpy_t = {r["N"]: r["seconds_per_step"] for r in core[name]["rows"]}
        for r in core.get(f"{name} chunked", {"rows": []})["rows"]:
            numpy_t[r["N"]] = min(numpy_t[r["N"]], r["seconds_per_step"])
        row = {"integrator": name, "jit_s": jit[name]}
        for n, t in numpy_t.items():
            row[f"N={n}"] = t / fast[n]
        big = core[name]["rows"][SIZES.index(4096)]
        saved = (big["seconds_per_step"] - fast[4096]) / 4096
        row["body_steps_to_repay_jit"] = jit[name] / saved if saved > 0 else None
        rows.append(row)
    return rows


def ufunc_costs() -> dict:
    """Cost of one binary NumPy ufunc call: fixed overhead and per element (for attribution)."""
    small = np.ones(16)
    big = np.ones(16384)
    t = best_times({"small": lambda: small * small, "big": lambda: big * big})
    return {"overhead_s": t["small"], "per_element_s": (t["big"] - t["small"]) / 16384}


def limits(core: dict, ufunc: dict) -> list[dict]:
    """Attribute the cost to Python/NumPy call overhead (small N) or per-element work (large N)."""
    rows = []
    for name in INTEGRATORS:
        res = core[name]
        rows.append({"integrator": name,
                     "ufunc calls per step (est.)": res["overhead_s"] / ufunc["overhead_s"],
                     "array passes per body (est.)":
                         res["per_body_s_at_4096"] / ufunc["per_element_s"],
                     "N where per-body work = overhead": res["crossover_N"]})
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
        t_loop = best_times({"loop": lambda model=model, data=data: mujoco.mj_step(model, data)})[
            "loop"]
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
            t = best_times({"rollout": lambda model=model, data=data, init=init, ctrl=ctrl,
                            s=state_out, so=sens_out: rollout.rollout(
                                model, data, init, ctrl, state=s, sensordata=so,
                                nstep=ROLLOUT_STEPS)})["rollout"]
            ours_n = next(r for r in core[ours]["rows"] if r["N"] == n)["seconds_per_step"]
            mj_step_time = t / steps
            out["rows"].append({"mujoco": f"rollout ({mj_name}, 1 thread)", "ours": ours, "N": n,
                                "mujoco_body_steps_per_s": n / mj_step_time,
                                "ours_body_steps_per_s": n / ours_n,
                                "ours_over_mujoco": mj_step_time / ours_n})
    return out


def plot(core: dict, mj: dict | None):
    plt = pyplot()
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(15, 5.5))
    for k, name in enumerate(INTEGRATORS):
        res = core[name]
        n = [r["N"] for r in res["rows"]]
        cross = res["crossover_N"]
        ax.loglog(n, [r["ns_per_body_step"] for r in res["rows"]], "o-", color=f"C{k}",
                  label=f"{name} (overhead = work at N ≈ {cross:.0f})" if cross else name)
        if cross:
            ax.axvline(cross, color=f"C{k}", ls=":", lw=0.8)
        if f"{name} chunked" in core:
            rows = core[f"{name} chunked"]["rows"]
            ax.loglog([r["N"] for r in rows], [r["ns_per_body_step"] for r in rows], "^-.",
                      color=f"C{k}", ms=3, label=f"{name}, advance_batch (chunks of "
                      f"{BATCH_CHUNK})")
        if f"compiled {name}" in core:
            rows = core[f"compiled {name}"]["rows"]
            ax.loglog([r["N"] for r in rows], [r["ns_per_body_step"] for r in rows], "s--",
                      color=f"C{k}", ms=3, label=f"{name}, compiled (numba)")
        bx.loglog(n, [r["body_steps_per_s"] for r in res["rows"]], "o-", color=f"C{k}",
                  label=f"rbenv {name}")
    ax.set_xlabel("bodies stepped per call (N)")
    ax.set_ylabel("ns per body-step (one core)")
    ax.set_title("Cost against N; dotted: N where per-call overhead = per-body work\n"
                 "(N = 1: the float path; dashed: the compiled path)", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    if mj:
        schemes = sorted({r["mujoco"].split("(")[1].split(",")[0].rstrip(")") for r in mj["rows"]})
        for k, scheme in enumerate(schemes):
            rows = sorted((r for r in mj["rows"] if f"({scheme}" in r["mujoco"]),
                          key=lambda r: r["N"])
            bx.loglog([r["N"] for r in rows], [r["mujoco_body_steps_per_s"] for r in rows],
                      "s--", color=f"C{k + 6}", label=f"MuJoCo {mj['version']} {scheme}")
    bx.set_xlabel("bodies stepped per call (N)")
    bx.set_ylabel("body-steps per second (one core)")
    bx.set_title("Throughput, one core (N = 1: our float path / MuJoCo's mj_step loop;\n"
                 "N > 1: our batched kernels / MuJoCo's rollout with one thread)", fontsize=10)
    bx.grid(True, which="both", alpha=0.3)
    bx.legend(fontsize=7)
    return fig


def main() -> dict:
    body = RigidBody(mass=1.0, inertia=np.diag(MOMENTS))
    jit = jit_costs(body)
    core = core_throughput(body)
    ratios = compiled_ratios(core, jit)
    ufunc = ufunc_costs()
    lim = limits(core, ufunc)
    mj = mujoco_compare(core)
    rows = [{"integrator": n, **{f"N={r['N']}": r["ns_per_body_step"] for r in res["rows"]}}
            for n, res in core.items()]
    for name in INTEGRATORS:
        if f"{name} chunked" in core:
            big = {r["N"]: r for r in core[name]["rows"]}
            for r in core[f"{name} chunked"]["rows"]:
                r["speedup_over_one_call"] = big[r["N"]]["seconds_per_step"] / r["seconds_per_step"]
    print("ns per body-step")
    print(table(rows, ["integrator", *[f"N={n}" for n in SIZES]]))
    print(table(lim, ["integrator", "ufunc calls per step (est.)", "array passes per body (est.)",
                      "N where per-body work = overhead"]))
    if ratios:
        print(f"compiled path (numba): import {jit['import_numba_s']:.2f} s; NumPy time / compiled "
              "time per body-step")
        print(table(ratios, ["integrator", "jit_s", *[f"N={n}" for n in SIZES],
                             "body_steps_to_repay_jit"]))
    if mj:
        print(table(mj["rows"], ["mujoco", "ours", "N", "mujoco_body_steps_per_s",
                                 "ours_body_steps_per_s", "ours_over_mujoco"]))
    data = {"core": core, "ufunc": ufunc, "limits": lim, "compiled": {"jit": jit,
            "numpy_over_compiled": ratios}, "mujoco": mj}
    write_json("speed", data)
    save_figure(plot(core, mj), "speed")
    return data


if __name__ == "__main__":
    from benchmarks.common import no_options

    no_options(__doc__)
    main()
