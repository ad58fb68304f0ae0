"""Gymnasium's standard wrappers, stacked the way CleanRL's PPO stacks them.

CleanRL's ``ppo_continuous_action.py`` wraps each env in RecordEpisodeStatistics, ClipAction,
NormalizeObservation, a clipping TransformObservation, NormalizeReward and a clipping
TransformReward, and records videos of env 0 with RecordVideo. The same stack is built here
around ``gym.make`` (inside a ``SyncVectorEnv``, as CleanRL does) and around the native
``gym.make_vec`` with the ``gymnasium.wrappers.vector`` equivalents.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.wrappers import vector as vw

import rbenv
from rbenv.envs.vector_env import AttitudeVectorEnv

GAMMA = 0.99
STEPS = 200  # more than one 160-step episode, so every env finishes at least once


def _clip(x):
    return np.clip(x, -10, 10)


def cleanrl_thunk(env_id: str, idx: int = 0, video_folder=None):
    """CleanRL's make_env(...) thunk, with its wrappers in its order."""

    def thunk():
        if video_folder is not None and idx == 0:
            env = gym.make(env_id, render_mode="rgb_array")
            env = gym.wrappers.RecordVideo(env, str(video_folder), disable_logger=True)
        else:
            env = gym.make(env_id)
        env = gym.wrappers.FlattenObservation(env)
        env = gym.wrappers.RecordEpisodeStatistics(env)
        env = gym.wrappers.ClipAction(env)
        env = gym.wrappers.NormalizeObservation(env)
        env = gym.wrappers.TransformObservation(env, _clip, env.observation_space)
        env = gym.wrappers.NormalizeReward(env, gamma=GAMMA)
        env = gym.wrappers.TransformReward(env, _clip)
        return env

    return thunk


def _run(envs, steps: int = STEPS, seed: int = 0) -> list[float]:
    """CleanRL's rollout loop with random actions; returns the finished episodes' returns."""
    obs, _ = envs.reset(seed=seed)
    rng = np.random.default_rng(seed)
    returns = []
    for _ in range(steps):
        # 3x the action range: ClipAction must bring it back to [-1, 1]
        action = rng.uniform(-3, 3, size=envs.action_space.shape).astype(np.float32)
        obs, reward, _, _, infos = envs.step(action)
        assert np.isfinite(obs).all() and np.isfinite(reward).all()
        assert np.abs(obs).max() <= 10 and np.abs(reward).max() <= 10
        if "episode" in infos:
            returns += [float(r) for r in infos["episode"]["r"][infos["_episode"]]]
    return returns


def test_cleanrl_stack_around_gym_make():
    envs = gym.vector.SyncVectorEnv([cleanrl_thunk(rbenv.ENV_ID, i) for i in range(2)],
                                    autoreset_mode=gym.vector.AutoresetMode.NEXT_STEP)
    assert isinstance(envs.single_action_space, gym.spaces.Box)  # CleanRL asserts this
    returns = _run(envs)
    assert len(returns) >= 2
    # NormalizeObservation has been learning: its running mean moved off zero.
    norm = envs.envs[0]
    while not isinstance(norm, gym.wrappers.NormalizeObservation):
        norm = norm.env
    assert np.abs(norm.obs_rms.mean).max() > 0.01
    envs.close()


def test_vector_wrappers_around_native_make_vec():
    envs = gym.make_vec(rbenv.ENV_ID, num_envs=8)
    envs = vw.RecordEpisodeStatistics(envs)
    envs = vw.ClipAction(envs)
    envs = vw.NormalizeObservation(envs)
    envs = vw.TransformObservation(envs, _clip, envs.observation_space)
    envs = vw.NormalizeReward(envs, gamma=GAMMA)
    envs = vw.TransformReward(envs, _clip)
    returns = _run(envs)
    assert len(returns) >= 8
    assert isinstance(envs.unwrapped, AttitudeVectorEnv)  # the native env
    envs.close()


