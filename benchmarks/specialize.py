"""Model only what a scene requires: what the specialised step saves, and that it changes nothing.

Compares the general step (full 3×3 inertia, gyroscopic term, change of basis, translation)
with the step specialised to the scene: isotropic inertia (no gyroscopic term, no change of
basis), principal-axis (diagonal) inertia, and attitude-only (no translation). Speed is a ratio
measured in one run; agreement is the max difference of the final states.
Run: ``python -m benchmarks.specialize`` or ``rbenv bench specialize``.
"""

from __future__ import annotations

from functools import partial

import numpy as np
from rbenv.core import INTEGRATORS, BodyState, RigidBody, inertia, quaternion, simulate

from benchmarks.common import best_times, components, pyplot, save_figure, table, write_json

STEPS = 200
H = 0.05


def _states(n: int):
    rng = np.random.default_rng(0)
    q = quaternion.random(rng, (n,) if n > 1 else ())
    w = rng.normal(0.0, 0.3, (n, 3) if n > 1 else (3,))
    tau = rng.normal(0.0, 0.01, w.shape)
    return q, w, tau


def kernel_costs(bodies: dict, integrator: str, n: int) -> dict:
    """Seconds per body-step of one integrator for each body at batch size n (1 = float path).

    The bodies are timed in interleaved rounds (best of rounds), so their ratio is fair.
    """
    q, w, tau = _states(n)
    qc, wc, tc = components(q), components(w), components(tau)
    advance = INTEGRATORS[integrator].advance
    t = best_times({label: (lambda b=b: advance(b, qc, wc, H, tc, None))
                    for label, b in bodies.items()})
    return {label: v / n for label, v in t.items()}


def agreement(specialised: RigidBody, general: RigidBody, integrator: str) -> float:
    """Max |Δ| of orientation and ω after STEPS steps of the two bodies from the same state."""
    q, w, tau = _states(64)
    state = BodyState(orientation=q, angular_velocity=w)
    a = simulate(specialised, state, H, STEPS, torque=tau, integrator=integrator)
    b = simulate(general, state, H, STEPS, torque=tau, integrator=integrator)
    return float(max(np.abs(a.orientation - b.orientation).max(),
                     np.abs(a.angular_velocity - b.angular_velocity).max()))


def inertia_cases() -> list[dict]:
    cube = inertia.solid_box(24.0, (0.3, 0.3, 0.3))
    cubesat = inertia.solid_box(24.0, (0.226, 0.226, 0.366))
    rows = []
    for label, tensor in (("isotropic (cube)", cube), ("diagonal (12U box)", cubesat)):
        fast = RigidBody(mass=24.0, inertia=tensor)
        full = RigidBody(mass=24.0, inertia=tensor, specialize=False)
        for integrator in ("euler_seed", "semi_implicit", "rk4", "midpoint", "splitting"):
            for n in (1, 4096):
                t = kernel_costs({"fast": fast, "full": full}, integrator, n)
                t_fast, t_full = t["fast"], t["full"]
                rows.append({"case": label, "integrator": integrator, "N": n,
                             "specialised_us": 1e6 * t_fast, "general_us": 1e6 * t_full,
                             "speedup": t_full / t_fast,
                             "max_abs_difference": agreement(fast, full, integrator)})
    return rows


def translation_cases() -> list[dict]:
    body = RigidBody(mass=24.0, inertia=inertia.solid_box(24.0, (0.226, 0.226, 0.366)))
    rows = []
    for n in (1, 4096):
        q, w, tau = _states(n)
        state = BodyState(orientation=q, angular_velocity=w)
        force = np.full(w.shape, 0.01)
        t = best_times({"on": partial(simulate, body, state, H, 20, force=force, torque=tau),
                        "off": partial(simulate, body, state, H, 20, torque=tau,
                                       translation=False)})
        t_on, t_off = t["on"] / 20, t["off"] / 20
        on = simulate(body, state, H, STEPS, force=force, torque=tau)
        off = simulate(body, state, H, STEPS, torque=tau, translation=False)
        rows.append({"case": "attitude-only (no translation)", "integrator": "midpoint", "N": n,
                     "specialised_us": 1e6 * t_off / n, "general_us": 1e6 * t_on / n,
                     "speedup": t_on / t_off,
                     "max_abs_difference": float(np.abs(on.orientation - off.orientation).max())})
    return rows


def plot(rows: list[dict]):
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(10, 4))
    labels = [f"{r['case']}\n{r['integrator']}, N={r['N']}" for r in rows]
    ax.barh(range(len(rows)), [r["speedup"] for r in rows],
            color=["C0" if r["N"] == 1 else "C1" for r in rows])
    ax.axvline(1.0, color="k", lw=0.8)
    ax.set_yticks(range(len(rows)), labels, fontsize=7)
    ax.invert_yaxis()
    ax.set_xlabel("speed-up of the specialised step (general time / specialised time)")
    ax.set_title("Model only what the scene requires (blue: one body, orange: N = 4096)")
    return fig


def main() -> dict:
    rows = inertia_cases() + translation_cases()
    print(table(rows, ["case", "integrator", "N", "specialised_us", "general_us", "speedup",
                       "max_abs_difference"]))
    write_json("specialize", {"rows": rows, "steps_for_agreement": STEPS, "dt": H})
    save_figure(plot(rows), "specialize")
    return {"rows": rows}


if __name__ == "__main__":
    from benchmarks.common import no_options

    no_options(__doc__)
    main()
