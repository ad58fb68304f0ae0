"""Identify: fit what flight telemetry can tell about a scene, by least squares on replays.

The model is rbenv itself: each evaluation builds the scene with the trial values
(:func:`rbenv.scene_variant`) and flies the controller that flew (``--policy``, the flight PD by
default) closed loop from every logged start (:func:`.replay.simulate`). The residuals are
rbenv minus flight at every logged sample of every sub-maneuver: attitude error (weight
1/1°), body rate per axis (1/0.1 °/s) and wheel speed per wheel (1/10 rpm).
``scipy.optimize.least_squares`` fits, and each value's uncertainty is the standard error from
the Jacobian at the fit, ``σ² (JᵀJ)⁻¹`` with σ² the residual variance. The samples of a closed
loop are correlated in time, so these are lower bounds on the real uncertainty.

What the data can tell, and so what is fitted (each where the scene has it):

* the wheels' ``realized_gain`` and ``deadband_rpm_s`` (commands in, wheel speeds out);
* the rotor inertia ``wheels.inertia`` and the inertia ratios I_y/I_x, I_z/I_x: a wheel
  acceleration turns the bus by J_r/I, so only ratios to one inertia are seen; I_x keeps the
  data sheet's value;
* the wheels' ``startup_delay_s``, on whole control steps, by a profile over the first slew of
  each run (the only one it affects): the uncertainty is the band where the cost stays within
  one σ² of its minimum;
* the gyro's white noise ``sensors.gyro_noise_dps``, where the scene has sensors as flown: it
  dithers the controller across the deadband, so it sets the steady error;
* a residual magnetic dipole (``orbit.residual_dipole``, three body components, A m²), where
  the scene has Earth's field; its torque m × B turns with the orbit, which a slew's two minutes
  barely see, so expect wide uncertainties.

The identified scene is written as TOML beside the scene it started from, every fitted value
quoted in ``sources``.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from rbenv.agents.flight import replay as replay_
from rbenv.agents.flight.telemetry import load
from rbenv.core import quaternion
from rbenv.core.errors import RbenvValueError
from scipy.optimize import least_squares

import rbenv
from rbenv.satellite.actuators.wheels import parse_wheels
from rbenv.satellite.scene import Scene, scene_table, scene_variant

WEIGHTS = {"error_deg": 1.0, "rate_dps": 0.1, "wheel_rpm": 10.0}  # the residuals' units
NAN_RESIDUAL = 10.0  # a sample after a simulated episode ended early: 10 units
DELAY_GRID_S = tuple(float(d) for d in range(0, 31))  # s


@dataclass(frozen=True)
class Parameter:
    """One fitted number: its report name, unit, start value and bounds."""

    name: str
    unit: str
    initial: float
    low: float
    high: float


@dataclass
class Fit:
    """The outcome: values and 1σ by parameter name, the scene's overrides, costs."""

    scene_name: str
    policy: str
    folder: str
    parameters: list
    values: dict
    sigmas: dict
    overrides: dict
    base: dict  # the scene's TOML tables it started from
    cost: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)
    cross_checks: dict = field(default_factory=dict)  # name -> (value, 1σ), other methods


def parameters(table: dict) -> list[Parameter]:
    """What can be fitted in the scene ``table`` (its TOML dict), with start values."""
    wheels = table.get("wheels")
    if not wheels:
        raise RbenvValueError("identify needs a scene with [wheels]: the telemetry logs "
                              "wheel speeds and commands")
    out = [Parameter("realized_gain", "", _mid(wheels.get("realized_gain", 1.0)), 0.2, 2.0),
           Parameter("deadband_rpm_s", "RPM/s", _deadband_rpm_s(wheels), 0.0, 30.0)]
    j = wheels["inertia"]
    if isinstance(j, (int, float)):
        out.append(Parameter("rotor_inertia", "kg m^2", float(j), float(j) / 10, float(j) * 10))
    inertia = table.get("body", {}).get("inertia")
    if isinstance(inertia, list) and len(inertia) == 3 and all(
            isinstance(v, (int, float)) for v in inertia):
        out += [Parameter("inertia_ratio_y_x", "", inertia[1] / inertia[0], 0.05, 20.0),
                Parameter("inertia_ratio_z_x", "", inertia[2] / inertia[0], 0.05, 20.0)]
    sensors = table.get("sensors", {})
    if "gyro_noise_dps" in sensors:
        out.append(Parameter("gyro_noise_dps", "deg/s", _mid(sensors["gyro_noise_dps"]),
                             1e-4, 0.1))  # > 0: relative finite-difference steps
    orbit = table.get("orbit", {})
    if orbit.get("magnetic_field") and _has_residual_dipole():
        start = orbit.get("residual_dipole", {}).get("moment_B_Am2", [0.0, 0.0, 0.0])
        out += [Parameter(f"residual_dipole_{axis}", "A m^2", float(m) or 0.01, -1.0, 1.0)
                for axis, m in zip("xyz", start, strict=True)]  # 0.01: relative steps
    return out


