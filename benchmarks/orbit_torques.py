"""The orbit's torques: convergence against a tight SciPy reference, the step targets,
and the cost of each torque per env step.

Bus: the 6U box of ``cubesat-6u-rw`` (12 kg, I = diag(0.185, 0.144, 0.061) kg·m²) with three
0.2 A·m² rods, on its 500 km, 97.4° orbit, tumbling at about 5e-3 rad/s. Cases, one torque
each (the rods present but idle unless the case commands them):

* ``gravity gradient``; ``magnetorquers``: constant rod commands (0.5, −0.3, 0.8) of 0.2 A·m²;
  ``residual dipole`` (0.05, −0.02, 0.08) A·m²; ``drag`` (0.06 m², C_D 2.2, centre of pressure
  5 cm off, density × 100 so the torque stands above the free body's error);
  ``srp`` (0.06 m², reflectivity 0.3, 5 cm off, × 100 area; the window is in sunlight).

1. **Convergence**: the plant's attitude after ``T_CONV`` s against ``solve_ivp`` (DOP853,
   rtol 1e-12, atol 1e-14) of the same model (the torques evaluated at continuous time);
   fitted order for rk4, midpoint and splitting.
2. **Targets** (rk4, 600 s): attitude difference against the plant at 0.1 s for gravity
   gradient at 10 s × 4 and for the magnetorquers at 0.5 s and at 10 s × 4.
3. **Cost**: seconds per env step of the detumble env on the bus with idle wheels (one
   satellite, and per satellite at N = 1024) for each case, and all five, against the same
   scene without orbit torques, interleaved in one run.

Run: ``python -m benchmarks.orbit_torques [--quick]`` (also part of ``rbenv bench accuracy``).
"""

from __future__ import annotations

import argparse
import json
import time
from types import SimpleNamespace

import numpy as np
from rbenv.core import kernels as k
from rbenv.core import quaternion
from rbenv.core.backend import FLOAT

from benchmarks.common import PROBE_PRELUDE, best_times, fit_order, table, write_json
from rbenv.satellite import disturbances as dist
from rbenv.satellite.orbit import gravity_gradient_torque_B
from rbenv.satellite.plant import make_plant
from rbenv.satellite.scene import Scene

INERTIA = [[0.185, 0.0, 0.0], [0.0, 0.144, 0.0], [0.0, 0.0, 0.061]]
Q0 = tuple(quaternion.normalize(np.array([0.9, 0.1, -0.3, 0.2])).tolist())
W0 = (0.003, -0.002, 0.004)  # rad/s
ROD_COMMAND = (0.5, -0.3, 0.8)
OFFSET = [0.01, -0.03, 0.04]  # m, centre of pressure from the centre of mass (5.1 cm)
CASES = {
    "gravity gradient": ({"gravity_gradient": True}, None),
    "magnetorquers": ({}, ROD_COMMAND),
    "residual dipole": ({"residual_dipole": {"moment_B_Am2": [0.05, -0.02, 0.08]}}, None),
    "drag": ({"drag": {"area_m2": 0.06, "cd": 2.2, "cp_offset_B_m": OFFSET,
                       "density_scale": 100.0}}, None),
    "srp": ({"srp": {"area_m2": 6.0, "reflectivity": 0.3, "cp_offset_B_m": OFFSET,
                     "epoch": "2025-03-20T12:00:00"}}, None),
}
T_CONV = 300.0  # s
CONV_STEPS = {"rk4": (20.0, 10.0, 5.0), "midpoint": (10.0, 5.0, 2.5),
              "splitting": (10.0, 5.0, 2.5)}


RODS = {"axes": np.eye(3).tolist(), "max_dipole": 0.2, "power_W": 0.2}
WHEELS = {"axes": np.eye(3).tolist(), "inertia": 2.94e-5, "max_torque": 0.0032,
          "max_speed_rpm": 6500.0}  # cubesat-6u-rw's RW0s


def scene(orbit_extra: dict, *, integrator="rk4", control_dt=0.5, substeps=1,
          duration=600.0, actuators=None) -> Scene:
    """The 6U bus on the 500 km orbit, plus ``orbit_extra`` ([orbit] keys); ``actuators``:
    scene tables (default: the rods, idle unless commanded)."""
    orbit = {"model": "circular", "altitude_km": 500.0, "inclination_deg": 97.4,
             "magnetic_field": True, **orbit_extra}
    return Scene.from_dict({
        "name": "orbit-torques", "body": {"mass": 12.0, "inertia": INERTIA},
        **(actuators or {"magnetorquers": RODS}),
        "orbit": orbit,
        "physics": {"integrator": integrator, "control_dt": control_dt, "substeps": substeps},
        "episode": {"duration": duration, "rate_limit": 5.0, "max_initial_rate": 0.01}})


