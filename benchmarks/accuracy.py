"""Work–precision: every integrator over a geometric sweep of dt, against exact references.

Scenes: (a) torque-free rotation near the major axis, (b) near the intermediate axis (the
Dzhanibekov flip), both against the exact Jacobi-elliptic solution (``rbenv.core.reference``); (c) a
thruster-driven slew with piecewise-constant body torque against a tight SciPy DOP853 solution;
(d) each orbit torque (gravity gradient, rods, residual dipole, drag, SRP) evaluated at every
stage, against SciPy of the same model (:mod:`benchmarks.orbit_torques`).
Error: geodesic attitude angle at the final time, plus relative drift of energy and L_W.
Cost: wall time per simulated second, for one body and per body in a batch of N = 4096.
``dominance`` says where ``splitting`` is cheaper than ``rk4`` and ``midpoint`` at equal error.
Run: ``python -m benchmarks.accuracy`` or ``rbenv bench accuracy``.
"""

from __future__ import annotations

import numpy as np
from rbenv.core import INTEGRATORS, RigidBody, quaternion, reference
from rbenv.core.body import invariants

from benchmarks.common import (
    best_times,
    components,
    fit_order,
    pyplot,
    save_figure,
    table,
    write_json,
)

MOMENTS = np.array([5.0, 10.0, 13.0])
Q0 = quaternion.normalize(np.array([0.9, 0.1, -0.3, 0.2]))
DTS = 0.5 * 2.0 ** -np.arange(0, 11)  # 0.5 s … 0.49 ms
SLEW_SEGMENT = 0.5  # s: control interval of scene (c); every dt in DTS divides it
BATCH = 4096


def _torque_schedule(duration: float) -> np.ndarray:
    """Piecewise-constant body torques (N·m) of scene (c): one per control interval."""
    rng = np.random.default_rng(42)
    n = round(duration / SLEW_SEGMENT)
    return rng.uniform(-1.0, 1.0, (n, 3)) * np.array([2.0, 3.0, 3.0])


SCENES = {
    "a: near major axis": {"omega_B0": [0.2, 0.3, 2.0], "T": 10.0, "torque": False},
    "b: near intermediate axis (flip)": {"omega_B0": [0.05, 2.0, 0.05], "T": 20.0,
                                         "torque": False},
    "c: thruster slew (piecewise torque)": {"omega_B0": [0.05, -0.02, 0.03], "T": 10.0,
                                            "torque": True},
}


def reference_final(scene: dict) -> np.ndarray:
    """Exact (a, b) or DOP853 (c) final orientation, (4,)."""
    if not scene["torque"]:
        sol = reference.TorqueFreeSolution(MOMENTS, scene["omega_B0"], Q0)
        return sol.orientation(scene["T"])
    q, w = Q0, np.asarray(scene["omega_B0"], float)
    for tau in _torque_schedule(scene["T"]):
        qs, ws = reference.solve_ivp_reference(MOMENTS, w, q, [SLEW_SEGMENT], torque_B=tau)
        q, w = qs[-1], ws[-1]
    return q


