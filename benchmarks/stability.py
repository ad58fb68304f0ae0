"""Numerical stability at the extremes, for every integrator.

Sweeps h·|ω| (0.01 to 10), inertia ratio (up to 1e6), mass (1e-6 to 1e6 kg) and horizon
(1e6 steps); records whether the state stays finite and the relative drift of energy and |L|.
Then drives the env to its limits (fast tumble, boom scene, thruster failure) and records that
each ends in a clear error or a clean termination, never a NaN.
Run: ``python -m benchmarks.stability`` or ``rbenv bench stability``.
"""

from __future__ import annotations

import numpy as np
from rbenv.core import INTEGRATORS, RigidBody, quaternion
from rbenv.core.body import invariants

from benchmarks.common import pyplot, save_figure, table, write_json

MOMENTS = np.array([5.0, 10.0, 13.0])
AXES = {"minor": [2.0, 0.3, 0.2], "intermediate": [0.05, 2.0, 0.05], "major": [0.2, 0.3, 2.0]}
Q0 = tuple(quaternion.normalize(np.array([0.9, 0.1, -0.3, 0.2])).tolist())
BLOW_UP = 1e6  # energy growth factor taken as divergence


def _invariants(body, q, w):
    energy, L_W = invariants(body, q, w)
    return float(energy), np.array(L_W, dtype=float)


def run(body, omega_B, h, n_steps, integrator, checkpoints=()):
    """Integrate one body torque-free; return drift record (and drift at checkpoints)."""
    advance = INTEGRATORS[integrator].advance
    q, w = Q0, tuple(float(x) for x in omega_B)
    E0, L0 = _invariants(body, q, w)
    marks, history, diverged_at = set(checkpoints), [], None
    for i in range(1, n_steps + 1):
        q, w = advance(body, q, w, h)
        if i % 16 == 0 or i == n_steps or i in marks:
            E, L = _invariants(body, q, w)
            if not np.isfinite(E) or E > BLOW_UP * E0:
                diverged_at = i
                break
            if i in marks:
                history.append((i, abs(E - E0) / E0, np.linalg.norm(L - L0) / np.linalg.norm(L0)))
    record = {"finite": diverged_at is None, "diverged_at_step": diverged_at}
    if diverged_at is None:
        E, L = _invariants(body, q, w)
        G0 = np.linalg.norm(L0)
        record.update(energy_drift=abs(E - E0) / E0,
                      momentum_drift=abs(np.linalg.norm(L) - G0) / G0,
                      L_W_drift=np.linalg.norm(L - L0) / G0)
    return record, history


def sweep_step_size(n_steps=2000) -> list[dict]:
    body = RigidBody(mass=1.0, inertia=np.diag(MOMENTS))
    rows = []
    for integrator in INTEGRATORS:
        for axis, omega in AXES.items():
            for hw in (0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0):
                h = hw / float(np.linalg.norm(omega))
                rec, _ = run(body, omega, h, n_steps, integrator)
                rows.append({"integrator": integrator, "axis": axis, "h_omega": hw, **rec})
    return rows


def sweep_inertia_ratio(n_steps=2000, h_omega=0.1) -> list[dict]:
    rows = []
    rng = np.random.default_rng(0)
    omega = rng.standard_normal(3)
    omega /= np.linalg.norm(omega)
    for ratio in (1e1, 1e2, 1e3, 1e4, 1e5, 1e6):
        # Slender body: I1 ≪ I2 < I3 with I1 + I2 ≥ I3 (a valid, nearly singular tensor).
        body = RigidBody(mass=1.0, inertia=np.diag([1.0 / ratio, 1.0, 1.0 + 0.5 / ratio]))
        for integrator in INTEGRATORS:
            rec, _ = run(body, omega, h_omega / 1.0, n_steps, integrator)
            rows.append({"integrator": integrator, "inertia_ratio": ratio, **rec})
    return rows


def sweep_mass(n_steps=2000, h_omega=0.1) -> list[dict]:
    rows = []
    omega = np.array(AXES["intermediate"])
    h = h_omega / float(np.linalg.norm(omega))
    for mass in (1e-6, 1e-3, 1.0, 1e3, 1e6):
        body = RigidBody(mass=mass, inertia=mass * np.diag(MOMENTS) / 10.0)
        for integrator in INTEGRATORS:
            rec, _ = run(body, omega, h, n_steps, integrator)
            rows.append({"integrator": integrator, "mass_kg": mass, **rec})
    return rows


def long_horizon(n_steps=1_000_000, h_omega=0.1) -> dict:
    body = RigidBody(mass=1.0, inertia=np.diag(MOMENTS))
    omega = np.array(AXES["major"])
    h = h_omega / float(np.linalg.norm(omega))
    marks = sorted({int(x) for x in np.logspace(1, np.log10(n_steps), 25)})
    out = {}
    for integrator in INTEGRATORS:
        rec, hist = run(body, omega, h, n_steps, integrator, checkpoints=marks)
        out[integrator] = {**rec, "history": hist}
    return out


