"""A new vector backend is one file: the contract (seeding, reset masks, the three autoreset
modes, final observations) is rbenv.envs.vector's, written once.

This file is the count, done: it adds a toy backend whose "arrays" are Python lists of single
envs on the float path, writes only the array methods of
:class:`rbenv.envs.vector.VectorContract`, touches no rbenv file, and gets episodes equal, bit
for bit, to the NumPy vector env's in every autoreset mode (sub-env i of either is a single
env seeded s + i, episode by episode).
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

import rbenv
from rbenv.envs.adapter import autoreset_mode_of
from rbenv.envs.vector import Step, VectorContract

N, EPISODE, STEPS = 4, 5, 23


class SingleEnvsVectorEnv(VectorContract):
    """N single envs (Python floats each) as one vector env: the backend's arrays are lists."""

    backend = "lists"
    metadata = {"render_modes": []}  # noqa: RUF012 (Gymnasium's class attribute)

    def __init__(self, num_envs: int, autoreset_mode=None, **options):
        self.envs = [gym.make(rbenv.ENV_ID, **options).unwrapped for _ in range(num_envs)]
        self.num_envs, self.autoreset_mode = num_envs, autoreset_mode_of(autoreset_mode)
        self.single_action_space = self.envs[0].action_space
        self.action_space = batch_space(self.single_action_space, num_envs)
        self._seeds, self._episodes, self._done = None, [0] * num_envs, [False] * num_envs
        self._mask = [True] * num_envs
        self._st = None

    # the array methods
    def _seed_array(self, seeds):
        return list(seeds)

    def _where(self, mask, a, b):
        a = a if isinstance(a, list) else [a] * self.num_envs
        return [x if m else y for m, x, y in zip(mask, a, b, strict=True)]

    def _keep(self, mask, value):
        return [v if m else 0 * v for m, v in zip(mask, value, strict=True)]

    def _any(self, mask) -> bool:
        return any(mask)

    def _all(self, mask) -> bool:
        return all(mask)

    def _rows(self, mask) -> list[int]:
        return [i for i, m in enumerate(mask) if m]

    def _mask_array(self, mask):
        return np.asarray(mask)

    def _is_bool(self, array) -> bool:
        return array.dtype == bool

    def _owner(self):
        return list

    def _reset_rows(self, mask, options):
        self._st = self.envs
        out = [self._new_episode(i) for i in self._rows(mask)]
        return np.stack([obs for obs, _ in out]), {"success": [False] * self.num_envs}

    def _new_episode(self, i: int):
        """Row i's next episode: its first with its seed, then the counter's next."""
        first = self._episodes[i] == 0
        self._episodes[i] += 1
        return self.envs[i].reset(seed=int(self._seeds[i]) if first else None)

    def _actions(self, actions):
        return np.asarray(actions, dtype=np.float32)

    def _advance(self, actions) -> Step:
        rows = [env.step(a) for env, a in zip(self.envs, actions, strict=True)]
        obs, reward, terminated, truncated, info = (list(c) for c in zip(*rows, strict=True))
        success = [i["is_success"] for i in info]
        self._rows_info = info
        return Step(self.envs, obs, np.array(reward), np.array(terminated),
                    np.array(truncated), None, success)

    def _step_info(self, s: Step) -> dict:
        return {"success": list(s.success)}

    def _restart(self, rows, s: Step, *, ended_before: bool) -> None:
        for i in self._rows(rows):
            s.obs[i], self._rows_info[i] = self._new_episode(i)
            s.success[i] = False
            if ended_before:
                s.reward[i], s.terminated[i], s.truncated[i] = 0.0, False, False

    def _final_obs(self, done, obs):
        return [o.copy() if d else None for o, d in zip(obs, done, strict=True)]

    def _finish(self, s: Step) -> None:
        s.obs = np.stack(s.obs)


@pytest.mark.parametrize("mode", list(AutoresetMode), ids=lambda m: m.value)
def test_a_toy_backend_gets_the_numpy_vector_envs_episodes_from_the_contract(mode):
    kwargs = {"max_episode_steps": EPISODE, "autoreset_mode": mode}
    ours = SingleEnvsVectorEnv(N, autoreset_mode=mode)
    for env in ours.envs:
        env._max_steps = EPISODE  # the vector envs' max_episode_steps
    numpy = gym.make_vec(rbenv.ENV_ID, num_envs=N, **kwargs)
    obs_a, _ = ours.reset(seed=5)
    obs_b, _ = numpy.reset(seed=5)
    np.testing.assert_array_equal(obs_a, obs_b)
    rng = np.random.default_rng(0)
    restarted = 0
    for t in range(STEPS):
        action = rng.uniform(-1, 1, numpy.action_space.shape)
        a, b = ours.step(action.astype(np.float32)), numpy.step(action.astype(np.float32))
        for got, want, what in zip(a[:4], b[:4], ("obs", "reward", "terminated", "truncated"),
                                   strict=True):
            np.testing.assert_array_equal(np.asarray(got, dtype=np.asarray(want).dtype), want,
                                          err_msg=f"step {t} {what}")
        assert a[4]["success"] == b[4]["is_success"].tolist(), t
        assert a[4]["_success"] == b[4]["_is_success"].tolist(), t
        if mode is AutoresetMode.SAME_STEP and b[4].get("_final_obs", np.zeros(N)).any():
            for i in np.flatnonzero(b[4]["_final_obs"]):
                np.testing.assert_array_equal(a[4]["final_obs"][i], b[4]["final_obs"][i])
        done = b[2] | b[3]
        restarted += int(done.sum())
        if mode is AutoresetMode.DISABLED and done.any():
            with pytest.raises(gym.error.ResetNeeded, match="have ended"):
                ours.step(action.astype(np.float32))  # the contract's guard, on this backend
            obs_a, _ = ours.reset(options={"reset_mask": done})
            obs_b, _ = numpy.reset(options={"reset_mask": done})
            np.testing.assert_array_equal(obs_a, obs_b[done])
    assert restarted >= N  # the run crossed autoresets


def test_the_autoreset_default_changed_in_one_place_reaches_a_new_backend_too(monkeypatch):
    """With the NumPy and torch vector envs (tests/rbenv/test_options.py), the third shell:
    the one value rbenv.envs.options.AUTORESET_DEFAULT sets the toy's mode, which it then acts
    on without a line of its own."""
    from rbenv.envs import options

    assert SingleEnvsVectorEnv(2).autoreset_mode is AutoresetMode.NEXT_STEP
    monkeypatch.setattr(options, "AUTORESET_DEFAULT", AutoresetMode.SAME_STEP)
    ours = SingleEnvsVectorEnv(2)
    assert ours.autoreset_mode is AutoresetMode.SAME_STEP
    for env in ours.envs:
        env._max_steps = 1
    ours.reset(seed=0)
    obs, _, _, truncated, info = ours.step(np.zeros(ours.action_space.shape, np.float32))
    assert truncated.all() and all(o is not None for o in info["final_obs"])
    assert not np.array_equal(obs[0], info["final_obs"][0])  # the new episode's first obs
