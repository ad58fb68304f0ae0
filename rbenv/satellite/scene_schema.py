"""The reference of a scene file, declared once: every table of a scene TOML and, for each key,
its unit, default and meaning.

docs/scenes.md's reference is generated from it (:func:`reference_markdown`; ``python -m
rbenv.satellite.scene_schema`` prints it). tests/rbenv/test_scene_schema.py holds the keys declared
here equal to the keys each table's parser accepts (:mod:`rbenv.satellite.scene`,
:mod:`rbenv.satellite.actuators`, :mod:`rbenv.satellite.orbit`,
:mod:`rbenv.satellite.randomization`, the tasks' ``OPTIONS``), the defaults equal to the parsers'
dataclass defaults, and the committed page equal to the generated text, so the page cannot drift
from the code.
"""

from __future__ import annotations

import dataclasses
import importlib
from typing import NamedTuple

REQUIRED = "required"


class Key(NamedTuple):
    """One key of a table: name, unit ("" when it has none), meaning, and its default (the text
    shown; :data:`REQUIRED` when it must be given; for a table with a ``source`` class, None
    means "read from that class's field")."""

    name: str
    unit: str
    meaning: str
    default: str | None = None


class Table(NamedTuple):
    """A table of the scene file: its TOML header, what it is, its keys, and the dataclass
    (``"module:Class"``) whose fields are its keys and defaults, if one is."""

    header: str
    about: str
    keys: tuple[Key, ...]
    source: str | None = None


SHAPE_KEYS = (
    Key("mass", "kg", "mass of the part", REQUIRED),
    Key("size", "m", "box: full extents [x, y, z] along the body axes", REQUIRED + " (box)"),
    Key("radius", "m", "cylinder: radius (the axis is body z)", REQUIRED + " (cylinder)"),
    Key("height", "m", "cylinder: height along body z", REQUIRED + " (cylinder)"),
    Key("hollow", "", "true: a closed thin-walled shell instead of a solid", "false"),
)