def run(body, scene: dict, integrator: str, dt: float):
    """Integrate one scene; return final q and the relative drift of energy and of L_W."""
    advance = INTEGRATORS[integrator].advance
    q = tuple(Q0.tolist())
    w = tuple(float(x) for x in scene["omega_B0"])
    steps_per_segment = round(SLEW_SEGMENT / dt) if scene["torque"] else None
    n_steps = round(scene["T"] / dt)
    schedule = _torque_schedule(scene["T"]) if scene["torque"] else None
    E0, L0 = invariants(body, q, w)
    with np.errstate(all="ignore"):
        for i in range(n_steps):
            tau = None if schedule is None else tuple(schedule[i // steps_per_segment].tolist())
            q, w = advance(body, q, w, dt, tau)
    E, L = invariants(body, q, w)
    L, L0 = np.array(L), np.array(L0)
    return np.array(q), abs(E - E0) / E0, np.linalg.norm(L - L0) / np.linalg.norm(L0)


def step_costs(body) -> dict:
    """Seconds per step: one body (float path) and per body at N = BATCH, per integrator.

    All timings interleaved in rounds, best of rounds (:func:`benchmarks.common.best_times`).
    """
    rng = np.random.default_rng(0)
    qb = components(quaternion.random(rng, (BATCH,)))
    wb = components(rng.normal(0, 1, (BATCH, 3)))
    tb = components(rng.normal(0, 1, (BATCH, 3)))
    q1, w1, t1 = tuple(Q0.tolist()), (0.2, 0.3, 2.0), (0.1, 0.2, 0.3)
    fns = {}
    for name, it in INTEGRATORS.items():
        fns[(name, "single")] = lambda it=it: it.advance(body, q1, w1, 0.01, t1)
        fns[(name, "batch")] = lambda it=it: it.advance(body, qb, wb, 0.01, tb)
    t = best_times(fns)
    return {name: {"single": t[(name, "single")], "batch_per_body": t[(name, "batch")] / BATCH}
            for name in INTEGRATORS}


def sweep(body) -> dict:
    results = {}
    for label, scene in SCENES.items():
        q_ref = reference_final(scene)
        per = {}
        for name in INTEGRATORS:
            rows = []
            for dt in DTS:
                q, dE, dL = run(body, scene, name, float(dt))
                err = float(quaternion.angle(q, q_ref)) if np.isfinite(q).all() else np.nan
                rows.append({"dt": float(dt), "attitude_error_rad": err,
                             "energy_drift": None if scene["torque"] else float(dE),
                             "L_W_drift": None if scene["torque"] else float(dL)})
            per[name] = {"rows": rows, "order": _order(rows)}
        results[label] = per
    return results


def _order(rows) -> float | None:
    """Fitted order over the asymptotic range (error between 1e-12 and 0.1 rad)."""
    pts = [(r["dt"], r["attitude_error_rad"]) for r in rows
           if r["attitude_error_rad"] is not None and 1e-12 < r["attitude_error_rad"] < 0.1]
    if len(pts) < 3:
        return None
    dt, err = zip(*pts, strict=True)
    return fit_order(dt, err)


def recommendations(results: dict, costs: dict) -> list[dict]:
    """Cheapest integrator meeting an error target at a use-case's step (scene c: slews)."""
    slew = results["c: thruster slew (piecewise torque)"]
    flip = results["b: near intermediate axis (flip)"]
    out = []
    for use, dt, target, scene in (
        ("RL at 10 Hz (dt = 0.125 s), 1° over a 10 s slew", 0.125, np.radians(1.0), slew),
        ("RL at 2 Hz (dt = 0.5 s), 1° over a 10 s slew", 0.5, np.radians(1.0), slew),
        ("accurate tumbling (flip), 1e-6 rad at 20 s", None, 1e-6, flip),
    ):
        best = None
        for name, res in scene.items():
            for r in res["rows"]:
                err = r["attitude_error_rad"]
                at_dt = dt is None or abs(r["dt"] - dt) < 1e-12
                if at_dt and err is not None and np.isfinite(err) and err < target:
                    cost = costs[name]["single"] / r["dt"]
                    if best is None or cost < best[1]:
                        best = (name, cost, r["dt"], err)
        out.append({"use": use, "integrator": best[0] if best else "none meets it",
                    "dt": best[2] if best else "-", "error_rad": best[3] if best else "-",
                    "cost_per_sim_second_us": 1e6 * best[1] if best else "-"})
    return out


def _curve(res: dict, step_cost: float):
    """(log error, log cost per simulated second) of one integrator, sorted by error.

    Only the converged part (1e-12 < error < 1 rad) is kept: round-off plateaus and diverged
    points say nothing about cost at equal accuracy.
    """
    pts = sorted((np.log(r["attitude_error_rad"]), np.log(step_cost / r["dt"]))
                 for r in res["rows"] if r["attitude_error_rad"] is not None
                 and np.isfinite(r["attitude_error_rad"]) and 1e-12 < r["attitude_error_rad"] < 1.0)
    return np.array([p[0] for p in pts]), np.array([p[1] for p in pts])


def dominance(results: dict, costs: dict, candidate: str = "splitting",
              rivals: tuple = ("rk4", "midpoint")) -> list[dict]:
    """Where ``candidate`` is cheaper than each rival at equal attitude error.

    For every dt of the candidate, the rival's cost at the same error is interpolated on its
    own work–precision curve (log–log); ``ratio`` = rival cost / candidate cost (> 1: the
    candidate dominates there). Done for one body and per body in a batch of N = BATCH.
    """
    rows = []
    for label, per in results.items():
        if candidate not in per:
            continue
        for rival in rivals:
            for mode in ("single", "batch_per_body"):
                ce, cc = _curve(per[candidate], costs[candidate][mode])
                re_, rc = _curve(per[rival], costs[rival][mode])
                inside = (ce >= re_.min()) & (ce <= re_.max()) if len(re_) else ce < 0
                ratio = np.exp(np.interp(ce[inside], re_, rc) - cc[inside])
                errs = np.exp(ce[inside])
                wins = errs[ratio > 1.0]
                rows.append({"scene": label, "rival": rival, "cost": mode,
                             "best_ratio": float(ratio.max()) if ratio.size else None,
                             "dominates_from_rad": float(wins.min()) if wins.size else None,
                             "dominates_to_rad": float(wins.max()) if wins.size else None,
                             "points": [{"error_rad": float(e), "ratio": float(r)}
                                        for e, r in zip(errs, ratio, strict=True)]})
    return rows


def plot(results: dict, costs: dict):
    plt = pyplot()
    fig, axes = plt.subplots(3, 3, figsize=(15, 12.5))
    for col, (label, per) in enumerate(results.items()):
        wp, wpn, conv = axes[0, col], axes[1, col], axes[2, col]
        for k, (name, res) in enumerate(per.items()):
            dt = np.array([r["dt"] for r in res["rows"]])
            err = np.array([r["attitude_error_rad"] if r["attitude_error_rad"] is not None
                            else np.nan for r in res["rows"]], dtype=float)
            err = np.where(np.isfinite(err), np.maximum(err, 1e-16), np.nan)
            style = {"color": f"C{k}", "ms": 3, "lw": 2.5 if name == "splitting" else 1.2}
            wp.loglog(err, costs[name]["single"] / dt, "o-", label=name, **style)
            wpn.loglog(err, costs[name]["batch_per_body"] / dt, "o-", label=name, **style)
            order = res["order"]
            tag = f"{name} (p = {order:.2f})" if order is not None else f"{name} (no convergence)"
            conv.loglog(dt, err, "o-", label=tag, **style)
        wp.set_title(label, fontsize=10)
        wp.set_ylabel("wall time per simulated second, one body (s)")
        wpn.set_ylabel(f"per body at N = {BATCH} (s per simulated s)")
        for ax in (wp, wpn):
            ax.set_xlabel("attitude error at final time (rad)")
        conv.set_xlabel("dt (s)")
        conv.set_ylabel("attitude error (rad)")
        for ax in (wp, wpn, conv):
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=7)
    fig.suptitle("Work–precision, one body (top) and batched (middle); error vs dt with fitted "
                 "order p (bottom)")
    fig.tight_layout()
    return fig


def orbit_work_precision() -> list[dict]:
    """Scene (d): the orbit's torques, one at a time, on the 6U bus (benchmarks.orbit_torques):
    error against solve_ivp of the same model and wall time per simulated second, per dt."""
    from benchmarks import orbit_torques

    conv = orbit_torques.convergence()
    rows = orbit_torques.work_precision_rows(conv)
    print("d: orbit torques (6U bus, 300 s): error against solve_ivp, rtol 1e-12")
    print(table(rows, ["torque", "integrator", "dt", "error_rad", "us_per_simulated_s"]))
    orders = [{"torque": n, **{i: r["order"] for i, r in per.items()}} for n, per in conv.items()]
    print(table(orders, ["torque", *orbit_torques.CONV_STEPS]))
    return rows


def main() -> dict:
    body = RigidBody(mass=1.0, inertia=np.diag(MOMENTS))
    costs = step_costs(body)
    results = sweep(body)
    orders = [{"integrator": n, **{s: results[s][n]["order"] for s in results}}
              for n in INTEGRATORS]
    print(table(orders, ["integrator", *results]))
    cost_rows = [{"integrator": n, "one body (us/step)": 1e6 * c["single"],
                  "N=4096 (ns/body-step)": 1e9 * c["batch_per_body"]} for n, c in costs.items()]
    print(table(cost_rows, ["integrator", "one body (us/step)", "N=4096 (ns/body-step)"]))
    rec = recommendations(results, costs)
    print(table(rec, ["use", "integrator", "dt", "error_rad", "cost_per_sim_second_us"]))
    dom = dominance(results, costs)
    print("splitting against rk4 and midpoint: rival cost / splitting cost at equal error")
    print(table(dom, ["scene", "rival", "cost", "best_ratio", "dominates_from_rad",
                      "dominates_to_rad"]))
    orbit = orbit_work_precision()
    write_json("accuracy", {"dts": DTS, "costs": costs, "results": results,
                            "recommendations": rec, "dominance": dom, "orbit_torques": orbit})
    save_figure(plot(results, costs), "accuracy")
    return {"costs": costs, "results": results, "recommendations": rec, "dominance": dom}


if __name__ == "__main__":
    from benchmarks.common import no_options

    no_options(__doc__)
    main()
