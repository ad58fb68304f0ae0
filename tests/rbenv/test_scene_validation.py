"""Scene files under hostile input: caps, file types, encodings, nesting, and mutated TOML.

The property-based test mutates the shipped scenes (one field replaced by an arbitrary TOML
value, or bytes spliced in) and asserts the invariant: loading raises a named
``RbenvValueError``, or the scene loads and a few env steps give finite observations, rewards
and info values.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import math
import os
from importlib import resources

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from rbenv.core.errors import InvalidParameterError, RbenvValueError

import rbenv
from rbenv.satellite.scene import MAX_SCENE_BYTES, MAX_SUBSTEPS, Scene, load_scene

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

SCENES = {name: tomllib.loads((resources.files("rbenv") / "scenes" / f"{name}.toml").read_text())
          for name in rbenv.list_scenes()}


def toml_text(data: dict) -> str:
    """A TOML document for a scene-shaped dict (top-level keys, then one table per group)."""

    def value(v) -> str:
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, float):
            return "nan" if math.isnan(v) else ("inf" if v == math.inf else
                                               ("-inf" if v == -math.inf else repr(v)))
        if isinstance(v, (int, str)):
            return json.dumps(v)
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return "{" + ", ".join(f"{json.dumps(k)} = {value(x)}" for k, x in v.items()) + "}"

    lines = [f"{json.dumps(k)} = {value(v)}" for k, v in data.items() if not isinstance(v, dict)]
    for k, table in data.items():
        if isinstance(table, dict):
            lines.append(f"[{json.dumps(k)}]")
            lines.extend(f"{json.dumps(kk)} = {value(vv)}" for kk, vv in table.items())
    return "\n".join(lines) + "\n"


def write(tmp_path, data, name="scene.toml"):
    path = tmp_path / name
    path.write_text(toml_text(data) if isinstance(data, dict) else data)
    return path


def scene_with(**tables) -> dict:
    data = copy.deepcopy(SCENES["cubesat-12u"])
    for key, table in tables.items():
        data.setdefault(key, {}).update(table)
    return data


# --------------------------------------------------------------------------- files


def test_round_trip_of_the_toml_writer_used_here(tmp_path):
    for name, data in SCENES.items():
        assert Scene.from_toml(write(tmp_path, data, f"{name}.toml")).name == name


def test_non_utf8_scene_is_a_named_error(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_bytes(toml_text(SCENES["cubesat-12u"]).encode() + b'\n# caf\xe9\n')
    with pytest.raises(InvalidParameterError, match=r"bad.toml.*must be UTF-8.*byte \d+"):
        load_scene(path)


def test_deeply_nested_toml_is_a_named_error(tmp_path):
    depth = 20_000
    path = write(tmp_path, "description = " + "[" * depth + "]" * depth + "\n")
    with pytest.raises(InvalidParameterError, match="nests arrays or tables too deeply"):
        load_scene(path)


def test_invalid_toml_names_the_file(tmp_path):
    path = write(tmp_path, "[body\nmass = 1\n")
    with pytest.raises(InvalidParameterError, match=r"scene.toml.*is not valid TOML"):
        load_scene(path)


def test_scene_file_size_cap(tmp_path):
    text = toml_text(SCENES["cubesat-12u"]) + "#" * MAX_SCENE_BYTES + "\n"
    with pytest.raises(InvalidParameterError, match=f"the limit is {MAX_SCENE_BYTES} bytes"):
        load_scene(write(tmp_path, text))


def test_only_regular_scene_files_are_read(tmp_path):
    fifo = tmp_path / "pipe.toml"
    os.mkfifo(fifo)
    with pytest.raises(InvalidParameterError, match="must be a regular file, got a FIFO"):
        load_scene(fifo)
    link = tmp_path / "zero.toml"
    link.symlink_to("/dev/zero")
    with pytest.raises(InvalidParameterError, match="character device"):
        load_scene(link)


# --------------------------------------------------------------------------- caps and bounds


@pytest.mark.parametrize(
    ("tables", "words"),
    [
        ({"physics": {"substeps": 10_000_000}}, ["physics.substeps", f"<= {MAX_SUBSTEPS}"]),
        ({"physics": {"substeps": 2.5}}, ["physics.substeps", "integer"]),
        ({"physics": {"translation": 1}}, ["physics.translation", "true or false"]),
        ({"physics": {"control_dt": 1e160}}, ["physics.control_dt", "<= 3600"]),
        ({"physics": {"control_dt": 1e-310}}, ["physics.control_dt", ">= 1e-06"]),
        ({"thrusters": {"max_force": True}}, ["thrusters.max_force", "bools"]),
        ({"thrusters": {"max_force": "0.05"}}, ["thrusters.max_force", "'0.05'"]),
        ({"thrusters": {"max_force": {"n": 1.0}}}, ["thrusters.max_force", "dict"]),
        ({"thrusters": {"isp": 1e-310}}, ["thrusters.isp", ">= 1.0"]),
        ({"episode": {"rate_limit": 1e-310}}, ["episode.rate_limit", ">= 1e-06"]),
        ({"episode": {"duration": 1e300}}, ["episode.duration", "<= 1000000"]),
        ({"episode": {"hold_time": 1e3}}, ["episode.hold_time", "episode.duration"]),
        ({"sensor_noise": {"model": "gaussian", "rate": 1e200}}, ["sensor_noise.rate", "<= 100"]),
        ({"sensor_noise": {"model": "gaussian", "attitude": 10.0}},
         ["sensor_noise.attitude", "<= 3.14159"]),
        ({"disturbance": {"model": "random", "noise_sigma": 1e6}},
         ["disturbance.noise_sigma", "<= 10"]),
        ({"body": {"parts": [{"shape": "point", "mass": 1e300, "position": [0, 0, 0]}]}},
         ["body.parts[0].mass", "<= 10000000"]),
    ],
)
def test_documented_bounds_name_field_value_and_rule(tmp_path, tables, words):
    data = scene_with(**tables)
    if "body" in tables:
        data["body"] = tables["body"]
    with pytest.raises(InvalidParameterError) as info:
        load_scene(write(tmp_path, data))
    for word in words:
        assert word in str(info.value)


def test_thruster_count_is_capped(tmp_path):
    data = scene_with()
    n = 300
    data["thrusters"]["positions"] = [[0.1, 0.1, 0.1]] * n
    data["thrusters"]["directions"] = [[1.0, 0.0, 0.0]] * n
    with pytest.raises(InvalidParameterError, match="300 thrusters; the limit is 256"):
        load_scene(write(tmp_path, data))


def test_numpy_scalars_are_accepted_in_code_built_scenes():
    base = load_scene("cubesat-12u")
    changed = base.with_physics(control_dt=np.float32(0.25), substeps=np.int64(2))
    assert changed.physics.control_dt == 0.25 and changed.physics.substeps == 2


# --------------------------------------------------------------------------- property


def _finite(value) -> bool:
    if isinstance(value, dict):
        return all(_finite(v) for v in value.values())
    if isinstance(value, (list, tuple)):
        return all(_finite(v) for v in value)
    if isinstance(value, (bool, np.bool_, str)) or value is None:
        return True
    arr = np.asarray(value)
    return arr.dtype.kind not in "fc" or bool(np.isfinite(arr).all())


def _leaves(obj, path=()):
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _leaves(v, (*path, k))
    elif isinstance(obj, list) and obj and isinstance(obj[0], (list, dict)):
        for i, v in enumerate(obj):
            yield from _leaves(v, (*path, i))
    else:
        yield path


LEAVES = [(name, path) for name, data in SCENES.items() for path in _leaves(data)]
TOML_VALUES = st.recursive(
    st.one_of(
        st.floats(allow_nan=True, allow_infinity=True),
        st.integers(-(2**63), 2**63 - 1),
        st.booleans(),
        st.text(max_size=6),
        st.sampled_from([0.0, -1.0, 1e-310, 1e308, 1e160, 1e200, 10_000_000, 2**63 - 1]),
    ),
    lambda inner: st.one_of(st.lists(inner, max_size=4),
                            st.dictionaries(st.text(max_size=3), inner, max_size=2)),
    max_leaves=6,
)


SCALES = st.sampled_from([0.0, -1.0, 1e-310, 1e-6, 0.5, 2.0, 1e3, 1e6, 1e300, math.nan, math.inf])


def _load_and_step(path):
    scene = load_scene(path)
    env = gym.make(rbenv.ENV_ID, scene=scene)
    try:
        out = [env.reset(seed=0)]
        for _ in range(3):
            out.append(env.step(env.action_space.high))
        return out
    finally:
        env.close()


@settings(max_examples=300, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(leaf=st.sampled_from(LEAVES), new=TOML_VALUES, scale=st.one_of(st.none(), SCALES),
       splice=st.binary(min_size=1, max_size=8), do_splice=st.integers(0, 3), at=st.floats(0, 1))
def test_mutated_scene_gives_named_error_or_finite_episodes(tmp_path, leaf, new, scale, splice,
                                                            do_splice, at):
    name, path = leaf
    data = copy.deepcopy(SCENES[name])
    target = data
    for p in path[:-1]:
        target = target[p]
    old = target[path[-1]]
    if scale is not None and isinstance(old, (int, float)) and not isinstance(old, bool):
        new = old * scale  # an extreme but well-typed value
    elif scale is not None and isinstance(old, list) and old and isinstance(old[0], float):
        new = [x * scale for x in old]
    target[path[-1]] = new
    raw = toml_text(data).encode()
    if do_splice == 0:
        cut = int(at * len(raw))
        raw = raw[:cut] + splice + raw[cut:]
    file = tmp_path / "mutated.toml"
    file.write_bytes(raw)
    try:
        out = _load_and_step(file)
    except RbenvValueError as exc:
        event(f"named error: {type(exc).__name__}")
        assert str(exc)
        return
    event("loaded and stepped")
    assert _finite(out), out


# --------------------------------------------------------------------------- randomization fuzz

# Every shipped actuator mix, as scene TOML: cubesat-12u (thrusters) with cubesat-6u-rw's wheels,
# rods and the orbit the rods need, each in or out.
MIXES = ("thrusters", "wheels", "magnetorquers", "thrusters+wheels", "thrusters+magnetorquers",
         "wheels+magnetorquers", "thrusters+wheels+magnetorquers")
# One size per [randomization] key (each inside its limit), and all of them at once.
RANDOMIZE = {"inertia_scale": 0.3, "inertia_rotation_deg": 15.0, "com_offset": 0.01,
             "force_scale": 0.2, "misalignment_deg": 3.0, "delay_probability": 0.5,
             "wheel_misalignment_deg": 3.0, "wheel_torque_scale": 0.2,
             "wheel_speed_scale": 0.1, "rod_dipole_scale": 0.3}


def mix_scene(mix: str) -> dict:
    """A scene dict with exactly the actuators of ``mix`` ("thrusters+wheels", ...)."""
    tables = mix.split("+")
    data = copy.deepcopy(SCENES["cubesat-12u"])
    data["name"] = f"mix-{mix.replace('+', '-')}"
    if "thrusters" not in tables:
        del data["thrusters"]
    rw = SCENES["cubesat-6u-rw"]
    for table in ("wheels", "magnetorquers"):
        if table in tables:
            data[table] = copy.deepcopy(rw[table])
    if "magnetorquers" in tables:
        data["orbit"] = copy.deepcopy(rw["orbit"])
    return data


def test_every_actuator_mix_is_covered():
    from rbenv.satellite.actuators import ACTUATORS
    from rbenv.satellite.randomization import ACTUATOR_FIELDS, Randomization

    assert {t for m in MIXES for t in m.split("+")} == set(ACTUATORS)
    assert len(MIXES) == 2 ** len(ACTUATORS) - 1
    assert set(RANDOMIZE) == {f.name for f in dataclasses.fields(Randomization)}
    assert set(ACTUATOR_FIELDS) <= set(RANDOMIZE)


@pytest.mark.parametrize("mix", MIXES)
def test_every_randomization_key_steps_or_is_refused_by_name_on_every_mix(tmp_path, mix):
    """Each key alone, then all keys, on one actuator mix: a few finite steps of the single env
    (the key in the scene's [randomization] table) and of the vector env (the key as
    ``randomize=``), or a named refusal exactly when the key perturbs an absent actuator."""
    from rbenv.satellite.randomization import ACTUATOR_FIELDS

    tables = set(mix.split("+"))
    plain = write(tmp_path, mix_scene(mix), "mix.toml")
    assert set(load_scene(plain).actuators) == tables
    cases = [{key: value} for key, value in RANDOMIZE.items()] + [dict(RANDOMIZE)]
    for randomize in cases:
        absent = [k for k in randomize
                  if k in ACTUATOR_FIELDS and ACTUATOR_FIELDS[k][0] not in tables]
        table = write(tmp_path, {**mix_scene(mix), "randomization": randomize}, "mix-rnd.toml")
        for make, kwargs in ((gym.make, {"scene": table}),
                             (gym.make_vec, {"num_envs": 2, "scene": plain,
                                             "randomize": randomize})):
            try:
                env = make(rbenv.ENV_ID, **kwargs)
            except RbenvValueError as exc:
                assert absent, f"{mix} {randomize}: refused {exc}"
                assert f"randomization.{absent[0]} = " in str(exc), str(exc)
                assert f"no [{ACTUATOR_FIELDS[absent[0]][0]}]" in str(exc), str(exc)
                continue
            assert not absent, f"{mix} {randomize}: accepted {absent}"
            try:
                out = [env.reset(seed=3)]
                env.action_space.seed(3)
                for _ in range(3):
                    out.append(env.step(env.action_space.sample()))
                assert _finite(out), (mix, randomize, out)
            finally:
                env.close()