def test_clip_action_reaches_the_env_clipped():
    """The env sees ClipAction's output: a 3x action equals the clipped one step for step."""
    outs = []
    for wrap in (True, False):
        env = gym.make(rbenv.ENV_ID)
        env = gym.wrappers.ClipAction(env) if wrap else env
        env.reset(seed=3)
        a = np.linspace(-3, 3, env.action_space.shape[0]).astype(np.float32)
        outs.append(env.step(a if wrap else np.clip(a, -1, 1))[0])
        env.close()
    np.testing.assert_array_equal(*outs)


def test_both_id_forms_work_as_cleanrl_passes_them(tmp_path):
    """``--env-id rbenv/SatelliteReorient-v0`` needs ``import rbenv``; ``rbenv:...`` does not.

    A fresh interpreter, as CleanRL's script is: it imports gymnasium but not rbenv.
    """
    code = textwrap.dedent(f"""
        import gymnasium as gym
        from gymnasium.error import NamespaceNotFound
        try:
            gym.make({rbenv.ENV_ID!r})
            print("plain-without-import: made")
        except NamespaceNotFound:
            print("plain-without-import: NamespaceNotFound")
        envs = gym.vector.SyncVectorEnv(
            [lambda: gym.make("rbenv:{rbenv.ENV_ID}") for _ in range(2)])
        envs.reset(seed=0)
        envs.step(envs.action_space.sample())
        print("colon-form: stepped", type(envs.envs[0].unwrapped).__name__)
        import rbenv
        envs = gym.vector.SyncVectorEnv([lambda: gym.make({rbenv.ENV_ID!r}) for _ in range(2)])
        envs.reset(seed=0)
        envs.step(envs.action_space.sample())
        print("plain-after-import: stepped")
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=tmp_path, timeout=300, check=True).stdout.splitlines()
    assert out == ["plain-without-import: NamespaceNotFound",
                   f"colon-form: stepped {type(gym.make(rbenv.ENV_ID).unwrapped).__name__}",
                   "plain-after-import: stepped"]


# moviepy (under RecordVideo) leaves its ffmpeg pipes for the garbage collector to close.
@pytest.mark.slow
@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
@pytest.mark.filterwarnings("ignore:unclosed file:ResourceWarning")
def test_record_video_around_gym_make_writes_an_mp4(tmp_path):
    pytest.importorskip("moviepy", reason="moviepy is not installed (render extra)")
    thunks = [cleanrl_thunk(rbenv.ENV_ID, i, tmp_path / "videos") for i in range(2)]
    envs = gym.vector.SyncVectorEnv(thunks)
    _run(envs, steps=170)  # the first episode of env 0 ends by step 160
    envs.close()
    _assert_video(tmp_path / "videos")


# moviepy (under RecordVideo) leaves its ffmpeg pipes for the garbage collector to close.
@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
@pytest.mark.filterwarnings("ignore:unclosed file:ResourceWarning")
def test_record_video_around_make_vec_writes_an_mp4(tmp_path):
    pytest.importorskip("moviepy", reason="moviepy is not installed (render extra)")
    envs = gym.make_vec(rbenv.ENV_ID, num_envs=2, render_mode="rgb_array")
    envs = vw.RecordVideo(envs, str(tmp_path / "videos"), video_length=20, disable_logger=True)
    envs.reset(seed=0)
    for _ in range(25):
        envs.step(envs.action_space.sample())
    envs.close()
    _assert_video(tmp_path / "videos", min_frames=20)


def _assert_video(folder, min_frames: int = 2):
    from moviepy import VideoFileClip

    videos = sorted(folder.glob("*.mp4"))
    assert videos, f"no .mp4 in {folder}: {sorted(p.name for p in folder.iterdir())}"
    clip = VideoFileClip(str(videos[0]))
    try:
        frames = np.stack(list(clip.iter_frames()))
    finally:
        clip.close()
    assert len(frames) >= min_frames
    assert frames[0].std() > 5  # a drawn satellite, not a blank frame