def overrides(params: list[Parameter], x, table: dict, delay_s: float | None) -> dict:
    """``scene_variant`` overrides of the values ``x`` (one per parameter) and the delay."""
    v = dict(zip((p.name for p in params), (float(xi) for xi in x), strict=True))
    wheels = {}
    if "realized_gain" in v:
        wheels["realized_gain"] = v["realized_gain"]
    if "deadband_rpm_s" in v:
        wheels.update(deadband_rpm_s=v["deadband_rpm_s"], deadband=None)
    if "rotor_inertia" in v:
        wheels["inertia"] = v["rotor_inertia"]
    if delay_s is not None:
        wheels["startup_delay_s"] = delay_s
    out = {"wheels": wheels}
    if "inertia_ratio_y_x" in v:
        ix = float(table["body"]["inertia"][0])
        out["body"] = {"inertia": [ix, ix * v["inertia_ratio_y_x"], ix * v["inertia_ratio_z_x"]]}
    if "gyro_noise_dps" in v:
        out["sensors"] = {"gyro_noise_dps": v["gyro_noise_dps"]}
    if "residual_dipole_x" in v:
        out["orbit"] = {"residual_dipole": {"moment_B_Am2": [v[f"residual_dipole_{a}"]
                                                             for a in "xyz"]}}
    return out


def identify(root, scene, *, policy: str = "innocube-pd", env_id: str | None = None,
             seed: int = 0, draws: int = 1, max_nfev: int = 40, only: tuple | None = None,
             delay_grid_s: tuple = DELAY_GRID_S) -> Fit:
    """Fit the parameters of ``scene`` (a shipped name or .toml path; :func:`parameters`) to
    the telemetry under ``root``; ``only``: the names to fit (default: all the scene has, and
    ``startup_delay_s`` where the scene has one), the others stay the scene's; delay_grid_s:
    the start-up delays (s, evenly spaced) of the profile; draws: each sub-maneuver is flown
    this many times side by side (the scene's drawn ranges and sensor noise drawn anew for
    each), and all their residuals are fitted at once."""
    logged = load(root)
    maneuvers = logged * draws
    table = scene_table(scene)
    base = rbenv.load_scene(scene)
    params = [p for p in parameters(table) if only is None or p.name in only]
    kwargs = {"env_id": env_id or replay_.DEFAULT_ENV_ID,
              "env_kwargs": dict(replay_.DEFAULT_ENV_KWARGS), "seed": seed}

    def residuals(x, delay_s, subset):
        variant = scene_variant(scene, overrides(params, x, table, delay_s), name=base.name)
        sim = replay_.simulate(subset, variant, policy, **kwargs)
        return _residuals(subset, sim)

    x0 = np.array([p.initial for p in params])
    fit = Fit(scene_name=base.name, policy=str(policy), folder=str(root), parameters=params,
              values={}, sigmas={}, overrides={}, base=table)
    has_delay = "startup_delay_s" in table["wheels"] and (only is None
                                                           or "startup_delay_s" in only)
    delay = _mid(table["wheels"].get("startup_delay_s", 0.0)) if has_delay else None
    r0 = residuals(x0, delay, maneuvers)
    fit.cost["start"] = _summary(r0, maneuvers)
    if has_delay:
        delay, delay_sigma = _profile_delay(residuals, x0, maneuvers, len(r0) - len(params),
                                            delay_grid_s)
    lower = np.array([p.low for p in params])
    upper = np.array([p.high for p in params])
    result = least_squares(residuals, np.clip(x0, lower, upper), bounds=(lower, upper),
                           args=(delay, maneuvers), x_scale="jac", diff_step=0.03,
                           max_nfev=max_nfev)
    dof = max(len(result.fun) - len(params), 1)
    s2 = 2.0 * result.cost / dof
    cov = s2 * np.linalg.pinv(result.jac.T @ result.jac)
    for p, value, var in zip(params, result.x, np.diag(cov), strict=True):
        fit.values[p.name], fit.sigmas[p.name] = float(value), float(math.sqrt(max(var, 0.0)))
    if has_delay:
        fit.values["startup_delay_s"], fit.sigmas["startup_delay_s"] = delay, delay_sigma
    fit.overrides = overrides(params, result.x, table, delay)
    fit.cost["fit"] = _summary(result.fun, maneuvers)
    fit.cost["nfev"] = int(result.nfev)
    if isinstance(table["wheels"]["inertia"], (int, float)):
        fit.cross_checks["rotor_inertia_momentum"] = rotor_inertia_from_momentum(
            logged, base.body.inertia, parse_wheels(table["wheels"]).axes_B)
    if not any(p.name.startswith("residual_dipole") for p in params):
        fit.notes.append("residual dipole not fitted: this rbenv's scenes have no "
                         "orbit.residual_dipole key, or the scene no magnetic field")
    fit.notes.append("gyro bias not fitted: the logged attitude is the on-board estimate, and "
                     "a bias needs a sensor model in the scene")
    return fit