def run_plant(sc: Scene, rods, duration: float) -> tuple:
    """(q, ω_B) of the plant after ``duration`` s from (Q0, W0) under constant rod commands
    (fractions, or None: idle)."""
    plant = make_plant(sc)
    st = SimpleNamespace(q=Q0, omega_B=W0, steps=0, bias=None, model=None, x=None, v=None,
                         field_B_T=(0.0, 0.0, 0.0), mtq_dipole_B=(0.0, 0.0, 0.0),
                         mtq_energy_J=0.0)
    action = np.array(rods or (0.0, 0.0, 0.0), dtype=np.float32)
    for _ in range(round(duration / plant.control_dt)):
        c = plant.actuate(st, action, None, FLOAT)
        if plant.advance(st, c, None, FLOAT):
            raise FloatingPointError("diverged")
    return st.q, st.omega_B


def reference(sc: Scene, rods, duration: float) -> tuple:
    """(q, ω_B) after ``duration`` s from solve_ivp (DOP853, rtol 1e-12, atol 1e-14) of the
    same torques evaluated at continuous time."""
    from scipy.integrate import solve_ivp

    orbit, body = sc.orbit, sc.body
    inertia = np.asarray(body.inertia)
    inv = np.linalg.inv(inertia)
    m_cmd = np.zeros(3) if rods is None else 0.2 * np.asarray(rods, float)
    m_res = (np.zeros(3) if orbit.residual_dipole is None
             else np.asarray(orbit.residual_dipole.moment_B_Am2))
    m_B = tuple((m_cmd + m_res).tolist())

    def torque(t, q):
        tau = np.zeros(3)
        if orbit.gravity_gradient:
            tau += gravity_gradient_torque_B(body, q, orbit.direction_N(t, FLOAT),
                                             orbit.mean_motion)
        tau += k.cross(m_B, k.rotate_inverse(q, orbit.field_N(t, FLOAT)))
        if orbit.drag is not None:
            tau += k.cross(orbit.drag.cp_offset_B_m,
                           k.rotate_inverse(q, dist.drag_force_N(orbit, t, FLOAT)))
        if orbit.srp is not None:
            tau += k.cross(orbit.srp.cp_offset_B_m,
                           k.rotate_inverse(q, dist.srp_force_N(orbit, t, FLOAT)))
        return tau

    def rhs(t, y):
        q = tuple((y[:4] / np.linalg.norm(y[:4])).tolist())
        w = y[4:]
        q_dot = k.qmul_vec(tuple(y[:4].tolist()), tuple((0.5 * w).tolist()))
        w_dot = inv @ (torque(t, q) - np.cross(w, inertia @ w))
        return np.concatenate([q_dot, w_dot])

    sol = solve_ivp(rhs, (0.0, duration), np.array([*Q0, *W0]), method="DOP853", rtol=1e-12,
                    atol=1e-14)
    y = sol.y[:, -1]
    return tuple((y[:4] / np.linalg.norm(y[:4])).tolist()), tuple(y[4:].tolist())


def angle(q1, q2) -> float:
    """Geodesic angle between two attitudes, rad."""
    return float(quaternion.angle(np.array(q1), np.array(q2)))


def convergence(cases=CASES, steps=CONV_STEPS, duration=T_CONV) -> dict:
    """Per case and integrator: error rows against the SciPy reference and the fitted order."""
    out = {}
    for name, (extra, rods) in cases.items():
        q_ref, _ = reference(scene(extra), rods, duration)
        out[name] = {}
        for integ, dts in steps.items():
            rows = []
            for dt in dts:
                sc = scene(extra, integrator=integ, control_dt=dt, duration=duration)
                t0 = time.perf_counter()
                q = run_plant(sc, rods, duration)[0]
                wall = time.perf_counter() - t0
                rows.append({"dt": dt, "attitude_error_rad": angle(q, q_ref),
                             "wall_s_per_simulated_s": wall / duration})
            out[name][integ] = {"rows": rows, "order": fit_order(
                [r["dt"] for r in rows], [r["attitude_error_rad"] for r in rows])}
    return out


def targets() -> list[dict]:
    """The targets: rk4, 600 s, against the plant at 0.1 s."""
    rows = []
    for name, step, subs, limit in (("gravity gradient", 10.0, 4, 1e-5),
                                    ("magnetorquers", 0.5, 1, 1e-6),
                                    ("magnetorquers", 10.0, 4, 1e-3)):
        extra, rods = CASES[name]
        q_ref, _ = run_plant(scene(extra, control_dt=0.1), rods, 600.0)
        q, _ = run_plant(scene(extra, control_dt=step, substeps=subs), rods, 600.0)
        err = angle(q, q_ref)
        rows.append({"torque": name, "step": f"{step:g} s x {subs}", "error_rad": err,
                     "target_rad": limit, "met": err <= limit})
    return rows


