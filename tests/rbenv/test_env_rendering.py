"""Rendering through the envs: rgb_array frames, human mode headless, GIF of an episode."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import rbenv

pytest.importorskip("pygame")

from rbenv.envs.rendering import save_video

SMALL_TURN = np.array([np.cos(0.3), np.sin(0.3), 0.0, 0.0])


def test_rgb_array_frame_shape_dtype_and_change_with_attitude():
    env = gym.make(rbenv.ENV_ID, render_mode="rgb_array")
    env.reset(seed=0, options={"q": [1.0, 0, 0, 0], "q_target": [1.0, 0, 0, 0]})
    f1 = env.render()
    assert f1.dtype == np.uint8 and f1.ndim == 3 and f1.shape[2] == 3
    env.reset(seed=0, options={"q": SMALL_TURN, "q_target": [1.0, 0, 0, 0]})
    f2 = env.render()
    assert f2.shape == f1.shape
    assert (f1 != f2).any(axis=2).mean() > 0.01  # a visible share of pixels moved
    env.close()


def test_human_mode_draws_and_returns_none(monkeypatch):
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    env = gym.make(rbenv.ENV_ID, render_mode="human")
    env.reset(seed=0)
    env.step(np.zeros(12, np.float32))
    assert env.render() is None
    env.close()
    env.close()  # closing twice is harmless


def test_short_episode_saves_as_gif(tmp_path):
    env = gym.make(rbenv.ENV_ID, render_mode="rgb_array", max_initial_angle_deg=20.0)
    env.reset(seed=1)
    frames = [env.render()]
    for _ in range(4):
        env.step(np.full(12, 0.3, np.float32))
        frames.append(env.render())
    path = save_video(frames, tmp_path / "episode.gif", fps=env.metadata["render_fps"])
    assert path.exists() and path.stat().st_size > 1000
    env.close()


def test_vector_env_renders_one_frame_per_sub_env():
    envs = gym.make_vec(rbenv.ENV_ID, num_envs=2, render_mode="rgb_array")
    envs.reset(seed=0)
    frames = envs.render()
    assert len(frames) == 2 and frames[0].dtype == np.uint8
    assert not np.array_equal(frames[0], frames[1])
    envs.close()