TABLES: tuple[Table, ...] = (
    Table("Top level", "keys outside any table", (
        Key("name", "", "the scene's name", "(the file's stem)"),
        Key("description", "", "one line on what the scene is", '""'),
        Key("sources", "", "list of strings: where the numbers come from", "[]"),
        Key("base", "", "a shipped scene this file builds on: its tables are merged key by key "
                        "with this file's, which win", "(none)"),
    )),
    Table("[body]", "the rigid body: exactly one of three forms, (1) one shape (shape, mass, "
                    "size or radius and height, hollow), (2) parts, (3) mass, inertia and com", (
        Key("shape", "", '(1) "box" or "cylinder", centred on the origin', "—"),
        *SHAPE_KEYS,
        Key("parts", "", "(2) list of part tables ([[body.parts]]), composed with the "
                         "parallel-axis theorem", "—"),
        Key("inertia", "kg·m²", "(3) about the centre of mass, body axes: [[3×3]] or the "
                                "principal moments [Ixx, Iyy, Izz]", "—"),
        Key("com", "m", "(3) the centre of mass [x, y, z], body axes", "[0, 0, 0]"),
    )),
    Table("[[body.parts]]", "one part of form (2), axis-aligned with the body", (
        Key("shape", "", '"box", "cylinder" or "point"', REQUIRED),
        *SHAPE_KEYS,
        Key("position", "m", "the part's centre [x, y, z], body axes (the origin of every "
                             "position in the file)", REQUIRED),
    )),
    Table("[thrusters]", "the thruster layout (optional if the scene has another actuator)", (
        Key("positions", "m", "mount points [[x, y, z], ...], body axes; 1 to 256 thrusters",
            REQUIRED),
        Key("directions", "", "direction of each thruster's force on the body (normalised)",
            REQUIRED),
        Key("max_force", "N", "full thrust: one number, or one per thruster", REQUIRED),
        Key("isp", "s", "specific impulse: propellant = impulse / (isp · g0)", "65.0"),
    )),
    Table("[wheels]", "reaction wheels (rbenv.satellite.actuators.wheels)", (
        Key("axes", "", "spin axes [[x, y, z], ...], body axes (normalised); 1 to 16 wheels",
            REQUIRED),
        Key("inertia", "kg·m²", "spin-axis inertia: one number, or one per wheel", REQUIRED),
        Key("max_torque", "N·m", "motor torque limit: one number, or one per wheel", REQUIRED),
        Key("max_speed_rpm", "rpm", "speed limit: one number, or one per wheel", REQUIRED),
        Key("viscous", "N·m·s/rad", "viscous friction coefficient; a number or [low, high] "
                                    "drawn per episode", "0.0"),
        Key("coulomb", "N·m", "Coulomb friction torque; a number or [low, high] drawn per "
                              "episode", "0.0"),
        Key("standby_power", "W", "electrical power of each wheel at rest", "0.0"),
        Key("initial_speed_rpm", "rpm", "speed at the episode start: one, or one per wheel",
            "0.0"),
        Key("random_speed_rpm", "rpm", "± uniform spread added to the start speed per episode",
            "0.0"),
        Key("max_acceleration", "rad/s²", "as flown: the flight software's clamp on a commanded "
                                          "wheel acceleration (needed by action_mode "
                                          '"acceleration" and "acceleration_lifted")',
            "(none)"),
        Key("max_acceleration_rpm_s", "RPM/s", "the same clamp in RPM/s (give one of the two)",
            "(none)"),
        Key("deadband", "rad/s²", "as flown: a commanded acceleration below it does nothing; a "
                                  "number, or [low, high] drawn per episode (action_mode "
                                  '"acceleration_lifted" lifts commands over its upper '
                                  "bound)", "0.0"),
        Key("deadband_rpm_s", "RPM/s", "the same deadband in RPM/s (give one of the two)",
            "(none)"),
        Key("realized_gain", "", "as flown: realized / commanded acceleration above the "
                                 "deadband; a number or [low, high]", "1.0"),
        Key("startup_delay_s", "s", "as flown: the wheels stay still this long after the "
                                    "episode's first command; a number or [low, high]", "0.0"),
        Key("speed_quantization_rpm", "rpm", "as flown: the observed wheel speed is rounded to "
                                             "this step", "0.0"),
    )),
    Table("[magnetorquers]", "magnetic torque rods (rbenv.satellite.actuators.magnetorquers); "
                             "they need an [orbit] with magnetic_field = true", (
        Key("axes", "", "rod axes [[x, y, z], ...], body axes (normalised); 1 to 16 rods",
            REQUIRED),
        Key("max_dipole", "A·m²", "largest dipole: one number, or one per rod", REQUIRED),
        Key("power_W", "W", "electrical power at full dipole: one, or one per rod", "0.0"),
    )),
    Table("[sensors]", "sensing as flown (opt-in): the observed attitude integrated from a "
                       "gyro with bias and noise, and an observation delay "
                       "(rbenv.satellite.scene)", (
        Key("attitude", "", '"true" (the state, or [sensor_noise]), "gyro" (integrated from '
                            'the gyro from the true start, so it drifts) or "estimator" (the '
                            "[estimator]'s MEKF estimate, fed by this gyro and the attitude "
                            "sensors; docs/estimation.md)"),
        Key("gyro_bias_sigma_dps", "°/s", "gyro bias drawn per episode, 1σ per axis"),
        Key("gyro_bias_walk_dps_sqrt_s", "°/s/√s", "random walk of the bias: σ of its change "
                                                  "over 1 s"),
        Key("gyro_noise_dps", "°/s", "white noise of each gyro sample, 1σ (the angle random "
                                     "walk is this × √control_dt, °/√s)"),
        Key("delay_steps", "", "0 or 1: the observation shows the previous control step's "
                               "measurement"),
    ), "rbenv.satellite.scene:Sensors"),
    Table("[star_tracker]", "a star-tracker head for the estimator (rbenv.satellite.sensors; "
                            "defaults: typical CubeSat-class values, docs/estimation.md)", (
        Key("boresight_B", "", "the boresight, body axes (normalised)"),
        Key("sigma_cross_arcsec", "arcsec", "noise across the boresight, 1σ per axis"),
        Key("sigma_about_arcsec", "arcsec", "noise about the boresight, 1σ"),
        Key("rate_hz", "Hz", "fixes per second (the filter takes at most one per control step)"),
        Key("sun_exclusion_deg", "deg", "no fix with the Sun within this of the boresight"),
        Key("earth_exclusion_deg", "deg", "no fix with the Earth's limb within this of the "
                                          "boresight"),
        Key("max_rate_dps", "°/s", "no fix above this body rate"),
        Key("dropout_probability", "", "probability that a fix is lost at random"),
    ), "rbenv.satellite.sensors:StarTracker"),
    Table("[magnetometer]", "a three-axis magnetometer for the estimator, reading the orbit's "
                            "field model (needs [orbit] magnetic_field = true)", (
        Key("noise_nT", "nT", "white noise, 1σ per axis"),
        Key("bias_nT", "nT", "bias drawn per episode, 1σ per axis (not estimated: the filter "
                             "counts it as noise)"),
    ), "rbenv.satellite.sensors:Magnetometer"),
    Table("[sun_sensors]", "coarse sun sensors for the estimator: cosine response, field of "
                           "view, dark in the Earth's shadow (needs an [orbit])", (
        Key("normals_B", "", "each cell's normal, body axes (3 to 32)"),
        Key("fov_deg", "deg", "half-angle off the normal beyond which a cell reads 0"),
        Key("noise", "", "white noise of each cell, 1σ, fraction of full scale"),
    ), "rbenv.satellite.sensors:SunSensors"),
    Table("[estimator]", "the MEKF in the loop (rbenv.satellite.estimation): the observation "
                         "is its estimate; needs [sensors] attitude = \"estimator\" and an "
                         "attitude sensor table", (
        Key("initial_attitude_sigma_deg", "deg", "1σ per axis of the first estimate's error "
                                                 "(drawn per episode; the filter's prior)"),
        Key("process_noise_scale", "", "factor ≥ 1 on the gyro's process noise Q"),
    ), "rbenv.satellite.estimation:Estimator"),
    Table("[physics]", "how the dynamics are integrated", (
        Key("integrator", "", "a name in rbenv.core.INTEGRATORS"),
        Key("substeps", "", "integrator steps per control step"),
        Key("control_dt", "s", "one env step; throttles are duty cycles over it"),
        Key("translation", "", "also integrate the centre of mass under the net force"),
    ), "rbenv.satellite.scene:Physics"),
    Table("[disturbance]", "a torque on the body, body axes", (
        Key("model", "", '"none", "constant" or "random"'),
        Key("torque", "N·m", "constant: this torque [x, y, z], always"),
        Key("bias_sigma", "N·m", "random: per-axis 1σ of a bias drawn at reset, held all "
                                 "episode"),
        Key("noise_sigma", "N·m", "random: per-axis 1σ of white noise redrawn each control "
                                  "step"),
    ), "rbenv.satellite.scene:Disturbance"),
    Table("[faults]", "thrusters failing stuck off (no thrust, no propellant)", (
        Key("model", "", '"none" or "random"'),
        Key("p_reset", "", "probability that each thruster fails at reset"),
        Key("p_step", "", "probability per control step that a working thruster fails"),
    ), "rbenv.satellite.scene:Faults"),
    Table("[sensor_noise]", "Gaussian noise on the observation only, 1σ", (
        Key("model", "", '"none" or "gaussian"'),
        Key("attitude", "rad", "per axis, a small rotation of the measured attitude"),
        Key("rate", "rad/s", "per axis of the measured body rate"),
        Key("magnetometer", "T", "per body axis of the measured field (scenes with rods)"),
    ), "rbenv.satellite.scene:SensorNoise"),
    Table("[episode]", "the episode's rules", (
        Key("duration", "s", "episode length (episode steps = round(duration / control_dt))"),
        Key("rate_limit", "rad/s", "|ω| above it is loss of control: the episode terminates"),
        Key("success_angle_deg", "deg", "success needs the attitude error below it ..."),
        Key("success_rate", "rad/s", "... and |ω| below it ..."),
        Key("hold_time", "s", "... held this long"),
        Key("max_initial_angle_deg", "deg", "initial attitude error at most this (180: "
                                            "attitude and target uniform)"),
        Key("max_initial_rate", "rad/s", "initial tumble |ω| uniform in [0, this]"),
    ), "rbenv.satellite.scene:Episode"),
    Table("[orbit]", "a circular orbit and its effects on the attitude (rbenv.satellite.orbit)", (
        Key("model", "", '"none" or "circular"'),
        Key("altitude_km", "km", "altitude above the equatorial radius"),
        Key("inclination_deg", "deg", "orbit inclination"),
        Key("raan_deg", "deg", "right ascension of the ascending node"),
        Key("arg_latitude_deg", "deg", "argument of latitude at the episode start"),
        Key("earth_rotation_deg", "deg", "angle of the Earth-fixed frame at the episode start "
                                          "(turns the magnetic field)"),
        Key("gravity_gradient", "", "apply the gravity-gradient torque"),
        Key("magnetic_field", "", "model Earth's field (IGRF-14 dipole): rods act, a "
                                  "magnetometer is observed"),
        Key("residual_dipole", "", "the nested table [orbit.residual_dipole] (opt-in)"),
        Key("drag", "", "the nested table [orbit.drag] (opt-in)"),
        Key("srp", "", "the nested table [orbit.srp] (opt-in)"),
    ), "rbenv.satellite.orbit:Orbit"),
    Table("[orbit.residual_dipole]", "the spacecraft's own magnetic dipole, torque m × B "
                                     "evaluated at every integrator stage (needs "
                                     "magnetic_field = true; rbenv.satellite.disturbances)", (
        Key("moment_B_Am2", "A·m²", "the dipole [x, y, z], body axes, |m| ≤ 10"),
    ), "rbenv.satellite.disturbances:ResidualDipole"),
    Table("[orbit.drag]", "aerodynamic torque: exponential atmosphere by altitude (Vallado "
                          "table 8-4), air co-rotating with the Earth "
                          "(rbenv.satellite.disturbances)", (
        Key("area_m2", "m²", "reference area facing the flow"),
        Key("cd", "", "drag coefficient (≈ 2.2 in free molecular flow)"),
        Key("cp_offset_B_m", "m", "centre of pressure minus centre of mass, body axes"),
        Key("density_scale", "", "factor on the table's density (solar activity)"),
    ), "rbenv.satellite.disturbances:Drag"),
    Table("[orbit.srp]", "solar radiation pressure torque, cylindrical Earth shadow "
                         "(info['eclipse']), analytic Sun direction "
                         "(rbenv.satellite.disturbances)", (
        Key("area_m2", "m²", "area facing the Sun"),
        Key("reflectivity", "", "in [0, 1]; C_R = 1 + reflectivity"),
        Key("cp_offset_B_m", "m", "centre of pressure minus centre of mass, body axes"),
        Key("epoch", "", "ISO 8601 UTC date-time of the episode start"),
    ), "rbenv.satellite.disturbances:SolarPressure"),
    Table("[randomization]", "domain randomization: sizes of the per-episode perturbations, all "
                             "0 = off (rbenv.satellite.randomization; gym.make's randomize= "
                             "overrides). A key that perturbs an actuator the scene lacks "
                             "(force_scale without [thrusters], say) must be 0", (
        Key("inertia_scale", "fraction", "each principal second moment scaled by 1 ± this"),
        Key("inertia_rotation_deg", "deg", "the mass distribution turned by up to this"),
        Key("com_offset", "m", "centre of mass moved within a ball of this radius"),
        Key("force_scale", "fraction", "each thruster's force scaled by 1 ± this"),
        Key("misalignment_deg", "deg", "each thruster's direction tilted by up to this"),
        Key("delay_probability", "", "probability of a one-step control delay for the episode"),
        Key("wheel_misalignment_deg", "deg", "each reaction wheel's spin axis tilted by up to "
                                             "this"),
        Key("wheel_torque_scale", "fraction", "each wheel's realized motor torque scaled by "
                                              "1 ± this"),
        Key("wheel_speed_scale", "fraction", "each wheel's speed reading scaled by 1 ± this "
                                             "(observation only)"),
        Key("rod_dipole_scale", "fraction", "each magnetorquer's dipole scaled by 1 ± this"),
    ), "rbenv.satellite.randomization:Randomization"),
)

