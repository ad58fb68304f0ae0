"""Every registered id renders on every scene it accepts, and wheels and rods are drawn."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import rbenv
from rbenv.envs import registry

pytest.importorskip("pygame")

from rbenv.core import inertia

from rbenv.envs.goal import GOAL_ID
from rbenv.envs.rendering import LEGEND, Renderer

GRID = [(spec.env_id, scene) for spec in registry.specs() for scene in rbenv.list_scenes()
        if spec.runs_on(scene)]
WHEEL_SCENES = [s for s in rbenv.list_scenes() if "wheels" in rbenv.load_scene(s).actuators]


def _frame_after_a_step(env_id, scene, **kwargs):
    env = gym.make(env_id, scene=scene, render_mode="rgb_array", **kwargs)
    env.reset(seed=3)
    env.step(env.action_space.sample())
    frame = env.render()
    env.close()
    return frame


def test_the_grid_holds_every_id_and_the_wheel_scenes():
    assert {env_id for env_id, _ in GRID} == {s.env_id for s in registry.specs()}
    assert "cubesat-6u-rw" in WHEEL_SCENES
    assert sum(scene == "cubesat-6u-rw" for _, scene in GRID) == len(registry.specs())


@pytest.mark.parametrize(("env_id", "scene"), GRID)
def test_every_id_renders_rgb_array_on_every_scene_it_accepts(env_id, scene):
    frame = _frame_after_a_step(env_id, scene)
    assert frame.shape == (480, 480, 3) and frame.dtype == np.uint8
    assert frame.std() > 5  # a drawing, not a blank background


@pytest.mark.parametrize("scene", rbenv.list_scenes())
def test_the_goal_env_renders_its_inner_env(scene):
    env = gym.make(GOAL_ID, scene=scene, render_mode="rgb_array")
    assert env.render_mode == "rgb_array" and "rgb_array" in env.metadata["render_modes"]
    env.reset(seed=3)
    inner = env.unwrapped.env
    np.testing.assert_array_equal(env.render(), inner.render())
    assert env.render().shape == (480, 480, 3)


def test_the_vector_env_renders_a_wheel_scene():
    envs = gym.make_vec(rbenv.DESATURATE_ID, num_envs=2, render_mode="rgb_array")
    envs.reset(seed=0)
    frames = envs.render()
    assert len(frames) == 2 and frames[0].shape == (480, 480, 3)
    assert (frames[0] != frames[1]).any()  # two satellites, two attitudes
    envs.close()


def _renderer(**kwargs):
    I = inertia.solid_box(10.0, [0.2, 0.3, 0.4])
    return Renderer(I, 10.0, np.zeros((0, 3)), np.zeros((0, 3)), 160, 160, supersample=1,
                    **kwargs)


def _share(frame, rgb, tol=40):
    """Share of pixels within ``tol`` of colour ``rgb`` (each channel)."""
    return float((np.abs(frame.astype(int) - rgb).max(axis=-1) <= tol).mean())


Q = np.array([0.9, 0.2, -0.3, 0.25])
WHEELS = {"wheel_axes_B": np.eye(3), "wheel_max_speed": np.full(3, 600.0)}


def test_wheel_discs_show_the_speed_and_its_sign():
    r = _renderer(**WHEELS)
    bare = _renderer().frame(Q)
    rest = r.frame(Q, wheel_speed=[0.0, 0.0, 0.0])
    plus, minus = r.frame(Q, wheel_speed=[600.0] * 3), r.frame(Q, wheel_speed=[-600.0] * 3)
    half = r.frame(Q, wheel_speed=[300.0] * 3)
    orange, cyan = (255, 150, 50), (70, 210, 235)
    assert (rest != bare).any(axis=2).mean() > 0.005  # the discs are drawn at rest too
    assert _share(rest, orange) == 0 and _share(rest, cyan) == 0
    assert _share(plus, orange) > 0.005 and _share(plus, cyan) == 0
    assert _share(minus, cyan) > 0.005 and _share(minus, orange) == 0
    # the slice grows with the speed: half speed fills about half the disc
    assert 0.3 < _share(half, orange) / _share(plus, orange) < 0.7


def test_the_dipole_arrow_appears_with_the_dipole_and_grows_with_it():
    r = _renderer(full_dipole=0.3)
    magenta = (235, 80, 235)
    assert _share(r.frame(Q, dipole_B=[0.0, 0.0, 0.0]), magenta) == 0
    small = _share(r.frame(Q, dipole_B=[0.0, 0.03, 0.03]), magenta)
    full = _share(r.frame(Q, dipole_B=[0.0, 0.21, 0.21]), magenta)
    assert 0 < small < full


def test_renderer_refuses_a_zero_wheel_axis_by_name():
    with pytest.raises(ValueError, match="wheel_axes_B"):
        _renderer(wheel_axes_B=np.zeros((1, 3)), wheel_max_speed=[1.0])
    with pytest.raises(ValueError, match="wheel_speed"):
        _renderer(**WHEELS).frame(Q, wheel_speed=[1.0, 2.0])


def test_the_legend_names_every_drawn_element():
    for words in ("inertia box", "body axes", "Dashed", "target", "thrusters", "reaction wheels",
                  "dipole", "error"):
        assert words in LEGEND


@pytest.mark.slow
@pytest.mark.parametrize("scene", WHEEL_SCENES)
def test_evaluate_video_on_a_wheel_scene(tmp_path, scene):
    pytest.importorskip("imageio")
    from rbenv.agents.policies.evaluate import record_video

    path = record_video("zero", tmp_path / "wheels.gif", scene=scene,
                        env_id="rbenv/SatelliteReorient-v1")
    assert path.stat().st_size > 1000