def rotor_inertia_from_momentum(maneuvers, inertia_B, axes_B) -> tuple[float, float]:
    """Rotor inertia (kg m²) and its 1σ from momentum conservation alone, independent of the
    simulation: within a sub-maneuver the angular momentum in the target frame,
    ``R(q) (I ω + J Σ_i Ω_i ĝ_i)``, stays constant (the target fixed in inertial space, the
    orbit's torques neglected), so J and one momentum per sub-maneuver solve a linear least
    squares problem. inertia_B (3, 3) the whole satellite's, rotors included; axes_B (n, 3)."""
    rows, rhs = [], []
    count = len(maneuvers)
    for m_index, m in enumerate(maneuvers):
        q = m.q / np.linalg.norm(m.q, axis=1, keepdims=True)
        r = quaternion.to_matrix(q)  # (K, 3, 3) body -> target
        spin_B = (m.wheel_rpm * math.pi / 30.0) @ np.asarray(axes_B)  # Σ Ω_i ĝ_i, (K, 3)
        body_B = np.radians(m.rate_dps) @ np.asarray(inertia_B).T  # I ω, (K, 3)
        a = np.zeros((len(q), 3, 1 + 3 * count))
        a[:, :, 0] = np.einsum("kij,kj->ki", r, spin_B)
        a[:, :, 1 + 3 * m_index:4 + 3 * m_index] = -np.eye(3)
        rows.append(a.reshape(-1, 1 + 3 * count))
        rhs.append(-np.einsum("kij,kj->ki", r, body_B).ravel())
    result = least_squares(lambda x: np.vstack(rows) @ x - np.concatenate(rhs),
                           np.zeros(1 + 3 * count), method="lm")
    dof = max(len(result.fun) - len(result.x), 1)
    cov = (2.0 * result.cost / dof) * np.linalg.pinv(result.jac.T @ result.jac)
    return float(result.x[0]), float(math.sqrt(cov[0, 0]))


def _profile_delay(residuals, x, maneuvers, dof: int, grid: tuple) -> tuple[float, float]:
    """The start-up delay (s) that fits the first slews of each run best, and the half-width
    of the band where the cost stays within one residual variance of the minimum (at least
    half a control step)."""
    first = [m for m in maneuvers if not m.commanded_before]
    full = residuals(x, grid[0], maneuvers)
    others = float(np.sum(full ** 2)) - float(np.sum(residuals(x, grid[0], first) ** 2))
    costs = np.array([float(np.sum(residuals(x, d, first) ** 2)) for d in grid])
    best = int(np.argmin(costs))
    s2 = (costs[best] + others) / max(dof, 1)
    band = np.array(grid)[costs <= costs[best] + s2]
    step = grid[1] - grid[0]
    return grid[best], max(float(band.max() - band.min()) / 2.0, step / 2.0)


def _residuals(maneuvers, sim) -> np.ndarray:
    """Weighted rbenv − flight at every logged sample (NaN: :data:`NAN_RESIDUAL`)."""
    parts = []
    for m, s in zip(maneuvers, sim, strict=True):
        logged = {"error_deg": m.error_deg, "rate_dps": m.rate_dps, "wheel_rpm": m.wheel_rpm}
        for name, weight in WEIGHTS.items():
            if name in s:
                diff = (s[name] - logged[name]) / weight
                parts.append(np.where(np.isfinite(diff), diff, NAN_RESIDUAL).ravel())
    return np.concatenate(parts)