def env_limits() -> list[dict]:
    """Drive the env where it breaks: each case must end in a clear error or a clean stop."""
    try:
        from benchmarks.env_limits import cases
    except ImportError:
        return []
    return cases()


def plot(step_rows, horizon):
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.3))
    ax = axes[0]
    for k, integrator in enumerate(INTEGRATORS):
        rows = [r for r in step_rows if r["integrator"] == integrator and r["axis"] == "major"]
        hw = [r["h_omega"] for r in rows]
        drift = [max(r.get("energy_drift", np.nan), 1e-17) if r["finite"] else np.nan for r in rows]
        ax.loglog(hw, drift, "o-", color=f"C{k}", label=integrator)
        for r in rows:
            if not r["finite"]:
                ax.plot(r["h_omega"], 1e2, "x", color=f"C{k}", ms=9, mew=2)
    ax.axhline(1e2, color="grey", lw=0.5, ls=":")
    ax.text(0.011, 1.5e2, "× = diverged", fontsize=8)
    ax.set_xlabel("h·|ω|")
    ax.set_ylabel("relative energy drift after 2000 steps")
    ax.set_title("Step-size stability (near the major axis)")
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    bx = axes[1]
    for k, (integrator, rec) in enumerate(horizon.items()):
        if rec["history"]:
            steps, e, _ = zip(*rec["history"], strict=True)
            bx.loglog(steps, np.maximum(e, 1e-17), "-", color=f"C{k}", label=integrator)
        if not rec["finite"]:
            bx.axvline(rec["diverged_at_step"], color=f"C{k}", ls="--", lw=0.8)
    bx.set_xlabel("steps (h·|ω| = 0.1)")
    bx.set_ylabel("relative energy drift")
    bx.set_title("Long horizon: 10⁶ steps (dashed: divergence)")
    bx.legend(fontsize=8)
    bx.grid(True, which="both", alpha=0.3)
    return fig


def summary(step_rows) -> list[dict]:
    out = []
    for integrator in INTEGRATORS:
        rows = [r for r in step_rows if r["integrator"] == integrator]
        stable = [r["h_omega"] for r in rows if r["finite"]]
        unstable = [r["h_omega"] for r in rows if not r["finite"]]
        drift = [r["energy_drift"] for r in rows if r["finite"]]
        out.append({"integrator": integrator,
                    "first h|w| that diverged": min(unstable) if unstable else "none ≤ 10",
                    "largest stable h|w|": max(stable) if stable else "-",
                    "worst energy drift (finite runs)": max(drift) if drift else "-"})
    return out


# --------------------------------------------------------------------------- wheels, rods

def _wheel_scene(inertia_B, wheel_J, speed_rpm, start_rpm, integrator, dt, rods=False):
    from rbenv.satellite.scene import Scene

    data = {"name": "stability-wheels", "body": {"mass": 12.0, "inertia": inertia_B},
            "wheels": {"axes": np.eye(3).tolist(), "inertia": wheel_J, "max_torque": 0.01,
                       "max_speed_rpm": speed_rpm, "initial_speed_rpm": start_rpm},
            "physics": {"integrator": integrator, "control_dt": dt},
            "episode": {"duration": 4e5, "rate_limit": 50.0, "max_initial_rate": 40.0,
                        "success_rate": 1e-9}}
    if rods:
        data["magnetorquers"] = {"axes": np.eye(3).tolist(), "max_dipole": 0.2}
        data["orbit"] = {"model": "circular", "altitude_km": 500.0, "inclination_deg": 97.4,
                         "magnetic_field": True}
    return Scene.from_dict(data)


def _momentum_W(env) -> np.ndarray:
    from rbenv.core import kernels

    st, plant = env._st, env.plant
    ws = plant.actuator("wheels").wheels
    w = np.array(st.omega_B, dtype=float)
    h = ws.inertia * (np.array(st.wheel_speed) + ws.axes_B @ w)
    return np.array(kernels.rotate(st.q, tuple(plant.body.inertia @ w + h @ ws.axes_B)))


def _drive(env, steps, action, omega0):
    import gymnasium as gym  # noqa: F401 (the env is made by the caller)

    env.reset(seed=0, options={"omega_B": omega0})
    L0 = _momentum_W(env)
    try:
        for _ in range(steps):
            env.step(action)
    except ValueError as exc:  # NonFiniteError and the named errors are ValueErrors
        return {"outcome": f"error: {type(exc).__name__}", "detail": str(exc)[:120]}
    st = env._st
    finite = bool(np.isfinite([*st.q, *st.omega_B, *st.wheel_speed]).all())
    return {"outcome": "finite" if finite else "NON-FINITE",
            "L_W_drift": float(np.abs(_momentum_W(env) - L0).max() / np.linalg.norm(L0)),
            "max_wheel_rpm": float(np.abs(st.wheel_speed).max() * 60 / (2 * np.pi))}


