"""Scenes: shipped TOML files, the three mass-property forms, validation messages, loading."""

from __future__ import annotations

import builtins
import dataclasses
import math

import gymnasium as gym
import numpy as np
import pytest
from rbenv.core import inertia
from rbenv.core.errors import InvalidInertiaError, InvalidParameterError

import rbenv
from rbenv.satellite.scene import Scene, list_scenes, load_scene, mass_properties

COUPLES = {  # a minimal valid layout: one couple each way about each axis (lever arm 0.1 m)
    "positions": [[0, 0.1, 0], [0, -0.1, 0], [0, 0.1, 0], [0, -0.1, 0],
                  [0, 0, 0.1], [0, 0, -0.1], [0, 0, 0.1], [0, 0, -0.1],
                  [0.1, 0, 0], [-0.1, 0, 0], [0.1, 0, 0], [-0.1, 0, 0]],
    "directions": [[0, 0, 1], [0, 0, -1], [0, 0, -1], [0, 0, 1],
                   [1, 0, 0], [-1, 0, 0], [-1, 0, 0], [1, 0, 0],
                   [0, 1, 0], [0, -1, 0], [0, -1, 0], [0, 1, 0]],
    "max_force": 0.05,
    "isp": 65.0,
}


def scene_dict(**overrides) -> dict:
    data = {"name": "t", "body": {"shape": "box", "mass": 10.0, "size": [0.2, 0.3, 0.4]},
            "thrusters": dict(COUPLES)}
    data.update(overrides)
    return data


def test_list_scenes_names_the_shipped_files():
    assert list_scenes() == ["boom-sat", "cubesat-12u", "cubesat-12u-dr", "cubesat-12u-rw",
                             "cubesat-6u-rw", "innocube-3u", "microsat-100kg"]
    assert rbenv.list_scenes() == list_scenes()


@pytest.mark.parametrize("name", list_scenes())
def test_every_shipped_scene_loads_with_sources(name):
    scene = load_scene(name)
    assert scene.name == name
    assert len(scene.sources) >= 3 and scene.description
    assert scene.episode_steps == rbenv.MAX_EPISODE_STEPS  # registered TimeLimit fits all


def test_default_scene_is_a_plausible_12u_cubesat():
    scene = load_scene("cubesat-12u")
    assert scene.body.mass == pytest.approx(24.0)
    diag = np.diag(scene.body.inertia)
    assert diag.min() > 0.15 and diag.max() < 0.36
    off = scene.body.inertia - np.diag(diag)
    assert 0.005 < np.abs(off).max() / diag.max() < 0.05  # small products of inertia
    thr = scene.thrusters
    assert thr.n == 12 and np.all((thr.max_force >= 0.01) & (thr.max_force <= 0.1))
    # Lever arm of each thruster about the centre of mass, perpendicular to its thrust.
    arms = np.linalg.norm(np.cross(thr.positions_B - thr.com_B, thr.directions_B), axis=1)
    assert np.all((arms > 0.1) & (arms < 0.2))
    assert 60.0 <= scene.actuators["thrusters"].isp <= 70.0
    assert scene.physics.translation is False
    assert scene.hold_steps == 4 and scene.physics.control_dt == 0.5


def test_boom_scene_is_extreme():
    moments = np.linalg.eigvalsh(load_scene("boom-sat").body.inertia)
    assert moments[-1] / moments[0] >= 100.0


def test_microsat_mass_and_models():
    scene = load_scene("microsat-100kg")
    assert 50 <= scene.body.mass <= 150
    assert scene.physics.translation and scene.sensor_noise.model == "gaussian"
    np.testing.assert_allclose(np.diag(scene.body.inertia), [8.3333, 8.3333, 6.0], atol=1e-3)


def test_shape_forms_match_core_closed_forms():
    for body, expected in [
        ({"shape": "box", "mass": 2.0, "size": [1, 2, 3]}, inertia.solid_box(2.0, [1, 2, 3])),
        ({"shape": "box", "hollow": True, "mass": 2.0, "size": [1, 2, 3]},
         inertia.hollow_box(2.0, [1, 2, 3])),
        ({"shape": "cylinder", "mass": 3.0, "radius": 0.5, "height": 2.0},
         inertia.solid_cylinder(3.0, 0.5, 2.0)),
        ({"shape": "cylinder", "hollow": True, "mass": 3.0, "radius": 0.5, "height": 2.0},
         inertia.hollow_cylinder(3.0, 0.5, 2.0)),
    ]:
        mass, com, J = mass_properties(body)
        assert mass == body["mass"]
        np.testing.assert_allclose(com, 0.0)
        np.testing.assert_allclose(J, expected)


def test_parts_compose_with_parallel_axis():
    parts = [{"shape": "point", "mass": 1.0, "position": [1.0, 0, 0]},
             {"shape": "point", "mass": 1.0, "position": [-1.0, 0, 0]},
             {"shape": "box", "mass": 2.0, "size": [0.1, 0.1, 0.1], "position": [0, 0, 0.5]}]
    mass, com, J = mass_properties({"parts": parts})
    assert mass == 4.0
    np.testing.assert_allclose(com, [0, 0, 0.25])
    box = inertia.solid_box(2.0, [0.1] * 3)
    expected = (inertia.parallel_axis(box, 2.0, [0, 0, 0.25])
                + inertia.parallel_axis(np.zeros((3, 3)), 1.0, [1, 0, -0.25])
                + inertia.parallel_axis(np.zeros((3, 3)), 1.0, [-1, 0, -0.25]))
    np.testing.assert_allclose(J, expected)


