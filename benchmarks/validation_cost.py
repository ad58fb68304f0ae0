"""Cost of the per-step finiteness check in ``core.step`` and ``core.simulate``.

``core.dynamics.check_finite_state`` runs after every step (|q| and ω finite and |q| = 1; the
position and velocity too when translation is integrated). This benchmark times the same calls
with the check and with it replaced by a no-op, in one run, interleaved, and reports the
ratio (best of several repeats; the machine is shared, so only the ratio is meaningful)::

    python benchmarks/validation_cost.py --out benchmarks/results/validation_cost.json
"""

from __future__ import annotations

import argparse
import json
import timeit
from pathlib import Path

import numpy as np

from core import BodyState, RigidBody, dynamics, simulate, step


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


def main(argv=None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("validation_cost.json"),
                        help="JSON file to write (default: ./validation_cost.json)")
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args(argv)
    rows = measure(args.repeat)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"rows": rows}, indent=1))
    print("| case | µs/step checked | µs/step unchecked | ratio |\n|---|---|---|---|")
    for r in rows:
        print(f"| {r['case']} | {r['us_per_step_checked']:.2f} | "
              f"{r['us_per_step_unchecked']:.2f} | {r['ratio']:.3f} |")
    return rows


if __name__ == "__main__":
    main()