def costs(num_envs: int = 1024) -> list[dict]:
    """Seconds per env step (detumble, rk4 at 0.5 s, one substep) of the 6U bus with idle
    wheels, with each torque against the same scene without orbit torques, one satellite and
    per satellite at N = ``num_envs``; one interleaved run."""
    import gymnasium as gym

    import rbenv

    everything = {k: v for extra, _ in CASES.values() for k, v in extra.items()}
    fns, labels = {}, {"none": ({}, None), **CASES, "all five": (everything, ROD_COMMAND)}
    for label, (extra, rods) in labels.items():
        acts = {"wheels": WHEELS, **({"magnetorquers": RODS} if rods else {})}
        sc = scene(extra, duration=1e5, actuators=acts)
        act = np.array((0.0, 0.0, 0.0, *(rods or ())), np.float32)
        env = gym.make(rbenv.DETUMBLE_ID, scene=sc).unwrapped
        env.reset(seed=0)
        venv = gym.make_vec(rbenv.DETUMBLE_ID, num_envs=num_envs, scene=sc)
        venv.reset(seed=0)
        acts = np.tile(act, (num_envs, 1))
        fns[(label, "single")] = lambda env=env, act=act: env.step(act)
        fns[(label, "batch")] = lambda venv=venv, acts=acts: venv.step(acts)
    t = best_times(fns)
    base_s, base_b = t[("none", "single")], t[("none", "batch")]
    return [{"torque": label, "single_us": 1e6 * t[(label, "single")],
             "single_ratio": t[(label, "single")] / base_s,
             "batch_us_per_env": 1e6 * t[(label, "batch")] / num_envs,
             "batch_ratio": t[(label, "batch")] / base_b} for label in labels]


# CPU seconds per env step on cubesat-6u-rw (wheels and rods, gravity gradient), in the tree
# on PYTHONPATH: reorient (0.5 s, rk4) and detumble (10 s x 4), one satellite and N = 256.
AB_PROBE = PROBE_PRELUDE + r"""
warnings.simplefilter("ignore")

def vec(env_id, n=256):
    env = gym.make_vec(env_id, num_envs=n, scene="cubesat-6u-rw")
    env.reset(seed=0)
    acts = 0.3 * np.random.default_rng(1).uniform(-1, 1, (16, n, 6)).astype(np.float32)
    def run(k):
        for i in range(k):
            env.step(acts[i % 16])
    return best(run, 50) / n

out = {}
for name, env_id in (("reorient", "rbenv/SatelliteReorient-v0"),
                     ("detumble", "rbenv/SatelliteDetumble-v0")):
    env = gym.make(env_id, scene="cubesat-6u-rw").unwrapped
    out[name + "_single_us"] = 1e6 * single(env, 1000, scale=0.3)
    out[name + "_vec256_us_per_env"] = 1e6 * vec(env_id)
print(json.dumps(out))
"""


def ab(baseline: str, rounds: int = 3) -> dict:
    """The wheel scene's step cost here against ``baseline`` (a source tree), alternating
    fresh interpreters round by round and keeping each figure's best."""
    from pathlib import Path

    from benchmarks.common import run_in_tree

    trees = {"old": Path(baseline), "new": Path(__file__).resolve().parents[1]}
    best = {}
    for _ in range(rounds):
        for name, tree in trees.items():
            got = run_in_tree(tree, AB_PROBE)
            best[name] = {k: min(v, best.get(name, {}).get(k, v)) for k, v in got.items()}
    return {"best": best, "new_over_old": {k: best["new"][k] / best["old"][k]
                                           for k in best["new"]}}


def work_precision_rows(conv: dict) -> list[dict]:
    """One row per torque, integrator and dt: error and wall time per simulated second
    (one satellite, plant step including the torque; a single timing, under the run's
    load)."""
    return [{"torque": n, "integrator": i, "dt": row["dt"],
             "error_rad": row["attitude_error_rad"],
             "us_per_simulated_s": 1e6 * row["wall_s_per_simulated_s"]}
            for n, per in conv.items() for i, r in per.items() for row in r["rows"]]


def main(argv=None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="convergence only, two cases (CI)")
    p.add_argument("--baseline", default=None,
                   help="only the A/B of cubesat-6u-rw's step cost against this source tree")
    args = p.parse_args(argv)
    if args.baseline:
        result = ab(args.baseline)
        print(json.dumps(result, indent=1))
        write_json("orbit_torques_ab", result)
        return result
    cases = {n: CASES[n] for n in ("gravity gradient", "magnetorquers")} if args.quick \
        else CASES
    conv = convergence(cases)
    rows = [{"torque": n, "integrator": i, "order": r["order"],
             "error at largest dt": r["rows"][0]["attitude_error_rad"],
             "error at smallest dt": r["rows"][-1]["attitude_error_rad"]}
            for n, per in conv.items() for i, r in per.items()]
    print(table(rows, ["torque", "integrator", "order", "error at largest dt",
                       "error at smallest dt"]))
    out = {"convergence": conv, "T_conv_s": T_CONV}
    if not args.quick:
        out["targets"] = targets()
        print(table(out["targets"], ["torque", "step", "error_rad", "target_rad", "met"]))
        out["costs"] = costs()
        print(table(out["costs"], ["torque", "single_us", "single_ratio", "batch_us_per_env",
                                   "batch_ratio"]))
    write_json("orbit_torques", out)
    return out


if __name__ == "__main__":
    main()