def wheels_at_the_extremes() -> list[dict]:
    """Wheels at their speed limit, rotor inertia near the bus's, fast tumbles under B-dot."""
    import gymnasium as gym

    import rbenv

    rows = []
    bus = np.diag([0.185, 0.144, 0.061]).tolist()
    for integrator in ("midpoint", "rk4"):
        env = gym.make(rbenv.DETUMBLE_ID, scene=_wheel_scene(
            bus, 3e-5, 6500, 6500, integrator, 0.5)).unwrapped
        row = _drive(env, 2000, np.ones(3, np.float32), [0.05, -0.05, 0.1])
        rows.append({"case": "wheels at 6500 rpm, pushed on", "integrator": integrator, **row})
        for frac in (1e-3, 0.3, 0.6, 0.9):  # rotor spin inertia / smallest bus inertia
            J = frac * 0.061
            try:
                env = gym.make(rbenv.DETUMBLE_ID, scene=_wheel_scene(
                    bus, J, 600, 0, integrator, 0.5)).unwrapped
            except ValueError as exc:
                rows.append({"case": f"rotor J = {frac} x bus I_min", "integrator": integrator,
                             "outcome": f"error: {type(exc).__name__}",
                             "detail": str(exc)[:120]})
                continue
            rng = np.random.default_rng(0)
            env.reset(seed=0, options={"omega_B": [0.3, -0.2, 0.4]})
            L0, out = _momentum_W(env), "finite"
            try:
                for _ in range(1000):
                    env.step(rng.uniform(-1, 1, 3).astype(np.float32))
            except ValueError as exc:
                out = f"error: {type(exc).__name__}"
            rows.append({"case": f"rotor J = {frac} x bus I_min", "integrator": integrator,
                         "outcome": out, "L_W_drift": float(
                             np.abs(_momentum_W(env) - L0).max() / np.linalg.norm(L0))})
    for rate in (0.1, 0.5, 1.0, 3.0):  # rad/s tumbles, B-dot at 1 s steps
        env = gym.make(rbenv.DETUMBLE_ID, scene=_wheel_scene(
            bus, 3e-5, 6500, 0, "rk4", 1.0, rods=True)).unwrapped
        env.reset(seed=0, options={"omega_B": [rate, -0.6 * rate, 0.8 * rate]})
        inertia = env.plant.body.inertia
        energy, rising, out = [], 0, "finite"
        try:
            for _ in range(500):
                w, b = np.array(env._st.omega_B), np.array(env._st.field_B_T)
                m = np.clip(2e4 * np.cross(w, b), -0.2, 0.2)
                env.step(np.concatenate([np.zeros(3), m / 0.2]).astype(np.float32))
                energy.append(0.5 * w @ inertia @ w)
        except ValueError as exc:
            out = f"error: {type(exc).__name__}"
        e = np.array(energy)
        rising = int(np.sum(np.diff(e) > 1e-12 * e[0])) if len(e) > 1 else 0
        rows.append({"case": f"B-dot on a {rate} rad/s tumble (h|w| = {rate:.1f})",
                     "integrator": "rk4", "outcome": out,
                     "energy_steps_rising": rising,
                     "energy_final_over_initial": float(e[-1] / e[0]) if len(e) else None})
    return rows


def main(horizon_steps: int = 1_000_000) -> dict:
    steps = sweep_step_size()
    ratios = sweep_inertia_ratio()
    masses = sweep_mass()
    horizon = long_horizon(horizon_steps)
    env = env_limits()
    print(table(summary(steps), ["integrator", "first h|w| that diverged", "largest stable h|w|",
                                 "worst energy drift (finite runs)"]))
    print(table(ratios, ["integrator", "inertia_ratio", "finite", "energy_drift", "L_W_drift"]))
    print(table(masses, ["integrator", "mass_kg", "finite", "energy_drift", "L_W_drift"]))
    print(table([{"integrator": k, **{x: v for x, v in r.items() if x != "history"}}
                 for k, r in horizon.items()],
                ["integrator", "finite", "diverged_at_step", "energy_drift", "momentum_drift",
                 "L_W_drift"]))
    if env:
        print(table(env, ["case", "outcome", "detail"]))
    wheels = wheels_at_the_extremes()
    print(table(wheels, ["case", "integrator", "outcome", "L_W_drift", "max_wheel_rpm",
                         "energy_steps_rising", "energy_final_over_initial"]))
    data = {"step_size": steps, "inertia_ratio": ratios, "mass": masses,
            "horizon": horizon, "horizon_steps": horizon_steps, "env_limits": env,
            "wheels": wheels}
    write_json("stability", data)
    save_figure(plot(steps, horizon), "stability")
    return data


if __name__ == "__main__":
    from benchmarks.common import no_options

    no_options(__doc__)
    main()