def test_explicit_inertia_diagonal_or_full():
    _, com, J = mass_properties({"mass": 5.0, "inertia": [1.0, 2.0, 2.5], "com": [0, 0, 0.1]})
    np.testing.assert_allclose(J, np.diag([1.0, 2.0, 2.5]))
    np.testing.assert_allclose(com, [0, 0, 0.1])
    full = [[1.0, 0.1, 0.0], [0.1, 2.0, 0.0], [0.0, 0.0, 2.5]]
    np.testing.assert_allclose(mass_properties({"mass": 5.0, "inertia": full})[2], full)


@pytest.mark.parametrize(("change", "words"), [
    ({"episode": {"hold_time": -1.0}}, ["episode.hold_time", "-1.0", ">= 0"]),
    ({"physics": {"integrator": "leapfrog"}}, ["physics.integrator", "leapfrog", "one of"]),
    ({"physics": {"substeps": 0}}, ["physics.substeps", "0", ">= 1"]),
    ({"physics": {"control_dt": 0.0}}, ["physics.control_dt", ">= 1e-06"]),
    ({"episode": {"rate_limit": 0.005}}, ["success_rate", "rate_limit"]),
    ({"disturbance": {"model": "none", "bias_sigma": 1e-6}}, ["disturbance.bias_sigma", "random"]),
    ({"faults": {"model": "random", "p_reset": 1.5}}, ["faults.p_reset", "1.5", "<= 1.0"]),
    ({"sensor_noise": {"model": "laplace"}}, ["sensor_noise.model", "laplace"]),
    ({"episode": {"duraton": 10.0}}, ["episode", "unknown", "duraton"]),
    ({"body": {"shape": "sphere", "mass": 1.0}}, ["body.shape", "sphere"]),
    ({"body": {"shape": "box", "mass": -1.0, "size": [1, 1, 1]}}, ["body.mass", "-1.0"]),
    ({"body": {"mass": 1.0}}, ["exactly one of"]),
])
def test_bad_fields_name_field_value_and_rule(change, words):
    with pytest.raises(InvalidParameterError) as exc:
        Scene.from_dict(scene_dict(**change))
    assert isinstance(exc.value, ValueError)
    for word in words:
        assert word in str(exc.value)


def test_invalid_inertia_is_refused():
    with pytest.raises(InvalidInertiaError, match="triangle"):
        Scene.from_dict(scene_dict(body={"mass": 1.0, "inertia": [1.0, 1.0, 3.0]}))


def test_layout_missing_a_direction_is_named():
    thr = dict(COUPLES)
    # Drop the -y couple (rows 6, 7) and the +y one's partner: no thruster torques -y any more.
    keep = [i for i in range(12) if i not in (5, 6, 7)]
    thr["positions"] = [COUPLES["positions"][i] for i in keep]
    thr["directions"] = [COUPLES["directions"][i] for i in keep]
    with pytest.raises(InvalidParameterError, match=r"torque along -y: .*residual: -y"):
        Scene.from_dict(scene_dict(thrusters=thr))


def test_scene_from_path_name_and_object_in_make(tmp_path):
    text = (rbenv.satellite.scene.resources.files("rbenv") / "scenes"
            / "microsat-100kg.toml").read_text()
    path = tmp_path / "copy.toml"
    path.write_text(text.replace('name = "microsat-100kg"', 'name = "copy"'))
    scene = load_scene(path)
    assert scene.name == "copy" and scene.thrusters.n == 8
    for spec in (path, str(path), scene, "microsat-100kg"):
        env = gym.make(rbenv.ENV_ID, scene=spec)
        assert env.unwrapped.scene.thrusters.n == 8
        assert env.action_space.shape == (8,)
    with pytest.raises(InvalidParameterError, match="shipped name"):
        load_scene("no-such-scene")


def test_with_physics_overrides_only_what_is_given():
    base = load_scene("cubesat-12u")
    changed = base.with_physics(integrator="midpoint", substeps=3)
    assert changed.physics.integrator == "midpoint" and changed.physics.substeps == 3
    assert changed.physics.control_dt == base.physics.control_dt
    assert dataclasses.replace(base).body is base.body


def test_tomllib_missing_gives_install_hint(monkeypatch):
    real_import = builtins.__import__

    def no_toml(name, *args, **kwargs):
        if name in ("tomllib", "tomli"):
            raise ModuleNotFoundError(name)
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_toml)
    with pytest.raises(ImportError, match="pip install tomli"):
        load_scene("cubesat-12u")


def test_episode_steps_and_hold_steps_round_sensibly():
    scene = load_scene("boom-sat")
    assert scene.episode_steps == round(scene.episode.duration / scene.physics.control_dt)
    assert scene.hold_steps == math.ceil(scene.episode.hold_time / scene.physics.control_dt)