# [tasks.<task>] tables: each task's options (defaults: the task class's OPTIONS).
TASK_TABLES: dict[str, tuple[str, tuple[Key, ...]]] = {
    "detumble": ("rbenv.tasks.detumble:Detumble", (
        Key("min_rate_fraction", "fraction", "initial tumble at least this fraction of "
                                             "rate_limit"),
        Key("max_rate_fraction", "fraction", "initial tumble at most this fraction of "
                                             "rate_limit"),
    )),
    "track": ("rbenv.tasks.track:Track", (
        Key("max_target_rate_fraction", "fraction", "the target turns at up to this fraction "
                                                    "of rate_limit"),
        Key("max_initial_angle_deg", "deg", "initial error to the target at most this"),
        Key("min_track_fraction", "fraction", "success: on target for at least this fraction "
                                              "of the second half"),
        Key("target", "", '"random" (a constant-rate target) or "nadir" (needs an [orbit])'),
    )),
    "desaturate": ("rbenv.tasks.desaturate:Desaturate", (
        Key("initial_speed_fraction", "fraction", "each wheel starts at this fraction of its "
                                                  "max speed"),
        Key("momentum_threshold_fraction", "fraction", "success: wheel momentum below this "
                                                       "fraction of one wheel's J·Ω_max"),
        Key("max_error_deg", "deg", "failure: attitude error above this"),
        Key("max_initial_angle_deg", "deg", "initial attitude error at most this"),
        Key("max_initial_rate_fraction", "fraction", "initial |ω| at most this fraction of "
                                                     "rate_limit"),
    )),
}


