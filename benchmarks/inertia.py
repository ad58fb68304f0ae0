"""The lecture's Challenge: particle sums converge to the closed-form inertia tensors.

Solid and hollow box and sphere, sampled at rising resolution; error against the closed form,
fitted rate; and the lecture's hollow-box formula drawn beside the correct one.
Run: ``python -m benchmarks.inertia`` or ``rbenv bench inertia``.
"""

from __future__ import annotations

import numpy as np
from rbenv.core import inertia

from benchmarks.common import fit_order, pyplot, save_figure, table, write_json

MASS = 2.0
BOX = (1.0, 2.0, 3.0)
CUBE = (1.0, 1.0, 1.0)
RADIUS = 0.5
RESOLUTIONS = (2, 4, 8, 16, 32, 64)

CASES = {
    "solid box": (lambda n: inertia.box_particles(MASS, BOX, n), inertia.solid_box(MASS, BOX)),
    "hollow box": (lambda n: inertia.box_particles(MASS, BOX, n, surface=True),
                   inertia.hollow_box(MASS, BOX)),
    "solid sphere": (lambda n: inertia.sphere_particles(MASS, RADIUS, n),
                     inertia.solid_sphere(MASS, RADIUS)),
    "hollow sphere": (lambda n: inertia.sphere_particles(MASS, RADIUS, n, surface=True),
                      inertia.hollow_sphere(MASS, RADIUS)),
}


def relative_error(approx: np.ndarray, exact: np.ndarray) -> float:
    """max |ΔI| / max |I| over the tensor entries."""
    return float(np.abs(approx - exact).max() / np.abs(exact).max())


def convergence() -> dict:
    """Error against resolution for each Challenge case, with particle counts and fitted rate."""
    out = {}
    for name, (sample, exact) in CASES.items():
        rows = []
        for n in RESOLUTIONS:
            masses, positions = sample(n)
            props = inertia.from_particles(masses, positions)
            rows.append({"n": n, "particles": len(masses),
                         "error": relative_error(props.inertia, exact)})
        ns = [r["n"] for r in rows]
        out[name] = {"rows": rows, "order": fit_order(ns, [r["error"] for r in rows])}
    return out


def hollow_box_verdict() -> dict:
    """Cube and 1×2×3 box: particle surface sum vs correct and lecture formulas (I_xx)."""
    out = {}
    for label, size in (("cube", CUBE), ("box 1x2x3", BOX)):
        masses, positions = inertia.box_particles(MASS, size, 64, surface=True)
        particles = inertia.from_particles(masses, positions).inertia
        out[label] = {
            "particles": np.diag(particles),
            "correct": np.diag(inertia.hollow_box(MASS, size)),
            "lecture": np.diag(inertia.lecture_hollow_box(MASS, size)),
        }
        out[label]["lecture_over_particles"] = out[label]["lecture"] / out[label]["particles"]
    return out


def plot(conv: dict, verdict: dict):
    plt = pyplot()
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.2))
    for name, res in conv.items():
        n = [r["n"] for r in res["rows"]]
        errors = [r["error"] for r in res["rows"]]
        ax.loglog(n, errors, "o-", label=f"{name} (order {-res['order']:.2f})")
    ax.set_xticks(RESOLUTIONS, [str(n) for n in RESOLUTIONS])
    ax.minorticks_off()
    ax.set_xlabel("resolution n (samples per edge / band)")
    ax.set_ylabel("relative error of particle-sum inertia")
    ax.set_title("Lecture's Challenge: particles → closed form")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    labels = list(verdict)
    x = np.arange(len(labels))
    for k, (key, colour) in enumerate((("particles", "C0"), ("correct", "C2"), ("lecture", "C3"))):
        vals = [verdict[lab][key][0] for lab in labels]
        bx.bar(x + (k - 1) * 0.27, vals, 0.27, label=key, color=colour)
    bx.set_yscale("log")
    bx.set_xticks(x, labels)
    bx.set_ylabel("hollow box I_xx (kg·m²), m = 2 kg")
    bx.set_title("Hollow box: lecture's (5/3)m(h²+d²) vs particles")
    bx.legend()
    return fig


def main() -> dict:
    conv = convergence()
    verdict = hollow_box_verdict()
    rows = [{"case": k, "order": -v["order"], "error at n=64": v["rows"][-1]["error"],
             "particles at n=64": v["rows"][-1]["particles"]} for k, v in conv.items()]
    print(table(rows, ["case", "order", "error at n=64", "particles at n=64"]))
    for label, v in verdict.items():
        print(f"{label}: lecture / particle-sum I_xx = {v['lecture_over_particles'][0]:.3f}")
    write_json("inertia", {"convergence": conv, "hollow_box": verdict})
    save_figure(plot(conv, verdict), "inertia")
    return {"convergence": conv, "hollow_box": verdict}


if __name__ == "__main__":
    from benchmarks.common import no_options

    no_options(__doc__)
    main()