def _summary(res: np.ndarray, maneuvers) -> dict:
    n_err = sum(len(m.time_s) for m in maneuvers)
    return {"cost": float(0.5 * np.sum(res ** 2)), "rms": float(np.sqrt(np.mean(res ** 2))),
            "samples": n_err}


def format_report(fit: Fit) -> str:
    """A Markdown table of the fitted values with their 1σ."""
    lines = [f"identification of scene {fit.scene_name} from {fit.folder} "
             f"(flown by {fit.policy})",
             "| parameter | value | ± 1σ | unit |", "|---|---|---|---|"]
    for name, value in fit.values.items():
        unit = next((p.unit for p in fit.parameters if p.name == name), "s")
        lines.append(f"| {name} | {value:.4g} | {fit.sigmas[name]:.2g} | {unit} |")
    c = fit.cost
    lines.append(f"residual rms (weighted units): {c['start']['rms']:.3f} at the scene's values, "
                 f"{c['fit']['rms']:.3f} fitted ({c['nfev']} evaluations)")
    for name, (value, sigma) in fit.cross_checks.items():
        lines.append(f"cross-check, {name}: {value:.4g} ± {sigma:.2g}")
    lines += [f"note: {n}" for n in fit.notes]
    return "\n".join(lines)


def write_json(fit: Fit, path) -> Path:
    data = {"scene": fit.scene_name, "policy": fit.policy, "telemetry": Path(fit.folder).name,
            "parameters": {n: {"value": v, "sigma": fit.sigmas[n]} for n, v in fit.values.items()},
            "cross_checks": {n: {"value": v, "sigma": e}
                             for n, (v, e) in fit.cross_checks.items()},
            "cost": fit.cost, "notes": fit.notes}
    Path(path).write_text(json.dumps(data, indent=2) + "\n")
    return Path(path)


def write_scene(fit: Fit, path) -> Path:
    """The identified scene as TOML: the start scene with the fitted values, each quoted in
    ``sources``; named ``<scene>-identified``."""
    data = json.loads(json.dumps(fit.base))  # a deep copy of plain TOML values
    for table, change in fit.overrides.items():
        merged = _merge(data.get(table, {}), change)
        data[table] = merged
    data["name"] = f"{fit.scene_name}-identified"
    quoted = ", ".join(f"{n} = {v:.4g} ± {fit.sigmas[n]:.2g}" for n, v in fit.values.items())
    data["sources"] = [*data.get("sources", []),
                       f"identified by `rbenv identify` from {Path(fit.folder).name} "
                       f"(flown by {fit.policy}): {quoted} (1σ from the Jacobian)"]
    Scene.from_dict(data)  # the file it writes loads
    Path(path).write_text(dump_toml(data))
    return Path(path)


def dump_toml(data: dict, prefix: str = "") -> str:
    """TOML of a scene dict: plain keys first, then each table (nested as dotted headers)."""
    lines = [f"{k} = {_toml_value(v)}" for k, v in data.items() if not isinstance(v, dict)]
    for k, v in data.items():
        if isinstance(v, dict):
            name = f"{prefix}{k}"
            lines.append(f"\n[{name}]\n{dump_toml(v, name + '.').rstrip()}")
    return "\n".join(lines) + "\n"


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        if not math.isfinite(v):
            raise RbenvValueError(f"a scene value must be finite, got {v!r}")
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise RbenvValueError(f"cannot write {type(v).__name__} {v!r} to a scene file")


def _merge(old: dict, change: dict) -> dict:
    out = dict(old)
    for k, v in change.items():
        if v is None:
            out.pop(k, None)
        elif isinstance(v, dict):
            out[k] = _merge(out.get(k, {}), v)
        else:
            out[k] = v
    return out


def _mid(value) -> float:
    """A number, or the middle of a [low, high] range."""
    return float(np.mean(value)) if isinstance(value, (list, tuple)) else float(value)


def _deadband_rpm_s(wheels: dict) -> float:
    if "deadband" in wheels:
        return _mid(wheels["deadband"]) * 30.0 / math.pi
    return _mid(wheels.get("deadband_rpm_s", 1.0)) or 1.0


def _has_residual_dipole() -> bool:
    """Whether this rbenv's scenes take ``[orbit.residual_dipole]``."""
    try:
        from rbenv.satellite import disturbances  # noqa: F401  (the module of orbit torques)
    except ImportError:
        return False
    return True