def resolve(ref: str):
    """The object named ``"module:attribute"``."""
    module, _, attr = ref.partition(":")
    return getattr(importlib.import_module(module), attr)


def _show(value) -> str:
    if value is None:
        return "(absent: off)"
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, str):
        return f'"{value}"'
    if hasattr(value, "tolist"):
        value = value.tolist()
    return str(value).replace("[0.0, 0.0, 0.0]", "[0, 0, 0]")


def class_defaults(ref: str) -> dict:
    """The TOML-visible fields of a dataclass and their defaults, shown as in TOML."""
    out = {}
    for f in dataclasses.fields(resolve(ref)):
        if not f.init:
            continue
        if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
            out[f.name] = REQUIRED
            continue
        value = f.default if f.default is not dataclasses.MISSING else f.default_factory()
        out[f.name] = _show(value)
    return out


def keys_with_defaults(table: Table) -> list[Key]:
    """The table's keys, each with its default text (read from ``source`` where it is one)."""
    defaults = class_defaults(table.source) if table.source else {}
    return [key._replace(default=defaults.get(key.name, key.default)) for key in table.keys]


def _default_cell(default: str | None) -> str:
    if default is None or default == "—":
        return "—"
    if default.startswith("("):
        return default[1:-1]  # prose, not a value
    return f"**{default}**" if default.startswith(REQUIRED) else f"`{default}`"


