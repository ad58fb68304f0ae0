"""Cost of the per-step finiteness check in ``rbenv.core.step`` and ``rbenv.core.simulate``.

``rbenv.core.dynamics.check_finite_state`` runs after every step (|q| and ω finite and |q| = 1; the
position and velocity too when translation is integrated). This benchmark times the same calls
with the check and with it replaced by a no-op, in one run, interleaved, and reports the
ratio (best of several repeats; the machine is shared, so only the ratio is meaningful). It
also times the check alone against one integrator step alone, on kernel components, which is
far less sensitive to a noisy machine::

    python benchmarks/validation_cost.py --out benchmarks/results/validation_cost.json
"""

from __future__ import annotations

import argparse
import json
import timeit
from pathlib import Path

import numpy as np
from rbenv.core import BodyState, RigidBody, dynamics, simulate, step


def _time(fn, number: int, repeat: int) -> float:
    return min(timeit.repeat(fn, number=number, repeat=repeat)) / number


def measure(repeat: int = 7) -> list[dict]:
    body = RigidBody(mass=2.0, inertia=np.diag([1.0, 2.0, 2.5]))
    one = BodyState(angular_velocity=[0.1, 0.2, 0.3])
    many = BodyState(angular_velocity=np.random.default_rng(0).normal(size=(4096, 3)))
    tau1, tauN = [0.01, 0.0, 0.0], np.full((4096, 3), 0.01)
    cases = []
    for integrator in ("semi_implicit", "rk4", "midpoint"):
        cases += [
            (f"step, one body, {integrator}", 2000,
             lambda i=integrator: step(body, one, 0.01, torque=tau1, integrator=i), 1),
            (f"simulate 1000 steps, one body, {integrator}, no translation", 3,
             lambda i=integrator: simulate(body, one, 0.01, 1000, torque=tau1, integrator=i,
                                           translation=False), 1000),
            (f"simulate 1000 steps, one body, {integrator}, translation", 3,
             lambda i=integrator: simulate(body, one, 0.01, 1000, torque=tau1, integrator=i),
             1000),
            (f"simulate 20 steps, N = 4096, {integrator}", 2,
             lambda i=integrator: simulate(body, many, 0.01, 20, torque=tauN, integrator=i), 20),
        ]
    real = dynamics.check_finite_state
    rows = []
    for name, number, fn, steps in cases:
        with_check, without = [], []
        for _ in range(repeat):  # interleaved, so drift in machine load hits both alike
            dynamics.check_finite_state = real
            with_check.append(_time(fn, number, 1))
            dynamics.check_finite_state = lambda *args: None
            without.append(_time(fn, number, 1))
        dynamics.check_finite_state = real
        a, b = min(with_check), min(without)
        rows.append({"case": name, "us_per_step_checked": 1e6 * a / steps,
                     "us_per_step_unchecked": 1e6 * b / steps, "ratio": a / b})
    return rows


def measure_components(repeat: int = 31) -> list[dict]:
    """The check alone against one integrator step alone, on kernel components (min of repeats).

    Short calls timed many times are far less sensitive to a noisy machine than whole runs.
    """
    from rbenv.core import integrators, kernels

    body = RigidBody(mass=2.0, inertia=np.diag([1.0, 2.0, 2.5]))
    rng = np.random.default_rng(0)
    rows = []
    for label, n in (("one body", None), ("N = 4096", 4096)):
        q = kernels.unpack(np.array([1.0, 0, 0, 0]) if n is None else
                           np.tile([1.0, 0, 0, 0], (n, 1)))
        w = kernels.unpack(np.array([0.1, 0.2, 0.3]) if n is None else rng.normal(size=(n, 3)))
        x = np.zeros(3) if n is None else np.zeros((n, 3))
        number = 2000 if n is None else 100
        t_check = _time(lambda q=q, w=w: dynamics.check_finite_state(q, w, "rk4", 0.01),
                        number, repeat)
        t_check_xv = _time(lambda q=q, w=w, x=x: dynamics.check_finite_state(
            q, w, "rk4", 0.01, x, x), number, repeat)
        for name in ("semi_implicit", "rk4", "midpoint"):
            advance = integrators.get(name).advance
            t_step = _time(lambda a=advance, q=q, w=w: a(body, q, w, 0.01, None, None),
                           number, repeat)
            rows.append({"case": f"check / {name} step, {label}", "check_us": 1e6 * t_check,
                         "check_with_x_v_us": 1e6 * t_check_xv, "step_us": 1e6 * t_step,
                         "ratio": t_check / t_step, "ratio_with_x_v": t_check_xv / t_step})
    return rows


def main(argv=None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("validation_cost.json"),
                        help="JSON file to write (default: ./validation_cost.json)")
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args(argv)
    rows = measure(args.repeat)
    parts = measure_components()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"rows": rows, "components": parts}, indent=1))
    print("| check alone vs one integrator step | check µs | check with x, v µs | step µs "
          "| check / step | with x, v |\n|---|---|---|---|---|---|")
    for r in parts:
        print(f"| {r['case']} | {r['check_us']:.2f} | {r['check_with_x_v_us']:.2f} | "
              f"{r['step_us']:.2f} | {r['ratio']:.3f} | {r['ratio_with_x_v']:.3f} |")
    print("| case | µs/step checked | µs/step unchecked | ratio |\n|---|---|---|---|")
    for r in rows:
        print(f"| {r['case']} | {r['us_per_step_checked']:.2f} | "
              f"{r['us_per_step_unchecked']:.2f} | {r['ratio']:.3f} |")
    return rows


if __name__ == "__main__":
    main()