def _rows(keys) -> list[str]:
    rows = ["| key | unit | default | meaning |", "|---|---|---|---|"]
    rows += [f"| `{k.name}` | {k.unit or '—'} | {_default_cell(k.default)} | "
             f"{k.meaning.replace('|', chr(92) + '|')} |" for k in keys]
    return rows


def reference_markdown() -> str:
    """docs/scenes.md's reference: one Markdown table per scene table."""
    lines = []
    for table in TABLES:
        title = f"`{table.header}`" if table.header.startswith("[") else table.header
        lines += [f"### {title}", "", table.about[0].upper() + table.about[1:] + ".", ""]
        lines += [*_rows(keys_with_defaults(table)), ""]
    lines += ["### `[tasks.<task>]`", "",
              "Per-task options of the scene, for the tasks that take them (gym.make's "
              "`task_options=` overrides them). `[tasks.<task>.physics]` and "
              "`[tasks.<task>.episode]` override the scene's `[physics]` and `[episode]` keys "
              "for that task alone (same keys as above). Every task's table is checked whichever "
              "task's env is made on the scene, and an error names the table and its task; a "
              "table whose task cannot run on the scene (`[tasks.desaturate]` on a scene without "
              "`[wheels]`) has only its option names checked, so it does not stop another "
              "task's env.", ""]
    for task, (ref, keys) in TASK_TABLES.items():
        options = resolve(ref).OPTIONS
        lines += [f"`[tasks.{task}]`:", ""]
        lines += [*_rows([k._replace(default=_show(options[k.name])) for k in keys]), ""]
    return "\n".join(lines).rstrip() + "\n"


if __name__ == "__main__":
    print(reference_markdown(), end="")
